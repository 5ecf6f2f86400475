//! The footprint test on a thinned subset that carries the whole input's footprint
//! (`BuildOptions::whole_footprint`) against the whole input's own test (the oracle), on an
//! open, jittered square patch with a round hole: the thinned test keeps every point within two
//! hops of the data's edge and a quarter of the others, and must answer as the whole test does
//! wherever the answer is clear (well inside the data, well beyond its edges), and mostly in
//! between. The subset's own test, without the carried footprint, is checked to agree as well
//! (the edge rule reads the position's own nearest points, `surrounded.rs`).

use glam::DVec3;
use psi_mpu::{Mpu, MpuParams, PointFootprint};
use psi_octree::OrientedPoint;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64Mcg;

mod common;
use common::{band_and_every_fourth, in_square, jittered_patch, subset_mpu};

/// The MPU over `points` (the paper's parameters) and every fourth of its points.
fn whole_and_every_fourth(points: &[OrientedPoint]) -> (Mpu, Vec<OrientedPoint>) {
    let whole = Mpu::build(points, &MpuParams::paper()).unwrap();
    let subset = whole.points().iter().copied().step_by(4).collect();
    (whole, subset)
}

#[test]
fn a_thinned_subset_with_the_whole_footprint_tests_as_the_whole_input() {
    let (side, h) = (80usize, 0.0125);
    let (hole, radius) = (DVec3::new(0.5, 0.5, 0.0), 0.2);
    let mut rng = Pcg64Mcg::seed_from_u64(5);
    let points: Vec<OrientedPoint> = jittered_patch(side, h, &mut rng)
        .into_iter()
        .filter(|p| (p.p - hole).length() > radius)
        .collect();
    let params = MpuParams::paper();
    let mut whole = Mpu::build(&points, &params).unwrap();
    // The band (two hops of the edge) whole, every fourth of the others.
    let (subset, carried, band) = band_and_every_fourth(&mut whole);
    assert!(band > 100 && band < points.len() / 2, "band {band}");
    let frame = *whole.frame();
    let thinned = subset_mpu(&subset, frame, Some(&carried));
    let own = subset_mpu(&subset, frame, None);
    // Positions on the plane over and around the patch; "clear" ones lie more than two steps
    // inside the data or beyond its edge (the outer square's or the hole's).
    let (mut clear, mut agree, mut all_tests, mut own_agree) = (0, 0, 0, 0);
    for _ in 0..20_000 {
        let x = in_square(-0.1, 1.2, &mut rng);
        let edge = (side - 1) as f64 * h;
        let to_square = x.x.min(x.y).min(edge - x.x).min(edge - x.y);
        let to_hole = (x - hole).length() - radius;
        let depth = to_square.min(to_hole);
        let expected = whole.near_data_from(x, 1.0, 0.0, None).inside;
        let got = thinned.near_data_from(x, 1.0, 0.0, None).inside;
        all_tests += 1;
        agree += usize::from(got == expected);
        own_agree += usize::from(own.near_data_from(x, 1.0, 0.0, None).inside == expected);
        if depth.abs() > 2.0 * h {
            clear += 1;
            assert_eq!(got, expected, "{x:?}: {depth} from the edge");
            assert_eq!(expected, depth > 0.0, "the oracle at {x:?}");
        }
    }
    assert!(clear > 15_000, "{clear}");
    assert!(
        agree as f64 >= 0.98 * all_tests as f64,
        "{agree} of {all_tests} agree"
    );
    // The subset's own test agrees about as well: its edge rule asks whether the position's
    // own nearest points surround it, which a quarter of the points still do. (The rule on
    // the centroid of the nearest point's 8 neighbours, before, took the subset's irregular
    // inside for edges and agreed less than 98 %.)
    assert!(
        own_agree as f64 >= 0.98 * all_tests as f64,
        "{own_agree} of {all_tests}: the subset's own test"
    );
}

