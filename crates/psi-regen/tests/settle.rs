//! Deferred strokes against their oracle, the same session applied eagerly: a stroke that runs
//! a few iterations in its frame and settles over later calls gives bitwise the eager particles
//! and attributes, whatever the split and the thread count.

use glam::DVec3;
use psi_mpu::MpuParams;
use psi_octree::{Monitor, OrientedPoint, PointAttributes};
use psi_particles::{DensityMode, ParticleParams};
use psi_regen::{Edit, FRAME_ITERATIONS, Scene};
use psi_shapes::AnalyticShape;

/// A torus with colours and a drag of `strokes` brushes along its outer equator.
fn torus_session(strokes: usize) -> (Vec<OrientedPoint>, PointAttributes, Vec<Edit>) {
    let points = AnalyticShape::Torus {
        major: 1.0,
        minor: 0.35,
    }
    .sample(6000, 5);
    let attributes = PointAttributes {
        colors: Some(
            points
                .iter()
                .map(|p| {
                    if p.p.y < 0.0 {
                        [200, 0, 0]
                    } else {
                        [0, 0, 200]
                    }
                })
                .collect(),
        ),
        ..Default::default()
    };
    let edits = (0..strokes)
        .map(|k| {
            let a = 0.25 * k as f64;
            let dir = DVec3::new(a.cos(), a.sin(), 0.0);
            Edit::Brush {
                center: 1.35 * dir,
                radius: 0.3,
                displacement: 0.02 * if k % 2 == 0 { dir } else { DVec3::Z },
            }
        })
        .collect();
    (points, attributes, edits)
}

fn scene(points: &[OrientedPoint], attributes: &PointAttributes, params: &ParticleParams) -> Scene {
    Scene::new_with(
        points.to_vec(),
        attributes.clone(),
        &MpuParams::paper(),
        params,
        &Monitor::silent(),
    )
    .unwrap()
    .0
}

/// The bits of a scene's particles and their attributes.
/// Positions and normals as bits, depths, colours.
type Bits = (Vec<[u64; 6]>, Vec<u8>, Option<Vec<[u8; 3]>>);

fn bits(scene: &Scene) -> Bits {
    let p = scene.particles();
    let xs = p
        .positions
        .iter()
        .zip(&p.normals)
        .map(|(x, n)| {
            [
                x.x.to_bits(),
                x.y.to_bits(),
                x.z.to_bits(),
                n.x.to_bits(),
                n.y.to_bits(),
                n.z.to_bits(),
            ]
        })
        .collect();
    (
        xs,
        p.depth.clone(),
        scene.particle_attributes().colors.clone(),
    )
}

/// Applies `edits` deferred, running `frame` iterations per stroke and `settle[k]` iterations
/// after stroke k (cycled), then settles what is left.
fn deferred(scene: &mut Scene, edits: &[Edit], frame: usize, settle: &[usize]) {
    let silent = Monitor::silent();
    let none = PointAttributes::default();
    for (k, e) in edits.iter().enumerate() {
        let r = scene.apply_deferred(e, &none, frame, &silent).unwrap();
        assert_eq!(r.pending_iterations, scene.pending_iterations());
        let s = scene.settle(settle[k % settle.len()]);
        assert_eq!(s.pending_iterations, scene.pending_iterations());
        // Attributes stay aligned with the particles while settling.
        assert!(scene.particle_attributes().fits(scene.particles().len()));
    }
    scene.settle(usize::MAX);
    assert_eq!(scene.pending_iterations(), 0);
}

