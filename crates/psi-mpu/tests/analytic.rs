//! MPU accuracy on analytic shapes with exact points and normals; the analytic signed distance
//! is the oracle. Distances are reported relative to the bounding-box diagonal D.

use glam::DVec3;
use psi_mpu::{FitKind, Mpu, MpuParams, PolygonizeParams, polygonize};
use psi_shapes::{AnalyticShape, assert_near};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64Mcg;

struct Case {
    name: &'static str,
    shape: AnalyticShape,
    n: usize,
}

fn slab() -> AnalyticShape {
    // Two parallel sheets 0.02 D apart: a 1 × 1 × t box with t = 0.02·sqrt(2 + t²).
    let t = 0.02 * 2f64.sqrt() / (1.0 - 0.0004f64).sqrt();
    AnalyticShape::Box {
        half: DVec3::new(0.5, 0.5, 0.5 * t),
    }
}

fn cases() -> Vec<Case> {
    vec![
        Case {
            name: "sphere",
            shape: AnalyticShape::Sphere { radius: 1.0 },
            n: 20_000,
        },
        Case {
            name: "ellipsoid",
            shape: AnalyticShape::Ellipsoid {
                radii: DVec3::new(1.0, 0.7, 0.45),
            },
            n: 20_000,
        },
        Case {
            name: "torus",
            shape: AnalyticShape::Torus {
                major: 1.0,
                minor: 0.35,
            },
            n: 30_000,
        },
        Case {
            name: "cube",
            shape: AnalyticShape::Box {
                half: DVec3::splat(0.5),
            },
            n: 30_000,
        },
        Case {
            name: "slab",
            shape: slab(),
            n: 40_000,
        },
    ]
}

fn build(case: &Case) -> (Mpu, f64) {
    let points = case.shape.sample(case.n, 11);
    let mpu = Mpu::build(&points, &MpuParams::paper()).expect("build");
    let d = mpu.diagonal();
    (mpu, d)
}

/// Newton projection of x onto f = 0.
fn project(mpu: &Mpu, mut x: DVec3) -> DVec3 {
    for _ in 0..20 {
        let (f, g) = mpu.value_and_gradient(x);
        if f.abs() < 1e-13 {
            break;
        }
        x -= f / g.length_squared() * g;
    }
    x
}

#[test]
fn sign_is_right_away_from_the_surface() {
    for case in cases() {
        let (mpu, d) = build(&case);
        let b = mpu.bounds();
        let mut rng = Pcg64Mcg::seed_from_u64(3);
        let mut checked = 0;
        for _ in 0..4000 {
            let t = DVec3::new(rng.random(), rng.random(), rng.random());
            let x = b.min - 0.1 * b.extent() + 1.2 * b.extent() * t;
            let sd = case.shape.signed_distance(x);
            if sd.abs() < 0.01 * d {
                continue;
            }
            let f = mpu.value(x);
            assert!(f.is_finite());
            assert_eq!(
                f > 0.0,
                sd > 0.0,
                "{}: sign wrong at {x} (sd {sd}, f {f})",
                case.name
            );
            checked += 1;
        }
        assert!(checked > 1000);
        // Far outside: finite and positive.
        let far = mpu.value(DVec3::splat(50.0));
        assert!(
            far.is_finite() && far > 0.0,
            "{}: far value {far}",
            case.name
        );
    }
}

#[test]
fn gradient_matches_central_differences() {
    for case in cases().into_iter().filter(|c| {
        matches!(
            c.shape,
            AnalyticShape::Sphere { .. }
                | AnalyticShape::Torus { .. }
                | AnalyticShape::Ellipsoid { .. }
        )
    }) {
        let (mpu, d) = build(&case);
        let pts = case.shape.sample(300, 99);
        let h = 1e-6 * d;
        for p in pts {
            let x = p.p + 0.01 * d * p.n;
            let (_, g) = mpu.value_and_gradient(x);
            for k in 0..3 {
                let mut e = DVec3::ZERO;
                e[k] = h;
                let fd = (mpu.value(x + e) - mpu.value(x - e)) / (2.0 * h);
                assert_near!(
                    fd,
                    g[k],
                    1e-5 * g.length().max(1.0),
                    "{}: ∂{k} at {x}",
                    case.name
                );
            }
        }
    }
}

