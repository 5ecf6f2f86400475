//! What the preprocessing stages out of core share (`tile_normals.rs`, `tile_outliers.rs`): a
//! store's tile with a halo as a part for psi-preprocess's by-parts functions, its halo grown
//! while they cannot certify its points, and scratch files of one fixed-size record a point by
//! the store's index, written at their offsets by tile and read back in input order.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use glam::DVec3;
use psi_octree::Monitor;
use psi_preprocess::IncompletePart;
use psi_tiles::{TileStore, TileWithHalo};

use crate::two_at_a_time::two_at_a_time;

/// Records read from a record file in windows of this many (a pass reads them in input
/// order).
const WINDOW: u64 = 1 << 16;

/// Sample spacings a first halo spans: the neighbourhoods the by-parts functions read reach
/// about 4 (the 47 nearest of a plane, a point's 16 nearest and theirs), so most tiles need
/// no second try (measured: `docs/notes/2026-12-03-outliers-by-parts.md`).
const FIRST_HALO_SPACINGS: f64 = 6.0;

/// A first halo for tile `key` of `store` (world units): six sample spacings, the spacing
/// taken as a surface's through the tile (its edge over the square root of its points), at
/// most an eighth of its edge; each tile's grows to what its points need.
pub(crate) fn first_halo(store: &TileStore, key: [u32; 3]) -> f64 {
    let m = store.manifest();
    let edge = 2.0 * m.frame.root_half / f64::from(1u32 << m.depth);
    let points = m
        .tiles
        .iter()
        .find(|t| t.key == key)
        .map_or(1, |t| t.points);
    (FIRST_HALO_SPACINGS * edge / (points.max(1) as f64).sqrt()).min(edge / 8.0)
}

/// Each tile's halo so far (world units), by key.
pub(crate) type Halos = BTreeMap<[u32; 3], f64>;

/// A tile's first halo (world units), by key.
pub(crate) type FirstHalo<'a> = dyn Fn([u32; 3]) -> f64 + Sync + 'a;

/// A stage's work on one tile (its key, its halo, grown as needed).
pub(crate) type TileWork<'a, T> = dyn Fn([u32; 3], &mut f64) -> Result<T, String> + Sync + 'a;

