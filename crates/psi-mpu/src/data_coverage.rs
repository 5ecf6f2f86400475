//! How much of the MPU's zero set is backed by data: among the leaves the zero set crosses (a
//! sign change over the cube's corners and centre), the share, weighted by cell area (edge²), of
//! those with an input point within 1.5 half-diagonals of their centre. About 1 for a complete scan; lower where the implicit closes
//! holes or extends past a scan's border (those parts get no particles).

use glam::DVec3;
use rayon::prelude::*;

use crate::Mpu;

/// The data-backed share (0..=1) of the leaves the zero set crosses, weighted by edge².
pub fn data_coverage(mpu: &Mpu) -> f64 {
    let tree = mpu.octree();
    let origin = mpu.frame_origin();
    let (covered, total) = mpu
        .leaves()
        .collect::<Vec<_>>()
        .par_iter()
        .map(|&l| {
            let c = tree.cell(l);
            let mut signs = [false; 9];
            for (k, s) in signs.iter_mut().enumerate() {
                let offset = if k == 8 {
                    DVec3::ZERO
                } else {
                    let b = |i: usize| if (k >> i) & 1 == 1 { 1.0 } else { -1.0 };
                    c.half * DVec3::new(b(0), b(1), b(2))
                };
                *s = mpu.value(origin + c.center + offset) < 0.0;
            }
            let crossed = signs.iter().any(|&s| s) && signs.iter().any(|&s| !s);
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

    #[test]
    fn a_hemisphere_is_less_covered_than_a_sphere() {
        let sphere = AnalyticShape::Sphere { radius: 1.0 }.sample(20_000, 2);
        let full = data_coverage(&Mpu::build(&sphere, &MpuParams::paper()).unwrap());
        assert!(full > 0.99, "{full}");
        let half: Vec<_> = sphere.into_iter().filter(|p| p.p.z > 0.0).collect();
        let partial = data_coverage(&Mpu::build(&half, &MpuParams::paper()).unwrap());
        // The open rim's extrapolated zero set is not backed by data.
        assert!(partial < full - 0.01, "{partial} vs {full}");
    }
}
