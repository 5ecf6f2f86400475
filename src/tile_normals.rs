//! Normals for a run out of core whose input has none: estimated and oriented tile by tile
//! (psi-preprocess's by-parts functions on each tile and a halo of the points around it), so
//! that the store the MPU is decided from holds, bitwise, the points and normals the in-core
//! preprocessing gives the same input with its other steps off (`--keep-outliers
//! --no-noise-estimate --no-denoise`). Stores in the scratch directory, each found again by a
//! run on the same input: the positions (`positions/`), the estimated normals by input index
//! (`normals.bin`, renamed into place once whole), the points with their unoriented normals
//! (`estimated/`), and the final store (`tiles/`, the normals oriented); the first three are
//! removed once it is written. Progress: stages `"positions"`, `"noise"`, `"planes"`,
//! `"normals"`, `"sides"`, `"orient"` (tiles done of tiles, where by tile). Notes:
//! `docs/notes/2026-12-03-orientation-by-parts.md`.
//!
//! Not yet: inputs whose noise asks for normals fitted among a coarser subset of the points
//! (refused, with the reason), and the stages as a cluster's tasks per tile (a cluster runs
//! them as one task).

use std::collections::BTreeMap;
use std::fs::{self, File};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use glam::DVec3;
use psi_io::Format;
use psi_mpu::MpuParams;
use psi_octree::Monitor;
use psi_preprocess::{
    IncompletePart, NoiseRound, PartEdges, noise_by_rounds, noise_level, orientation_flips,
    part_noise_samples, part_normals, part_orientation_edges,
};
use psi_tiles::{TileStore, TileWithHalo};

use crate::PsiError;
use crate::budget::OutOfCore;
use crate::partition::{Normals, Partition, StoreKind, failure, found, partition_with};

/// Bytes of a normal in `normals.bin` (three little-endian f64).
const NORMAL_BYTES: u64 = 24;

/// Bytes a point the orientation's join holds at once (all points together): its sets (the
/// trees, the sides and their parities, the islands, their sizes, the seeds, the pieces: 23),
/// x and the side of n.x (9), the flips (1), the parts' forests and same-sheet links (up to 32).
const JOIN_BYTES: u64 = 65;

/// Normals read from `normals.bin` in windows of this many points (the partition reads them
/// in input order).
const WINDOW: u64 = 1 << 16;