/// `work` on each tile of `keys` with its halo (from `halos`, else `first(key)`; grown as the
/// work needs, and kept in `halos`), two tiles at a time (the budget's tiling allows two built
/// at once: [`two_at_a_time`]), each result given to `sink` in the order of `keys`. Reports
/// stage `stage` to `monitor` (tiles done of tiles) and stops taking tiles once its flag is
/// set.
pub(crate) fn each_tile_into<T: Send>(
    keys: &[[u32; 3]],
    (halos, first): (&mut Halos, &FirstHalo<'_>),
    (stage, monitor): (&str, &Monitor<'_>),
    work: &TileWork<'_, T>,
    sink: &mut (dyn FnMut(T) -> Result<(), String> + Send),
) -> Result<(), String> {
    let _span = tracing::info_span!("out_of_core_stage", stage, tiles = keys.len()).entered();
    let total = keys.len() as u64;
    monitor.report(stage, 0, total);
    let start: Vec<f64> = keys
        .iter()
        .map(|k| halos.get(k).copied().unwrap_or_else(|| first(*k)))
        .collect();
    let one = |i: usize| {
        let mut halo = start[i];
        work(keys[i], &mut halo).map(|out| (halo, out))
    };
    let mut deliver = |i: usize, (halo, out): (f64, T)| {
        halos.insert(keys[i], halo);
        monitor.report(stage, i as u64 + 1, total);
        sink(out)
    };
    two_at_a_time(keys.len(), &one, &|| monitor.stopped(), &mut deliver)?;
    monitor.check().map_err(|_| "interrupted".to_string())
}

/// [`each_tile_into`], the results collected in the order of `keys`.
pub(crate) fn each_tile<T: Send>(
    keys: &[[u32; 3]],
    halos: (&mut Halos, &FirstHalo<'_>),
    stage: (&str, &Monitor<'_>),
    work: &TileWork<'_, T>,
) -> Result<Vec<T>, String> {
    let mut out = Vec::with_capacity(keys.len());
    each_tile_into(keys, halos, stage, work, &mut |t| {
        out.push(t);
        Ok(())
    })?;
    Ok(out)
}

/// `f` on tile `key` of `store` with its halo (its input indices as 32 bits, and whether a ball
/// lies in what it holds), the halo grown and the tile gathered again while `f` cannot certify
/// its points; the tile and `f`'s result, or why the store could not be read.
pub(crate) fn by_tile<T>(
    store: &TileStore,
    key: [u32; 3],
    halo: &mut f64,
    f: impl Fn(&TileWithHalo, &[u32], &(dyn Fn(DVec3, f64) -> bool + Sync)) -> Result<T, IncompletePart>,
) -> Result<(TileWithHalo, T), String> {
    loop {
        let tile = store
            .tile_with_halo(key, *halo)
            .map_err(|e| e.to_string())?;
        let ids = tile
            .ids
            .iter()
            .map(|&i| u32::try_from(i).ok().filter(|&i| i < u32::MAX))
            .collect::<Option<Vec<u32>>>()
            .ok_or("too many points for 32-bit indices")?;
        let holds = |x: DVec3, r: f64| tile.holds_ball(x, r);
        match f(&tile, &ids, &holds) {
            Ok(out) => return Ok((tile, out)),
            // (Holding every point certifies any part: a refusal then is a defect, reported
            // rather than tried for ever.)
            Err(e) if tile.ids.len() as u64 >= store.manifest().population => {
                return Err(format!(
                    "tile {key:?}: point {} undecided with every point held",
                    e.id
                ));
            }
            // Fewer points held than a point's neighbours: twice the halo. Else the reach the
            // refused point needs (or half as much again, should rounding on the held cube's
            // face refuse it at that reach). The halo grows geometrically until the held cube
            // holds every point, which certifies any part: the loop ends.
            Err(e) if e.reach.is_infinite() => *halo *= 2.0,
            Err(e) => *halo = (1.01 * e.reach).max(1.5 * *halo),
        }
    }
}

/// A scratch file of one `B`-byte record a point, by index, read a window at a time.
pub(crate) struct RecordFile<const B: usize> {
    path: PathBuf,
    file: File,
    len: u64,
    window: Mutex<(u64, Vec<u8>)>,
}

impl<const B: usize> RecordFile<B> {
    /// The file at `path`, whole (its length a multiple of `B`).
    pub(crate) fn open(path: &Path) -> Result<Self, String> {
        let file = File::open(path).map_err(|e| io_reason(path, &e))?;
        let len = file.metadata().map_err(|e| io_reason(path, &e))?.len() / B as u64;
        Ok(Self {
            path: path.to_path_buf(),
            file,
            len,
            window: Mutex::new((0, Vec::new())),
        })
    }

    /// The record of point `i`.
    pub(crate) fn get(&self, i: u64) -> Result<[u8; B], String> {
        let mut window = self.window.lock().expect("not poisoned");
        let (start, bytes) = &mut *window;
        let held = bytes.len() as u64 / B as u64;
        if i < *start || i >= *start + held {
            if i >= self.len {
                return Err(format!("{}: no record for point {i}", self.path.display()));
            }
            let count = WINDOW.min(self.len - i);
            bytes.resize((count * B as u64) as usize, 0);
            read_at(&self.file, bytes, i * B as u64).map_err(|e| io_reason(&self.path, &e))?;
            *start = i;
        }
        let at = ((i - *start) * B as u64) as usize;
        Ok(bytes[at..at + B].try_into().expect("B bytes"))
    }
}

/// A file written whole or not at all: streamed to `<path>.partial`, renamed once finished.
pub(crate) struct WholeFile {
    path: PathBuf,
    partial: PathBuf,
    writer: BufWriter<File>,
}

impl WholeFile {
    /// Starts the file at `path`.
    pub(crate) fn create(path: &Path) -> Result<Self, String> {
        let partial = path.with_extension("partial");
        let file = File::create(&partial).map_err(|e| io_reason(&partial, &e))?;
        Ok(Self {
            path: path.to_path_buf(),
            writer: BufWriter::with_capacity(1 << 20, file),
            partial,
        })
    }

    /// Appends `bytes`.
    pub(crate) fn write(&mut self, bytes: &[u8]) -> Result<(), String> {
        self.writer
            .write_all(bytes)
            .map_err(|e| io_reason(&self.partial, &e))
    }

    /// Flushes, syncs and renames the file into place.
    pub(crate) fn finish(self) -> Result<(), String> {
        let file = self
            .writer
            .into_inner()
            .map_err(|e| io_reason(&self.partial, e.error()))?;
        file.sync_all().map_err(|e| io_reason(&self.partial, &e))?;
        std::fs::rename(&self.partial, &self.path).map_err(|e| io_reason(&self.path, &e))
    }
}

/// A normal as the 24 bytes of its record (three little-endian f64).
pub(crate) fn normal_bytes(n: DVec3) -> [u8; 24] {
    let mut out = [0u8; 24];
    for (k, v) in n.to_array().iter().enumerate() {
        out[8 * k..8 * k + 8].copy_from_slice(&v.to_le_bytes());
    }
    out
}

/// The normal of a 24-byte record.
pub(crate) fn normal_of_bytes(c: [u8; 24]) -> DVec3 {
    let f = |k: usize| f64::from_le_bytes(c[8 * k..8 * k + 8].try_into().expect("8"));
    DVec3::new(f(0), f(1), f(2))
}

/// A file's path and what went wrong with it.
pub(crate) fn io_reason(path: &Path, e: &std::io::Error) -> String {
    format!("{}: {e}", path.display())
}

/// Writes `bytes` at `offset` of `file`.
#[cfg(unix)]
pub(crate) fn write_at(file: &File, bytes: &[u8], offset: u64) -> std::io::Result<()> {
    std::os::unix::fs::FileExt::write_all_at(file, bytes, offset)
}

/// Reads `bytes.len()` bytes at `offset` of `file`.
#[cfg(unix)]
pub(crate) fn read_at(file: &File, bytes: &mut [u8], offset: u64) -> std::io::Result<()> {
    std::os::unix::fs::FileExt::read_exact_at(file, bytes, offset)
}

/// Writes `bytes` at `offset` of `file`.
#[cfg(not(unix))]
pub(crate) fn write_at(file: &File, bytes: &[u8], offset: u64) -> std::io::Result<()> {
    use std::io::{Seek, SeekFrom, Write};
    let mut f = file;
    f.seek(SeekFrom::Start(offset))?;
    f.write_all(bytes)
}

/// Reads `bytes.len()` bytes at `offset` of `file`.
#[cfg(not(unix))]
pub(crate) fn read_at(file: &File, bytes: &mut [u8], offset: u64) -> std::io::Result<()> {
    use std::io::{Read, Seek, SeekFrom};
    let mut f = file;
    f.seek(SeekFrom::Start(offset))?;
    f.read_exact(bytes)
}
