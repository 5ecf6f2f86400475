//! The memory budget of a run out of core: what a tile, a point of the input and a point held
//! by the relaxation cost, and the tile depth and relaxation points a budget allows.

use std::path::PathBuf;

/// Bytes a tile's build holds per point of the tile: its points with their halo in the MPU's
/// arrays, kd-tree and footprint table, and the balls its far cells fetch (the peaks this is
/// set from: docs/notes/2026-11-25-tiles.md).
const BYTES_PER_TILE_POINT: u64 = 1500;
/// Bytes a point of the whole input costs wherever it is: its coarse copy (1 in 16 of 56
/// bytes) and its share of the cell table.
const BYTES_PER_INPUT_POINT: u64 = 8;

/// Memory of one point held by the relaxation's MPU (an MPU assembled from the decisions: the
/// point, its local position, the kd-tree, the octree's order and the data footprint's cache),
/// with room to spare.
const BYTES_PER_RELAX_POINT: u64 = 400;

/// Bytes the process holds whatever its input: the program, the threads' stacks, and the
/// pages the allocator keeps after freeing (the measurements it is set from:
/// docs/notes/2026-12-04-cell-bound.md).
pub(crate) const PROCESS_BYTES: u64 = 24 << 20;

/// Bytes a cell of the MPU costs the run at its peak while it holds the decisions: its entry
/// in the cell table (address, split flag, fit radius and fit, in a B-tree's nodes), again in
/// the tile's outcome it is merged from, then in the relaxation's MPU (the peak it is set
/// from: docs/notes/2026-12-04-cell-bound.md).
pub(crate) const BYTES_PER_CELL: u64 = 1700;

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

    /// The input points the particles' relaxation may hold (its MPU's data test) for `points`
    /// input points: what the budget leaves after the share of the whole input
    /// ([`crate::sample_files_out_of_core`] relaxes all particles at once; their number follows the
    /// surface, not the input). Neither the process's baseline nor the cells are taken off:
    /// a thinned relaxation holds the thinned data's footprints as well, and peaked higher
    /// than the whole one (docs/notes/2026-12-04-cell-bound.md).
    pub fn relax_points_for(&self, points: u64) -> usize {
        let shared = points.saturating_mul(BYTES_PER_INPUT_POINT);
        (self.max_memory.saturating_sub(shared) / BYTES_PER_RELAX_POINT) as usize
    }

    /// The most cells the decisions may hold within the budget (about 1.7 kB each at the peak):
    /// more cannot fit whatever the tiling (the cells follow the surface's detail and ε0, not
    /// the number of points).
    pub fn max_cells(&self) -> u64 {
        self.data_bytes() / BYTES_PER_CELL
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
        let shared = points.saturating_mul(BYTES_PER_INPUT_POINT);
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
