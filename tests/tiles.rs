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
    let mut w = TileWriter::create(&dir.join("store"), frame, 3, 10_000).unwrap();
    for chunk in points.chunks(4096) {
        w.push(chunk).unwrap();
    }
    let store = w.finish().unwrap();
    let decided = decide_store(&store, &params, 0.0, &Monitor::silent()).unwrap();
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
