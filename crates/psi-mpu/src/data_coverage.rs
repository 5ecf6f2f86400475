//! How much of the MPU's zero set is backed by data: among the leaves the zero set crosses (a
//! sign change over the cube's corners and centre), the share, weighted by cell area (edge²), of
//! those with an input point within 1.5 half-diagonals of their centre. About 1 for a complete
//! scan; lower where the implicit closes holes or extends past a scan's border (those parts get
//! no particles).

use glam::DVec3;
use rayon::prelude::*;

use crate::Mpu;

/// The data-backed share (0..=1) of the leaves the zero set crosses, weighted by edge².
///
/// The corners lie on the lattice of the deepest level (root corner + integer × that level's
/// edge) and each is evaluated once, however many leaves share it (measured against nine
/// evaluations per leaf in docs/results/2026-12-02-throughput/).
pub fn data_coverage(mpu: &Mpu) -> f64 {
    let tree = mpu.octree();
    let origin = mpu.frame_origin();
    let leaves: Vec<u32> = mpu.leaves().collect();
    let deepest = tree.max_depth_reached();
    let root = tree.root();
    let root_min = root.center - DVec3::splat(root.half);
    let step = tree.edge_at_depth(deepest);
    // Corner k (bit i: +1 along axis i) of leaf l on the deepest level's lattice.
    let corner = |l: u32, k: usize| -> [u32; 3] {
        let c = tree.cell(l);
        let shift = deepest - c.depth;
        std::array::from_fn(|i| (c.key[i] + ((k >> i) & 1) as u32) << shift)
    };
    let mut corners: Vec<[u32; 3]> = leaves
        .par_iter()
        .flat_map_iter(|&l| (0..8).map(move |k| corner(l, k)))
        .collect();
    corners.par_sort_unstable();
    corners.dedup();
    let inside = |y: DVec3| mpu.value(origin + y) < 0.0;
    let corner_inside: Vec<bool> = corners
        .par_iter()
        .map(|q| inside(root_min + DVec3::new(q[0] as f64, q[1] as f64, q[2] as f64) * step))
        .collect();
    let (covered, total) = leaves
        .par_iter()
        .map(|&l| {
            let c = tree.cell(l);
            let centre = inside(c.center);
            let crossed = (0..8).any(|k| {
                let at = corners
                    .binary_search(&corner(l, k))
                    .expect("every corner is listed");
                corner_inside[at] != centre
            });
            if !crossed {
                return (0.0, 0.0);
            }
            let w = c.edge() * c.edge();
            // Backed by data: an input point within 1.5 half-diagonals of the centre (the
            // surface may only graze a leaf whose cube holds no point).
            let near = mpu.distance_to_data(origin + c.center) <= 1.5 * 3f64.sqrt() * c.half;
            (if near { w } else { 0.0 }, w)
        })
        .collect::<Vec<(f64, f64)>>()
        // Summed in leaf order, so the figure does not depend on the thread count.
        .iter()
        .fold((0.0, 0.0), |a, b| (a.0 + b.0, a.1 + b.1));
    if total > 0.0 { covered / total } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::MpuParams;
    use psi_shapes::AnalyticShape;

    /// Brute-force twin: the nine evaluations of every leaf (its centre and corners from its
    /// own centre and half edge), one leaf at a time.
    fn nine_per_leaf(mpu: &Mpu) -> f64 {
        let (mut covered, mut total) = (0.0, 0.0);
        for l in mpu.leaves() {
            let c = mpu.octree().cell(l);
            let signs: Vec<bool> = (0..9)
                .map(|k| {
                    let b = |i: usize| if (k >> i) & 1 == 1 { 1.0 } else { -1.0 };
                    let offset = if k == 8 {
                        DVec3::ZERO
                    } else {
                        c.half * DVec3::new(b(0), b(1), b(2))
                    };
                    mpu.value(mpu.frame_origin() + c.center + offset) < 0.0
                })
                .collect();
            if signs.iter().all(|&s| s == signs[0]) {
                continue;
            }
            let w = c.edge() * c.edge();
            total += w;
            if mpu.distance_to_data(mpu.frame_origin() + c.center) <= 1.5 * 3f64.sqrt() * c.half {
                covered += w;
            }
        }
        if total > 0.0 { covered / total } else { 0.0 }
    }

    #[test]
    fn a_hemisphere_is_less_covered_than_a_sphere() {
        let sphere = AnalyticShape::Sphere { radius: 1.0 }.sample(20_000, 2);
        let mpu = Mpu::build(&sphere, &MpuParams::paper()).unwrap();
        let full = data_coverage(&mpu);
        assert_eq!(full, nine_per_leaf(&mpu));
        assert!(full > 0.99, "{full}");
        let half: Vec<_> = sphere.into_iter().filter(|p| p.p.z > 0.0).collect();
        let mpu = Mpu::build(&half, &MpuParams::paper()).unwrap();
        let partial = data_coverage(&mpu);
        assert_eq!(partial, nine_per_leaf(&mpu));
        // The open rim's extrapolated zero set is not backed by data.
        assert!(partial < full - 0.01, "{partial} vs {full}");
    }
}
