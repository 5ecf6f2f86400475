use psi_mpu::{BuildOptions, Mpu, MpuParams};
use psi_octree::Monitor;
use psi_particles::{ParticleParams, sample};
use psi_shapes::AnalyticShape;
use psi_tiles::{TileParams, decide_tiled};
use std::time::Instant;
#[test]
#[ignore]
fn timing() {
    let n: usize = std::env::var("TN").map_or(1_000_000, |v| v.parse().unwrap());
    let points = if std::env::var("TB").is_ok() {
        psi_shapes::sample_builtin(n, 1)
    } else {
        AnalyticShape::Torus {
            major: 1.0,
            minor: 0.35,
        }
        .sample(n, 9)
    };
    let mp = MpuParams::paper();
    let t = Instant::now();
    let whole = Mpu::build(&points, &mp).unwrap();
    eprintln!(
        "build {:.3}s cells {}",
        t.elapsed().as_secs_f64(),
        whole.octree().cells().len()
    );
    let t = Instant::now();
    let s = sample(&whole, &ParticleParams::paper());
    eprintln!(
        "sample {:.3}s particles {}",
        t.elapsed().as_secs_f64(),
        s.particles.len()
    );
    let t = Instant::now();
    let tp = TileParams {
        depth: std::env::var("TD").map_or(2, |v| v.parse().unwrap()),
        halo: std::env::var("TH").map_or(0.25, |v| v.parse().unwrap()),
        shared_levels: std::env::var("TS").map_or(2, |v| v.parse().unwrap()),
    };
    let d = decide_tiled(&points, &mp, &tp, &Monitor::silent()).unwrap();
    eprintln!(
        "decide tiled {:.3}s {:?}",
        t.elapsed().as_secs_f64(),
        (
            d.report.top_seconds,
            d.report.tile_seconds,
            d.report.halos_grown,
            d.report.balls_fetched,
            d.report.crossing_cells,
            d.report.cells
        )
    );
    for (i, (a, b)) in d
        .report
        .points_per_tile
        .iter()
        .zip(&d.report.halo_points)
        .enumerate()
    {
        if *b > 0 {
            eprintln!("tile {i}: {a} own, {b} gathered");
        }
    }
    let t = Instant::now();
    let opts = BuildOptions {
        frame: Some(d.frame),
        known_cells: Some(&d.cells),
        ..Default::default()
    };
    let a = Mpu::build_with(&points, &mp, opts).unwrap();
    eprintln!("assemble {:.3}s", t.elapsed().as_secs_f64());
    drop(a);
}
