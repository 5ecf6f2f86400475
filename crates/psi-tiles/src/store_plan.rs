//! A store written in parts (a cluster's partition tasks, run side by side): the plan, what the
//! first pass over the input found (its source, frame and tile depth), is written first; each
//! part then streams the whole input and writes the tiles it owns ([`StorePart`]; part 0 also
//! the coarse points) with a record of what it wrote; the manifest is assembled from those
//! records last. A tile's file holds its records in input order whichever part wrote it, so the
//! store's bytes do not depend on how many parts wrote it.

use std::fs;
use std::path::{Path, PathBuf};

use psi_mpu::MpuFrame;
use serde::{Deserialize, Serialize};

use crate::TileError;
use crate::tile_store::{
    MANIFEST, StoreManifest, StoredTile, TileStore, VERSION, frame_bits, frame_from_bits, io_error,
};

/// The plan's file name in a store directory.
const PLAN: &str = "plan.json";

/// What every part of a store needs before it writes: the input's description, its frame and
/// the tile depth (`plan.json`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StorePlan {
    /// What the points came from ([`StoreManifest::source`]).
    pub source: String,
    /// The whole input's frame as the IEEE bits of its eight numbers (every fit depends on
    /// them; [`StorePlan::frame`] reads them).
    pub frame_bits: [u64; 8],
    /// The depth whose cells the tile files hold.
    pub depth: u8,
}

/// Which tiles one writer writes: part `index` of `count`. A tile belongs to the part its key's
/// hash names (spread evenly over space, so parts hold about equal shares of any input); part
/// 0 also writes the coarse points' file.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct StorePart {
    /// This part, `0..count`.
    pub index: u32,
    /// How many parts write the store (at least 1).
    pub count: u32,
}

/// What one part wrote (`part-<index>-of-<count>.json`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct WrittenPart {
    /// The part.
    pub part: StorePart,
    /// Points in the whole input, as this part counted them.
    pub population: u64,
    /// Its tile files, by key.
    pub tiles: Vec<StoredTile>,
    /// The coarse points' file (part 0 only).
    pub coarse: Option<StoredTile>,
}

impl StorePlan {
    /// The plan of a store of the input described by `source`, in `frame`, tiled at `depth`.
    pub fn new(source: &str, frame: &MpuFrame, depth: u8) -> StorePlan {
        StorePlan {
            source: source.to_owned(),
            frame_bits: frame_bits(frame),
            depth,
        }
    }

    /// The frame, bitwise as given to [`StorePlan::new`].
    pub fn frame(&self) -> MpuFrame {
        frame_from_bits(self.frame_bits)
    }

    /// Starts a store in `dir` (created) for this plan: the files of an earlier store there
    /// are removed, the manifest first (so an interrupted start leaves nothing that looks
    /// finished), then the plan is written (atomically). Files a store does not write are the
    /// user's and stay.
    pub fn start(&self, dir: &Path) -> Result<(), TileError> {
        fs::create_dir_all(dir).map_err(|e| io_error(dir, e))?;
        let manifest = dir.join(MANIFEST);
        if manifest.exists() {
            fs::remove_file(&manifest).map_err(|e| io_error(&manifest, e))?;
        }
        remove_store_files(dir, &is_store_file)?;
        let text = serde_json::to_string_pretty(self).expect("serialisable");
        crate::write_atomically(&dir.join(PLAN), text.as_bytes())
    }

    /// The plan of the store being written in `dir`.
    pub fn read(dir: &Path) -> Result<StorePlan, TileError> {
        read_json(&dir.join(PLAN))
    }
}

impl StorePart {
    /// The whole store as one part.
    pub const WHOLE: StorePart = StorePart { index: 0, count: 1 };

    /// Part `index` of `count`.
    ///
    /// # Errors
    ///
    /// [`TileError::Store`] unless `index < count`.
    pub fn new(index: u32, count: u32) -> Result<StorePart, TileError> {
        if index >= count {
            return Err(TileError::Store(format!(
                "part {index} of {count}: a part's index must be below the count"
            )));
        }
        Ok(StorePart { index, count })
    }

    /// Whether the tile `key` is this part's.
    pub fn holds(&self, key: [u32; 3]) -> bool {
        // SplitMix64's finaliser of the packed key (Steele, Lea and Flood 2014): neighbouring
        // tiles land in unrelated parts.
        let mut z = u64::from(key[0]) | u64::from(key[1]) << 21 | u64::from(key[2]) << 42;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        z % u64::from(self.count) == u64::from(self.index)
    }

    /// Whether this part writes the coarse points' file.
    pub fn holds_coarse(&self) -> bool {
        self.index == 0
    }

    /// The file recording what this part wrote, in `dir`.
    pub(crate) fn record_path(&self, dir: &Path) -> PathBuf {
        dir.join(format!("part-{}-of-{}.json", self.index, self.count))
    }
}

