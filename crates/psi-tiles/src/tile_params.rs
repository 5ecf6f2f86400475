//! How the octree is cut into tiles.

use serde::{Deserialize, Serialize};

use crate::TileError;

/// The tiling: tiles are the octree's cells at `depth` (at most 8^depth of them, those under
/// cells that split), each decided from its points and a halo around it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct TileParams {
    /// Depth of the tile cells (≥ 1; the cells above are decided by one pass over all points).
    pub depth: u8,
    /// The first halo, as a fraction of the tile's edge (≥ 0): the points within this
    /// ∞-distance of the tile's cube come with it. A tile whose fits read farther is decided
    /// again with a halo that covers them (the report counts these).
    pub halo: f64,
    /// Levels of each tile decided by the pass above the tiles (0 to 4): a cell's fit reads
    /// a ball about 1.3 of its edges wide around its centre, so a tile fitting its own top
    /// cell needs a halo of most of a tile edge; with its first 2 levels decided above (from
    /// the coarse points out of core, where those fits thin their balls anyway) a quarter
    /// edge suffices.
    pub shared_levels: u8,
    /// The most cells the decisions may hold at once (`None`: no bound): a build whose cells
    /// pass it stops with [`TileError::TooManyCells`] instead of outgrowing the memory it was
    /// given (the cells follow the surface's detail and ε0, not the points, so no bound on the
    /// input foresees them). Not part of the decisions' files: it changes no decision.
    #[serde(default)]
    pub max_cells: Option<u64>,
}

impl Default for TileParams {
    /// Depth 2 (up to 64 tiles), a halo of a quarter tile edge, 2 shared levels, no bound on
    /// the cells.
    fn default() -> Self {
        TileParams {
            depth: 2,
            halo: 0.25,
            shared_levels: 2,
            max_cells: None,
        }
    }
}

impl TileParams {
    /// Tiles at `depth` with the default halo.
    pub fn at_depth(depth: u8) -> Self {
        TileParams {
            depth,
            ..Default::default()
        }
    }

    /// Checks the ranges: depth 1 to 8, a finite non-negative halo, 0 to 4 shared levels.
    pub fn validate(&self) -> Result<(), TileError> {
        if !(1..=8).contains(&self.depth) {
            return Err(TileError::BadParameter(format!(
                "the tile depth must be 1 to 8, not {}",
                self.depth
            )));
        }
        if self.shared_levels > 4 {
            return Err(TileError::BadParameter(format!(
                "the levels shared above the tiles must be 0 to 4, not {}",
                self.shared_levels
            )));
        }
        if !(self.halo.is_finite() && self.halo >= 0.0) {
            return Err(TileError::BadParameter(format!(
                "the halo must be a finite non-negative fraction of the tile edge, not {}",
                self.halo
            )));
        }
        Ok(())
    }
}