/// The store of `paths`' points (files without normals, read as `format` or as their
/// extensions say) with normals estimated and oriented tile by tile, in `options.scratch/tiles`
/// (found there when an earlier run wrote it for the same files), where the decisions of
/// [`crate::sample_files_out_of_core`] read it; on a cluster, one task
/// (`psi.distributed.sample_files`).
///
/// # Errors
///
/// [`PsiError::OutOfCore`] naming the first file: a scratch file fails, the input's noise asks
/// for a coarser level, or its points are too many for 32-bit indices; the partition's errors.
pub fn partition_estimating_normals(
    paths: &[PathBuf],
    format: Option<Format>,
    mpu_params: &MpuParams,
    options: &OutOfCore,
    monitor: &Monitor<'_>,
) -> Result<Partition, PsiError> {
    let fail = failure(&paths[0]);
    let scratch = &options.scratch;
    let final_dir = scratch.join("tiles");
    let positions_dir = scratch.join("positions");
    let estimated_dir = scratch.join("estimated");
    let normals_path = scratch.join("normals.bin");
    // The stages' files, once the final store is whole (also those a run stopped between the
    // two left).
    let clean_up = || -> Result<(), PsiError> {
        for dir in [&positions_dir, &estimated_dir] {
            if dir.exists() {
                fs::remove_dir_all(dir).map_err(|e| fail(io_reason(dir, &e)))?;
            }
        }
        if normals_path.exists() {
            fs::remove_file(&normals_path).map_err(|e| fail(io_reason(&normals_path, &e)))?;
        }
        Ok(())
    };
    if let Some(found) = found(paths, options, &final_dir, StoreKind::Oriented)? {
        clean_up()?;
        return Ok(found);
    }
    // The positions, every point with a zero normal.
    let bare = at_stage(monitor, "positions", || {
        partition_with(
            paths,
            format,
            mpu_params,
            options,
            (&positions_dir, Normals::Zero),
            monitor,
        )
    })?;
    let store = &bare.store;
    // Normals of another input (an earlier run's, left in this scratch directory) never serve:
    // a positions store written afresh writes them afresh.
    if !bare.resumed && normals_path.exists() {
        fs::remove_file(&normals_path).map_err(|e| fail(io_reason(&normals_path, &e)))?;
    }
    let n = usize::try_from(bare.points)
        .ok()
        .filter(|&n| n < u32::MAX as usize)
        .ok_or_else(|| fail("too many points for 32-bit indices".into()))?;
    // The join holds every point at once: refused up front when that does not fit.
    let join = bare.points.saturating_mul(JOIN_BYTES);
    if join > options.max_memory {
        return Err(fail(format!(
            "its {} points have no normals, and orienting the normals joins them all at once: \
             about {} MiB, more than the {} MiB of --max-memory; give more, or give the points \
             with normals",
            bare.points,
            join.div_ceil(1 << 20),
            options.max_memory >> 20
        )));
    }
    // The level the noise asks for: only level 0 (every point's own neighbourhood) is done.
    // Each tile's halo, grown as its points need (a stray point's far neighbours grow its own
    // tile's only), kept for the next stage over the same tiles.
    let mut halos: BTreeMap<[u32; 3], f64> = BTreeMap::new();
    let first = first_halo(store);
    let keys = store.tile_keys();
    let (noise, reach) = noise_by_rounds(n, |round: NoiseRound| {
        let mut found = Vec::new();
        for (done, &key) in keys.iter().enumerate() {
            monitor.report("noise", done as u64, keys.len() as u64);
            let halo = halos.entry(key).or_insert(first);
            let (tile, fits) = by_tile(store, key, halo, |t, ids, holds| {
                let positions: Vec<DVec3> = t.points.iter().map(|p| p.p).collect();
                part_noise_samples(&positions, ids, &t.own, holds, round)
            })
            .map_err(&fail)?;
            drop(tile);
            found.extend(fits);
            monitor.check().map_err(|_| fail("interrupted".into()))?;
        }
        Ok::<_, PsiError>(found)
    })?;
    let level = noise_level(noise.sigma, reach);
    if level > 0 {
        return Err(fail(format!(
            "its noise ({:.3e}, about {:.2} of the spacing) asks for normals fitted among one \
             point in {} (dense noisy scans), which a run out of core does not do yet; run \
             without --max-memory, or give the points with normals",
            noise.sigma,
            noise.sigma / reach.max(f64::MIN_POSITIVE),
            4u32.pow(level)
        )));
    }
    // The normals by input index.
    if fs::metadata(&normals_path).map(|m| m.len()).ok() != Some(n as u64 * NORMAL_BYTES) {
        let partial = scratch.join("normals.bin.partial");
        let file = File::create(&partial).map_err(|e| fail(io_reason(&partial, &e)))?;
        file.set_len(n as u64 * NORMAL_BYTES)
            .map_err(|e| fail(io_reason(&partial, &e)))?;
        for (done, &key) in keys.iter().enumerate() {
            monitor.report("planes", done as u64, keys.len() as u64);
            let halo = halos.entry(key).or_insert(first);
            let (tile, normals) = by_tile(store, key, halo, |t, ids, holds| {
                let positions: Vec<DVec3> = t.points.iter().map(|p| p.p).collect();
                part_normals(&positions, ids, &t.own, holds)
            })
            .map_err(&fail)?;
            for ((i, _), normal) in tile.own_points().zip(normals) {
                let bytes: Vec<u8> = normal
                    .to_array()
                    .iter()
                    .flat_map(|v| v.to_le_bytes())
                    .collect();
                write_at(&file, &bytes, i * NORMAL_BYTES)
                    .map_err(|e| fail(io_reason(&partial, &e)))?;
            }
            monitor.check().map_err(|_| fail("interrupted".into()))?;
        }
        file.sync_all().map_err(|e| fail(io_reason(&partial, &e)))?;
        fs::rename(&partial, &normals_path).map_err(|e| fail(io_reason(&normals_path, &e)))?;
    }
    let reader = NormalsFile::open(&normals_path).map_err(&fail)?;
    let read = |i: u64| reader.get(i);
    // The points with their estimated normals (none dropped where no plane was found), then
    // their sides from the parts' edges.
    let estimated = at_stage(monitor, "normals", || {
        let normals = Normals::Estimated {
            normals: &read,
            flips: None,
        };
        partition_with(
            paths,
            format,
            mpu_params,
            options,
            (&estimated_dir, normals),
            monitor,
        )
    })?;
    let kept = estimated.points as usize;
    let mut parts: Vec<PartEdges> = Vec::new();
    let (mut x, mut x_negative) = (vec![0.0; kept], vec![false; kept]);
    let first = first_halo(&estimated.store);
    let keys = estimated.store.tile_keys();
    for (done, &key) in keys.iter().enumerate() {
        monitor.report("sides", done as u64, keys.len() as u64);
        let mut halo = first;
        let (tile, edges) = by_tile(&estimated.store, key, &mut halo, |t, ids, holds| {
            part_orientation_edges(&t.points, ids, &t.own, holds)
        })
        .map_err(&fail)?;
        for (i, p) in tile.own_points() {
            x[i as usize] = p.p.x;
            x_negative[i as usize] = p.n.x < 0.0;
        }
        parts.push(edges);
        monitor.check().map_err(|_| fail("interrupted".into()))?;
    }
    let flips = orientation_flips(kept, &parts, &|i| x[i as usize], &|i| {
        x_negative[i as usize]
    });
    drop(parts);
    let oriented = at_stage(monitor, "orient", || {
        let normals = Normals::Estimated {
            normals: &read,
            flips: Some(&flips),
        };
        partition_with(
            paths,
            format,
            mpu_params,
            options,
            (&final_dir, normals),
            monitor,
        )
    })?;
    drop(reader);
    clean_up()?;
    Ok(Partition {
        dropped: estimated.dropped,
        ..oriented
    })
}