impl TileStore {
    /// Writes the manifest of the store in `dir` from its plan and the records of its `count`
    /// parts (every one written), atomically and last, and opens the store.
    ///
    /// # Errors
    ///
    /// [`TileError::Store`] naming the file when the plan or a part's record is missing or
    /// unreadable, or when the parts counted different inputs.
    pub fn assemble(dir: &Path, count: u32) -> Result<TileStore, TileError> {
        let plan = StorePlan::read(dir)?;
        let (mut tiles, mut coarse, mut population) = (Vec::new(), None, None);
        for index in 0..count {
            let part = StorePart::new(index, count)?;
            let path = part.record_path(dir);
            let written: WrittenPart = read_json(&path)?;
            if written.part != part || population.is_some_and(|n| n != written.population) {
                return Err(io_error(
                    &path,
                    "the parts disagree on the input: run the partition again",
                ));
            }
            population = Some(written.population);
            tiles.extend(written.tiles);
            coarse = coarse.or(written.coarse);
        }
        let coarse = coarse.ok_or_else(|| io_error(dir, "no part wrote the coarse points"))?;
        tiles.sort_by_key(|t| t.key);
        let manifest = StoreManifest {
            version: VERSION,
            source: plan.source.clone(),
            frame: plan.frame(),
            frame_bits: plan.frame_bits,
            population: population.unwrap_or(0),
            depth: plan.depth,
            tiles,
            coarse,
            normals_negated: false,
        };
        let text = serde_json::to_string_pretty(&manifest).expect("serialisable");
        crate::write_atomically(&dir.join(MANIFEST), text.as_bytes())?;
        TileStore::open(dir)
    }
}

fn read_json<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T, TileError> {
    let text = fs::read_to_string(path).map_err(|e| io_error(path, e))?;
    serde_json::from_str(&text).map_err(|e| io_error(path, e))
}

/// Removes the files in `dir` whose names satisfy `remove`.
pub(crate) fn remove_store_files(
    dir: &Path,
    remove: &dyn Fn(&str) -> bool,
) -> Result<(), TileError> {
    for entry in fs::read_dir(dir).map_err(|e| io_error(dir, e))? {
        let path = entry.map_err(|e| io_error(dir, e))?.path();
        if path
            .file_name()
            .is_some_and(|n| remove(&n.to_string_lossy()))
        {
            fs::remove_file(&path).map_err(|e| io_error(&path, e))?;
        }
    }
    Ok(())
}

/// The key in a file name `<prefix>X-Y-Z<ext>`, if it is one.
pub(crate) fn key_in_name(name: &str, prefix: &str, ext: &str) -> Option<[u32; 3]> {
    let k = name.strip_prefix(prefix)?.strip_suffix(ext)?;
    let mut parts = k.split('-');
    let mut key = [0u32; 3];
    for v in &mut key {
        let p = parts.next()?;
        if p.is_empty() || !p.bytes().all(|b| b.is_ascii_digit()) {
            return None;
        }
        *v = p.parse().ok()?;
    }
    parts.next().is_none().then_some(key)
}

/// Whether `name` is one of the files a store writes: its plan, its parts' records, its point
/// files (`tile-X-Y-Z.pts`, `coarse.pts`) and the decisions and seeds made from them.
fn is_store_file(name: &str) -> bool {
    let part_record = name
        .strip_prefix("part-")
        .and_then(|r| r.strip_suffix(".json"))
        .and_then(|r| r.split_once("-of-"))
        .is_some_and(|(a, b)| a.parse::<u32>().is_ok() && b.parse::<u32>().is_ok());
    name == PLAN
        || part_record
        || name == "coarse.pts"
        || name == "cells-top.bin"
        || name == "cells-upper.bin"
        || key_in_name(name, "tile-", ".pts").is_some()
        || key_in_name(name, "cells-group-", ".bin").is_some()
        || key_in_name(name, "seeds-", ".bin").is_some()
        || key_in_name(name, "cells-", ".bin").is_some()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parts_split_the_tiles_evenly_and_exactly_once() {
        for count in [1, 2, 3, 8] {
            let mut held = vec![0usize; count as usize];
            for x in 0..16 {
                for y in 0..16 {
                    for z in 0..16 {
                        let owners: Vec<u32> = (0..count)
                            .filter(|&i| StorePart::new(i, count).unwrap().holds([x, y, z]))
                            .collect();
                        assert_eq!(owners.len(), 1, "{x} {y} {z} of {count}");
                        held[owners[0] as usize] += 1;
                    }
                }
            }
            // As even as a random assignment: within 4.5 standard deviations of the binomial.
            let p = 1.0 / f64::from(count);
            let (even, sd) = (4096.0 * p, (4096.0 * p * (1.0 - p)).sqrt());
            for h in held {
                assert!((h as f64 - even).abs() <= 4.5 * sd, "{count}: {h}");
            }
        }
        assert!(StorePart::new(2, 2).is_err());
    }

    #[test]
    fn store_file_names_are_told_from_the_users() {
        for name in [
            "tile-0-12-3.pts",
            "coarse.pts",
            "plan.json",
            "part-0-of-2.json",
            "cells-1-2-3.bin",
            "cells-group-1-0-1.bin",
            "seeds-0-1-1.bin",
        ] {
            assert!(is_store_file(name), "{name}");
        }
        for name in [
            "tile-0-1.pts",
            "tile-a-1-2.pts",
            "notes.txt",
            "part-x-of-2.json",
        ] {
            assert!(!is_store_file(name), "{name}");
        }
        assert_eq!(
            key_in_name("tile-4-0-17.pts", "tile-", ".pts"),
            Some([4, 0, 17])
        );
        assert_eq!(key_in_name("tile-4-0-17-1.pts", "tile-", ".pts"), None);
    }
}
