//! Local regeneration against its oracles: an MPU built from scratch on the edited points, the
//! particles before the edit, and brute-force marking.

use std::collections::BTreeSet;

use glam::DVec3;
use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed};
use psi_mpu::{Mpu, MpuParams};
use psi_octree::OrientedPoint;
use psi_particles::{DensityMode, ParticleParams, RelaxOptions, cover_data, relax, seed_leaves};
use psi_regen::{Edit, Scene, mark_cells, mark_cells_brute_force};
use psi_shapes::AnalyticShape;

fn leaves(mpu: &Mpu) -> BTreeSet<(u8, [u32; 3])> {
    mpu.leaves()
        .map(|l| {
            let c = mpu.octree().cell(l);
            (c.depth, c.key)
        })
        .collect()
}

fn assert_same_mpu(local: &Mpu, scratch: &Mpu) {
    assert_eq!(leaves(local), leaves(scratch), "leaf sets differ");
    // The same points in every cell, in the same order (the local rebuild copies partitions).
    let (lo, so) = (local.octree(), scratch.octree());
    for (i, c) in lo.cells().iter().enumerate() {
        let j = so.cell_at(c.depth, c.key).expect("same cells");
        assert_eq!(
            lo.points_in(i as u32),
            so.points_in(j),
            "cell {:?} {:?}",
            c.depth,
            c.key
        );
    }
    let b = scratch.bounds();
    let d = scratch.diagonal();
    for i in 0..200 {
        let t = DVec3::new(
            (i as f64 * 0.37).fract(),
            (i as f64 * 0.61).fract(),
            (i as f64 * 0.83).fract(),
        );
        let x = b.min - 0.1 * b.extent() + 1.2 * b.extent() * t;
        let (f1, g1) = local.value_and_gradient(x);
        let (f2, g2) = scratch.value_and_gradient(x);
        psi_shapes::assert_near!(f1, f2, 1e-12 * d.max(f2.abs()));
        psi_shapes::assert_near!((g1 - g2).length(), 0.0, 1e-12 * g2.length().max(1.0));
    }
}

/// A scene of `points` with the paper's parameters and `iterations` relaxation steps.
fn scene_of(points: Vec<OrientedPoint>, iterations: usize) -> Scene {
    let params = ParticleParams {
        iterations,
        ..ParticleParams::paper()
    };
    Scene::new(points, &MpuParams::paper(), &params).unwrap().0
}

fn shape(kind: u8) -> Vec<OrientedPoint> {
    match kind % 2 {
        0 => AnalyticShape::Sphere { radius: 1.0 }.sample(5000, 3),
        _ => AnalyticShape::Torus {
            major: 1.0,
            minor: 0.4,
        }
        .sample(6000, 4),
    }
}

fn edits() -> impl Strategy<Value = Edit> {
    let center = 0usize..5000;
    prop_oneof![
        (
            center.clone(),
            0.1f64..0.5,
            (-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0)
        )
            .prop_map(|(i, r, (x, y, z))| {
                Edit::Brush {
                    center: DVec3::new(i as f64, 0.0, 0.0),
                    radius: r,
                    displacement: 0.25 * r * DVec3::new(x, y, z),
                }
            }),
        (center.clone(), 0.05f64..0.3).prop_map(|(i, r)| Edit::Remove {
            center: DVec3::new(i as f64, 0.0, 0.0),
            radius: r
        }),
    ]
}

/// Puts the edit's centre (an index in the strategy) on a point of the shape.
fn place(edit: Edit, points: &[OrientedPoint]) -> Edit {
    let at = |c: DVec3| points[c.x as usize % points.len()].p;
    match edit {
        Edit::Brush {
            center,
            radius,
            displacement,
        } => Edit::Brush {
            center: at(center),
            radius,
            displacement,
        },
        Edit::Remove { center, radius } => Edit::Remove {
            center: at(center),
            radius,
        },
        e => e,
    }
}