/// `f` between the monitor's reports of stage `name` (started, done).
fn at_stage<T>(
    monitor: &Monitor<'_>,
    name: &str,
    f: impl FnOnce() -> Result<T, PsiError>,
) -> Result<T, PsiError> {
    monitor.report(name, 0, 1);
    let out = f()?;
    monitor.report(name, 1, 1);
    Ok(out)
}

/// A first halo for the stores' tiles: an eighth of a tile's edge (world units); each tile's
/// grows to what its points need.
fn first_halo(store: &TileStore) -> f64 {
    let m = store.manifest();
    m.frame.root_half / f64::from(1u32 << m.depth) / 4.0
}

/// `f` on tile `key` of `store` with its halo (its input indices as 32 bits, and whether a ball
/// lies in what it holds), the halo grown and the tile gathered again while `f` cannot certify
/// its points; the tile and `f`'s result, or why the store could not be read.
fn by_tile<T>(
    store: &TileStore,
    key: [u32; 3],
    halo: &mut f64,
    f: impl Fn(&TileWithHalo, &[u32], &(dyn Fn(DVec3, f64) -> bool + Sync)) -> Result<T, IncompletePart>,
) -> Result<(TileWithHalo, T), String> {
    loop {
        let tile = store
            .tile_with_halo(key, *halo)
            .map_err(|e| e.to_string())?;
        let ids: Vec<u32> = tile.ids.iter().map(|&i| i as u32).collect();
        let holds = |x: DVec3, r: f64| tile.holds_ball(x, r);
        match f(&tile, &ids, &holds) {
            Ok(out) => return Ok((tile, out)),
            // Fewer points held than a point's neighbours: twice the halo. Else the reach the
            // refused point needs (or half as much again, should rounding on the held cube's
            // face refuse it at that reach). The halo grows geometrically until the held cube
            // holds every point, which certifies any part: the loop ends.
            Err(e) if e.reach.is_infinite() => *halo *= 2.0,
            Err(e) => *halo = (1.01 * e.reach).max(1.5 * *halo),
        }
    }
}

