//! Errors of a tiled build.

use psi_mpu::{CellAddress, MpuError};
use thiserror::Error;

/// Why a tiled build failed.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum TileError {
    /// A tiling parameter is out of range.
    ///
    /// ```
    /// use psi_tiles::{TileError, TileParams};
    /// assert!(matches!(TileParams { depth: 0, ..TileParams::default() }.validate(), Err(TileError::BadParameter(_))));
    /// ```
    #[error("tiling: {0}")]
    BadParameter(String),
    /// The MPU layer refused the input or a region (see [`MpuError`]).
    #[error(transparent)]
    Mpu(#[from] MpuError),
    /// A store file could not be read or written, or failed its check (the message names the
    /// file and the problem).
    #[error("tile store: {0}")]
    Store(String),
    /// A long call was stopped by its monitor.
    #[error(transparent)]
    Interrupted(#[from] psi_octree::Interrupted),
    /// Two regions decided the same cell differently (a bug: tiles overlap only in the cells
    /// above them, which the top pass alone decides).
    #[error("two regions disagree on the cell at depth {}, key {:?}", .0.0, .0.1)]
    Conflict(CellAddress),
    /// The MPU has more cells than [`crate::TileParams::max_cells`] (`max`) allows (the build
    /// stopped once those decided passed it).
    #[error("the MPU has more than {max} cells")]
    TooManyCells {
        /// The bound.
        max: u64,
    },
}
