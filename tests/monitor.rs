//! Progress and interruption across the layers ([`psi::octree::Monitor`]): a monitored run
//! equals an unmonitored one bit for bit, reports each stage monotonically to its total, and a
//! stop flag set part-way (by the observer itself, at a chosen point) ends each long function
//! with `Interrupted` instead of a result.

use std::collections::HashMap;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};

use psi::mpu::{BuildOptions, polygonize_with};
use psi::octree::{Interrupted, Monitor};
use psi::preprocess::{PointOrigin, PreprocessError, PreprocessParams, ScanInput, preprocess};
use psi::{Mpu, MpuError, MpuParams, OrientedPoint, ParticleParams, PolygonizeParams};

/// Every report, in order.
#[derive(Default)]
struct Log(Mutex<Vec<(String, u64, u64)>>);

impl Log {
    fn push(&self, stage: &str, done: u64, total: u64) {
        self.0.lock().unwrap().push((stage.to_owned(), done, total));
    }

    /// Checks each stage's reports never decrease (reports may come from several threads, so
    /// only the running maximum is compared) and that every stage reached its total; returns
    /// the stages in the order first seen.
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
            e.0 = e.0.max(*done);
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
    let stop = AtomicBool::new(false);
    let monitor = Monitor::new(Some(&observe), Some(&stop));

    let silent = Mpu::build(&points, &params).unwrap();
    let options = BuildOptions {
        monitor,
        ..Default::default()
    };
    let watched = Mpu::build_with(&points, &params, options).unwrap();
    same_mpu(&silent, &watched);

    for density in [psi::DensityMode::Adaptive, psi::DensityMode::Uniform] {
        let sp = ParticleParams {
            iterations: 6,
            density,
            count: (density == psi::DensityMode::Uniform).then_some(800),
            ..ParticleParams::paper()
        };
        let a = psi::sample(&silent, &sp);
        let b = psi::particles::sample_with(&silent, &sp, &monitor).unwrap();
        assert_eq!(a.particles, b.particles);
    }
    let mesh = PolygonizeParams {
        resolution: 48,
        ..PolygonizeParams::standard()
    };
    let a = psi::polygonize(&silent, &mesh);
    let b = polygonize_with(&silent, &mesh, &monitor).unwrap();
    assert_eq!((a.vertices, a.faces), (b.vertices, b.faces));

    let stages = log.stages_complete();
    for s in ["mpu", "seed", "relax", "separate", "measure", "mesh"] {
        assert!(
            stages.iter().any(|x| x == s),
            "{s} not reported: {stages:?}"
        );
    }
}

/// A monitor whose observer sets the stop flag once `stage` reports `at` done.
fn stop_at<'a>(
    stop: &'a AtomicBool,
    stage: &'static str,
    at: u64,
) -> impl Fn(&str, u64, u64) + Sync + 'a {
    move |s: &str, done: u64, _| {
        if s == stage && done >= at {
            stop.store(true, Ordering::Relaxed);
        }
    }
}

#[test]
fn a_stop_flag_ends_each_long_function_with_interrupted() {
    let points = torus(6000);
    let params = MpuParams::paper();
    let mpu = Mpu::build(&points, &params).unwrap();

    let stop = AtomicBool::new(false);
    let observe = stop_at(&stop, "mpu", 2);
    let options = BuildOptions {
        monitor: Monitor::new(Some(&observe), Some(&stop)),
        ..Default::default()
    };
    let built = Mpu::build_with(&points, &params, options);
    assert!(matches!(built, Err(MpuError::Interrupted(Interrupted))));

    let stop = AtomicBool::new(false);
    let observe = stop_at(&stop, "relax", 3);
    let monitor = Monitor::new(Some(&observe), Some(&stop));
    let sp = ParticleParams {
        iterations: 10,
        ..ParticleParams::paper()
    };
    assert_eq!(
        psi::particles::sample_with(&mpu, &sp, &monitor).unwrap_err(),
        Interrupted
    );

    let stop = AtomicBool::new(false);
    let observe = stop_at(&stop, "mesh", 1);
    let monitor = Monitor::new(Some(&observe), Some(&stop));
    let mesh = PolygonizeParams {
        resolution: 48,
        ..PolygonizeParams::standard()
    };
    assert!(polygonize_with(&mpu, &mesh, &monitor).is_err());

    let stop = AtomicBool::new(false);
    let observe = stop_at(&stop, "outliers", 1);
    let monitor = Monitor::new(Some(&observe), Some(&stop));
    let input = ScanInput {
        points: points.clone(),
        normals_given: true,
        origin: PointOrigin::Scan,
    };
    let prepared = psi::preprocess::preprocess_with(input, &PreprocessParams::scan(), &monitor);
    assert!(matches!(prepared, Err(PreprocessError::Interrupted(_))));

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
    let before = scene.particles().clone();
    let edit = psi::regen::Edit::Brush {
        center: psi::DVec3::new(1.0, 0.0, 0.35),
        radius: 0.3,
        displacement: psi::DVec3::new(0.0, 0.0, 0.02),
    };
    let stop = AtomicBool::new(false);
    let observe = stop_at(&stop, "relax", 1);
    let monitor = Monitor::new(Some(&observe), Some(&stop));
    let r = scene.apply_with(&edit, &monitor);
    assert!(matches!(r, Err(psi::regen::RegenError::Interrupted(_))));
    assert_eq!(scene.particles(), &before);
    // And the scene still edits as one that was never interrupted.
    let (mut fresh, _) = psi::regen::Scene::new(torus(5000), &MpuParams::paper(), &sp).unwrap();
    scene.apply(&edit).unwrap();
    fresh.apply(&edit).unwrap();
    assert_eq!(scene.particles(), fresh.particles());
}