#[test]
fn zero_set_is_close_to_the_true_surface() {
    for case in cases() {
        let (mpu, d) = build(&case);
        let mut rng = Pcg64Mcg::seed_from_u64(5);
        let pts = case.shape.sample(2000, 77);
        let mut sum = 0.0;
        let mut max: f64 = 0.0;
        for p in &pts {
            let off: f64 = rng.random::<f64>() * 0.02 - 0.01;
            let x = project(&mpu, p.p + off * d * p.n);
            let e = case.shape.signed_distance(x).abs() / d;
            sum += e;
            max = max.max(e);
        }
        let mean = sum / pts.len() as f64;
        let r = mpu.report();
        eprintln!(
            "{}: mean {mean:.2e} D, max {max:.2e} D; leaves {} (surface {}), depth {}, fits {:?}, fallbacks {}, {:.2} s",
            case.name, r.leaves, r.surface_leaves, r.max_depth, r.fits, r.fallbacks, r.seconds
        );
        assert!(max <= 1e-3, "{}: max {max:e} D", case.name);
        // Regression bounds just above what the paper's parameters give today.
        let bound = match case.name {
            "sphere" => 2e-4,
            "torus" => 3e-4,
            "ellipsoid" => 2.5e-4,
            "cube" => 1e-6,
            _ => 3.5e-4,
        };
        assert!(
            max <= bound,
            "{}: max {max:e} D above its regression bound {bound:e}",
            case.name
        );
        if matches!(
            case.shape,
            AnalyticShape::Sphere { .. } | AnalyticShape::Torus { .. }
        ) {
            assert!(mean <= 1e-4, "{}: mean {mean:e} D", case.name);
        }
    }
}

#[test]
fn accelerated_evaluation_equals_brute_force() {
    for case in cases() {
        let (mpu, d) = build(&case);
        let b = mpu.bounds();
        let mut rng = Pcg64Mcg::seed_from_u64(8);
        for _ in 0..300 {
            let t = DVec3::new(rng.random(), rng.random(), rng.random());
            let x = b.min - 0.2 * b.extent() + 1.4 * b.extent() * t;
            let (f, g) = mpu.value_and_gradient(x);
            let (fb, gb) = mpu.value_and_gradient_brute_force(x);
            assert_near!(f, fb, 1e-12 * d.max(f.abs()));
            assert_near!((g - gb).length(), 0.0, 1e-12 * g.length().max(1.0));
            assert_near!(mpu.value(x), f, 1e-12 * d.max(f.abs()));
        }
    }
}

#[test]
fn cube_edges_stay_sharp() {
    let case = &cases()[3];
    let (mpu, d) = build(case);
    let mesh = polygonize(
        &mpu,
        &PolygonizeParams {
            resolution: 128,
            newton_steps: 6,
            ..PolygonizeParams::standard()
        },
    );
    assert!(mesh.faces.len() > 1000);
    let mut worst: f64 = 0.0;
    let mut near_edges = 0;
    for v in &mesh.vertices {
        worst = worst.max(case.shape.signed_distance(*v).abs() / d);
        // Vertices within 2 % of D of two faces at once lie along an edge.
        let q = (v.abs() - DVec3::splat(0.5)).abs();
        if [q.x < 0.02, q.y < 0.02, q.z < 0.02]
            .iter()
            .filter(|b| **b)
            .count()
            >= 2
        {
            near_edges += 1;
        }
    }
    eprintln!("cube: worst polygonized vertex {worst:.2e} D, {near_edges} near edges");
    assert!(near_edges > 50);
    assert!(worst <= 2e-3, "worst vertex {worst:e} D");
}

#[test]
fn thin_slab_keeps_both_sheets() {
    let case = &cases()[4];
    let (mpu, d) = build(case);
    // Between the sheets: inside (negative); just beyond each sheet: outside.
    let t = match case.shape {
        AnalyticShape::Box { half } => half.z,
        _ => unreachable!(),
    };
    for (x, y) in [(0.0, 0.0), (0.2, -0.3), (-0.35, 0.1)] {
        assert!(mpu.value(DVec3::new(x, y, 0.0)) < 0.0);
        assert!(mpu.value(DVec3::new(x, y, 2.0 * t)) > 0.0);
        assert!(mpu.value(DVec3::new(x, y, -2.0 * t)) > 0.0);
        let top = project(&mpu, DVec3::new(x, y, 1.5 * t));
        assert!((top.z - t).abs() < 1e-3 * d, "top sheet at {}", top.z);
    }
}

#[test]
fn polygonized_open_cap_has_no_cap_over_the_hole_and_no_stray_vertices() {
    // The upper half of a sphere: the MPU closes it below, the polygonizer must not.
    let points: Vec<_> = AnalyticShape::Sphere { radius: 1.0 }
        .sample(20_000, 5)
        .into_iter()
        .filter(|p| p.p.z > 0.0)
        .collect();
    let mpu = Mpu::build(&points, &MpuParams::paper()).expect("build");
    let mesh = polygonize(
        &mpu,
        &PolygonizeParams {
            resolution: 64,
            ..PolygonizeParams::standard()
        },
    );
    assert!(mesh.faces.len() > 1000);
    let mut used = vec![false; mesh.vertices.len()];
    for f in &mesh.faces {
        for &v in f {
            used[v as usize] = true;
        }
    }
    let stray = used.iter().filter(|u| !**u).count();
    assert_eq!(stray, 0, "{stray} vertices belong to no triangle");
    // Every vertex on the sampled upper half: none on a cap closing the hole (flat or not), none
    // on the lower half the MPU extrapolates.
    for v in &mesh.vertices {
        assert!(
            (v.length() - 1.0).abs() < 1e-2,
            "vertex {v:?} off the sphere"
        );
        assert!(v.z > -0.1, "vertex {v:?} on the extrapolated lower half");
    }
}

