//! The memory budget of a run out of core: what the process, a tile, a point of the input, a
//! cell and a point held by the relaxation cost, and the tile depth, the most cells, the
//! relaxation's points and the stores' write buffers a budget allows.

use std::path::PathBuf;

/// Bytes a tile's build holds per point of the tile: its points with their halo in the MPU's
/// arrays, kd-tree and footprint table, and the balls its far cells fetch (the peaks this is
/// set from: docs/notes/2026-11-25-tiles.md).
const BYTES_PER_TILE_POINT: u64 = 1500;
/// Bytes a point of the whole input costs wherever it is: its coarse copy (1 in 16 of 56
/// bytes) and its share of the cell table.
const BYTES_PER_INPUT_POINT: u64 = 8;

/// Memory of one point held by the relaxation's MPU (an MPU assembled from the decisions: the
/// point, its local position, the kd-tree, the octree's order and the data footprint's cache;
/// a thinned subset's footprints and the seeding's share of it before the trim), with room to
/// spare (the peaks it is set from: docs/notes/2026-12-05-relaxation-budget.md).
const BYTES_PER_RELAX_POINT: u64 = 350;

/// The cells leave the relaxation's points at least 1/`RELAX_SHARE` of what the process's
/// baseline and the input's share leave of the budget, unless every point fits in less.
const RELAX_SHARE: u64 = 4;

/// Bytes of a point's record in a store (its index, position and normal).
const STORE_RECORD_BYTES: u64 = 56;

/// Bytes the process holds whatever its input: the program, the threads' stacks, and the
/// pages the allocator keeps after freeing (the measurements it is set from:
/// docs/notes/2026-12-04-cell-bound.md).
pub(crate) const PROCESS_BYTES: u64 = 24 << 20;

/// Bytes a cell of the MPU costs the run at its peak while it holds the decisions: its entry
/// in the cell table (address, split flag, fit radius and fit, in a B-tree's nodes), again in
/// the tile's outcome it is merged from, then in the relaxation's MPU (the peak it is set
/// from: docs/notes/2026-12-04-cell-bound.md).
pub(crate) const BYTES_PER_CELL: u64 = 1700;

/// The points a store's writer buffers before appending them to their tile files, within a
/// budget of `max_memory` bytes: an eighth of it in records (a tile's buffer grows by doubling,
/// up to twice its records: a quarter overran small budgets,
/// docs/notes/2026-12-05-relaxation-budget.md), at least 65 536.
pub(crate) fn write_buffer_points(max_memory: u64) -> usize {
    (max_memory / 8 / STORE_RECORD_BYTES).max(1 << 16) as usize
}

/// How a run out of core may use the machine.
#[derive(Clone, Debug)]
pub struct OutOfCore {
    /// Bytes the process may hold resident at its peak (its own baseline, about 24 MiB,
    /// included).
    pub max_memory: u64,
    /// Where the tile files go (created; a run finds its earlier files there and resumes).
    pub scratch: PathBuf,
    /// Tiles at this depth instead of the one `max_memory` gives.
    pub tile_depth: Option<u8>,
}

impl OutOfCore {
    /// Bytes the run's data may take: the budget less the process's baseline.
    fn data_bytes(&self) -> u64 {
        self.max_memory.saturating_sub(PROCESS_BYTES)
    }

    /// Bytes the input's `points` cost wherever they are (their coarse copy, their share of
    /// the cell table).
    fn shared_bytes(points: u64) -> u64 {
        points.saturating_mul(BYTES_PER_INPUT_POINT)
    }

    /// The input points the particles' relaxation may hold (its MPU's data test) for `points`
    /// input points decided into `cells` cells: what the budget leaves after the process's
    /// baseline, the whole input's share and the cells (held by the decisions and by the
    /// relaxation's MPU while it runs; [`crate::sample_files_out_of_core`] relaxes all particles
    /// at once, and their number follows the surface, not the input).
    pub fn relax_points_for(&self, points: u64, cells: u64) -> usize {
        let held = Self::shared_bytes(points).saturating_add(cells.saturating_mul(BYTES_PER_CELL));
        (self.data_bytes().saturating_sub(held) / BYTES_PER_RELAX_POINT) as usize
    }

