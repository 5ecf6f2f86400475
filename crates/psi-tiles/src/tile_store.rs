//! Points partitioned into tile files on disk (the out-of-core input of a tiled build): one
//! file per non-empty tile cube at the tile depth, each point with its index in the whole
//! input, grouped by sub-cell and in increasing index order within each (`sub_cells.rs`, so a
//! small box reads only part of a file); the coarse points in a file of their own, in index
//! order. Each file ends with a CRC-32 per run of records (`run_digests.rs`), so a reader
//! checks what it reads and no more. A manifest with the frame, the counts, the sub-cell runs
//! and every file's checksum is written last (temporary file, then rename), so a store without
//! a manifest is unfinished and one whose file fails its checksum is refused by name. Records:
//! `tile_records.rs`; writing: `tile_writer.rs`, whole or in parts (`store_plan.rs`).

use std::collections::{BTreeMap, HashMap};
use std::fs::{self, File};
use std::io::{Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use glam::DVec3;
use psi_mpu::MpuFrame;
use psi_octree::OrientedPoint;
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use crate::TileError;
use crate::input_order::in_input_order;
use crate::run_digests::{check_runs, trailer_len, trailer_sum};
use crate::sub_cells::{SUB, SUB_LEVELS, box_distance, sub_cell_box, sub_cell_ranges};
use crate::tile_records::{RECORD, record_position, tile_key};

/// The manifest format this code writes and reads.
pub(crate) const VERSION: u32 = 4;
/// The manifest's file name in a store directory.
pub(crate) const MANIFEST: &str = "manifest.json";

/// One tile file of a store.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StoredTile {
    /// The tile's integer key at the store's depth.
    pub key: [u32; 3],
    /// Points in the file.
    pub points: u64,
    /// SHA-256 of the file's trailer (the CRC-32 of each run, `run_digests.rs`),
    /// hexadecimal.
    pub sha256: String,
    /// The file's runs: `runs[s]` records come before run `s`. A tile file's runs are its
    /// sub-cells (shape 8³ + 1; `sub_cells.rs`); the coarse points' file is one run
    /// (`[0, points]`).
    pub runs: Vec<u64>,
}

/// What a store holds: the frame and count of the whole input, the depth, the files.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StoreManifest {
    /// Format version (2: tile files grouped by sub-cell; 3: a checksum per run).
    pub version: u32,
    /// What the points came from, as the writer's caller described it (a file's path, size
    /// and time): a run finds its own store by it and resumes.
    pub source: String,
    /// The whole input's frame (as JSON numbers, for reading; the build uses `frame_bits`).
    pub frame: MpuFrame,
    /// The frame's eight numbers (origin, root centre, root half, diagonal) as their IEEE
    /// bits: JSON numbers need not read back to the same bits, and every fit depends on them.
    pub frame_bits: [u64; 8],
    /// Points in the whole input.
    pub population: u64,
    /// The depth whose cells the files hold.
    pub depth: u8,
    /// The non-empty tiles, by key.
    pub tiles: Vec<StoredTile>,
    /// The coarse points' file.
    pub coarse: StoredTile,
    /// Whether every normal is read negated: the files as written, their normals judged to
    /// point inward as a whole afterwards ([`TileStore::with_normals_negated`]).
    #[serde(default)]
    pub normals_negated: bool,
}

/// A finished store, its manifest read and trusted; files are checked as they are read (each
/// file's size every time, each run of records against its checksum the first time this
/// store, or a clone of it, reads it).
#[derive(Clone, Debug)]
pub struct TileStore {
    dir: PathBuf,
    manifest: StoreManifest,
    by_key: BTreeMap<[u32; 3], usize>,
    /// Per file, the runs checked already (a far ball reads the same tiles many times:
    /// hashing them at every read took more time than the fits).
    checked: Arc<Mutex<HashMap<PathBuf, Vec<bool>>>>,
}

pub(crate) fn io_error(path: &Path, e: impl std::fmt::Display) -> TileError {
    TileError::Store(format!("{}: {e}", path.display()))
}

pub(crate) fn tile_path(dir: &Path, key: [u32; 3]) -> PathBuf {
    dir.join(format!("tile-{}-{}-{}.pts", key[0], key[1], key[2]))
}

pub(crate) fn frame_bits(f: &MpuFrame) -> [u64; 8] {
    let v = [
        f.origin.x,
        f.origin.y,
        f.origin.z,
        f.root_center.x,
        f.root_center.y,
        f.root_center.z,
        f.root_half,
        f.diagonal,
    ];
    v.map(f64::to_bits)
}

