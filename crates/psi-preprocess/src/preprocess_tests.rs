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
