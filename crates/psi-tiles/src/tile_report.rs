//! What a tiled build did: tiles, halos and where the time went.

use serde::{Deserialize, Serialize};

/// Figures of a tiled build (`tiles` in the JSON report).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TileReport {
    /// Tiles decided (cells at the tile depth under cells that split).
    pub count: usize,
    /// The tile depth.
    pub depth: u8,
    /// The first halo, a fraction of the tile edge.
    pub halo: f64,
    /// Per tile, in tile order: the points in its cube.
    pub points_per_tile: Vec<usize>,
    /// Per tile: the points it was decided from (cube and final halo).
    pub halo_points: Vec<usize>,
    /// Tiles decided again with a larger halo because a fit read beyond the first one.
    pub halos_grown: usize,
    /// Cells whose fit ball crosses a face of their tile's cube.
    pub crossing_cells: usize,
    /// Of those, cells whose ball reached beyond the tile's halo and was fetched whole.
    pub balls_fetched: usize,
    /// Cells decided by the pass over all points above the tiles.
    pub top_cells: usize,
    /// Cells in all.
    pub cells: usize,
    /// Seconds: the pass above the tiles, the tiles, putting the MPU together.
    pub top_seconds: f64,
    /// Seconds deciding the tiles.
    pub tile_seconds: f64,
    /// Seconds assembling the MPU from the decisions.
    pub assemble_seconds: f64,
}
