//! Issue "Beyond one machine" on real models: the bunny (and the igea) built tile by tile, in
//! memory and through a tile store on disk, equal the build over all points — the same cells,
//! bitwise the same leaf functions, f and ∇f — and sample bitwise the same particles.

mod common;

use psi::mpu::{BuildOptions, MpuFrame};
use psi::octree::Monitor;
use psi::tiles::{TileParams, TileWriter, build_tiled, decide_store};
use psi::{Mpu, MpuParams, ParticleParams, ReadOptions, sample};

#[test]
fn the_bunny_tiled_in_memory_and_from_disk_is_the_whole_build() {
    let Some(path) = common::model("bunny.ply") else {
        return;
    };
    let points = psi::load_points(&path, &ReadOptions::paper())
        .unwrap()
        .points;
    let params = MpuParams::paper();
    let whole = Mpu::build(&points, &params).unwrap();
    let tiles = TileParams {
        depth: 3,
        halo: 0.0,
        ..TileParams::default()
    };
    let (tiled, report) = build_tiled(&points, &params, &tiles, &Monitor::silent()).unwrap();
    assert!(report.count >= 8 && report.crossing_cells > 0 && report.halos_grown > 0);
    assert_eq!(tiled.octree().cells(), whole.octree().cells());
    for l in whole.leaves() {
        assert_eq!(tiled.leaf_function(l), whole.leaf_function(l));
    }
    for p in points.iter().step_by(97) {
        let x = p.p + 0.003 * p.n;
        assert_eq!(tiled.value_and_gradient(x), whole.value_and_gradient(x));
    }
    let a = sample(&whole, &ParticleParams::paper());
    let b = sample(&tiled, &ParticleParams::paper());
    assert_eq!(a.particles.positions, b.particles.positions);

    // Through a store on disk, in chunks as a reader streams them.
    let dir = common::scratch("tiles-bunny");
    let frame = MpuFrame::for_points(&points, &params).unwrap();
    let mut w = TileWriter::create(&dir.join("store"), frame, 3, 10_000, "test").unwrap();
    for chunk in points.chunks(4096) {
        w.push(chunk).unwrap();
    }
    let store = w.finish().unwrap();
    let decided = decide_store(&store, &params, &tiles, &Monitor::silent()).unwrap();
    let options = BuildOptions {
        frame: Some(decided.frame),
        known_cells: Some(&decided.cells),
        ..Default::default()
    };
    let from_disk = Mpu::build_with(&points, &params, options).unwrap();
    assert_eq!(from_disk.octree().cells(), whole.octree().cells());
    for l in whole.leaves() {
        assert_eq!(from_disk.leaf_function(l), whole.leaf_function(l));
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Particles tile by tile on real models: the seeds are bitwise the whole sampling's; with
/// every point in the relaxation the particles are too; with a thinned data test (half, a
/// quarter, a tenth of the points fit: the relaxation's MPU holds the whole input's footprint
/// at the points it keeps, docs/notes/2026-11-27-carried-footprint.md) the count is the same,
/// every particle on the surface and the spacing per level within [`LEVEL_CV_RATIO`] × the
/// whole sampling's, as issue 26 asks.
#[test]
fn real_models_sampled_tile_by_tile_have_the_whole_samplings_seeds_count_and_spacing() {
    for name in ["bunny.ply", "horse.ply", "igea.ply", "armadillo.ply"] {
        let Some(path) = common::model(name) else {
            return;
        };
        sampled_tile_by_tile(&path);
    }
}

/// Per-level spacing CV of a thinned tiled sampling over the whole one's, at most, for levels of
/// at least 1000 particles, when the relaxation holds half the points (issue 26 asks 5 % of
/// runs out of core, whose relaxation holds millions of points: `cargo xtask bench scale`).
/// With a quarter or a tenth of these models of 35 000 to 170 000 points the kept points are
/// only 1 to 4 times the particles, and the lenient test's reach is a fraction of their
/// spacing; where the band along the data's edge then does not fit, the bunny's holes are
/// tested leniently too: those are held to [`LEVEL_CV_RATIO_SPARSE`]. Measured ratios, and the
/// old subset test's: docs/notes/2026-11-27-carried-footprint.md.
const LEVEL_CV_RATIO: f64 = 1.1;
/// See [`LEVEL_CV_RATIO`].
const LEVEL_CV_RATIO_SPARSE: f64 = 1.3;
/// The bound for a level of 100 to 999 particles (see `sampled_tile_by_tile`).
const SMALL_LEVEL_CV_RATIO: f64 = 1.25;

fn sampled_tile_by_tile(path: &std::path::Path) {
    use psi::particles::{initialize, measure_quality};
    use psi::tiles::{PointsInMemory, decide_tiled, sample_tiled};
    let points = psi::load_points(path, &ReadOptions::paper())
        .unwrap()
        .points;
    let mparams = MpuParams::paper();
    // (The thinned relaxation judged alone: the ceiling's darts follow the relaxed positions;
    // `crates/psi-tiles/tests/sample_tiles.rs` checks it tile by tile.)
    let pparams = ParticleParams {
        max_spacing: Some(f64::INFINITY),
        ..ParticleParams::paper()
    };
    let whole = Mpu::build(&points, &mparams).unwrap();
    let expected = sample(&whole, &pparams);
    let tiles = TileParams {
        depth: 2,
        halo: 0.25,
        ..TileParams::default()
    };
    let decisions = decide_tiled(&points, &mparams, &tiles, &Monitor::silent()).unwrap();
    let source = PointsInMemory::new(&points, decisions.frame, tiles.depth);
    let run = |relax_points: usize| {
        sample_tiled(
            &source,
            &decisions,
            &mparams,
            &pparams,
            relax_points,
            &Monitor::silent(),
        )
        .unwrap()
    };
    let exact = run(points.len());
    assert_eq!(exact.seeds, initialize(&whole, &pparams).particles);
    assert_eq!(exact.particles, expected.particles);
    assert!(exact.report.regions >= 8);
    let a = measure_quality(&whole, &expected.particles);
    for (share, ratio) in [
        (2, LEVEL_CV_RATIO),
        (4, LEVEL_CV_RATIO_SPARSE),
        (10, LEVEL_CV_RATIO_SPARSE),
    ] {
        let tiled = run(points.len() / share);
        assert_eq!(tiled.seeds, exact.seeds);
        assert_eq!(tiled.particles.len(), expected.particles.len());
        assert!(tiled.report.relax_points < points.len());
        let b = measure_quality(&whole, &tiled.particles);
        let what = format!("{}, 1/{share} of the points", path.display());
        assert!(
            b.max_surface_distance < 1e-4,
            "{what}: {} D",
            b.max_surface_distance
        );
        for (la, lb) in a.levels.iter().zip(&b.levels) {
            // A CV measured on n spacings has a standard error of about CV/√(2n): 2 % of it
            // at 1000 particles, 6 % at 150, too much to test a bound of 5 % on.
            let bound = if la.spacing.count >= 1000 {
                ratio
            } else {
                SMALL_LEVEL_CV_RATIO
            };
            if la.spacing.count >= 100 {
                assert!(
                    lb.spacing.cv <= bound * la.spacing.cv,
                    "{what}, level {}: {} vs {}",
                    la.depth,
                    lb.spacing.cv,
                    la.spacing.cv
                );
            }
        }
    }
}
