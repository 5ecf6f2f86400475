//! The out-of-core path: points partitioned into checksummed tile files, the cells above the
//! tiles decided from the coarse points (fetching balls from the files), the tiles from their
//! files; the decisions equal those of the build in memory, an interrupted run resumes
//! without redoing finished tiles, and damaged files are refused or decided again.

use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};

use glam::DVec3;
use psi_mpu::{
    BuildOptions, Mpu, MpuFrame, MpuParams, Region, RegionPoints, fit_region, fit_top,
    is_coarse_point,
};
use psi_octree::{Aabb, Monitor, OrientedPoint};
use psi_particles::ParticleParams;
use psi_shapes::{AnalyticShape, gaussian_vector};
use psi_tiles::{
    PointSource, PointsInMemory, TileParams, TileStore, TileWriter, decide_store,
    decide_store_tiles, decide_store_top_group, decide_store_top_keys, decide_store_top_upper,
    decide_tiled, sample_tiled, sample_tiled_from, seed_octants, seed_store_octant,
};
use rand::SeedableRng;
use rand_pcg::Pcg64Mcg;

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("psi-tiles-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// Tiles at `depth` with a first halo of `halo` tile edges.
fn tiles(depth: u8, halo: f64) -> TileParams {
    TileParams {
        depth,
        halo,
        ..TileParams::default()
    }
}

fn noisy_torus(n: usize, seed: u64) -> Vec<OrientedPoint> {
    let mut points = AnalyticShape::Torus {
        major: 1.0,
        minor: 0.35,
    }
    .sample(n, seed);
    let mut rng = Pcg64Mcg::seed_from_u64(seed + 1);
    for p in &mut points {
        p.p += 3e-3 * gaussian_vector(&mut rng);
    }
    points
}

/// Streams `points` into a store at `depth` in chunks of 777, buffering 1000 points.
fn store_of(points: &[OrientedPoint], depth: u8, dir: &std::path::Path) -> TileStore {
    let params = MpuParams::paper();
    let bounds = Aabb::from_points(points.iter().map(|p| p.p)).unwrap();
    let frame = MpuFrame::for_bounds(&bounds, points.len(), &params).unwrap();
    assert_eq!(frame, MpuFrame::for_points(points, &params).unwrap());
    let frame_check = frame;
    let mut w = TileWriter::create(dir, frame, depth, 1000, "test").unwrap();
    for chunk in points.chunks(777) {
        w.push(chunk).unwrap();
    }
    let store = w.finish().unwrap();
    // Bitwise: every fit depends on the frame's last bits.
    assert_eq!(store.manifest().frame, frame_check);
    store
}

#[test]
fn a_store_gives_back_every_point_in_input_order_and_the_coarse_ones() {
    let points = noisy_torus(12_000, 1);
    let dir = scratch("roundtrip");
    let store = store_of(&points, 2, &dir);
    let m = store.manifest();
    assert_eq!(m.population, points.len() as u64);
    assert!(m.tiles.len() >= 8);
    assert_eq!(
        m.tiles.iter().map(|t| t.points).sum::<u64>(),
        points.len() as u64
    );
    let all = store
        .gather_box(m.frame.root_center, m.frame.root_half, 0.0)
        .unwrap();
    assert_eq!(all, points, "bitwise, in input order");
    let coarse: Vec<OrientedPoint> = points
        .iter()
        .copied()
        .filter(|p| is_coarse_point(&m.frame, p.p))
        .collect();
    assert_eq!(store.coarse_points().unwrap(), coarse);
    // A ball gathered from the files is the brute-force ball.
    let c = DVec3::new(0.9, 0.2, 0.1);
    let ball = store.gather_ball(c, 0.3).unwrap();
    let brute: Vec<OrientedPoint> = points
        .iter()
        .copied()
        .filter(|p| (p.p - c).length() <= 0.3)
        .collect();
    assert_eq!(ball, brute);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Boxes and balls of every size gathered from a store (the files grouped by sub-cell, read
/// whole the first time and by runs after) are the brute-force ones, in input order; so are
/// the k-th nearest distances.
#[test]
fn boxes_and_balls_of_any_size_are_the_brute_force_ones() {
    use rand::RngExt;
    let points = noisy_torus(20_000, 11);
    for depth in [1u8, 2] {
        let dir = scratch(&format!("boxes-{depth}"));
        let store = store_of(&points, depth, &dir);
        let frame = store.manifest().frame;
        let mut rng = Pcg64Mcg::seed_from_u64(u64::from(depth));
        for round in 0..60 {
            // Centres anywhere in the root cube, some on a tile or sub-cell face.
            let mut local = DVec3::new(rng.random(), rng.random(), rng.random()) * 2.0 - 1.0;
            local = frame.root_center + local * frame.root_half;
            if round % 4 == 0 {
                local.x = frame.root_center.x;
            }
            let half = frame.root_half * 0.3 * rng.random::<f64>().powi(2);
            let halo = frame.root_half * 0.05 * rng.random::<f64>();
            let reach = half + halo;
            let brute: Vec<OrientedPoint> = points
                .iter()
                .copied()
                .filter(|p| (p.p - frame.origin - local).abs().max_element() <= reach)
                .collect();
            for pass in 0..2 {
                let got = store.gather_box(local, half, halo).unwrap();
                assert_eq!(got, brute, "depth {depth}, round {round}, pass {pass}");
            }
            let (c, r) = (local + frame.origin, reach);
            let ball: Vec<OrientedPoint> = points
                .iter()
                .copied()
                .filter(|p| (p.p - c).length() <= r)
                .collect();
            assert_eq!(store.gather_ball(c, r).unwrap(), ball, "round {round}");
            // The k-th nearest distance, against sorting every distance.
            let mut d: Vec<f64> = points.iter().map(|p| (p.p - c).length()).collect();
            d.sort_by(f64::total_cmp);
            for k in [1, 16, 300] {
                let got = store.kth_distance(c, k).unwrap().expect("enough points");
                assert_eq!(got.to_bits(), d[k - 1].to_bits(), "round {round}, k {k}");
            }
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

#[test]
fn the_cells_above_the_tiles_from_the_coarse_points_are_those_from_all_points() {
    let params = MpuParams::paper();
    for (points, until) in [(noisy_torus(40_000, 2), 3u8), (noisy_torus(3_000, 3), 4)] {
        let frame = MpuFrame::for_points(&points, &params).unwrap();
        let all = fit_region(
            &RegionPoints::new(&points, points.len()),
            &frame,
            &params,
            &Region::top(until),
            &Monitor::silent(),
        )
        .unwrap();
        let coarse: Vec<OrientedPoint> = points
            .iter()
            .copied()
            .filter(|p| is_coarse_point(&frame, p.p))
            .collect();
        let fetched = AtomicUsize::new(0);
        let fetch = |c: DVec3, r: f64| {
            fetched.fetch_add(1, Ordering::Relaxed);
            Ok(points
                .iter()
                .copied()
                .filter(|p| (p.p - c).length() <= r)
                .collect())
        };
        // The k-th nearest distance by brute force: balls fetched at R1 itself.
        let kth = |c: DVec3, k: usize| {
            let mut d: Vec<f64> = points.iter().map(|p| (p.p - c).length()).collect();
            d.sort_by(f64::total_cmp);
            Ok(d.get(k.wrapping_sub(1)).copied())
        };
        for kth in [None, Some(&kth as &psi_mpu::KthDistance<'_>)] {
            let top = fit_top(
                &coarse,
                points.len(),
                &frame,
                &params,
                until,
                &psi_mpu::BallSource { fetch: &fetch, kth },
                &Monitor::silent(),
            )
            .unwrap();
            assert_eq!(top.cells, all.cells);
        }
        assert!(
            fetched.load(Ordering::Relaxed) > 0,
            "no cell needed its whole ball"
        );
    }
}

#[test]
fn decisions_from_the_store_equal_the_build_in_memory() {
    let points = noisy_torus(30_000, 4);
    let params = MpuParams::paper();
    let dir = scratch("decide");
    let store = store_of(&points, 2, &dir);
    let from_store = decide_store(&store, &params, &tiles(2, 0.0), &Monitor::silent()).unwrap();
    let in_memory = decide_tiled(&points, &params, &tiles(2, 0.0), &Monitor::silent()).unwrap();
    assert_eq!(from_store.cells, in_memory.cells);
    assert_eq!(from_store.frame, in_memory.frame);
    assert_eq!(from_store.surface, in_memory.surface);
    assert!(from_store.report.count >= 8 && from_store.report.halos_grown > 0);
    assert!(from_store.report.crossing_cells > 0);
    // Assembled, the MPU is the build over all points.
    let options = BuildOptions {
        frame: Some(from_store.frame),
        known_cells: Some(&from_store.cells),
        ..Default::default()
    };
    let tiled = Mpu::build_with(&points, &params, options).unwrap();
    let whole = Mpu::build(&points, &params).unwrap();
    let mut surface: Vec<_> = whole
        .surface_leaves()
        .map(|l| {
            let c = whole.octree().cell(l);
            (c.depth, c.key)
        })
        .collect();
    surface.sort_unstable();
    assert_eq!(
        from_store.surface, surface,
        "the surface leaves, top ones included"
    );
    assert_eq!(tiled.octree().cells(), whole.octree().cells());
    for l in whole.leaves() {
        assert_eq!(tiled.leaf_function(l), whole.leaf_function(l));
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A store whose normals are read negated (the manifest's flag, the files untouched) gives
/// the flipped points everywhere, decides the cells the build in memory decides from the
/// flipped points, and reads as written again once the flag is cleared.
#[test]
fn a_store_read_negated_is_the_store_of_the_flipped_points() {
    let points = noisy_torus(12_000, 6);
    let flipped: Vec<OrientedPoint> = points
        .iter()
        .map(|p| OrientedPoint { p: p.p, n: -p.n })
        .collect();
    let params = MpuParams::paper();
    let dir = scratch("negated");
    let store = store_of(&points, 2, &dir);
    let sums: Vec<String> = store
        .manifest()
        .tiles
        .iter()
        .map(|t| t.sha256.clone())
        .collect();
    let before = decide_store(&store, &params, &tiles(2, 0.0), &Monitor::silent()).unwrap();
    let store = store.with_normals_negated(true).unwrap();
    // Opened again from its directory: the flag is in the manifest.
    let store = TileStore::open(store.dir()).unwrap();
    assert!(store.manifest().normals_negated);
    let m = store.manifest().clone();
    assert_eq!(
        m.tiles.iter().map(|t| t.sha256.clone()).collect::<Vec<_>>(),
        sums
    );
    let all = store
        .gather_box(m.frame.root_center, m.frame.root_half, 0.0)
        .unwrap();
    assert_eq!(all, flipped, "bitwise, in input order");
    let coarse: Vec<OrientedPoint> = flipped
        .iter()
        .copied()
        .filter(|p| is_coarse_point(&m.frame, p.p))
        .collect();
    assert_eq!(store.coarse_points().unwrap(), coarse);
    let mut parts: Vec<(u64, OrientedPoint)> = (0..store.part_count())
        .flat_map(|i| store.part_where(i, &|_| true).unwrap())
        .collect();
    parts.sort_by_key(|p| p.0);
    assert!(parts.iter().all(|(i, p)| *p == flipped[*i as usize]));
    // The decisions are the flipped points' (not the earlier ones, found on disk).
    let from_store = decide_store(&store, &params, &tiles(2, 0.0), &Monitor::silent()).unwrap();
    let in_memory = decide_tiled(&flipped, &params, &tiles(2, 0.0), &Monitor::silent()).unwrap();
    assert_eq!(from_store.cells, in_memory.cells);
    assert_ne!(from_store.cells, before.cells);
    let store = store.with_normals_negated(false).unwrap();
    let again = store
        .gather_box(m.frame.root_center, m.frame.root_half, 0.0)
        .unwrap();
    assert_eq!(again, points);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn an_interrupted_run_resumes_and_damaged_decisions_are_decided_again() {
    use std::os::unix::fs::MetadataExt;
    let points = noisy_torus(15_000, 5);
    let params = MpuParams::paper();
    let dir = scratch("resume");
    let store = store_of(&points, 2, &dir);
    // As a cluster runs it: the upper levels, each octant of the root, then the rest.
    let t = tiles(2, 0.1);
    let groups = decide_store_top_upper(&store, &params, &t, &Monitor::silent()).unwrap();
    // The groups come largest first (a cluster starts the longest tasks first).
    let m = store.manifest();
    let points_in = |o: &[u32; 3]| -> u64 {
        let tiles = m
            .tiles
            .iter()
            .filter(|x| x.key.map(|k| k >> (m.depth - 1)) == *o);
        tiles.map(|x| x.points).sum()
    };
    assert!(groups.len() > 1);
    assert!(
        groups
            .windows(2)
            .all(|w| points_in(&w[0]) >= points_in(&w[1]))
    );
    assert_eq!(
        groups.iter().map(points_in).sum::<u64>(),
        points.len() as u64
    );
    for key in groups {
        decide_store_top_group(&store, &params, &t, key, &Monitor::silent()).unwrap();
    }
    // The tiles in batches of three, the last batch first: a decisions file for every tile.
    let keys = decide_store_top_keys(&store, &params, &t, &Monitor::silent()).unwrap();
    for batch in keys.chunks(3).rev() {
        decide_store_tiles(&store, &params, &t, batch, &Monitor::silent()).unwrap();
    }
    for k in &keys {
        assert!(
            dir.join(format!("cells-{}-{}-{}.bin", k[0], k[1], k[2]))
                .exists()
        );
    }
    let first = decide_store(&store, &params, &t, &Monitor::silent()).unwrap();
    assert_eq!(first.report.count, keys.len());
    // The same as the command line's one pass above the tiles, bit for bit.
    let one_dir = scratch("resume-one-pass");
    let one_pass = decide_store(
        &store_of(&points, 2, &one_dir),
        &params,
        &t,
        &Monitor::silent(),
    );
    let one_pass = one_pass.unwrap();
    assert_eq!(one_pass.cells, first.cells);
    assert_eq!(one_pass.surface, first.surface);
    assert!(!one_dir.join("cells-upper.bin").exists());
    std::fs::remove_dir_all(&one_dir).unwrap();
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| {
            p.file_name()
                .unwrap()
                .to_string_lossy()
                .starts_with("cells-")
        })
        .collect();
    files.sort();
    let named =
        |p: &PathBuf, prefix: &str| p.file_name().unwrap().to_string_lossy().starts_with(prefix);
    // A file per tile, the levels above the groups, a group per octant of the root, the merge.
    let groups: Vec<PathBuf> = files
        .iter()
        .filter(|p| named(p, "cells-group-"))
        .cloned()
        .collect();
    assert_eq!(groups.len(), 8);
    assert_eq!(files.len(), first.report.count + 2 + groups.len());
    let inode = |p: &PathBuf| std::fs::metadata(p).unwrap().ino();
    let before: Vec<u64> = files.iter().map(inode).collect();
    // As if killed before two tiles finished, and a third file damaged on disk.
    std::fs::remove_file(&files[1]).unwrap();
    std::fs::remove_file(&files[2]).unwrap();
    let mut bytes = std::fs::read(&files[3]).unwrap();
    let mid = bytes.len() / 2;
    bytes[mid] ^= 0x40;
    std::fs::write(&files[3], &bytes).unwrap();
    let before3 = inode(&files[3]);
    let again = decide_store(&store, &params, &tiles(2, 0.1), &Monitor::silent()).unwrap();
    assert_eq!(again.cells, first.cells);
    for (i, f) in files.iter().enumerate() {
        match i {
            1 | 2 => assert!(f.exists()),
            3 => assert_ne!(inode(f), before3, "the damaged file was decided again"),
            _ => assert_eq!(inode(f), before[i], "{} was redone", f.display()),
        }
    }
    // The pass above the tiles killed after its groups: one group lost, one damaged.
    let top = dir.join("cells-top.bin");
    let upper = inode(&dir.join("cells-upper.bin"));
    std::fs::remove_file(&top).unwrap();
    std::fs::remove_file(&groups[0]).unwrap();
    let mut bytes = std::fs::read(&groups[1]).unwrap();
    bytes[0] ^= 0x40;
    std::fs::write(&groups[1], &bytes).unwrap();
    let damaged = inode(&groups[1]);
    let third = decide_store(&store, &params, &tiles(2, 0.1), &Monitor::silent()).unwrap();
    assert_eq!(third.cells, first.cells);
    assert_eq!(third.surface, first.surface);
    assert!(top.exists() && groups[0].exists());
    assert_ne!(
        inode(&groups[1]),
        damaged,
        "the damaged group was decided again"
    );
    assert_eq!(inode(&dir.join("cells-upper.bin")), upper);
    // Decisions made with other parameters are not taken for these.
    let other = MpuParams {
        error_rel: 2.0 * params.error_rel,
        ..params
    };
    let fresh = decide_store(&store, &other, &tiles(2, 0.1), &Monitor::silent()).unwrap();
    let expected = decide_tiled(&points, &other, &tiles(2, 0.1), &Monitor::silent()).unwrap();
    assert_eq!(fresh.cells, expected.cells);
    assert_ne!(fresh.cells, first.cells);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_damaged_or_truncated_tile_file_is_refused_by_name() {
    let points = noisy_torus(8_000, 6);
    let params = MpuParams::paper();
    for damage in ["flip", "truncate"] {
        let dir = scratch(&format!("damaged-{damage}"));
        let store = store_of(&points, 2, &dir);
        let t = &store.manifest().tiles[store.manifest().tiles.len() / 2];
        let path = dir.join(format!("tile-{}-{}-{}.pts", t.key[0], t.key[1], t.key[2]));
        let mut bytes = std::fs::read(&path).unwrap();
        if damage == "flip" {
            bytes[20] ^= 1;
        } else {
            bytes.truncate(bytes.len() - 10);
        }
        std::fs::write(&path, &bytes).unwrap();
        let err = decide_store(&store, &params, &tiles(2, 0.1), &Monitor::silent()).unwrap_err();
        let msg = err.to_string();
        assert!(msg.contains(&path.display().to_string()), "{msg}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

/// A reader checks the runs it reads (a halo reads a few sub-cells of a neighbouring tile):
/// a damaged record is refused by any box that reads its sub-cell, even by a store that never
/// read the whole file, and does not stop a box that reads only other sub-cells.
#[test]
fn a_box_checks_the_runs_it_reads_and_only_those() {
    let dir = scratch("runs-checked");
    let points = noisy_torus(20_000, 4);
    let store = store_of(&points, 1, &dir);
    let m = store.manifest().clone();
    let t = m.tiles.iter().max_by_key(|t| t.points).unwrap();
    let path = dir.join(format!("tile-{}-{}-{}.pts", t.key[0], t.key[1], t.key[2]));
    let mut bytes = std::fs::read(&path).unwrap();
    let at = |r: &[u8], k: usize| f64::from_le_bytes(r[8 + 8 * k..16 + 8 * k].try_into().unwrap());
    let position = |i: usize| {
        let r = &bytes[i * 56..(i + 1) * 56];
        DVec3::new(at(r, 0), at(r, 1), at(r, 2))
    };
    // The first record (of the first non-empty sub-cell) and the tile's last one, far from it.
    let (damaged, far) = (position(0), position(t.points as usize - 1));
    assert!((damaged - far).length() > 0.5, "{damaged} {far}");
    bytes[40] ^= 1;
    std::fs::write(&path, &bytes).unwrap();
    let small = 0.01;
    let gather = |p: DVec3| {
        TileStore::open(&dir)
            .unwrap()
            .gather_box_where(p - m.frame.origin, small, 0.0, &|_| true)
    };
    let err = gather(damaged).unwrap_err().to_string();
    assert!(
        err.contains(&path.display().to_string()) && err.contains("corrupted"),
        "{err}"
    );
    let near_far = gather(far).unwrap();
    let brute = points
        .iter()
        .filter(|p| (p.p - far).abs().max_element() <= small)
        .count();
    assert_eq!(near_far.len(), brute);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A store hashes each file the first time it reads it (a far ball reads the same tiles many
/// times); its size is checked at every read, and a store opened afresh hashes again.
#[test]
fn a_store_checks_a_file_once_and_its_size_at_every_read() {
    let dir = scratch("checked-once");
    let points = noisy_torus(4_000, 9);
    let store = store_of(&points, 1, &dir);
    let path = dir.join("coarse.pts");
    let coarse = store.coarse_points().unwrap();
    assert!(!coarse.is_empty());
    let mut bytes = std::fs::read(&path).unwrap();
    bytes[20] ^= 1;
    std::fs::write(&path, &bytes).unwrap();
    // The same store (and its clones) trusts the bytes it checked: this read is not hashed.
    assert_eq!(store.clone().coarse_points().unwrap().len(), coarse.len());
    let err = TileStore::open(&dir).unwrap().coarse_points().unwrap_err();
    assert!(err.to_string().contains("coarse.pts"), "{err}");
    bytes.truncate(bytes.len() - 7);
    std::fs::write(&path, &bytes).unwrap();
    let err = store.coarse_points().unwrap_err();
    assert!(err.to_string().contains("truncated"), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_new_store_removes_only_the_files_a_store_writes() {
    let dir = scratch("own-files");
    std::fs::create_dir_all(&dir).unwrap();
    // The user's files beside an old store: an XYZ scan named .pts, some binary file.
    std::fs::write(dir.join("scan.pts"), "0 0 0\n").unwrap();
    std::fs::write(dir.join("notes.bin"), "mine").unwrap();
    std::fs::write(dir.join("tile-1-2-3.pts"), "old").unwrap();
    std::fs::write(dir.join("cells-0-1-1.bin"), "old").unwrap();
    let points = noisy_torus(2_000, 8);
    store_of(&points, 1, &dir);
    assert!(dir.join("scan.pts").is_file() && dir.join("notes.bin").is_file());
    assert!(!dir.join("tile-1-2-3.pts").exists() && !dir.join("cells-0-1-1.bin").exists());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_store_without_its_manifest_is_unfinished_and_refused() {
    let dir = scratch("unfinished");
    let points = noisy_torus(2_000, 7);
    let store = store_of(&points, 1, &dir);
    std::fs::remove_file(store.dir().join("manifest.json")).unwrap();
    let err = TileStore::open(&dir).unwrap_err();
    assert!(err.to_string().contains("manifest.json"), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The seeds by octant of the root (a cluster's tasks) from the store's files equal the seeds
/// in memory, bitwise, and so do the particles; a lost or damaged seeds file is seeded again,
/// the others are taken as they are.
#[test]
fn seeds_by_octant_in_files_equal_the_seeds_in_memory_and_resume() {
    use std::os::unix::fs::MetadataExt;
    let points = noisy_torus(20_000, 7);
    let params = MpuParams::paper();
    let pparams = ParticleParams {
        max_spacing: Some(f64::INFINITY),
        ..ParticleParams::paper()
    };
    let silent = Monitor::silent();
    let dir = scratch("seeds");
    let store = store_of(&points, 2, &dir);
    let t = tiles(2, 0.25);
    let decisions = decide_store(&store, &params, &t, &silent).unwrap();
    let octants = seed_octants(&decisions);
    assert!(octants.len() >= 4, "{octants:?}");
    let source = PointsInMemory::new(&points, decisions.frame, 2);
    let expected = sample_tiled(&source, &decisions, &params, &pparams, 2_000, &silent).unwrap();
    let from_files = || {
        let seeds_of =
            |o| seed_store_octant(&store, &t, &decisions, &params, &pparams, 2_000, o, &silent);
        sample_tiled_from(
            &store, &decisions, &params, &pparams, 2_000, &seeds_of, &silent,
        )
        .unwrap()
    };
    let first = from_files();
    assert_eq!(first.seeds, expected.seeds);
    assert_eq!(first.particles, expected.particles);
    assert_eq!(first.report.regions, expected.report.regions);
    let file = |o: [u32; 3]| dir.join(format!("seeds-{}-{}-{}.bin", o[0], o[1], o[2]));
    let inode = |o: [u32; 3]| std::fs::metadata(file(o)).unwrap().ino();
    let before: Vec<u64> = octants.iter().map(|&o| inode(o)).collect();
    std::fs::remove_file(file(octants[0])).unwrap();
    let mut bytes = std::fs::read(file(octants[1])).unwrap();
    let mid = bytes.len() / 2;
    bytes[mid] ^= 0x10;
    std::fs::write(file(octants[1]), &bytes).unwrap();
    let damaged = inode(octants[1]);
    let again = from_files();
    assert_eq!(again.particles, first.particles);
    assert!(file(octants[0]).exists());
    assert_ne!(
        inode(octants[1]),
        damaged,
        "the damaged file was seeded again"
    );
    for (i, &o) in octants.iter().enumerate().skip(2) {
        assert_eq!(inode(o), before[i], "octant {o:?} was seeded again");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
