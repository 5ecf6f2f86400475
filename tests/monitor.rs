//! Progress and interruption across the layers ([`psi::octree::Monitor`]): a monitored run
//! equals an unmonitored one bit for bit, reports each stage monotonically to its total, and a
//! stop flag set part-way (by the observer itself, at a chosen point) ends each long function
//! with `Interrupted` instead of a result.

use std::collections::HashMap;
use std::sync::Mutex;

use psi::mpu::{BuildOptions, polygonize_with};
use psi::octree::{Interrupted, Monitor, StopFlag};
use psi::preprocess::{PointOrigin, PreprocessError, PreprocessParams, ScanInput, preprocess};
use psi::{Mpu, MpuError, MpuParams, OrientedPoint, ParticleParams, PolygonizeParams};

/// Every report, in order.
#[derive(Default)]
struct Log(Mutex<Vec<(String, u64, u64)>>);

impl Log {
    fn push(&self, stage: &str, done: u64, total: u64) {
        self.0.lock().unwrap().push((stage.to_owned(), done, total));
    }

    /// Checks that each stage's reports, in the order made (the layers report from the
    /// calling thread), never decrease, and that every stage reached its total; returns the
    /// stages in the order first seen.
    fn stages_complete(&self) -> Vec<String> {
        let log = self.0.lock().unwrap();
        let mut best: HashMap<&str, (u64, u64)> = HashMap::new();
        let mut order = Vec::new();
        for (stage, done, total) in log.iter() {
            assert!(done <= total, "{stage}: {done} of {total}");
            let e = best.entry(stage).or_insert_with(|| {
                order.push(stage.clone());
                (0, *total)
            });
            assert!(*done >= e.0, "{stage} went back from {} to {done}", e.0);
            e.0 = *done;
        }
        for (stage, (done, total)) in &best {
            assert_eq!(done, total, "{stage} did not reach its total");
        }
        order
    }
}

fn torus(n: usize) -> Vec<OrientedPoint> {
    psi::AnalyticShape::Torus {
        major: 1.0,
        minor: 0.35,
    }
    .sample(n, 7)
}

fn same_mpu(a: &Mpu, b: &Mpu) {
    assert_eq!(a.report().leaves, b.report().leaves);
    for p in a.points().iter().step_by(97) {
        let x = p.p + 0.01 * p.n;
        assert_eq!(a.value_and_gradient(x), b.value_and_gradient(x));
    }
}

#[test]
fn a_monitored_pipeline_equals_a_silent_one_and_reports_every_stage() {
    let points = torus(6000);
    let params = MpuParams::paper();
    let log = Log::default();
    let observe = |s: &str, d: u64, t: u64| log.push(s, d, t);
    let stop = StopFlag::new();
    let monitor = Monitor::new(Some(&observe), Some(&stop));

    let silent = Mpu::build(&points, &params).unwrap();
    let options = BuildOptions {
        monitor,
        ..Default::default()
    };
    let watched = Mpu::build_with(&points, &params, options).unwrap();
    same_mpu(&silent, &watched);

    let mut stages = log.stages_complete();
    for density in [psi::DensityMode::Adaptive, psi::DensityMode::Uniform] {
        let sp = ParticleParams {
            iterations: 6,
            density,
            count: (density == psi::DensityMode::Uniform).then_some(800),
            ..ParticleParams::paper()
        };
        let a = psi::sample(&silent, &sp);
        let run = Log::default();
        let observe = |s: &str, d: u64, t: u64| run.push(s, d, t);
        let monitor = Monitor::new(Some(&observe), Some(&stop));
        let b = psi::particles::sample_with(&silent, &sp, &monitor).unwrap();
        assert_eq!(a.particles, b.particles);
        stages.extend(run.stages_complete());
    }
    let mesh = PolygonizeParams {
        resolution: 48,
        ..PolygonizeParams::standard()
    };
    let a = psi::polygonize(&silent, &mesh);
    let run = Log::default();
    let observe = |s: &str, d: u64, t: u64| run.push(s, d, t);
    let b = polygonize_with(&silent, &mesh, &Monitor::new(Some(&observe), Some(&stop))).unwrap();
    assert_eq!((a.vertices, a.faces), (b.vertices, b.faces));
    stages.extend(run.stages_complete());

    for s in ["mpu", "seed", "relax", "separate", "measure", "mesh"] {
        assert!(
            stages.iter().any(|x| x == s),
            "{s} not reported: {stages:?}"
        );
    }
}

