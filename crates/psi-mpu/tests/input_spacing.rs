//! The per-point input caches (`Mpu::input_spacing`, `Mpu::input_is_interior`) against a
//! brute-force oracle on an open, jittered square patch, whose border is known: its corners
//! are never interior, points three steps inside always are. (Points on a straight border of
//! such a regular sampling often pass the interior test: their 8 nearest points' centroid lies
//! about 0.45 spacing inside, not the 0.95 of a half disc.)

use glam::DVec3;
use psi_mpu::{Mpu, MpuParams};
use psi_shapes::assert_near;

mod common;
use common::jittered_patch;
use rand::SeedableRng;
use rand_pcg::Pcg64Mcg;

#[test]
fn spacing_and_interior_equal_brute_force_and_find_the_border() {
    let (side, h) = (40usize, 0.025);
    let points = jittered_patch(side, h, &mut Pcg64Mcg::seed_from_u64(11));
    let mpu = Mpu::build(&points, &MpuParams::paper()).expect("patch builds");
    let pts = mpu.points();
    let (mut inner, mut corners) = (0, 0);
    // Every point, in an order that fills the caches from both ends.
    for q in (0..pts.len() as u32).rev() {
        let y = pts[q as usize].p;
        let mut by_distance: Vec<(f64, usize)> = pts
            .iter()
            .enumerate()
            .map(|(i, p)| ((p.p - y).length_squared(), i))
            .collect();
        by_distance.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let spacing = by_distance[8].0.sqrt() * (std::f64::consts::PI / 8.0).sqrt();
        assert_near!(mpu.input_spacing(q), spacing, 1e-12 * spacing);
        let centroid = by_distance[..8]
            .iter()
            .map(|&(_, i)| pts[i].p)
            .sum::<DVec3>()
            / 8.0;
        let offset = (centroid - y).truncate().length(); // tangent plane: z = 0
        if (offset - 0.5 * spacing).abs() > 1e-9 * spacing {
            assert_eq!(
                mpu.input_is_interior(q),
                offset <= 0.5 * spacing,
                "point {q}"
            );
        }
        // Distance to the patch's border, in grid steps, per axis.
        let far = (side - 1) as f64 * h;
        let ex = y.x.min(far - y.x) / h;
        let ey = y.y.min(far - y.y) / h;
        let interior = mpu.input_is_interior(q);
        if ex < 0.5 && ey < 0.5 {
            assert!(!interior, "corner point {q} called interior");
            corners += 1;
        } else if ex.min(ey) > 3.0 {
            assert!(
                interior,
                "point {q}, {ex:.1} × {ey:.1} steps inside, not called interior"
            );
            inner += 1;
        }
    }
    assert!(
        inner > 300 && corners >= 2,
        "{inner} inner points, {corners} corners"
    );
}
