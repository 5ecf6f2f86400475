//! Tests of the preprocessing stage as a whole ([`super::preprocess`]).

use super::*;
use psi_shapes::{AnalyticShape, gaussian_vector};
use rand::SeedableRng;
use rand_pcg::Pcg64Mcg;

/// A sphere of 20 000 points with noise of 0.6 sample spacings (enough to raise ε0 and to
/// call for denoising) and 50 points strewn around it.
fn noisy_sphere_with_strays() -> Vec<OrientedPoint> {
    let sphere = AnalyticShape::Sphere { radius: 1.0 };
    let spacing = (sphere.area() / 20_000.0).sqrt();
    let mut rng = Pcg64Mcg::seed_from_u64(5);
    let mut points: Vec<OrientedPoint> = sphere
        .sample(20_000, 4)
        .into_iter()
        .map(|p| OrientedPoint {
            p: p.p + 0.6 * spacing * gaussian_vector(&mut rng),
            n: p.n,
        })
        .collect();
    for i in 0..50 {
        let d = gaussian_vector(&mut rng).normalize();
        let r = if i % 2 == 0 { 0.5 } else { 1.5 };
        points.push(OrientedPoint { p: r * d, n: d });
    }
    points
}

/// The same points as a scan lose their strays and are denoised; as a mesh's vertices they
/// are kept as they are, with the paper's threshold.
#[test]
fn a_meshs_points_are_neither_pruned_nor_denoised() {
    let points = noisy_sphere_with_strays();
    let run = |origin| {
        let input = ScanInput {
            points: points.clone(),
            normals_given: true,
            origin,
        };
        preprocess(input, &PreprocessParams::scan()).unwrap()
    };
    let scan = run(PointOrigin::Scan);
    assert!(
        scan.report.outliers.unwrap().removed >= 40,
        "{:?}",
        scan.report
    );
    assert!(scan.report.denoised.is_some());
    let mesh = run(PointOrigin::MeshVertices);
    assert_eq!(mesh.report.outliers, None);
    assert_eq!(mesh.report.denoised, None);
    assert_eq!(mesh.report.error_rel, PAPER_ERROR_REL);
    assert_eq!(mesh.points, points);
}

/// Given normals of which a third point inward are not denoised as they are (each point
/// would see few neighbours on its side); reoriented first, they are.
#[test]
fn inconsistent_given_normals_are_denoised_only_once_reoriented() {
    let mut points = noisy_sphere_with_strays();
    for p in points.iter_mut().step_by(3) {
        p.n = -p.n;
    }
    let run = |orient_given_normals| {
        let input = ScanInput {
            points: points.clone(),
            normals_given: true,
            origin: PointOrigin::Scan,
        };
        let params = PreprocessParams {
            orient_given_normals,
            ..PreprocessParams::scan()
        };
        preprocess(input, &params).unwrap().report
    };
    let as_given = run(false);
    let opposed = as_given.consistency.unwrap().opposed_fraction();
    assert!(opposed > INCONSISTENT_NORMALS);
    assert_eq!(as_given.inconsistent_normals(), Some(opposed));
    assert_eq!(as_given.denoised, None);
    assert!(as_given.error_rel > PAPER_ERROR_REL);
    let reoriented = run(true);
    assert!(reoriented.denoised.is_some());
    assert_eq!(reoriented.inconsistent_normals(), None);
}

/// Every point passed on names the input point it came from: the strays left out are named by
/// no point, the others keep their order, and without denoising each sits where its source
/// was; estimated normals keep the mapping too.
#[test]
fn sources_name_the_input_points_kept() {
    let points = noisy_sphere_with_strays();
    for normals_given in [true, false] {
        let mut input_points = points.clone();
        if !normals_given {
            for p in &mut input_points {
                p.n = DVec3::ZERO;
            }
        }
        let params = PreprocessParams {
            denoise: false,
            ..PreprocessParams::scan()
        };
        let input = ScanInput {
            points: input_points,
            normals_given,
            origin: PointOrigin::Scan,
        };
        let done = preprocess(input, &params).unwrap();
        assert_eq!(done.source.len(), done.points.len());
        assert!(done.source.windows(2).all(|w| w[0] < w[1]));
        for (p, &s) in done.points.iter().zip(&done.source) {
            assert_eq!(p.p, points[s as usize].p);
        }
        // The 50 strays are the last points: most are left out, so not named.
        let strays_named = done.source.iter().filter(|&&s| s >= 20_000).count();
        assert!(strays_named < 10, "{strays_named} strays kept");
    }
}

/// A coarse mesh's added points name their own triangle's point.
#[test]
fn densified_points_name_their_triangle() {
    // Two large triangles, one degenerate between them (no point of its own).
    let vertices = [
        DVec3::ZERO,
        DVec3::new(4.0, 0.0, 0.0),
        DVec3::new(0.0, 4.0, 0.0),
        DVec3::new(4.0, 4.0, 0.0),
    ];
    let faces = [[0, 1, 2], [1, 1, 3], [1, 3, 2]];
    let (extra, from) = crate::densify_mesh_with_sources(&vertices, &faces, 0.5);
    assert_eq!(extra.len(), from.len());
    for (p, &t) in extra.iter().zip(&from) {
        // Triangle 0's point is point 0; the third face's point is point 1.
        let expected = if p.p.x + p.p.y < 4.0 { 0 } else { 1 };
        assert_eq!(t, expected, "{p:?}");
    }
}

