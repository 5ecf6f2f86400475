//! Writing a store's files from the input as it streams: each point's record (with its index
//! in the whole input) appended to its tile's file, buffered; when the input ends, each file
//! grouped by sub-cell (`sub_cells.rs`) and given its runs' checksums (`run_digests.rs`). A
//! writer writes one part of the store ([`StorePart`]; `store_plan.rs`), which is the whole
//! store unless a cluster's tasks write it side by side.

use std::collections::BTreeMap;
use std::fs::{self, File};
use std::io::{BufWriter, Read, Write};
use std::path::{Path, PathBuf};

use psi_mpu::{MpuFrame, is_coarse_point};
use psi_octree::OrientedPoint;
use rayon::prelude::*;

use crate::TileError;
use crate::run_digests::{RunDigest, run_digests, trailer_sum};
use crate::store_plan::{StorePart, StorePlan, WrittenPart, key_in_name, remove_store_files};
use crate::sub_cells::order_by_sub_cell;
use crate::tile_records::{RECORD, tile_key};
use crate::tile_store::{StoredTile, TileStore, io_error, tile_path};

/// Writes points into a store (one part of it), buffering at most about `buffer_points` of
/// them in memory.
pub struct TileWriter {
    dir: PathBuf,
    frame: MpuFrame,
    depth: u8,
    part: StorePart,
    buffer_points: usize,
    buffered: usize,
    next_index: u64,
    pending: BTreeMap<[u32; 3], Vec<u8>>,
    counts: BTreeMap<[u32; 3], u64>,
    /// The coarse points' file and its count (the part that holds it).
    coarse: Option<(BufWriter<File>, u64)>,
}

fn push_record(out: &mut Vec<u8>, index: u64, p: &OrientedPoint) {
    out.extend_from_slice(&index.to_le_bytes());
    for v in [p.p.x, p.p.y, p.p.z, p.n.x, p.n.y, p.n.z] {
        out.extend_from_slice(&v.to_le_bytes());
    }
}

impl TileWriter {
    /// Starts a whole store in `dir` (created; an earlier store there is replaced when this
    /// one finishes) for an input whose frame is `frame`, tiles at `depth`, described by
    /// `source` ([`crate::StoreManifest::source`]): [`StorePlan::start`], then
    /// [`TileWriter::create_part`] of [`StorePart::WHOLE`].
    pub fn create(
        dir: &Path,
        frame: MpuFrame,
        depth: u8,
        buffer_points: usize,
        source: &str,
    ) -> Result<TileWriter, TileError> {
        let plan = StorePlan::new(source, &frame, depth);
        plan.start(dir)?;
        TileWriter::create_part(dir, &plan, StorePart::WHOLE, buffer_points)
    }

    /// Starts `part` of the store `plan` describes in `dir` ([`StorePlan::start`] came
    /// first). Whatever the part wrote before (a task that died and is run again) is removed.
    pub fn create_part(
        dir: &Path,
        plan: &StorePlan,
        part: StorePart,
        buffer_points: usize,
    ) -> Result<TileWriter, TileError> {
        let record = part.record_path(dir);
        if record.exists() {
            fs::remove_file(&record).map_err(|e| io_error(&record, e))?;
        }
        remove_store_files(dir, &|name| {
            key_in_name(name, "tile-", ".pts").is_some_and(|key| part.holds(key))
        })?;
        let coarse = if part.holds_coarse() {
            let path = dir.join("coarse.pts");
            let file = File::create(&path).map_err(|e| io_error(&path, e))?;
            Some((BufWriter::new(file), 0))
        } else {
            None
        };
        Ok(TileWriter {
            dir: dir.to_path_buf(),
            frame: plan.frame(),
            depth: plan.depth,
            part,
            buffer_points: buffer_points.max(1),
            buffered: 0,
            next_index: 0,
            pending: BTreeMap::new(),
            counts: BTreeMap::new(),
            coarse,
        })
    }

