//! What a build did: counts of cells, leaves per depth, fit kinds, fallbacks and time.

use serde::{Deserialize, Serialize};

use crate::FitKind;

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
    /// Where they went (a timing, as every key ending in `seconds`).
    #[serde(default)]
    pub phase_seconds: BuildPhases,
    /// Refits after a brush whose ball was read from the cell's earlier answer instead of the
    /// kd-tree (the same points: it changes no fit).
    #[serde(default)]
    pub balls_from_earlier: usize,
    /// Marked cells not refitted because a marked ancestor no longer splits (they are not in
    /// the new octree; which of them are caught varies with the threads' timing).
    #[serde(default)]
    pub refits_skipped: usize,
}

/// Wall-clock seconds of a build's phases.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct BuildPhases {
    /// Checking the points and moving them to the local frame.
    pub prepare: f64,
    /// The kd-trees (built, or derived after a brush; after other edits, with the large
    /// marked cells fitted while they are built).
    pub indexes: f64,
    /// The octree level by level with every cell's decision, and beside it, in a local
    /// rebuild, the fits of the marked cells.
    pub fits_and_octree: f64,
    /// The leaves' functions, the report and the evaluation nodes.
    pub assemble: f64,
}

impl BuildReport {
    /// Counts one surface leaf at `depth` (counted as a leaf apart).
    pub(crate) fn count_surface_leaf(&mut self, depth: u8) {
        self.surface_leaves += 1;
        self.surface_leaves_per_depth[usize::from(depth)] += 1;
    }

    /// Counts one leaf at `depth` (the per-depth vectors must reach it) with its fit `kind`,
    /// whether it is a surface leaf (`surface`) and whether its fit fell back.
    pub(crate) fn count_leaf(&mut self, depth: u8, surface: bool, kind: FitKind, fallback: bool) {
        self.leaves += 1;
        self.leaves_per_depth[usize::from(depth)] += 1;
        if surface {
            self.count_surface_leaf(depth);
        }
        self.fallbacks += usize::from(fallback);
        let counts = &mut self.fits;
        match kind {
            FitKind::GeneralQuadric => counts.general_quadric += 1,
            FitKind::Bivariate => counts.bivariate += 1,
            FitKind::Edge => counts.edge += 1,
            FitKind::Corner => counts.corner += 1,
            FitKind::Plane => counts.plane += 1,
        }
    }
}