#[test]
fn leaf_refit_keeps_the_octree_and_improves_small_scale_fits() {
    // A torus 0.1 across: in world units the cut-offs flatten its fits (fit_unit = Some(1.0)).
    let points = AnalyticShape::Torus {
        major: 0.04,
        minor: 0.014,
    }
    .sample(30_000, 4);
    let with = Mpu::build(&points, &MpuParams::paper()).expect("build");
    let without = Mpu::build(
        &points,
        &MpuParams {
            leaf_refit: false,
            ..MpuParams::paper()
        },
    )
    .expect("build");
    // Same octree: the refit never changes a split decision.
    assert_eq!(with.octree().cells().len(), without.octree().cells().len());
    for (a, b) in with.octree().cells().iter().zip(without.octree().cells()) {
        assert_eq!(
            (a.depth, a.key, a.first_child),
            (b.depth, b.key, b.first_child)
        );
    }
    // Some leaves took the scale-invariant fit, none took a sharp one it did not have.
    let leaves: Vec<u32> = with.leaves().collect();
    let changed = leaves
        .iter()
        .filter(|&&l| with.leaf_function(l) != without.leaf_function(l))
        .count();
    assert!(changed > 0, "no leaf was refitted");
    for &l in &leaves {
        let sharp = |k| matches!(k, Some(FitKind::Edge | FitKind::Corner));
        assert!(!sharp(with.leaf_kind(l)) || sharp(without.leaf_kind(l)));
    }
    // And the surface is closer to the torus at the data.
    let shape = AnalyticShape::Torus {
        major: 0.04,
        minor: 0.014,
    };
    let mean_error = |mpu: &Mpu| {
        let pts = shape.sample(2000, 8);
        pts.iter()
            .map(|p| shape.signed_distance(project(mpu, p.p)).abs())
            .sum::<f64>()
            / pts.len() as f64
    };
    let (e_with, e_without) = (mean_error(&with), mean_error(&without));
    eprintln!("torus 0.1 across: mean error {e_with:.2e} with leaf refit, {e_without:.2e} without");
    assert!(e_with < e_without, "{e_with:e} vs {e_without:e}");
}

#[test]
fn leaf_lookup_and_evaluation_with_a_hint_equal_the_plain_ones() {
    let case = &cases()[2];
    let (mpu, _) = build(case);
    let leaves: Vec<u32> = mpu.leaves().collect();
    let origin = mpu.frame_origin();
    let mut rng = Pcg64Mcg::seed_from_u64(9);
    let mut hinted = 0;
    for k in 0..4000 {
        let leaf = leaves[rng.random_range(0..leaves.len())];
        let cell = *mpu.octree().cell(leaf);
        // Inside the leaf, on its faces and corners (where the octant rule decides), and just
        // outside it.
        let u = DVec3::new(rng.random(), rng.random(), rng.random()) * 2.0 - 1.0;
        let local = match k % 3 {
            0 => u,
            1 => u.signum(),
            _ => u * 1.01,
        };
        let x = origin + cell.center + cell.half * local;
        let hint = match k % 4 {
            0 => Some(leaf),
            1 => Some(leaves[rng.random_range(0..leaves.len())]),
            2 => Some(0), // the root: never a leaf here
            _ => None,
        };
        let got = mpu.leaf_containing_from(x, hint);
        let nan = DVec3::new(f64::NAN, x.y, x.z);
        assert_eq!(mpu.leaf_containing_from(nan, hint), None);
        assert_eq!(got, mpu.leaf_containing(x), "x {x:?} hint {hint:?}");
        hinted += usize::from(hint == Some(leaf) && got == hint);
        // The evaluation with the same guess (right, wrong or none) sums the same leaves as the
        // brute force over all of them.
        let e = mpu.value_and_gradient_from(x, hint);
        let (f, g) = (e.f, e.gradient);
        let (fb, gb) = mpu.value_and_gradient_brute_force(x);
        assert_near!(f, fb, 1e-12 * (1.0 + fb.abs()));
        assert_near!((g - gb).length(), 0.0, 1e-12 * (1.0 + gb.length()));
    }
    assert!(hinted > 200, "the hint was rarely used ({hinted})");
}
