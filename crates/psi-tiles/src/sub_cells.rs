//! A tile file's records grouped by sub-cell, so that a box smaller than the tile reads only
//! the runs of records it needs: the tile cube split [`SUB_LEVELS`] levels further, the
//! sub-cells taken x fastest, then y, then z, each sub-cell's records in input order, and the
//! run boundaries kept in the manifest ([`crate::StoredTile::runs`]).

use glam::DVec3;
use psi_mpu::MpuFrame;

use crate::tile_records::{RECORD, record_position, tile_key};

/// Levels below the tile at which its records are grouped (8 × 8 × 8 sub-cells).
pub(crate) const SUB_LEVELS: u8 = 3;

/// Sub-cells per axis of a tile.
pub(crate) const SUB: u32 = 1 << SUB_LEVELS;

/// The sub-cell (per axis, `0..SUB`) of world position `p` in the tile `key` at `depth`:
/// its key [`SUB_LEVELS`] deeper, relative to the tile, clamped into it (the tile's key is
/// that key shifted, so the clamp only guards; readers bound the keys of what they gather the
/// same way, `TileStore::keys_around`).
pub(crate) fn sub_cell_of(frame: &MpuFrame, depth: u8, key: [u32; 3], p: DVec3) -> [u32; 3] {
    let fine = tile_key(frame, depth + SUB_LEVELS, p);
    std::array::from_fn(|a| fine[a].saturating_sub(key[a] * SUB).min(SUB - 1))
}

/// The linear index of sub-cell `s` (x fastest).
fn linear(s: [u32; 3]) -> usize {
    (s[0] + SUB * (s[1] + SUB * s[2])) as usize
}

/// The records of the tile `key` at `depth` (`bytes`, whole records, in input order) grouped
/// by sub-cell (a stable counting sort, so each sub-cell keeps input order), and the runs:
/// `runs[s]` records come before sub-cell `s`, `runs[SUB³]` is the count (shape SUB³ + 1).
pub(crate) fn order_by_sub_cell(
    frame: &MpuFrame,
    depth: u8,
    key: [u32; 3],
    bytes: &[u8],
) -> (Vec<u8>, Vec<u64>) {
    let cells = (SUB * SUB * SUB) as usize;
    let of: Vec<usize> = bytes
        .chunks_exact(RECORD)
        .map(|r| linear(sub_cell_of(frame, depth, key, record_position(r))))
        .collect();
    let mut runs = vec![0u64; cells + 1];
    for &s in &of {
        runs[s + 1] += 1;
    }
    for s in 0..cells {
        runs[s + 1] += runs[s];
    }
    let mut next: Vec<u64> = runs[..cells].to_vec();
    let mut out = vec![0u8; bytes.len()];
    for (r, &s) in bytes.chunks_exact(RECORD).zip(&of) {
        let at = next[s] as usize * RECORD;
        out[at..at + RECORD].copy_from_slice(r);
        next[s] += 1;
    }
    (out, runs)
}

/// The record ranges (first, end; records) of the sub-cells `lo..=hi` per axis (sub-cell
/// coordinates within the tile, `hi` at most `SUB - 1`) that `touches` keeps, given the
/// tile's `runs`; adjoining ones merged, empty ones left out.
pub(crate) fn sub_cell_ranges(
    runs: &[u64],
    lo: [u32; 3],
    hi: [u32; 3],
    touches: &dyn Fn([u32; 3]) -> bool,
) -> Vec<(u64, u64)> {
    let mut out: Vec<(u64, u64)> = Vec::new();
    for z in lo[2]..=hi[2] {
        for y in lo[1]..=hi[1] {
            for x in lo[0]..=hi[0] {
                let s = linear([x, y, z]);
                let (first, end) = (runs[s], runs[s + 1]);
                if end == first || !touches([x, y, z]) {
                    continue;
                }
                match out.last_mut() {
                    Some(last) if last.1 == first => last.1 = end,
                    _ => out.push((first, end)),
                }
            }
        }
    }
    out
}

/// The non-empty sub-cells of a tile file whose runs are `runs` (shape SUB³ + 1): each one's
/// linear index and its coordinates within the tile (x fastest).
pub(crate) fn occupied_sub_cells(runs: &[u64]) -> impl Iterator<Item = (usize, [u32; 3])> + '_ {
    (0..runs.len().saturating_sub(1))
        .filter(move |&s| runs[s + 1] != runs[s])
        .map(|s| {
            let l = s as u32;
            (s, [l % SUB, (l / SUB) % SUB, l / (SUB * SUB)])
        })
}

