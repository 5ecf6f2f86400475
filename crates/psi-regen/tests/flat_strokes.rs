//! Strokes over a flat region under the ceiling on spacing: the region stays covered as a
//! sampling from scratch covers it, the count follows the area, colours follow the points, and
//! deferred strokes equal eager ones. Oracles: brute-force point-to-particle distances, the
//! particles before the stroke, the eager session.

use glam::DVec3;
use psi_mpu::MpuParams;
use psi_octree::{Monitor, OrientedPoint, PointAttributes};
use psi_particles::{MAX_SPACING, ParticleParams};
use psi_regen::{Edit, FRAME_ITERATIONS, Scene};

/// A uniform number in [0, 1) from `state` (splitmix64, seeded).
fn uniform(state: &mut u64) -> f64 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    (z ^ (z >> 31)) as f64 / 2f64.powi(64)
}

/// `n` points on the unit square in z = 0, normals +z, coloured by side (x < 0.5 red).
fn sheet(n: usize, seed: u64) -> (Vec<OrientedPoint>, PointAttributes) {
    let mut state = seed;
    let points: Vec<OrientedPoint> = (0..n)
        .map(|_| OrientedPoint {
            p: DVec3::new(uniform(&mut state), uniform(&mut state), 0.0),
            n: DVec3::Z,
        })
        .collect();
    let colors = points
        .iter()
        .map(|p| {
            if p.p.x < 0.5 {
                [200, 0, 0]
            } else {
                [0, 0, 200]
            }
        })
        .collect();
    let attributes = PointAttributes {
        colors: Some(colors),
        ..Default::default()
    };
    (points, attributes)
}

fn scene(points: &[OrientedPoint], attributes: &PointAttributes) -> Scene {
    let params = ParticleParams {
        iterations: 10,
        ..ParticleParams::paper()
    };
    Scene::new_with(
        points.to_vec(),
        attributes.clone(),
        &MpuParams::paper(),
        &params,
        &Monitor::silent(),
    )
    .unwrap()
    .0
}

/// The largest distance from an input point of `scene` to its nearest particle, over the
/// ceiling.
fn farthest_point(scene: &Scene) -> f64 {
    let p = &scene.particles().positions;
    let ceiling = MAX_SPACING * scene.mpu().diagonal();
    scene
        .points()
        .iter()
        .map(|q| {
            p.iter()
                .map(|x| x.distance(q.p))
                .fold(f64::INFINITY, f64::min)
        })
        .fold(0.0, f64::max)
        / ceiling
}

fn strokes() -> Vec<Edit> {
    vec![
        Edit::Brush {
            center: DVec3::new(0.5, 0.5, 0.0),
            radius: 0.15,
            displacement: DVec3::new(0.0, 0.0, 0.02),
        },
        Edit::Brush {
            center: DVec3::new(0.55, 0.5, 0.02),
            radius: 0.15,
            displacement: DVec3::new(0.03, 0.0, 0.0),
        },
        Edit::Remove {
            center: DVec3::new(0.2, 0.3, 0.0),
            radius: 0.1,
        },
    ]
}

#[test]
fn strokes_over_a_flat_region_keep_it_covered_and_its_count() {
    let (points, attributes) = sheet(20_000, 11);
    let mut scene = scene(&points, &attributes);
    assert!(scene.density().cap.is_some(), "the sheet needs the ceiling");
    let before = farthest_point(&scene);
    assert!(before <= 1.0, "{before}");
    for edit in &strokes() {
        let old = scene.particles().clone();
        let report = scene.apply(edit).unwrap();
        assert!(report.particles_regenerated > 0);
        let after = farthest_point(&scene);
        eprintln!("{edit:?}: farthest input point {after:.2} ceilings from a particle");
        assert!(after <= 1.0, "{after}");
        // A brush keeps the count (the sheet's area barely changes); a removal lowers it.
        let ratio = scene.particles().len() as f64 / old.len() as f64;
        match edit {
            Edit::Brush { .. } => assert!((0.9..=1.1).contains(&ratio), "{ratio}"),
            _ => assert!((0.8..1.0).contains(&ratio), "{ratio}"),
        }
        // Colours follow the sides.
        let colors = scene.particle_attributes().colors.as_ref().unwrap();
        for (x, c) in scene.particles().positions.iter().zip(colors) {
            if (x.x - 0.5).abs() > 0.1 {
                assert_eq!(*c, if x.x < 0.5 { [200, 0, 0] } else { [0, 0, 200] });
            }
        }
    }
    // The removed ball holds no particle.
    let hole = DVec3::new(0.2, 0.3, 0.0);
    assert!(
        scene
            .particles()
            .positions
            .iter()
            .all(|x| x.distance(hole) > 0.05)
    );
}

#[test]
fn deferred_flat_strokes_equal_eager_ones_bitwise() {
    let (points, attributes) = sheet(12_000, 12);
    let mut eager = scene(&points, &attributes);
    let mut deferred = eager.clone();
    for edit in &strokes() {
        eager.apply(edit).unwrap();
        deferred
            .apply_deferred(
                edit,
                &PointAttributes::default(),
                FRAME_ITERATIONS,
                &Monitor::silent(),
            )
            .unwrap();
    }
    deferred.settle(usize::MAX);
    assert_eq!(eager.particles(), deferred.particles());
    assert_eq!(eager.particle_attributes(), deferred.particle_attributes());
}