fn config() -> Config {
    Config {
        cases: 24,
        rng_seed: RngSeed::Fixed(0x5e6e),
        failure_persistence: None,
        ..Config::default()
    }
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn local_regeneration_equals_a_rebuild_and_leaves_the_rest_alone(
        kind in 0u8..2,
        edit in edits(),
        uniform in proptest::bool::ANY,
    ) {
        let points = shape(kind);
        // Uniform mode also runs the separation pass on the new particles.
        let density = if uniform { DensityMode::Uniform } else { DensityMode::Adaptive };
        let params = ParticleParams { iterations: 5, density, ..ParticleParams::paper() };
        let (mut scene, _) = Scene::new(points.clone(), &MpuParams::paper(), &params).unwrap();
        let edit = place(edit, &points);
        let before = scene.particles().clone();
        let old_mpu = scene.mpu().clone();
        let report = scene.apply(&edit).unwrap();
        prop_assert!(!report.full_rebuild);
        // The MPU equals one built from scratch on the edited points (same frame).
        assert_same_mpu(scene.mpu(), &scene.rebuild_from_scratch().unwrap());
        // Marking equals brute force.
        let (_, changed) = edit.apply(old_mpu.points()).unwrap();
        let marked = mark_cells_brute_force(&old_mpu, &changed);
        prop_assert_eq!(&mark_cells(&old_mpu, &changed), &marked);
        // Which particles must survive, worked out here from brute-force marking: those whose
        // old leaf is unmarked and whose new leaf is a reused (unmarked, pre-existing) cell.
        let old_keys: std::collections::HashMap<(u8, [u32; 3]), usize> =
            old_mpu.octree().cells().iter().enumerate().map(|(i, c)| ((c.depth, c.key), i)).collect();
        let new_mpu = scene.mpu();
        let survives = |x: DVec3| {
            let old_ok = old_mpu.leaf_containing(x).is_some_and(|l| !marked[l as usize]);
            let new_ok = new_mpu.leaf_containing(x).is_some_and(|l| {
                let c = new_mpu.octree().cell(l);
                old_keys.get(&(c.depth, c.key)).is_some_and(|&o| !marked[o])
            });
            old_ok && new_ok
        };
        let keep: Vec<bool> = before.positions.iter().map(|&x| survives(x)).collect();
        let kept = keep.iter().filter(|k| **k).count();
        let after = scene.particles();
        prop_assert_eq!(kept, before.len() - report.particles_removed);
        prop_assert_eq!(after.len(), kept + report.particles_regenerated);
        // The survivors come first, in order, bitwise unchanged in every field.
        let mut expected = before.clone();
        expected.retain_mask(&keep);
        prop_assert_eq!(&after.positions[..kept], &expected.positions[..]);
        prop_assert_eq!(&after.normals[..kept], &expected.normals[..]);
        prop_assert_eq!(&after.depth[..kept], &expected.depth[..]);
        prop_assert_eq!(&after.sigma[..kept], &expected.sigma[..]);
        prop_assert_eq!(&after.target[..kept], &expected.target[..]);
        // Locality, from geometry alone: a particle farther from the brush than its leaf can
        // reach (old and new leaf: the cube's half-diagonal plus the fit radius, plus the brush
        // radius) survives. On these shapes that is a few brush radii for most particles; a
        // coarse leaf's fit reaches farther.
        let (center, radius) = match &edit {
            Edit::Brush { center, radius, .. } | Edit::Remove { center, radius } => (*center, *radius),
            _ => unreachable!(),
        };
        let mut far = 0;
        for (i, x) in before.positions.iter().enumerate() {
            let d = (*x - center).length() - radius;
            if d > reach(&old_mpu, *x) && d > reach(new_mpu, *x) {
                prop_assert!(keep[i], "a particle beyond its leaves' reach was regenerated");
                far += 1;
            }
        }
        prop_assert!(far > before.len() / 4, "only {far} of {} particles out of reach", before.len());
        // New particles meet the full run's adherence figure.
        let d = scene.mpu().diagonal();
        for x in &after.positions[kept..] {
            let (f, g) = scene.mpu().value_and_gradient(*x);
            prop_assert!(f.abs() / g.length() <= 1e-4 * d * (1.0 + 1e-9), "new particle off the surface");
        }
    }
}

#[test]
fn an_edit_of_the_whole_shape_equals_a_full_rebuild() {
    let points = shape(0);
    let mut scene = scene_of(points, 5);
    let report = scene
        .apply(&Edit::Brush {
            center: DVec3::ZERO,
            radius: 3.0,
            displacement: DVec3::new(0.05, 0.0, 0.0),
        })
        .unwrap();
    assert_eq!(report.refit_cells, scene.mpu().octree().cells().len());
    assert_same_mpu(scene.mpu(), &scene.rebuild_from_scratch().unwrap());
}

