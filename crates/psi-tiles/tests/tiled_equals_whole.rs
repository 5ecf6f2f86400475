//! A tiled build equals the build over all points (the oracle): the same cells, bitwise the
//! same local functions, f and ∇f, and the same particles; with at least 8 tiles, cells whose
//! fit balls cross tile faces, and halos that had to grow.

use glam::DVec3;
use psi_mpu::{Mpu, MpuParams};
use psi_octree::{Monitor, OrientedPoint};
use psi_particles::{ParticleParams, sample};
use psi_shapes::{AnalyticShape, assert_near, gaussian_vector, tolerance::EXACT};
use psi_tiles::{TileParams, TileReport, TiledDecisions, build_tiled, decide_tiled};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64Mcg;

/// Asserts `tiled` is `whole`: cells, leaf functions, f and ∇f at `probes` points around it.
fn assert_same_mpu(tiled: &Mpu, whole: &Mpu, probes: usize, seed: u64) {
    assert_eq!(tiled.octree().cells(), whole.octree().cells());
    for l in whole.leaves() {
        assert_eq!(tiled.leaf_function(l), whole.leaf_function(l), "leaf {l}");
        assert_eq!(tiled.fit_radius(l).to_bits(), whole.fit_radius(l).to_bits());
    }
    let b = whole.bounds();
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    for _ in 0..probes {
        let t = DVec3::new(rng.random(), rng.random(), rng.random());
        let x = b.min + t * (b.max - b.min) * 1.2 - 0.1 * (b.max - b.min);
        let (f, g) = whole.value_and_gradient(x);
        let (ft, gt) = tiled.value_and_gradient(x);
        assert_near!(ft, f, EXACT);
        assert_near!((gt - g).length(), 0.0, EXACT);
    }
}

/// `points` moved by seeded Gaussian noise of deviation `sigma` per axis (world units).
fn noisy(mut points: Vec<OrientedPoint>, sigma: f64) -> Vec<OrientedPoint> {
    let mut rng = Pcg64Mcg::seed_from_u64(8);
    for p in &mut points {
        p.p += sigma * gaussian_vector(&mut rng);
    }
    points
}

/// The decisions of `points` by tiles at depth 2.
fn decided_at_depth_2(points: &[OrientedPoint], params: &MpuParams) -> TiledDecisions {
    decide_tiled(points, params, &TileParams::at_depth(2), &Monitor::silent()).unwrap()
}

/// The tiling's own claims: enough tiles, faces crossed, halos grown when the first is 0.
fn assert_tiling_exercised(report: &TileReport) {
    assert!(report.count >= 8, "{} tiles", report.count);
    assert!(report.crossing_cells > 0, "no fit crosses a tile face");
    assert!(report.halos_grown > 0, "no halo had to grow");
    assert_eq!(report.points_per_tile.len(), report.count);
}

fn run(points: &[OrientedPoint], tiles: &TileParams) -> (Mpu, Mpu, TileReport) {
    let params = MpuParams::paper();
    let whole = Mpu::build(points, &params).unwrap();
    let (tiled, report) = build_tiled(points, &params, tiles, &Monitor::silent()).unwrap();
    (whole, tiled, report)
}

#[test]
fn a_noisy_sphere_tiled_is_the_whole_build_and_samples_the_same_particles() {
    let points = noisy(
        AnalyticShape::Sphere { radius: 1.0 }.sample(20_000, 7),
        2e-3,
    );
    // No first halo and no shared levels (the sphere's octree is shallow): every tile whose
    // fits read outside its cube grows a halo.
    let tiles = TileParams {
        depth: 2,
        halo: 0.0,
        shared_levels: 0,
        max_cells: None,
    };
    let (whole, tiled, report) = run(&points, &tiles);
    assert_tiling_exercised(&report);
    assert_same_mpu(&tiled, &whole, 2000, 1);
    let params = ParticleParams::paper();
    let a = sample(&whole, &params);
    let b = sample(&tiled, &params);
    assert_eq!(a.particles.len(), b.particles.len());
    assert_eq!(
        a.particles.positions, b.particles.positions,
        "particles bitwise equal"
    );
}

#[test]
fn a_torus_at_depth_three_and_an_offset_frame_tile_exactly() {
    // Far from the origin: the local frame must keep the tiles' fits exact too.
    let mut points = AnalyticShape::Torus {
        major: 1.0,
        minor: 0.3,
    }
    .sample(30_000, 11);
    for p in &mut points {
        p.p += DVec3::new(1e5, -2e5, 3e4);
    }
    let (whole, tiled, report) = run(&points, &TileParams::at_depth(3));
    assert!(report.count >= 64, "{} tiles", report.count);
    assert!(report.crossing_cells > 0);
    assert_same_mpu(&tiled, &whole, 1000, 2);
}

