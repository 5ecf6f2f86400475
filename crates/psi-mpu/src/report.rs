//! What a build did: counts of cells, leaves per depth, fit kinds, fallbacks and time.

use serde::{Deserialize, Serialize};

/// Counts of leaf fits by kind.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct FitCounts {
    /// General 3D quadrics.
    pub general_quadric: usize,
    /// Bivariate quadratics.
    pub bivariate: usize,
    /// Sharp edges.
    pub edge: usize,
    /// Sharp corners.
    pub corner: usize,
    /// Planes (last fallback).
    pub plane: usize,
}

/// Diagnostics of one MPU build.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct BuildReport {
    /// Oriented input points.
    pub points: usize,
    /// Octree cells (inner and leaves).
    pub cells: usize,
    /// Leaves (each holds a local fit).
    pub leaves: usize,
    /// Leaves whose cube holds at least one input point ("surface-containing").
    pub surface_leaves: usize,
    /// Leaves per depth (index = depth).
    pub leaves_per_depth: Vec<usize>,
    /// Surface-containing leaves per depth (index = depth).
    pub surface_leaves_per_depth: Vec<usize>,
    /// Deepest leaf.
    pub max_depth: u8,
    /// Leaf fits by kind.
    pub fits: FitCounts,
    /// Leaves whose selected fit was degenerate and fell back to a simpler one.
    pub fallbacks: usize,
    /// ε0 in world units (error_rel × D).
    pub eps0: f64,
    /// Bounding-box diagonal D of the input, world units.
    pub bbox_diagonal: f64,
    /// Wall-clock seconds of the build.
    pub seconds: f64,
}