/// A subset whose points were not measured (an irregular sampling's regions carry only their
/// spacing, `PointFootprint::unmeasured`), beside a thin feature: two jittered squares joined
/// by a bridge one point wide. A subset point on the bridge has its 9th nearest far along it,
/// so its own spacing or d₈ would let positions in the gaps beside the bridge pass, several
/// spacings off the data. With the region's spacing known, both the lenient test and the whole
/// test on the subset's own points (`PointFootprint::with_own_test`) cap it (`SUBSET_SLACK`)
/// and hold those out, as the whole input's test does; inside the squares both accept, and the
/// own test answers as an MPU over the subset alone does (its oracle).
#[test]
fn a_thin_feature_does_not_open_its_gaps_to_an_unmeasured_subset() {
    let h = 0.0125;
    let mut rng = Pcg64Mcg::seed_from_u64(9);
    let points: Vec<OrientedPoint> = jittered_patch(81, h, &mut rng)
        .into_iter()
        .filter(|p| p.p.x < 0.3 || p.p.x > 0.7 || (p.p.y - 0.5).abs() < 0.6 * h)
        .collect();
    let (whole, subset) = whole_and_every_fourth(&points);
    let frame = *whole.frame();
    let lenient = vec![PointFootprint::unmeasured(h).thinned_to(0.25, 0); subset.len()];
    let own_test: Vec<_> = lenient.iter().map(|f| f.with_own_test()).collect();
    let both = [
        subset_mpu(&subset, frame, Some(&lenient)),
        subset_mpu(&subset, frame, Some(&own_test)),
    ];
    let own = subset_mpu(&subset, frame, None);
    // Beside the bridge, where its nearest subset points are the bridge's.
    let mut near_bridge = 0;
    for _ in 0..4_000 {
        let x = DVec3::new(
            0.42 + 0.16 * rng.random::<f64>(),
            0.5 + (0.09 + 0.06 * rng.random::<f64>())
                * if rng.random::<bool>() { 1.0 } else { -1.0 },
            0.0,
        );
        assert!(
            !whole.near_data_from(x, 1.0, 0.0, None).inside,
            "the oracle at {x:?}"
        );
        for thinned in &both {
            assert!(
                !thinned.near_data_from(x, 1.0, 0.0, None).inside,
                "{x:?} in a gap passed"
            );
        }
        // The subset's own spacing on the bridge reaches the gaps (the case this guards).
        let dist = |j: usize| (own.points()[j].p - x).length();
        let q = (0..subset.len())
            .min_by(|&a, &b| dist(a).total_cmp(&dist(b)))
            .unwrap();
        near_bridge += usize::from(dist(q) <= own.input_spacing(q as u32));
    }
    assert!(near_bridge > 400, "{near_bridge}: the case this guards");
    for _ in 0..4_000 {
        let x = in_square(0.05, 0.9, &mut rng);
        // Inside the squares, away from the bridge (whose points' spacing is capped).
        if x.x < 0.25 || x.x > 0.75 {
            let got = both[1].near_data_from(x, 1.0, 0.0, None).inside;
            assert_eq!(got, own.near_data_from(x, 1.0, 0.0, None).inside, "{x:?}");
            assert!(got, "{x:?} inside a square");
            assert!(both[0].near_data_from(x, 1.0, 0.0, None).inside, "{x:?}");
        }
    }
}

/// On a random sampling (uniform points on a square: the unmeasured case, whose seeming edges
/// are too many for a band), a hashed subset is as random as the input, and its unmeasured
/// points answer as an MPU over the subset alone does (the oracle): the distance part rejects
/// positions in the subset's own gaps, a few in a hundred, as the whole test does on the whole
/// input, where the lenient test on distances alone accepts nearly all of them.
#[test]
fn an_unmeasured_subset_of_a_random_sampling_tests_as_the_subset_alone() {
    let mut rng = Pcg64Mcg::seed_from_u64(13);
    let points: Vec<OrientedPoint> = (0..40_000)
        .map(|_| OrientedPoint {
            p: DVec3::new(rng.random::<f64>(), rng.random::<f64>(), 0.0),
            n: DVec3::Z,
        })
        .collect();
    let (whole, subset) = whole_and_every_fourth(&points);
    let frame = *whole.frame();
    let mut spacings: Vec<f64> = (0..2_000u32).map(|q| whole.input_spacing(q * 7)).collect();
    spacings.sort_by(f64::total_cmp);
    let lenient = PointFootprint::unmeasured(spacings[1_000]).thinned_to(0.25, 0);
    let carried = vec![lenient.with_own_test(); subset.len()];
    let thinned = subset_mpu(&subset, frame, Some(&carried));
    let own = subset_mpu(&subset, frame, None);
    let lenient = subset_mpu(&subset, frame, Some(&vec![lenient; subset.len()]));
    let (mut agree, mut rejected, mut lenient_rejected, tests) = (0, 0, 0, 20_000);
    for _ in 0..tests {
        let x = in_square(0.1, 0.8, &mut rng);
        let expected = own.near_data_from(x, 1.0, 0.0, None).inside;
        agree += usize::from(thinned.near_data_from(x, 1.0, 0.0, None).inside == expected);
        rejected += usize::from(!expected);
        lenient_rejected += usize::from(!lenient.near_data_from(x, 1.0, 0.0, None).inside);
    }
    // The cap on a point's spacing (twice the rate's) only binds where the subset is sparsest.
    assert!(agree as f64 >= 0.995 * tests as f64, "{agree} of {tests}");
    assert!(
        rejected > tests / 100 && rejected < tests / 10,
        "{rejected} of {tests} rejected"
    );
    assert!(
        lenient_rejected < rejected / 4,
        "lenient {lenient_rejected}"
    );
}