#[test]
fn random_clouds_with_random_normals_tile_exactly() {
    // Inputs no surface explains: deep, irregular octrees and fits that read far.
    for seed in 0..3 {
        let mut rng = Pcg64Mcg::seed_from_u64(100 + seed);
        let points: Vec<OrientedPoint> = (0..3000)
            .map(|_| OrientedPoint {
                p: DVec3::new(rng.random(), rng.random::<f64>().powi(2), rng.random()),
                n: gaussian_vector(&mut rng),
            })
            .collect();
        let tiles = TileParams {
            depth: 2,
            halo: 0.0,
            ..TileParams::default()
        };
        let (whole, tiled, report) = run(&points, &tiles);
        assert_tiling_exercised(&report);
        assert_same_mpu(&tiled, &whole, 300, seed);
    }
}

#[test]
fn the_decisions_do_not_depend_on_the_thread_count() {
    let points = AnalyticShape::Torus {
        major: 1.0,
        minor: 0.4,
    }
    .sample(8000, 4);
    let decide = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| {
                decide_tiled(
                    &points,
                    &MpuParams::paper(),
                    &TileParams::at_depth(2),
                    &Monitor::silent(),
                )
                .unwrap()
            })
    };
    let (one, two) = (decide(1), decide(2));
    assert_eq!(one.cells, two.cells);
    assert_eq!(one.report.points_per_tile, two.report.points_per_tile);
}

#[test]
fn a_table_missing_a_cell_is_refused_not_refitted() {
    let points = AnalyticShape::Sphere { radius: 1.0 }.sample(3000, 3);
    let params = MpuParams::paper();
    let d = decided_at_depth_2(&points, &params);
    let mut partial = psi_mpu::CellTable::default();
    for (a, c) in d.cells.iter().filter(|(a, _)| a.0 < 3) {
        partial.insert(*a, c.clone()).unwrap();
    }
    let options = psi_mpu::BuildOptions {
        frame: Some(d.frame),
        known_cells: Some(&partial),
        ..Default::default()
    };
    let err = Mpu::build_with(&points, &params, options).unwrap_err();
    assert!(
        err.to_string().contains("no decision for the cell"),
        "{err}"
    );
}

#[test]
fn bad_tiling_parameters_are_refused() {
    let points = AnalyticShape::Sphere { radius: 1.0 }.sample(1000, 3);
    for tiles in [
        TileParams {
            depth: 0,
            halo: 0.1,
            ..TileParams::default()
        },
        TileParams {
            depth: 9,
            halo: 0.1,
            ..TileParams::default()
        },
        TileParams {
            depth: 2,
            halo: -1.0,
            ..TileParams::default()
        },
        TileParams {
            depth: 2,
            halo: f64::NAN,
            ..TileParams::default()
        },
    ] {
        let r = decide_tiled(&points, &MpuParams::paper(), &tiles, &Monitor::silent());
        assert!(matches!(r, Err(psi_tiles::TileError::BadParameter(_))));
    }
}

/// A leaf meeting a cube: depth, key, and for one inside it whether it holds the surface and
/// its point count.
type LeafNear = (u8, [u32; 3], Option<(bool, usize)>);