#[test]
fn a_long_run_of_edits_keeps_equalling_a_rebuild() {
    // Successive local rebuilds share the earlier MPUs' stored functions and compact them now
    // and then: after every edit of a run longer than that cycle (and a removal and an
    // insertion, which renumber the points), the MPU still equals one built from scratch.
    let points = shape(1);
    let mut scene = scene_of(points.clone(), 3);
    for k in 0..12 {
        let p = points[(k * 487) % points.len()];
        let edit = match k {
            5 => Edit::Remove {
                center: p.p,
                radius: 0.15,
            },
            9 => Edit::Insert {
                points: vec![OrientedPoint {
                    p: p.p + 0.01 * p.n,
                    n: p.n,
                }],
            },
            _ => Edit::Brush {
                center: p.p,
                radius: 0.4,
                displacement: 0.04 * p.n * if k % 2 == 0 { 1.0 } else { -1.0 },
            },
        };
        let report = scene.apply(&edit).unwrap();
        assert!(!report.full_rebuild);
        assert_same_mpu(scene.mpu(), &scene.rebuild_from_scratch().unwrap());
    }
}

#[test]
fn sparse_points_rebuild_like_a_fresh_build() {
    // Few points: fit radii grow past their cells, so a marked cell can sit under an unmarked
    // one whose partition the rebuild copies; the cells must still hold their points in the
    // order a fresh build gives.
    let points = AnalyticShape::Sphere { radius: 1.0 }.sample(400, 9);
    for k in 0..8 {
        let mut scene = scene_of(points.clone(), 2);
        let p = points[k * 47];
        scene
            .apply(&Edit::Brush {
                center: p.p,
                radius: 0.3,
                displacement: 0.05 * p.n,
            })
            .unwrap();
        assert_same_mpu(scene.mpu(), &scene.rebuild_from_scratch().unwrap());
    }
}

#[test]
fn brush_normals_follow_the_inverse_transpose() {
    // A plane z = 0 under a brush: the new normal must be orthogonal to the deformed surface,
    // checked by finite differences of the deformation.
    let c = DVec3::new(0.1, 0.0, 0.0);
    let (r, d) = (1.0, DVec3::new(0.0, 0.0, 0.3));
    let edit = Edit::Brush {
        center: c,
        radius: r,
        displacement: d,
    };
    let p = DVec3::new(0.4, 0.3, 0.0);
    let (out, _) = edit.apply(&[OrientedPoint { p, n: DVec3::Z }]).unwrap();
    let deform = |q: DVec3| {
        edit.apply(&[OrientedPoint { p: q, n: DVec3::Z }])
            .unwrap()
            .0[0]
            .p
    };
    let h = 1e-6;
    let tx = (deform(p + DVec3::X * h) - deform(p - DVec3::X * h)) / (2.0 * h);
    let ty = (deform(p + DVec3::Y * h) - deform(p - DVec3::Y * h)) / (2.0 * h);
    psi_shapes::assert_near!(out[0].n.dot(tx), 0.0, 1e-8);
    psi_shapes::assert_near!(out[0].n.dot(ty), 0.0, 1e-8);
    assert!(out[0].n.z > 0.0);
}

#[test]
fn a_failed_edit_leaves_the_scene_unchanged() {
    let mut scene = scene_of(shape(0), 2);
    let before = scene.particles().clone();
    assert!(
        scene
            .apply(&Edit::Remove {
                center: DVec3::ZERO,
                radius: 10.0
            })
            .is_err()
    );
    assert_eq!(scene.particles(), &before);
}

/// A patch of points to insert: a small disc tangent to the shape at point `i`, lifted off it
/// by `lift` along the normal, sampled on a grid, with the normal of the surface there.
fn patch(points: &[OrientedPoint], i: usize, radius: f64, lift: f64) -> Vec<OrientedPoint> {
    let p = points[i % points.len()];
    let t = p.n.any_orthonormal_vector();
    let b = p.n.cross(t);
    let mut out = Vec::new();
    for u in -4i32..=4 {
        for v in -4i32..=4 {
            let (u, v) = (u as f64 / 4.0, v as f64 / 4.0);
            if u * u + v * v <= 1.0 {
                out.push(OrientedPoint {
                    p: p.p + lift * p.n + radius * (u * t + v * b),
                    n: p.n,
                });
            }
        }
    }
    out
}

/// How far from `x` (world units) a change can still alter the fit of the leaf holding `x`:
/// the leaf cube's half-diagonal plus its fit radius (infinite outside the octree).
fn reach(mpu: &Mpu, x: DVec3) -> f64 {
    mpu.leaf_containing(x).map_or(f64::INFINITY, |l| {
        3f64.sqrt() * mpu.octree().cell(l).half + mpu.fit_radius(l)
    })
}