/// The box (world units, min and max) of sub-cell `sub` of the tile `key` at `depth`, grown by
/// far more than rounding, so that it holds every point keyed to the sub-cell.
pub(crate) fn sub_cell_box(
    frame: &MpuFrame,
    depth: u8,
    key: [u32; 3],
    sub: [u32; 3],
) -> (DVec3, DVec3) {
    let low = frame.origin + frame.root_center - DVec3::splat(frame.root_half);
    let edge = 2.0 * frame.root_half / f64::from(1u32 << (depth + SUB_LEVELS));
    let slack = 1e-9 * frame.root_half + 1e-12 * low.abs().max_element();
    let corner = DVec3::from_array(std::array::from_fn(|a| f64::from(key[a] * SUB + sub[a])));
    let min = low + corner * edge - DVec3::splat(slack);
    (min, min + DVec3::splat(edge + 2.0 * slack))
}

/// The distance from `x` to the box (`min`, `max`): 0 inside.
pub(crate) fn box_distance(x: DVec3, (min, max): (DVec3, DVec3)) -> f64 {
    (min - x).max(x - max).max(DVec3::ZERO).length()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Grouping keeps every record once, each sub-cell's records in input order, and the runs
    /// name each record's sub-cell; the ranges of a box of sub-cells hold exactly their
    /// records (brute force over the grouped records).
    #[test]
    fn grouping_keeps_every_record_and_each_runs_order() {
        let frame = MpuFrame {
            origin: DVec3::new(10.0, -3.0, 0.5),
            root_center: DVec3::ZERO,
            root_half: 1.0,
            diagonal: 2.0,
        };
        let depth = 1;
        let key = [1, 0, 1];
        // Points spread over the tile [0, 1] × [-1, 0] × [0, 1] (local), faces included.
        let mut bytes = Vec::new();
        let mut state = 12345u64;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        for i in 0..4000u64 {
            let mut local = DVec3::new(next(), next() - 1.0, next());
            if i % 50 == 0 {
                local.x = 0.5; // on a sub-cell face
            }
            let p = local + frame.origin;
            bytes.extend_from_slice(&i.to_le_bytes());
            for v in [p.x, p.y, p.z, 0.0, 0.0, 1.0] {
                bytes.extend_from_slice(&v.to_le_bytes());
            }
        }
        let (grouped, runs) = order_by_sub_cell(&frame, depth, key, &bytes);
        assert_eq!(grouped.len(), bytes.len());
        assert_eq!(runs.len(), (SUB * SUB * SUB) as usize + 1);
        assert_eq!(runs[runs.len() - 1], 4000);
        let index = |r: &[u8]| u64::from_le_bytes(r[..8].try_into().unwrap());
        let mut seen: Vec<u64> = grouped.chunks_exact(RECORD).map(index).collect();
        for s in 0..runs.len() - 1 {
            let run = &seen[runs[s] as usize..runs[s + 1] as usize];
            assert!(run.is_sorted(), "sub-cell {s} keeps input order");
            for r in grouped[runs[s] as usize * RECORD..runs[s + 1] as usize * RECORD]
                .chunks_exact(RECORD)
            {
                let c = sub_cell_of(&frame, depth, key, record_position(r));
                assert_eq!(linear(c), s);
            }
        }
        seen.sort_unstable();
        assert_eq!(seen, (0..4000).collect::<Vec<_>>());
        for (lo, hi) in [
            ([1, 0, 2], [2, 7, 3]),
            ([0, 0, 0], [7, 7, 7]),
            ([3, 3, 3], [3, 3, 3]),
        ] {
            let from_ranges: Vec<u64> = sub_cell_ranges(&runs, lo, hi, &|_| true)
                .iter()
                .flat_map(|&(a, b)| {
                    grouped[a as usize * RECORD..b as usize * RECORD]
                        .chunks_exact(RECORD)
                        .map(index)
                })
                .collect();
            let brute: Vec<u64> = grouped
                .chunks_exact(RECORD)
                .filter(|r| {
                    let c = sub_cell_of(&frame, depth, key, record_position(r));
                    (0..3).all(|a| lo[a] <= c[a] && c[a] <= hi[a])
                })
                .map(index)
                .collect();
            assert_eq!(from_ranges, brute);
        }
    }
}
