//! Tests of `fit_cell`: fits without the kd-tree, and first fits against the full fits.

use super::*;
use crate::{Mpu, MpuParams};
use psi_shapes::AnalyticShape;

#[test]
fn a_fit_without_the_kd_tree_is_the_fit_with_it_or_none() {
    // Enough points that the coarse cells hold more than 256 coarse points.
    let pts = AnalyticShape::Torus {
        major: 1.0,
        minor: 0.35,
    }
    .sample(40_000, 5);
    let params = MpuParams::paper();
    let mpu = Mpu::build(&pts, &params).unwrap();
    let coarse = CoarseIndex::new(mpu.octree.positions());
    let with = input_of(&mpu, &coarse, &params);
    let without = FitInput {
        index: None,
        ..with
    };
    let eps0 = params.error_rel * mpu.frame.diagonal;
    let (mut same, mut gave_up) = (0, 0);
    for c in mpu.octree.cells() {
        let full = fit_cell(&with, c.center, c.half, eps0, true);
        match try_fit_cell(&without, c.center, c.half, eps0, true, None) {
            Some(f) => {
                assert_eq!(f.fit.function, full.fit.function);
                assert_eq!(f.fit.kind, full.fit.kind);
                assert_eq!(f.fit.fallback, full.fit.fallback);
                assert_eq!(f.error.to_bits(), full.error.to_bits());
                assert_eq!(f.fit_radius.to_bits(), full.fit_radius.to_bits());
                assert!(
                    f.error > eps0,
                    "only splitting cells complete without the tree"
                );
                same += 1;
            }
            None => gave_up += 1,
        }
    }
    assert!(
        same > 0 && gave_up > 0,
        "{same} completed, {gave_up} gave up"
    );
}

/// A brute-force twin of the first fit: every cell of a build decides its split as the fit
/// from its whole neighbourhood does (`may_split = false` skips the first fit), a cell that
/// does not split gets that fit bitwise, and some splits were decided by a first fit (its
/// function differs from the full fit's). With the paper's maximum error and with a
/// ranked error on noisy points.
#[test]
fn first_fits_split_exactly_the_cells_the_full_fits_split() {
    let clean = psi_shapes::sample_builtin(60_000, 3);
    let mut noisy = AnalyticShape::Torus {
        major: 1.0,
        minor: 0.35,
    }
    .sample(80_000, 9);
    // Seeded Gaussian noise of about 1e-3 D along the normals.
    let mut rng = <rand_pcg::Pcg64Mcg as rand::SeedableRng>::seed_from_u64(9);
    for p in &mut noisy {
        p.p += p.n * 1.7e-3 * psi_shapes::gaussian(&mut rng);
    }
    let ranked = MpuParams {
        error_rank: Some(256),
        ..MpuParams::paper()
    };
    // A sweep of ε0 puts some cells' errors near it at every level.
    let mut cases: Vec<(&[psi_octree::OrientedPoint], MpuParams)> =
        [0.002, 0.003, 0.004, 0.005, 0.007, 0.01, 0.014, 0.02, 0.03]
            .iter()
            .map(|&error_rel| {
                let params = MpuParams {
                    error_rel,
                    ..MpuParams::paper()
                };
                (&clean[..], params)
            })
            .collect();
    cases.push((&noisy[..], ranked));
    for (points, params) in cases {
        let mpu = Mpu::build(points, &params).unwrap();
        let coarse = CoarseIndex::new(mpu.octree.positions());
        let input = input_of(&mpu, &coarse, &params);
        let eps0 = params.error_rel * mpu.frame.diagonal;
        let (mut first, mut splits) = (0, 0);
        for c in mpu.octree.cells() {
            let quick = fit_cell(&input, c.center, c.half, eps0, true);
            let full = fit_cell(&input, c.center, c.half, eps0, false);
            assert_eq!(
                quick.error > eps0,
                full.error > eps0,
                "cell at {}",
                c.center
            );
            assert_eq!(quick.fit_radius.to_bits(), full.fit_radius.to_bits());
            if full.error > eps0 {
                splits += 1;
                first += usize::from(quick.fit.function != full.fit.function);
            } else {
                assert_eq!(quick.fit, full.fit);
                assert_eq!(quick.error.to_bits(), full.error.to_bits());
            }
        }
        assert!(
            first >= 5 && first < splits,
            "{first} of {splits} splits by a first fit"
        );
    }
}