    /// Adds the next `points` of the input (their indices follow the points added before);
    /// keeps those of this part's tiles.
    pub fn push(&mut self, points: &[OrientedPoint]) -> Result<(), TileError> {
        let mut record = Vec::with_capacity(RECORD);
        for p in points {
            let index = self.next_index;
            self.next_index += 1;
            let key = tile_key(&self.frame, self.depth, p.p);
            if self.part.holds(key) {
                push_record(self.pending.entry(key).or_default(), index, p);
                *self.counts.entry(key).or_default() += 1;
                self.buffered += 1;
            }
            if let Some((file, count)) = &mut self.coarse
                && is_coarse_point(&self.frame, p.p)
            {
                record.clear();
                push_record(&mut record, index, p);
                let path = self.dir.join("coarse.pts");
                file.write_all(&record).map_err(|e| io_error(&path, e))?;
                *count += 1;
            }
            if self.buffered >= self.buffer_points {
                self.flush()?;
            }
        }
        Ok(())
    }

    /// Appends the buffered records to their tile files.
    fn flush(&mut self) -> Result<(), TileError> {
        for (key, bytes) in std::mem::take(&mut self.pending) {
            let path = tile_path(&self.dir, key);
            let mut f = fs::OpenOptions::new()
                .create(true)
                .append(true)
                .open(&path)
                .map_err(|e| io_error(&path, e))?;
            f.write_all(&bytes).map_err(|e| io_error(&path, e))?;
        }
        self.buffered = 0;
        Ok(())
    }

    /// Writes what is buffered, groups and checksums every file of this part and writes the
    /// part's record (atomically, last); returns it.
    pub fn finish_part(mut self) -> Result<WrittenPart, TileError> {
        self.flush()?;
        let coarse = match self.coarse.take() {
            Some((mut file, points)) => {
                let path = self.dir.join("coarse.pts");
                file.flush().map_err(|e| io_error(&path, e))?;
                drop(file);
                Some(StoredTile {
                    key: [0; 3],
                    points,
                    sha256: append_digest(&path)?,
                    runs: vec![0, points],
                })
            }
            None => None,
        };
        // Each file grouped by sub-cell, one tile at a time per thread (a tile fits in
        // memory); the tiles in key order whatever the threads.
        let (frame, depth, dir) = (self.frame, self.depth, &self.dir);
        let counts: Vec<([u32; 3], u64)> = self.counts.iter().map(|(&k, &n)| (k, n)).collect();
        let tiles = counts
            .into_par_iter()
            .map(|(key, points)| {
                let path = tile_path(dir, key);
                let bytes = fs::read(&path).map_err(|e| io_error(&path, e))?;
                let (bytes, runs) = order_by_sub_cell(&frame, depth, key, &bytes);
                let trailer = run_digests(&bytes, &runs);
                crate::write_atomically::write_parts_atomically(&path, &[&bytes, &trailer])?;
                Ok(StoredTile {
                    key,
                    points,
                    sha256: trailer_sum(&trailer),
                    runs,
                })
            })
            .collect::<Result<Vec<StoredTile>, TileError>>()?;
        let written = WrittenPart {
            part: self.part,
            population: self.next_index,
            tiles,
            coarse,
        };
        let text = serde_json::to_string_pretty(&written).expect("serialisable");
        crate::write_atomically(&self.part.record_path(&self.dir), text.as_bytes())?;
        Ok(written)
    }

    /// [`TileWriter::finish_part`], then the store's manifest ([`TileStore::assemble`]: every
    /// other part must have finished, as when this writer writes the whole store).
    pub fn finish(self) -> Result<TileStore, TileError> {
        let (dir, count) = (self.dir.clone(), self.part.count);
        self.finish_part()?;
        TileStore::assemble(&dir, count)
    }
}

/// Appends to the file at `path` (whole records, one run) its run's digest, as its trailer
/// (`run_digests.rs`); returns the manifest's checksum of it.
fn append_digest(path: &Path) -> Result<String, TileError> {
    let mut f = fs::OpenOptions::new()
        .read(true)
        .append(true)
        .open(path)
        .map_err(|e| io_error(path, e))?;
    let mut h = RunDigest::default();
    let mut buf = vec![0u8; 1 << 20];
    loop {
        let n = f.read(&mut buf).map_err(|e| io_error(path, e))?;
        if n == 0 {
            break;
        }
        h.update(&buf[..n]);
    }
    let trailer = h.finish();
    f.write_all(&trailer).map_err(|e| io_error(path, e))?;
    f.sync_all().map_err(|e| io_error(path, e))?;
    Ok(trailer_sum(&trailer))
}
