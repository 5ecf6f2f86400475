//! The footprint test's floor on the spacing it reads (`Mpu::near_data_from`'s `floor`, a
//! particle's resolution): on a random sampling of a square with a round hole, the gaps of the
//! sampling refuse positions without the floor and none with it, whether the test reads the
//! whole input or an unmeasured subset taking its own test (a random sampling's regions out of
//! core), while the hole and the square's outside stay refused, also by a thinned subset
//! carrying the whole input's footprint. Oracle: the brute-force distance to the nearest input
//! point and the analytic geometry of the square and the hole.

use glam::DVec3;
use psi_mpu::{Mpu, MpuParams, PointFootprint};
use psi_octree::OrientedPoint;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64Mcg;

mod common;
use common::{band_and_every_fourth, in_square, subset_mpu};

/// Uniform random points on the unit square (z = 0, normals +z) outside the disc of `radius`
/// around `hole`.
fn random_square(n: usize, hole: DVec3, radius: f64, seed: u64) -> Vec<OrientedPoint> {
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    std::iter::repeat_with(|| DVec3::new(rng.random(), rng.random(), 0.0))
        .filter(|p| (*p - hole).length() > radius)
        .take(n)
        .map(|p| OrientedPoint { p, n: DVec3::Z })
        .collect()
}

#[test]
fn the_floor_ignores_the_samplings_gaps_and_keeps_holes_and_borders() {
    let (hole, radius) = (DVec3::new(0.5, 0.5, 0.0), 0.15);
    let points = random_square(20_000, hole, radius, 3);
    let mut whole = Mpu::build(&points, &MpuParams::paper()).unwrap();
    // The spacing of a uniform sampling of density n / area, about 0.0075.
    let area = 1.0 - std::f64::consts::PI * radius * radius;
    let spacing = (area / points.len() as f64).sqrt();
    let floor = 5.0 * spacing;

    // A thinned subset carrying the whole input's footprint (the relaxation's data out of
    // core): the points within two hops of the data's edge and every fourth of the others. On
    // a random sampling its band of seeming edges spans much of the data (why out of core
    // does not measure such regions), whose positions read the input's own spacing: only the
    // outside is asserted for it.
    let (subset, carried, _) = band_and_every_fourth(&mut whole);
    let thinned = subset_mpu(&subset, *whole.frame(), Some(&carried));
    // Every fourth point, unmeasured, taking the whole test on its own points.
    let quarter: Vec<OrientedPoint> = points.iter().copied().step_by(4).collect();
    let own = vec![
        PointFootprint::unmeasured(spacing)
            .thinned_to(0.25, 0)
            .with_own_test();
        quarter.len()
    ];
    let own = subset_mpu(&quarter, *whole.frame(), Some(&own));

    let nearest = |x: DVec3| {
        points
            .iter()
            .map(|p| (p.p - x).length())
            .fold(f64::INFINITY, f64::min)
    };
    let mut rng = Pcg64Mcg::seed_from_u64(11);
    let (mut deep, mut gaps_refused, mut own_refused, mut outside) = (0, 0, 0, 0);
    for _ in 0..20_000 {
        let x = in_square(-0.2, 1.4, &mut rng);
        let to_square = x.x.min(x.y).min(1.0 - x.x).min(1.0 - x.y);
        let depth = to_square.min((x - hole).length() - radius);
        let d = nearest(x);
        let test = |mpu: &Mpu, floor: f64| mpu.near_data_from(x, 1.0, floor, None).inside;
        if depth > 2.0 * floor {
            deep += 1;
            assert!(test(&whole, floor), "{x:?}: {depth} inside, nearest {d}");
            assert!(test(&own, floor), "{x:?}: {depth} inside, own test");
            gaps_refused += usize::from(!test(&whole, 0.0));
            own_refused += usize::from(!test(&own, 0.0));
        } else if depth < -floor {
            outside += 1;
            // Farther than the floor from every input point: the distance rule refuses it.
            assert!(d > floor, "{x:?}: nearest {d}");
            assert!(!test(&whole, floor), "{x:?}: {depth} outside");
            assert!(!test(&thinned, floor), "{x:?}: {depth} outside, thinned");
            assert!(!test(&own, floor), "{x:?}: {depth} outside, own test");
            assert!(!test(&whole, 0.0), "{x:?}: {depth} outside, no floor");
        }
    }
    assert!(
        deep > 5_000 && outside > 5_000,
        "{deep} deep, {outside} outside"
    );
    // Without the floor the sampling's gaps (about e^−π of the positions lie farther than a
    // spacing from every point of a random sampling) are refused, and the subset's own test
    // refuses its own gaps, other positions than the whole input's.
    for (refused, what) in [(gaps_refused, "whole"), (own_refused, "own test")] {
        assert!(
            refused as f64 > 0.01 * deep as f64,
            "{what}: {refused} of {deep} refused without the floor"
        );
    }
}