#[test]
fn deferred_sessions_equal_the_eager_session_bitwise() {
    let (points, attributes, edits) = torus_session(6);
    let params = ParticleParams::paper();
    let mut eager = scene(&points, &attributes, &params);
    let before = bits(&eager);
    for e in &edits {
        let r = eager.apply(e).unwrap();
        assert_eq!(r.pending_iterations, 0);
        assert!(r.particles_regenerated > 0);
    }
    let expected = bits(&eager);
    assert_ne!(
        expected.0, before.0,
        "the strokes must change the particles"
    );
    // Several ways of splitting the same iterations: none settled between strokes, a few,
    // all, and a frame that runs everything.
    for (frame, settle) in [
        (FRAME_ITERATIONS, vec![0]),
        (1, vec![2, 0, 7]),
        (0, vec![usize::MAX]),
        (3, vec![5, 30]),
        (usize::MAX, vec![0]),
    ] {
        let mut s = scene(&points, &attributes, &params);
        deferred(&mut s, &edits, frame, &settle);
        assert_eq!(bits(&s), expected, "frame {frame}, settle {settle:?}");
    }
}

#[test]
fn a_stroke_left_settling_shows_part_way_particles_and_then_settles() {
    let (points, attributes, edits) = torus_session(1);
    let params = ParticleParams::paper();
    let mut s = scene(&points, &attributes, &params);
    let silent = Monitor::silent();
    let r = s
        .apply_deferred(&edits[0], &PointAttributes::default(), 2, &silent)
        .unwrap();
    assert_eq!(r.pending_iterations, params.iterations - 2);
    let part_way = bits(&s);
    let step = s.settle(5);
    assert_eq!(step.iterations, 5);
    assert_eq!(step.pending_iterations, params.iterations - 7);
    assert_ne!(
        bits(&s).0,
        part_way.0,
        "settling moves the regenerated particles"
    );
    let rest = s.settle(usize::MAX);
    assert_eq!(rest.iterations, params.iterations - 7);
    assert_eq!(s.pending_iterations(), 0);
    // Settled: one more call does nothing.
    let after = bits(&s);
    assert_eq!(s.settle(3).iterations, 0);
    assert_eq!(bits(&s), after);
}

#[test]
fn deferred_sessions_are_the_same_for_one_and_two_threads() {
    let (points, attributes, edits) = torus_session(4);
    // Uniform mode too: its close-pair separation belongs to the finish.
    for params in [
        ParticleParams::paper(),
        ParticleParams {
            density: DensityMode::Uniform,
            ..ParticleParams::paper()
        },
    ] {
        let run = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| {
                let mut s = scene(&points, &attributes, &params);
                deferred(&mut s, &edits, 2, &[3, 0]);
                bits(&s)
            })
        };
        assert_eq!(run(1), run(2));
    }
}

/// A scene's points after a session equal the edits applied in turn to the whole point array
/// by [`Edit::apply`] (the oracle of the brush's own path, which reaches only the points near
/// the brush and keeps the previous stroke's buffers in step), bitwise; a removal and an
/// insertion in between put the buffers out of step and back.
#[test]
fn a_session_moves_exactly_the_points_edit_apply_moves() {
    let (points, _, mut edits) = torus_session(8);
    edits.insert(
        3,
        Edit::Remove {
            center: DVec3::new(-1.35, 0.0, 0.0),
            radius: 0.1,
        },
    );
    edits.insert(
        5,
        Edit::Insert {
            points: vec![OrientedPoint {
                p: DVec3::new(0.0, -1.35, 0.05),
                n: DVec3::Y,
            }],
        },
    );
    let params = ParticleParams {
        iterations: 2,
        ..ParticleParams::paper()
    };
    let mut s = scene(&points, &PointAttributes::default(), &params);
    let mut oracle = s.points().to_vec();
    for (k, e) in edits.iter().enumerate() {
        s.apply(e).unwrap();
        oracle = e.apply(&oracle).unwrap().0;
        let same = s.points().iter().zip(&oracle).all(|(a, b)| {
            a.p.to_array().map(f64::to_bits) == b.p.to_array().map(f64::to_bits)
                && a.n.to_array().map(f64::to_bits) == b.n.to_array().map(f64::to_bits)
        });
        assert!(same && s.points().len() == oracle.len(), "edit {k}");
        // The MPU's bounding box is the points' own.
        let b = psi_octree::Aabb::from_points(oracle.iter().map(|p| p.p)).unwrap();
        assert_eq!(*s.mpu().bounds(), b, "edit {k}");
    }
}