/// One edit of a session: a brush, a removal or an inserted patch, its place an index into the
/// shape's points.
fn session_edit() -> impl Strategy<Value = (u8, usize, f64, (f64, f64, f64))> {
    (
        0u8..3,
        0usize..5000,
        0.1f64..0.4,
        (-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0),
    )
}

fn session_config() -> Config {
    Config {
        cases: 8,
        rng_seed: RngSeed::Fixed(0x5e55),
        failure_persistence: None,
        ..Config::default()
    }
}

proptest! {
    #![proptest_config(session_config())]

    /// A session does not drift: after every edit of a random sequence (brushes, removals,
    /// inserted patches) the MPU equals one built from scratch on the edited points, and the
    /// particles beyond their leaves' reach from the edit are the ones from before, bitwise.
    #[test]
    fn a_session_of_random_edits_keeps_equalling_a_rebuild(
        kind in 0u8..2,
        edits in proptest::collection::vec(session_edit(), 2..5),
    ) {
        let points = shape(kind);
        let mut scene = scene_of(points.clone(), 3);
        for (what, i, r, (x, y, z)) in edits {
            let p = points[i % points.len()];
            let edit = match what {
                0 => Edit::Brush { center: p.p, radius: r, displacement: 0.2 * r * DVec3::new(x, y, z) },
                1 => Edit::Remove { center: p.p, radius: 0.5 * r },
                _ => Edit::Insert { points: patch(&points, i, 0.5 * r, 0.02 * x) },
            };
            let before = scene.particles().clone();
            let old = scene.mpu().clone();
            let report = scene.apply(&edit).unwrap();
            prop_assert!(!report.full_rebuild);
            assert_same_mpu(scene.mpu(), &scene.rebuild_from_scratch().unwrap());
            // Beyond reach: farther from every changed position than the old and new leaves'
            // cube and fit radius can reach.
            let (_, changed) = edit.apply(old.points()).unwrap();
            let after: std::collections::HashSet<[u64; 3]> = scene
                .particles()
                .positions
                .iter()
                .map(|x| x.to_array().map(f64::to_bits))
                .collect();
            let mut far = 0;
            for x in &before.positions {
                let d = changed.iter().map(|c| (*c - *x).length()).fold(f64::INFINITY, f64::min);
                if d > reach(&old, *x) && d > reach(scene.mpu(), *x) {
                    prop_assert!(after.contains(&x.to_array().map(f64::to_bits)), "a far particle changed");
                    far += 1;
                }
            }
            prop_assert!(far > before.len() / 4, "only {far} of {} particles out of reach", before.len());
        }
    }
}

/// An inserted patch and a removed ball, each in a scene, against a scene built from scratch
/// on the edited points: the same MPU, the new particles on the surface, the particles far from
/// the edit untouched, and the count near the full run's.
#[test]
fn removing_a_ball_and_inserting_a_patch_are_local_and_exact() {
    let points = shape(1);
    let spot = points[1234];
    for edit in [
        Edit::Remove {
            center: spot.p,
            radius: 0.2,
        },
        Edit::Insert {
            points: patch(&points, 1234, 0.15, 0.03),
        },
    ] {
        let mut scene = scene_of(points.clone(), 10);
        let before = scene.particles().clone();
        let report = scene.apply(&edit).unwrap();
        assert!(
            report.marked_cells > 0 && report.particles_regenerated > 0,
            "{report:?}"
        );
        assert_same_mpu(scene.mpu(), &scene.rebuild_from_scratch().unwrap());
        let after = scene.particles();
        let far = |x: &DVec3| (*x - spot.p).length() > 1.0;
        let kept: Vec<&DVec3> = before.positions.iter().filter(|x| far(x)).collect();
        let now: Vec<&DVec3> = after.positions.iter().filter(|x| far(x)).collect();
        assert_eq!(kept, now, "{edit:?}: far particles changed");
        // The new particles meet the full run's adherence (1e-4 D); a kept one near the edit,
        // whose own leaf was not refitted, can feel a refitted neighbour's support, but stays
        // within the 2e-3 D of the new surface.
        let d = scene.mpu().diagonal();
        let kept_count = before.len() - report.particles_removed;
        for (k, x) in after.positions.iter().enumerate() {
            let (f, g) = scene.mpu().value_and_gradient(*x);
            let off = f.abs() / g.length() / d;
            let limit = if k >= kept_count { 1e-4 } else { 2e-3 };
            assert!(
                off <= limit * (1.0 + 1e-9),
                "{edit:?}: particle {k} {off:.1e} D off"
            );
        }
        // A scene keeps its first density field (far particles must keep their σ̂), so the
        // count is compared with a from-scratch sampling of the edited points under that field:
        // an edit that creates deeper leaves (the lifted patch) changes a fresh run's depth
        // range, and with it every particle's σ̂.
        let full = sampled_under_field(&scene);
        let ratio = after.len() as f64 / full as f64;
        assert!((0.95..1.05).contains(&ratio), "{edit:?}: {ratio}");
    }
}