/// `normals.bin` read by input index, a window at a time (the partition reads in input
/// order).
struct NormalsFile {
    path: PathBuf,
    file: File,
    len: u64,
    window: Mutex<(u64, Vec<DVec3>)>,
}

impl NormalsFile {
    fn open(path: &Path) -> Result<Self, String> {
        let file = File::open(path).map_err(|e| io_reason(path, &e))?;
        let len = file.metadata().map_err(|e| io_reason(path, &e))?.len() / NORMAL_BYTES;
        Ok(Self {
            path: path.to_path_buf(),
            file,
            len,
            window: Mutex::new((0, Vec::new())),
        })
    }

    /// The normal of the point of input index `i`.
    fn get(&self, i: u64) -> Result<DVec3, String> {
        let mut window = self.window.lock().expect("not poisoned");
        let (start, normals) = &mut *window;
        if i < *start || i >= *start + normals.len() as u64 {
            if i >= self.len {
                return Err(format!("{}: no normal for point {i}", self.path.display()));
            }
            let count = WINDOW.min(self.len - i);
            let mut bytes = vec![0u8; (count * NORMAL_BYTES) as usize];
            read_at(&self.file, &mut bytes, i * NORMAL_BYTES)
                .map_err(|e| io_reason(&self.path, &e))?;
            *start = i;
            *normals = bytes
                .chunks_exact(NORMAL_BYTES as usize)
                .map(|c| {
                    let f =
                        |k: usize| f64::from_le_bytes(c[8 * k..8 * k + 8].try_into().expect("8"));
                    DVec3::new(f(0), f(1), f(2))
                })
                .collect();
        }
        Ok(normals[(i - *start) as usize])
    }
}

/// A file's path and what went wrong with it.
fn io_reason(path: &Path, e: &std::io::Error) -> String {
    format!("{}: {e}", path.display())
}

/// Writes `bytes` at `offset` of `file`.
#[cfg(unix)]
fn write_at(file: &File, bytes: &[u8], offset: u64) -> std::io::Result<()> {
    std::os::unix::fs::FileExt::write_all_at(file, bytes, offset)
}

/// Reads `bytes.len()` bytes at `offset` of `file`.
#[cfg(unix)]
fn read_at(file: &File, bytes: &mut [u8], offset: u64) -> std::io::Result<()> {
    std::os::unix::fs::FileExt::read_exact_at(file, bytes, offset)
}

/// Writes `bytes` at `offset` of `file`.
#[cfg(not(unix))]
fn write_at(file: &File, bytes: &[u8], offset: u64) -> std::io::Result<()> {
    use std::io::{Seek, SeekFrom, Write};
    let mut f = file;
    f.seek(SeekFrom::Start(offset))?;
    f.write_all(bytes)
}

/// Reads `bytes.len()` bytes at `offset` of `file`.
#[cfg(not(unix))]
fn read_at(file: &File, bytes: &mut [u8], offset: u64) -> std::io::Result<()> {
    use std::io::{Read, Seek, SeekFrom};
    let mut f = file;
    f.seek(SeekFrom::Start(offset))?;
    f.read_exact(bytes)
}