pub(crate) fn frame_from_bits(b: [u64; 8]) -> MpuFrame {
    let v = b.map(f64::from_bits);
    MpuFrame {
        origin: DVec3::new(v[0], v[1], v[2]),
        root_center: DVec3::new(v[3], v[4], v[5]),
        root_half: v[6],
        diagonal: v[7],
    }
}

impl TileStore {
    /// Opens the store in `dir`: its manifest must be there (an unfinished store has none).
    pub fn open(dir: &Path) -> Result<TileStore, TileError> {
        let path = dir.join(MANIFEST);
        let text = fs::read_to_string(&path).map_err(|e| io_error(&path, e))?;
        let mut manifest: StoreManifest =
            serde_json::from_str(&text).map_err(|e| io_error(&path, e))?;
        manifest.frame = frame_from_bits(manifest.frame_bits);
        if manifest.version != VERSION {
            return Err(io_error(
                &path,
                format!("unknown version {}", manifest.version),
            ));
        }
        let by_key = manifest
            .tiles
            .iter()
            .enumerate()
            .map(|(i, t)| (t.key, i))
            .collect();
        Ok(TileStore {
            dir: dir.to_path_buf(),
            manifest,
            by_key,
            checked: Arc::default(),
        })
    }

    /// The manifest.
    pub fn manifest(&self) -> &StoreManifest {
        &self.manifest
    }

    /// The sign every normal is read with (−1 when [`StoreManifest::normals_negated`]).
    fn sign(&self) -> f64 {
        if self.manifest.normals_negated {
            -1.0
        } else {
            1.0
        }
    }

    /// This store with its normals read negated, or as written again (`negated`): the
    /// manifest rewritten (a temporary file, renamed), the files untouched.
    pub fn with_normals_negated(self, negated: bool) -> Result<TileStore, TileError> {
        if self.manifest.normals_negated == negated {
            return Ok(self);
        }
        let manifest = StoreManifest {
            normals_negated: negated,
            ..self.manifest.clone()
        };
        let text = serde_json::to_string_pretty(&manifest).expect("serialisable");
        crate::write_atomically(&self.dir.join(MANIFEST), text.as_bytes())?;
        TileStore::open(&self.dir)
    }

    /// What the store's points are, hashed (SHA-256, hexadecimal): its source, frame, count,
    /// depth and every file's checksum; not whether the normals are read negated.
    pub fn digest(&self) -> String {
        let m = &self.manifest;
        let mut h = Sha256::new();
        h.update(format!(
            "{}\n{:?} {} {}",
            m.source, m.frame_bits, m.population, m.depth
        ));
        for t in m.tiles.iter().chain([&m.coarse]) {
            h.update(&t.sha256);
        }
        h.finalize().iter().map(|b| format!("{b:02x}")).collect()
    }

    /// The store's directory.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Points in the tile `key`'s file (0 for a tile without one).
    pub fn count(&self, key: [u32; 3]) -> u64 {
        self.by_key
            .get(&key)
            .map_or(0, |&i| self.manifest.tiles[i].points)
    }

    /// The records `ranges` (first, end; records, whole runs) of a file, or all of it
    /// (`None`). Its size is checked against `entry` at every read; the runs read that this
    /// store has not checked before are checked against the file's trailer, and the trailer
    /// against the manifest.
    pub(crate) fn read_ranges(
        &self,
        path: &Path,
        entry: &StoredTile,
        ranges: Option<&[(u64, u64)]>,
    ) -> Result<Vec<u8>, TileError> {
        let mut f = File::open(path).map_err(|e| io_error(path, e))?;
        let len = f.metadata().map_err(|e| io_error(path, e))?.len();
        let records = entry.points * RECORD as u64;
        let expected = records + trailer_len(entry.runs.len());
        if len != expected || entry.runs.last() != Some(&entry.points) {
            return Err(wrong_size(path, len, entry.points, expected));
        }
        let whole = [(0, entry.points)];
        let ranges = ranges.unwrap_or(&whole);
        let total: u64 = ranges.iter().map(|(a, b)| b - a).sum();
        // (Read into spare capacity: zeroing a tile's bytes first cost as much as a copy.)
        let mut out = Vec::with_capacity(total as usize * RECORD);
        for &(a, b) in ranges {
            let n = (b - a) * RECORD as u64;
            let before = out.len();
            f.seek(SeekFrom::Start(a * RECORD as u64))
                .and_then(|_| (&mut f).take(n).read_to_end(&mut out))
                .map_err(|e| io_error(path, e))?;
            if (out.len() - before) as u64 != n {
                return Err(io_error(path, "ended early: the file is truncated"));
            }
        }
        let runs = entry.runs.len() - 1;
        let mut checked = (self.checked.lock().expect("not poisoned"))
            .get(path)
            .cloned()
            .unwrap_or_else(|| vec![false; runs]);
        let mut trailer = || -> Result<Vec<u8>, String> {
            let mut trailer = vec![0u8; (len - records) as usize];
            f.seek(SeekFrom::Start(records))
                .and_then(|_| f.read_exact(&mut trailer))
                .map_err(|e| e.to_string())?;
            if trailer_sum(&trailer) != entry.sha256 {
                return Err("its SHA-256 does not match the manifest".into());
            }
            Ok(trailer)
        };
        check_runs(&out, ranges, &entry.runs, &mut checked, &mut trailer)
            .map_err(|why| io_error(path, format!("{why}: the file is corrupted")))?;
        (self.checked.lock().expect("not poisoned")).insert(path.to_path_buf(), checked);
        Ok(out)
    }