#[test]
fn a_build_of_the_cells_near_a_cube_is_the_whole_build_inside_it() {
    // Oracle: the build of every known cell. Only the points of a small cube are given (as a
    // region's seeding gathers them); f and ∇f inside the cube, the leaves meeting it and
    // their points must be the whole build's, and far cells must be left out.
    let torus = AnalyticShape::Torus {
        major: 1.0,
        minor: 0.4,
    };
    let points = noisy(torus.sample(20_000, 5), 2e-3);
    let mut rng = Pcg64Mcg::seed_from_u64(9);
    // (A finer threshold than the paper's: leaves small enough that many lie in each cube.)
    let params = MpuParams {
        error_rel: 0.002,
        ..MpuParams::paper()
    };
    let d = decided_at_depth_2(&points, &params);
    let built = |within: Option<(DVec3, f64)>, pts: &[OrientedPoint]| {
        let options = psi_mpu::BuildOptions {
            frame: Some(d.frame),
            known_cells: Some(&d.cells),
            known_within: within,
            ..Default::default()
        };
        Mpu::build_with(pts, &params, options).unwrap()
    };
    let whole = built(None, &points);
    for (k, &(c, h)) in [(points[0].p, 0.45), (points[12_345].p, 0.6)]
        .iter()
        .enumerate()
    {
        let local = c - d.frame.origin;
        let inside = |x: DVec3| (x - d.frame.origin - local).abs().max_element() <= h;
        let own: Vec<OrientedPoint> = points.iter().copied().filter(|p| inside(p.p)).collect();
        let part = built(Some((local, h)), &own);
        assert!(
            part.octree().cells().len() < whole.octree().cells().len() / 2,
            "cube {k}: {} of {} cells built",
            part.octree().cells().len(),
            whole.octree().cells().len()
        );
        // The leaves meeting the cube, and the points and surface flag of those inside it.
        let leaves = |m: &Mpu| -> Vec<LeafNear> {
            m.leaves()
                .filter_map(|l| {
                    let cell = m.octree().cell(l);
                    let gap = (cell.center - local).abs() - DVec3::splat(h);
                    (gap.max_element() < cell.half).then(|| {
                        let within = (gap.max_element() + 2.0 * cell.half <= 0.0)
                            .then(|| (m.is_surface_leaf(l), m.octree().points_in(l).len()));
                        (cell.depth, cell.key, within)
                    })
                })
                .collect()
        };
        let expected = leaves(&whole);
        let surface = expected.iter().filter(|l| l.2.is_some_and(|w| w.0)).count();
        assert!(surface > 10, "cube {k}: {surface} surface leaves inside");
        assert_eq!(leaves(&part), expected, "cube {k}: the leaves meeting it");
        for _ in 0..400 {
            let t = DVec3::new(rng.random(), rng.random(), rng.random()) * 2.0 - DVec3::ONE;
            let x = c + t * h;
            let (f, g) = whole.value_and_gradient(x);
            let (fp, gp) = part.value_and_gradient(x);
            assert_eq!(
                (fp.to_bits(), gp.to_array()),
                (f.to_bits(), g.to_array()),
                "at {x}"
            );
        }
    }
}

/// A noisy point cloud's MPU ranks its cells' errors ([`MpuParams::error_rank`]) and seeds
/// only in the leaves whose points, moved onto their fits, stay in them: tiled, the same.
#[test]
fn a_ranked_error_tiles_exactly() {
    let points = noisy(
        AnalyticShape::Torus {
            major: 1.0,
            minor: 0.35,
        }
        .sample(20_000, 9),
        8e-3,
    );
    let params = MpuParams {
        error_rel: 0.008,
        error_rank: Some(256),
        ..MpuParams::paper()
    };
    let whole = Mpu::build(&points, &params).unwrap();
    let (tiled, report) = build_tiled(
        &points,
        &params,
        &TileParams::at_depth(2),
        &Monitor::silent(),
    )
    .unwrap();
    assert!(report.count >= 8 && report.crossing_cells > 0);
    assert_same_mpu(&tiled, &whole, 2000, 3);
    assert_eq!(
        tiled.surface_leaves().collect::<Vec<_>>(),
        whole.surface_leaves().collect::<Vec<_>>()
    );
    let decisions = decided_at_depth_2(&points, &params);
    let mut surface: Vec<_> = whole
        .surface_leaves()
        .map(|l| {
            let c = whole.octree().cell(l);
            (c.depth, c.key)
        })
        .collect();
    surface.sort_unstable();
    assert_eq!(decisions.surface, surface);
}

/// The bound on the cells: decisions of exactly as many cells as it allows are made (and are
/// the unbounded ones); one cell fewer stops the build with `TooManyCells`, on one thread and
/// on two (whatever order the tiles end in).
#[test]
fn the_bound_on_the_cells_stops_the_build_exactly_past_it() {
    let points = noisy(
        AnalyticShape::Torus {
            major: 1.0,
            minor: 0.35,
        }
        .sample(15_000, 5),
        3e-3,
    );
    let params = MpuParams::paper();
    let free = decided_at_depth_2(&points, &params);
    let n = free.cells.len() as u64;
    assert!(free.report.count >= 8 && n > free.report.top_cells as u64);
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let decide = |max: u64| {
            let tiles = TileParams {
                max_cells: Some(max),
                ..TileParams::at_depth(2)
            };
            pool.install(|| decide_tiled(&points, &params, &tiles, &Monitor::silent()))
        };
        let at_bound = decide(n).unwrap();
        assert_eq!(at_bound.cells, free.cells);
        for max in [n - 1, n / 2, 1] {
            let e = decide(max).map(|_| ()).unwrap_err();
            assert_eq!(
                e,
                psi_tiles::TileError::TooManyCells { max },
                "{threads} threads"
            );
        }
    }
}