/// Stray clumps that support themselves leave with the outliers, counted apart; every point
/// of the surface stays, named by its source.
#[test]
fn stray_clumps_are_left_out_with_the_outliers() {
    let sphere = AnalyticShape::Sphere { radius: 1.0 };
    let mut points = sphere.sample(30_000, 8);
    let d = 2.0 * 3f64.sqrt();
    let mut rng = Pcg64Mcg::seed_from_u64(9);
    // 20 points 5 % D off the surface, 100 points 8 % D off it.
    for (k, (size, offset)) in [(20, 0.05), (100, 0.08)].into_iter().enumerate() {
        let base = points[k * 1000];
        for _ in 0..size {
            let n = gaussian_vector(&mut rng).normalize();
            let p = base.p + offset * d * base.n + 0.002 * d * n;
            points.push(OrientedPoint { p, n });
        }
    }
    let input = ScanInput {
        points: points.clone(),
        normals_given: true,
        origin: PointOrigin::Scan,
    };
    let done = preprocess(input, &PreprocessParams::scan()).unwrap();
    let o = done.report.outliers.unwrap();
    assert!(o.clumps > 0, "{o:?}");
    assert_eq!(o.removed, o.far + o.off_surface + o.clumps);
    assert_eq!(done.report.points_out, points.len() - o.removed);
    assert_eq!(done.source.len(), done.points.len());
    assert_eq!(done.source[..30_000], (0..30_000).collect::<Vec<u32>>());
    assert_eq!(done.source.len(), 30_000, "clump points kept");
    for (p, &s) in done.points.iter().zip(&done.source) {
        assert_eq!(p.p, points[s as usize].p);
    }
}

/// The one Morton index carried through the steps (retained as points are dropped) gives what
/// each public step gives with its own index: the same outliers, clumps, estimated and oriented
/// normals, noise and normal check, x y z only and with normals reoriented.
#[test]
fn the_carried_index_answers_as_each_steps_own() {
    let mut points = noisy_sphere_with_strays();
    let mut rng = Pcg64Mcg::seed_from_u64(3);
    let base = points[500];
    for _ in 0..30 {
        let p = base.p + 0.25 * base.n + 0.01 * gaussian_vector(&mut rng);
        points.push(OrientedPoint { p, n: base.n });
    }
    let positions = |pts: &[OrientedPoint]| pts.iter().map(|p| p.p).collect::<Vec<_>>();
    let params = PreprocessParams {
        denoise: false,
        orient_given_normals: true,
        ..PreprocessParams::scan()
    };
    for normals_given in [false, true] {
        let mut expected = points.clone();
        if !normals_given {
            expected.iter_mut().for_each(|p| p.n = DVec3::ZERO);
        }
        let done = preprocess(
            ScanInput {
                points: expected.clone(),
                normals_given,
                origin: PointOrigin::Scan,
            },
            &params,
        )
        .unwrap();
        // Step by step, each with its own index.
        let given = normals_given.then(|| expected.iter().map(|p| p.n).collect::<Vec<_>>());
        let found = crate::find_outliers(&positions(&expected), given.as_deref());
        let mut keep = found.mask.iter();
        expected.retain(|_| !keep.next().unwrap());
        let clumps = crate::find_clumps(&positions(&expected));
        assert!(clumps.points > 0, "no clump to drop");
        let mut keep = clumps.mask.iter();
        expected.retain(|_| !keep.next().unwrap());
        if normals_given {
            let check = crate::check_normal_consistency(&expected, 20_000);
            assert_eq!(done.report.consistency, Some(check));
            crate::orient_normals(&mut expected);
        } else {
            let normals = crate::estimate_normals(&positions(&expected));
            expected.iter_mut().zip(normals).for_each(|(p, n)| p.n = n);
            expected.retain(|p| p.n != DVec3::ZERO);
            crate::orient_normals(&mut expected);
        }
        let noise = crate::estimate_noise(&positions(&expected));
        assert_eq!(done.report.noise, Some(noise));
        assert_eq!(done.points, expected, "normals given: {normals_given}");
    }
}

/// A scan whose every point comes 20 times (copies interleaved, and the first copies with
/// another normal) is prepared as the scan once: the same points and sources (each the first
/// copy's input index), the repeats counted. At 16 copies or more the outlier search, given
/// the repeats, took nearly every point for an outlier (all 16 nearest at distance 0).
#[test]
fn repeated_points_count_once() {
    let sphere = AnalyticShape::Sphere { radius: 1.0 };
    let once: Vec<OrientedPoint> = sphere.sample(2_000, 9);
    let copies = 20;
    let mut repeated = Vec::with_capacity(copies * once.len());
    for k in 0..copies {
        // (A later copy's normal differs: the first copy's is kept.)
        let flip = if k == 0 { 1.0 } else { -1.0 };
        repeated.extend(once.iter().map(|p| OrientedPoint {
            p: p.p,
            n: flip * p.n,
        }));
    }
    let run = |points: Vec<OrientedPoint>, normals_given| {
        let input = ScanInput {
            points,
            normals_given,
            origin: PointOrigin::Scan,
        };
        preprocess(input, &PreprocessParams::scan()).unwrap()
    };
    for normals_given in [true, false] {
        let a = run(once.clone(), normals_given);
        let b = run(repeated.clone(), normals_given);
        assert_eq!(a.report.repeated, 0);
        assert_eq!(b.report.repeated, (copies - 1) * once.len());
        assert_eq!(b.points, a.points, "normals given: {normals_given}");
        assert_eq!(b.source, a.source);
        assert!(a.points.len() > 1_900, "{}", a.points.len());
    }
}