    /// The most cells the decisions of `points` input points may hold within the budget
    /// (about 1.7 kB each at the peak): what the process's baseline and the input's share
    /// leave, less the relaxation's room for every point or, when that is more, a quarter of
    /// that room (the least a thinned relaxation keeps). More cannot fit whatever the tiling (the
    /// cells follow the surface's detail and ε0, not the number of points).
    pub fn max_cells_for(&self, points: u64) -> u64 {
        let room = self.data_bytes().saturating_sub(Self::shared_bytes(points));
        let relax = points
            .saturating_mul(BYTES_PER_RELAX_POINT)
            .min(room / RELAX_SHARE);
        (room - relax) / BYTES_PER_CELL
    }

    /// The tile depth for `points` input points: the shallowest (at least 1, at most 8)
    /// whose tiles, about `points / 4^depth` each on a surface, fit the budget with two
    /// built at once; an error naming the memory needed when even the whole input's share
    /// (coarse points, cell table) would not fit.
    pub fn tile_depth_for(&self, points: u64) -> Result<u8, String> {
        if let Some(d) = self.tile_depth {
            if !(1..=8).contains(&d) {
                return Err(format!("the tile depth must be 1 to 8, not {d}"));
            }
            return Ok(d);
        }
        let shared = Self::shared_bytes(points);
        if 2 * shared > self.data_bytes() {
            return Err(format!(
                "{} points need at least {} MiB out of core (their coarse copy and cell table, \
                 and the process itself), more than --max-memory {} MiB allows",
                points,
                (2 * shared + PROCESS_BYTES).div_ceil(1 << 20),
                self.max_memory >> 20
            ));
        }
        let per_tile = (self.data_bytes() - shared) / (2 * BYTES_PER_TILE_POINT);
        (1..=8u8)
            .find(|&d| points / 4u64.pow(u32::from(d)) <= per_tile)
            .ok_or_else(|| {
                format!(
                    "{points} points need tiles deeper than 8 levels within --max-memory {} MiB; \
                     give more memory",
                    self.max_memory >> 20
                )
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Whatever the input and the cells the bound lets through, the process's baseline, the
    /// input's share, the cells and the relaxation's points add up to the budget at most, and
    /// the relaxation keeps at least what the cells' share leaves.
    #[test]
    fn the_cells_and_the_relaxation_share_the_budget() {
        for mib in [64u64, 69, 96, 256, 1024, 4096] {
            let budget = OutOfCore {
                max_memory: mib << 20,
                scratch: PathBuf::new(),
                tile_depth: None,
            };
            for points in [0u64, 20_000, 1_000_000, 3_000_000, 100_000_000] {
                let shared = points * BYTES_PER_INPUT_POINT;
                if 2 * shared > budget.data_bytes() {
                    assert!(budget.tile_depth_for(points).is_err());
                    continue;
                }
                let max = budget.max_cells_for(points);
                for cells in [0, max / 2, max] {
                    let relax = budget.relax_points_for(points, cells) as u64;
                    let total = PROCESS_BYTES
                        + shared
                        + cells * BYTES_PER_CELL
                        + relax * BYTES_PER_RELAX_POINT;
                    assert!(total <= budget.max_memory, "{mib} MiB, {points}, {cells}");
                    let room = budget.data_bytes() - shared;
                    let least = (room / RELAX_SHARE / BYTES_PER_RELAX_POINT).min(points);
                    assert!(relax >= least, "{mib} MiB, {points}: {relax}");
                }
                // One more cell than the bound would leave the relaxation less than its room.
                let room = budget.data_bytes() - shared;
                let relax_room = (points * BYTES_PER_RELAX_POINT).min(room / RELAX_SHARE);
                let after = room.saturating_sub((max + 1) * BYTES_PER_CELL);
                assert!(after < relax_room || points == 0, "{mib} MiB, {points}");
            }
        }
    }
}