    /// The coarse points ([`psi_mpu::is_coarse_point`]), in increasing input index order.
    pub fn coarse_points(&self) -> Result<Vec<OrientedPoint>, TileError> {
        let path = self.dir.join("coarse.pts");
        let bytes = self.read_ranges(&path, &self.manifest.coarse, None)?;
        let mut found = Vec::new();
        decode_into(&bytes, &|_| true, self.sign(), &mut found);
        Ok(found.into_iter().map(|(_, p)| p).collect())
    }

    /// Every point whose position (world units) satisfies `keep`, from the tiles whose keys
    /// lie in `lo..=hi` per axis and, within each, the sub-cells whose keys
    /// [`SUB_LEVELS`] deeper lie in `fine.0..=fine.1`; in increasing input index order.
    fn gather_keys(
        &self,
        lo: [u32; 3],
        hi: [u32; 3],
        fine: ([u32; 3], [u32; 3]),
        ball: Option<(DVec3, f64)>,
        keep: &dyn Fn(DVec3) -> bool,
    ) -> Result<Vec<(u64, OrientedPoint)>, TileError> {
        if (0..3).any(|a| lo[a] > hi[a]) {
            // (A box of negative reach holds nothing.)
            return Ok(Vec::new());
        }
        let cells = (SUB * SUB * SUB) as usize;
        let mut reads = Vec::new();
        for (&key, &i) in self.by_key.range(lo..=hi) {
            if (0..3).any(|a| key[a] < lo[a] || key[a] > hi[a]) {
                continue;
            }
            let entry = &self.manifest.tiles[i];
            let within = |k: [u32; 3]| -> [u32; 3] {
                std::array::from_fn(|a| k[a].saturating_sub(key[a] * SUB).min(SUB - 1))
            };
            let (sub_lo, sub_hi) = (within(fine.0), within(fine.1));
            let whole = sub_lo == [0; 3] && sub_hi == [SUB - 1; 3] && ball.is_none();
            // (For a ball, only the sub-cells it reaches.)
            let depth = self.manifest.depth;
            let touches = |sub: [u32; 3]| {
                ball.is_none_or(|(c, r)| {
                    box_distance(c, sub_cell_box(&self.manifest.frame, depth, key, sub)) <= r
                })
            };
            let ranges = (!whole && entry.runs.len() == cells + 1)
                .then(|| sub_cell_ranges(&entry.runs, sub_lo, sub_hi, &touches));
            reads.push((key, entry, ranges));
        }
        // At most every record read is kept: room for them at once, not grown by copies
        // (asked for, not demanded: the manifest's counts are checked against the files as
        // they are read); what a sparse test left unused is given back.
        let most: u64 = reads
            .iter()
            .map(|(_, entry, ranges)| match ranges {
                Some(r) => r.iter().map(|(a, b)| b - a).sum(),
                None => entry.points,
            })
            .sum();
        let mut found: Vec<(u64, OrientedPoint)> = Vec::new();
        let _ = usize::try_from(most).map(|m| found.try_reserve_exact(m));
        for (key, entry, ranges) in reads {
            let path = tile_path(&self.dir, key);
            let bytes = self.read_ranges(&path, entry, ranges.as_deref())?;
            decode_into(&bytes, keep, self.sign(), &mut found);
        }
        if found.capacity() > 2 * found.len() {
            found.shrink_to_fit();
        }
        Ok(in_input_order(found))
    }

    /// The points of the `i`-th tile file (of the manifest's) whose world position `keep`
    /// accepts, with their input indices, in the file's order (by sub-cell).
    pub(crate) fn tile_file_where(
        &self,
        i: usize,
        keep: &dyn Fn(DVec3) -> bool,
    ) -> Result<Vec<(u64, OrientedPoint)>, TileError> {
        let entry = &self.manifest.tiles[i];
        let bytes = self.read_ranges(&tile_path(&self.dir, entry.key), entry, None)?;
        let mut found = Vec::new();
        decode_into(&bytes, keep, self.sign(), &mut found);
        Ok(found)
    }