/// Runs `work` with a monitor whose observer sets the stop flag once `stage` reports `at`
/// done; returns its result and every report made, so that a test can check nothing ran on.
fn stopped_at<T>(
    stage: &'static str,
    at: u64,
    work: impl FnOnce(&Monitor<'_>) -> T,
) -> (T, Vec<(String, u64, u64)>) {
    let stop = StopFlag::new();
    let log = Log::default();
    let observe = |s: &str, done: u64, total: u64| {
        log.push(s, done, total);
        if s == stage && done >= at {
            stop.stop();
        }
    };
    let result = work(&Monitor::new(Some(&observe), Some(&stop)));
    (result, log.0.into_inner().unwrap())
}

/// The largest `done` reported for `stage`, and whether any stage after it was reported.
fn reach(log: &[(String, u64, u64)], stage: &str) -> (u64, u64, bool) {
    let first = log
        .iter()
        .position(|r| r.0 == stage)
        .expect("stage reported");
    let done = log
        .iter()
        .filter(|r| r.0 == stage)
        .map(|r| r.1)
        .max()
        .unwrap();
    let total = log[first].2;
    let later = log[first..].iter().any(|r| r.0 != stage);
    (done, total, later)
}

#[test]
fn a_stop_flag_ends_each_long_function_with_interrupted() {
    let points = torus(6000);
    let params = MpuParams::paper();
    let mpu = Mpu::build(&points, &params).unwrap();

    let (built, log) = stopped_at("mpu", 2, |monitor| {
        let options = BuildOptions {
            monitor: *monitor,
            ..Default::default()
        };
        Mpu::build_with(&points, &params, options)
    });
    assert!(matches!(built, Err(MpuError::Interrupted(Interrupted))));
    let (done, total, _) = reach(&log, "mpu");
    assert!(
        done <= 3 && done < total,
        "the build went on to level {done}"
    );

    let sp = ParticleParams {
        iterations: 10,
        ..ParticleParams::paper()
    };
    let (sampled, log) = stopped_at("relax", 3, |m| psi::particles::sample_with(&mpu, &sp, m));
    assert_eq!(sampled.unwrap_err(), Interrupted);
    assert_eq!(reach(&log, "relax"), (3, 10, false));

    let mesh = PolygonizeParams {
        resolution: 48,
        ..PolygonizeParams::standard()
    };
    let (meshed, log) = stopped_at("mesh", 1, |m| polygonize_with(&mpu, &mesh, m));
    assert!(meshed.is_err());
    assert_eq!(reach(&log, "mesh"), (1, 4, false));

    let (prepared, log) = stopped_at("outliers", 1, |m| {
        let input = ScanInput {
            points: points.clone(),
            normals_given: true,
            origin: PointOrigin::Scan,
        };
        psi::preprocess::preprocess_with(input, &PreprocessParams::scan(), m)
    });
    assert!(matches!(prepared, Err(PreprocessError::Interrupted(_))));
    assert_eq!(reach(&log, "outliers"), (1, 1, false));

    // The same input, unstopped, prepares as the silent path does.
    let input = |points: &[OrientedPoint]| ScanInput {
        points: points.to_vec(),
        normals_given: true,
        origin: PointOrigin::Scan,
    };
    let silent = preprocess(input(&points), &PreprocessParams::scan()).unwrap();
    let log = Log::default();
    let observe = |s: &str, d: u64, t: u64| log.push(s, d, t);
    let watched = psi::preprocess::preprocess_with(
        input(&points),
        &PreprocessParams::scan(),
        &Monitor::new(Some(&observe), None),
    )
    .unwrap();
    assert_eq!(silent.points, watched.points);
    assert_eq!(log.stages_complete(), ["outliers", "normals", "noise"]);
}

#[test]
fn an_interrupted_edit_leaves_the_scene_as_it_was() {
    let points = torus(5000);
    let sp = ParticleParams {
        iterations: 4,
        ..ParticleParams::paper()
    };
    let (mut scene, _) = psi::regen::Scene::new(points, &MpuParams::paper(), &sp).unwrap();
    // A first brush, so that the stopped ones take the brush's own path (buffers in step, the
    // footprint table carried over and given back when stopped).
    // (Small brushes: a brush changing few positions carries the table rather than filling
    // a fresh one.)
    let warm = psi::regen::Edit::Brush {
        center: psi::DVec3::new(-1.0, 0.0, 0.35),
        radius: 0.08,
        displacement: psi::DVec3::new(0.0, 0.0, 0.005),
    };
    scene.apply(&warm).unwrap();
    let before = scene.particles().clone();
    let edit = psi::regen::Edit::Brush {
        center: psi::DVec3::new(1.0, 0.0, 0.35),
        radius: 0.08,
        displacement: psi::DVec3::new(0.0, 0.0, 0.005),
    };
    let points_before = scene.points().to_vec();
    // (The stop in the relaxation first: a stop in the build leaves the buffers out of step.)
    for (stage, at) in [("relax", 1), ("mpu", 1)] {
        let (r, _) = stopped_at(stage, at, |m| scene.apply_with(&edit, m));
        assert!(matches!(r, Err(psi::regen::RegenError::Interrupted(_))));
        assert_eq!(scene.particles(), &before);
        assert_eq!(scene.points(), &points_before[..]);
        // The MPU still answers everywhere (its footprint table came back).
        let last = scene.points().len() as u32 - 1;
        assert!(scene.mpu().input_spacing(last) > 0.0);
    }
    // A stop that comes after the edit claimed its commit does not take effect.
    let flag = StopFlag::new();
    let mut copy = scene.clone();
    copy.apply_with(&edit, &Monitor::new(None, Some(&flag)))
        .unwrap();
    assert!(!flag.stop());
    // And the scene still edits as one that was never interrupted.
    let (mut fresh, _) = psi::regen::Scene::new(torus(5000), &MpuParams::paper(), &sp).unwrap();
    fresh.apply(&warm).unwrap();
    scene.apply(&edit).unwrap();
    fresh.apply(&edit).unwrap();
    assert_eq!(scene.particles(), fresh.particles());
    // Its footprint answers as a fresh build's.
    let scratch = scene.rebuild_from_scratch().unwrap();
    for q in 0..scene.points().len() as u32 {
        assert_eq!(scene.mpu().input_spacing(q), scratch.input_spacing(q));
    }
}