/// The particle count of a from-scratch sampling of `scene`'s MPU under `scene`'s density
/// field (every surface leaf seeded, all relaxed, the ceiling on spacing covered): the count
/// local regeneration approximates.
fn sampled_under_field(scene: &Scene) -> usize {
    let mpu = scene.mpu();
    let params = scene.particle_params();
    let mut field = *scene.density();
    let leaves: Vec<u32> = mpu.surface_leaves().collect();
    let mut particles = seed_leaves(mpu, &leaves, &field, params);
    relax(mpu, &mut particles, &field, params, RelaxOptions::default());
    if let Some(ceiling) = field.ceiling {
        cover_data(mpu, &mut particles, 0, &mut field, ceiling, None, params);
    }
    particles.len()
}

/// Attributes follow the points through edits (survivors keep theirs, added points carry the
/// caller's), and particles keep theirs where the edit did not regenerate them; regenerated
/// particles take the colour of the points around them.
#[test]
fn attributes_follow_points_and_particles_through_edits() {
    use psi_octree::{Monitor, PointAttributes};
    let points = AnalyticShape::Torus {
        major: 1.0,
        minor: 0.35,
    }
    .sample(6000, 11);
    let colour = |p: DVec3| {
        if p.x < 0.0 {
            [200, 10, 10]
        } else {
            [10, 10, 200]
        }
    };
    let attributes = PointAttributes {
        colors: Some(points.iter().map(|p| colour(p.p)).collect()),
        intensity: Some((0..points.len()).map(|i| i as f32).collect()),
        classification: None,
    };
    let params = ParticleParams {
        iterations: 4,
        ..ParticleParams::paper()
    };
    let silent = Monitor::silent();
    let (mut scene, _) = Scene::new_with(
        points.clone(),
        attributes,
        &MpuParams::paper(),
        &params,
        &silent,
    )
    .unwrap();
    let check = |scene: &Scene, away: DVec3| {
        let a = scene.attributes();
        assert!(a.fits(scene.points().len()));
        assert!(scene.particle_attributes().fits(scene.particles().len()));
        // Away from x = 0 a particle's colour is its side's.
        let colors = scene.particle_attributes().colors.as_ref().unwrap();
        for (x, c) in scene.particles().positions.iter().zip(colors) {
            if x.x.abs() > 0.3 && (*x - away).length() > 0.3 {
                assert_eq!(*c, colour(*x), "particle at {x}");
            }
        }
    };
    let nowhere = DVec3::splat(1e9);
    check(&scene, nowhere);
    // A removal: the survivors keep their own intensity (their original index).
    let centre = points[10].p;
    scene
        .apply(&Edit::Remove {
            center: centre,
            radius: 0.2,
        })
        .unwrap();
    let kept: Vec<f32> = (0..points.len())
        .filter(|&i| (points[i].p - centre).length() > 0.2)
        .map(|i| i as f32)
        .collect();
    assert_eq!(scene.attributes().intensity.as_ref().unwrap(), &kept);
    check(&scene, nowhere);
    // An insertion carries the caller's attributes; a brush keeps everyone's.
    let before = scene.particles().clone();
    let before_attributes = scene.particle_attributes().clone();
    let new = vec![OrientedPoint {
        p: DVec3::new(1.35, 0.0, 0.0),
        n: DVec3::X,
    }];
    let added = PointAttributes {
        colors: Some(vec![[0, 255, 0]]),
        intensity: None,
        classification: Some(vec![6]),
    };
    let report = scene
        .apply_attributed(&Edit::Insert { points: new }, &added, &silent)
        .unwrap();
    let a = scene.attributes();
    assert_eq!(a.colors.as_ref().unwrap().last(), Some(&[0, 255, 0]));
    assert_eq!(a.intensity.as_ref().unwrap().last(), Some(&0.0));
    let classes = a.classification.as_ref().unwrap();
    assert_eq!(classes.last(), Some(&6));
    assert!(classes[..classes.len() - 1].iter().all(|&c| c == 0));
    // Particles the insertion did not regenerate (the first ones: a regenerated dart may land
    // where one was before, on the same input point) keep their attributes bitwise.
    let colors = scene.particle_attributes().colors.as_ref().unwrap();
    let old_colors = before_attributes.colors.as_ref().unwrap();
    let kept = &scene.particles().positions[..before.len() - report.particles_removed];
    let mut unchanged = 0;
    for (i, x) in before.positions.iter().enumerate() {
        if let Some(j) = kept.iter().position(|y| y == x) {
            assert_eq!(colors[j], old_colors[i]);
            unchanged += 1;
        }
    }
    assert!(unchanged > before.len() / 2);
    // Away from the green point, colours are the sides' still.
    check(&scene, DVec3::new(1.35, 0.0, 0.0));
}