    /// The points within ∞-distance `halo` of the cube with local centre `center` and
    /// half-edge `half` (world units) whose world position `keep` accepts, in increasing input
    /// index order ([`crate::PointSource::gather_box_where`]; its `gather_box` keeps all).
    pub fn gather_box_where(
        &self,
        center: DVec3,
        half: f64,
        halo: f64,
        keep: &dyn Fn(DVec3) -> bool,
    ) -> Result<Vec<OrientedPoint>, TileError> {
        let found = self.gather_box_indexed(center, half, halo, keep)?;
        Ok(found.into_iter().map(|(_, p)| p).collect())
    }

    /// [`TileStore::gather_box_where`] with each point's index in the whole input.
    pub fn gather_box_indexed(
        &self,
        center: DVec3,
        half: f64,
        halo: f64,
        keep: &dyn Fn(DVec3) -> bool,
    ) -> Result<Vec<(u64, OrientedPoint)>, TileError> {
        let frame = self.manifest.frame;
        let reach = half + halo;
        let (lo, hi, fine) = self.keys_around(center + frame.origin, reach);
        self.gather_keys(lo, hi, fine, None, &|p| {
            (p - frame.origin - center).abs().max_element() <= reach && keep(p)
        })
    }

    /// The tile keys and the sub-cell keys ([`SUB_LEVELS`] deeper) of the cube of half-edge
    /// `reach` around world position `world`, grown by far more than the rounding of the
    /// gathers' tests against these keys' arithmetic (a negative reach may give `lo` above
    /// `hi`: nothing). Exact bounds: [`tile_key`] is monotone in each coordinate (correctly
    /// rounded operations and `floor` are), and a point's key at the tile depth is its
    /// sub-cell key shifted by [`SUB_LEVELS`] (the edges differ by a power of two, so the
    /// quotients do, exactly); a stored point's sub-cell, its sub-cell key clamped into its
    /// tile, then lies within these keys clamped the same way.
    #[allow(clippy::type_complexity)]
    fn keys_around(&self, world: DVec3, reach: f64) -> ([u32; 3], [u32; 3], ([u32; 3], [u32; 3])) {
        let frame = self.manifest.frame;
        let scale = frame.origin.abs().max_element() + world.abs().max_element();
        let grown = DVec3::splat(reach + 1e-9 * frame.root_half + 1e-12 * scale);
        let keys = |depth: u8| {
            (
                tile_key(&frame, depth, world - grown),
                tile_key(&frame, depth, world + grown),
            )
        };
        let (lo, hi) = keys(self.manifest.depth);
        (lo, hi, keys(self.manifest.depth + SUB_LEVELS))
    }

    /// The points within `radius` of world position `center` (and perhaps a few more), in
    /// increasing input index order.
    pub fn gather_ball(&self, center: DVec3, radius: f64) -> Result<Vec<OrientedPoint>, TileError> {
        let (lo, hi, fine) = self.keys_around(center, radius);
        let found = self.gather_keys(lo, hi, fine, Some((center, radius)), &|p| {
            (p - center).length() <= radius
        })?;
        Ok(found.into_iter().map(|(_, p)| p).collect())
    }
}

/// The error for a file of `len` bytes whose manifest entry says `points` records and
/// `expected` bytes with its trailer.
fn wrong_size(path: &Path, len: u64, points: u64, expected: u64) -> TileError {
    io_error(
        path,
        format!(
            "{len} bytes where the manifest says {points} points ({expected} bytes): truncated or replaced"
        ),
    )
}

/// Appends the records of `bytes` whose position satisfies `keep` to `found`, with their
/// input indices and their normals times `sign` (±1: a negation, exact).
fn decode_into(
    bytes: &[u8],
    keep: &dyn Fn(DVec3) -> bool,
    sign: f64,
    found: &mut Vec<(u64, OrientedPoint)>,
) {
    let f = |r: &[u8], k: usize| {
        f64::from_le_bytes(r[8 + 8 * k..16 + 8 * k].try_into().expect("8 bytes"))
    };
    for r in bytes.chunks_exact(RECORD) {
        let p = record_position(r);
        if keep(p) {
            let index = u64::from_le_bytes(r[..8].try_into().expect("8 bytes"));
            found.push((
                index,
                OrientedPoint {
                    p,
                    n: sign * DVec3::new(f(r, 3), f(r, 4), f(r, 5)),
                },
            ));
        }
    }
}