/// A scene's MPU after edits is bitwise the build from scratch of its own points in its frame
/// (the kept points' normals are never renormalised, so every cell fits what a fresh build
/// fits): what lets a pickled scene come back exactly.
#[test]
fn local_rebuilds_are_bitwise_a_build_from_scratch() {
    let points = AnalyticShape::Torus {
        major: 1.0,
        minor: 0.35,
    }
    .sample(5000, 13);
    let mut scene = scene_of(points.clone(), 2);
    let edits = [
        Edit::Brush {
            center: points[5].p,
            radius: 0.3,
            displacement: 0.03 * points[5].n,
        },
        Edit::Remove {
            center: points[900].p,
            radius: 0.1,
        },
        Edit::Insert {
            points: vec![OrientedPoint {
                p: DVec3::new(1.36, 0.0, 0.0),
                n: DVec3::new(3.0, 0.1, 0.0),
            }],
        },
        Edit::Brush {
            center: points[2000].p,
            radius: 0.25,
            displacement: -0.02 * points[2000].n,
        },
    ];
    // The same brush forth and back: its refits read the cells' earlier ball answers.
    let forth = |sign: f64| Edit::Brush {
        center: points[2000].p,
        radius: 0.25,
        displacement: 0.02 * sign * points[2000].n,
    };
    let edits: Vec<Edit> = edits.into_iter().chain([forth(1.0), forth(-1.0)]).collect();
    let mut from_earlier = 0;
    for edit in &edits {
        scene.apply(edit).unwrap();
        from_earlier += scene.mpu().report().balls_from_earlier;
        let scratch = scene.rebuild_from_scratch().unwrap();
        for p in scene.points().iter().step_by(37) {
            let x = p.p + 0.02 * p.n;
            assert_eq!(
                scene.mpu().value_and_gradient(x),
                scratch.value_and_gradient(x)
            );
        }
        assert_same_mpu(scene.mpu(), &scratch);
    }
    assert!(
        from_earlier > 20,
        "{from_earlier} refits read earlier balls"
    );
}

/// The footprint table a brush carries to the next MPU answers as a fresh table does: with
/// every entry filled before each stroke, after the stroke each point's spacing and interior
/// flag equal those of a build from scratch of the edited points, bitwise.
#[test]
fn a_carried_footprint_answers_as_a_fresh_one() {
    let points = AnalyticShape::Torus {
        major: 1.0,
        minor: 0.4,
    }
    .sample(6000, 9);
    let mut scene = scene_of(points, 2);
    for k in 0..6 {
        // Fill every entry, so that a stale one would show.
        let n = scene.points().len() as u32;
        for q in 0..n {
            scene.mpu().input_spacing(q);
        }
        let a = 0.4 * k as f64;
        scene
            .apply(&Edit::Brush {
                center: DVec3::new(1.4 * a.cos(), 1.4 * a.sin(), 0.0),
                // Small: a brush changing few positions carries the table over.
                radius: if k < 4 { 0.1 } else { 0.35 },
                displacement: DVec3::new(0.0, 0.0, if k % 2 == 0 { 0.01 } else { -0.008 }),
            })
            .unwrap();
        let scratch = scene.rebuild_from_scratch().unwrap();
        for q in 0..n {
            assert_eq!(
                scene.mpu().input_spacing(q).to_bits(),
                scratch.input_spacing(q).to_bits(),
                "stroke {k}, point {q}"
            );
            assert_eq!(
                scene.mpu().input_is_interior(q),
                scratch.input_is_interior(q),
                "stroke {k}, point {q}"
            );
        }
    }
}
