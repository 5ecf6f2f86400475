//! Parameters of the MPU build, with Ohtake's published defaults.

use serde::{Deserialize, Serialize};

/// Every parameter of the MPU build. Construct with [`MpuParams::paper`] and override fields
/// with struct-update syntax.
///
/// Sources (`../shared/reference/algorithms.md` §1 and §5): Ohtake's `vtkMPU.cxx` and
/// `ImplicitOctTree.h` ("recommended values").
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct MpuParams {
    /// Error threshold ε0 relative to the input's bounding-box diagonal D (Ohtake: 0.005).
    pub error_rel: f64,
    /// Support radius R = α × cell diagonal (Ohtake: 0.75).
    pub alpha: f64,
    /// Radius growth step λ: R1 ← R1 + λR until more than `n_min` points are inside (0.1).
    pub lambda: f64,
    /// A fit needs more than this many points (Ohtake: 15).
    pub n_min: usize,
    /// Maximum octree depth (root = 0). Ohtake's 20 is effectively unbounded; 12 by default.
    pub max_depth: u8,
    /// Root cube edge as a multiple of the largest bounding-box extent (Ohtake's `Box` = 1.2).
    pub box_scale: f64,
    /// Whether sharp edge and corner functions are used.
    pub sharp: bool,
    /// Edge test: the cell holds an edge when min n_i·n_j < T_edge (0.9).
    pub t_edge: f64,
    /// Corner test: a corner when max |(n_i × n_j)·n_k| ≥ T_corner (0.7).
    pub t_corner: f64,
    /// The length unit (world units) of the local least-squares solves, in which the relative
    /// singular-value cut-offs (1e-5 bivariate, 1e-7 general, 1e-3 sharp) apply. `Some(1.0)` is
    /// Ohtake's code, which solves in raw world coordinates: in small cells the quadratic terms
    /// then fall below the cut-off and the fits become nearly planar, so the octree subdivides
    /// further — this reproduces the paper's cell (and particle) counts, but makes the MPU depend
    /// on the input's units. `None` solves in units of each cell's fit radius: unit-independent
    /// full quadratic fits and fewer cells.
    pub fit_unit: Option<f64>,
    /// With world-unit solves (`fit_unit = Some(_)`), whether each leaf with a smooth fit within
    /// ε0 (not a leaf only for reaching the depth limit) is solved again in units of its fit
    /// radius, the one with the smaller error (largest Taubin distance within R) kept. The split
    /// decisions — so the octree, its leaves and the particle count — stay those of the
    /// world-unit fits; only the leaves' functions get closer to the data (figures in
    /// docs/results, reasons in docs/notes/2026-11-24-mpu-fits.md). Ignored when `fit_unit` is
    /// `None`.
    pub leaf_refit: bool,
    /// For noisy point clouds: a cell's error is the ⌈n/M⌉-th largest distance of the points
    /// from its fit, M = this and n the points it is measured over (the ball's, or its 1 in 16
    /// or 1 in 256 hash subset once that holds M), instead of the largest. The largest of n
    /// noisy distances grows with n (as σ·√(2 ln n)), so a denser sampling of the same surface
    /// split more cells (issue 28); an order statistic at a fixed rank per M points does not,
    /// and a spike of fewer than n/M points does not split a cell either. `None` (the paper;
    /// meshes): the largest. Measured in docs/notes/2026-11-25-density-invariance.md. With a
    /// rank, the surface leaves are those holding a point projected onto their fit
    /// ([`crate::Mpu::surface_leaves`]; docs/notes/2026-11-29-surface-leaves.md).
    #[serde(default)]
    pub error_rank: Option<usize>,
}

impl MpuParams {
    /// Ohtake et al.'s published values and code: ε0 = 0.005 D, α = 0.75, λ = 0.1, N_min = 15,
    /// maximum depth 12, root box 1.2, sharp features on with T_edge = 0.9 and T_corner = 0.7,
    /// fits solved in world units (`fit_unit = Some(1.0)`) for the octree, and the leaves'
    /// fits kept from a second, scale-invariant solve where that is more accurate
    /// (`leaf_refit = true`, psi's addition).
    pub fn paper() -> Self {
        Self {
            error_rel: 0.005,
            alpha: 0.75,
            lambda: 0.1,
            n_min: 15,
            max_depth: 12,
            box_scale: 1.2,
            sharp: true,
            t_edge: 0.9,
            t_corner: 0.7,
            fit_unit: Some(1.0),
            leaf_refit: true,
            error_rank: None,
        }
    }

    /// Checks that every parameter is usable: ε0, λ and the box scale finite and positive,
    /// α ≥ 0.5 (nested supports, so pruned evaluation is exact), the maximum depth at most
    /// [`psi_octree::DEPTH_LIMIT`], thresholds finite, a fit unit (if any) finite and positive.
    pub fn validate(&self) -> Result<(), crate::MpuError> {
        let bad = |what: &str| Err(crate::MpuError::BadParameter(what.to_owned()));
        let positive = |v: f64| v.is_finite() && v > 0.0;
        if !positive(self.error_rel) {
            return bad("the error threshold must be finite and positive");
        }
        if !positive(self.lambda) {
            return bad("the radius growth λ must be finite and positive");
        }
        if !(self.alpha.is_finite() && self.alpha >= 0.5) {
            return bad("the support factor α must be at least 0.5");
        }
        if !(self.box_scale.is_finite() && self.box_scale >= 1.0) {
            return bad("the root box scale must be at least 1");
        }
        if self.max_depth > psi_octree::DEPTH_LIMIT {
            return bad("the maximum depth exceeds the octree's limit");
        }
        if !(self.t_edge.is_finite() && self.t_corner.is_finite()) {
            return bad("the sharp-feature thresholds must be finite");
        }
        if self.fit_unit.is_some_and(|u| !positive(u)) {
            return bad("the fit unit must be finite and positive");
        }
        if self.error_rank == Some(0) {
            return bad("the error rank's points per rank must be positive");
        }
        Ok(())
    }

    /// [`MpuParams::paper`] with unit-independent fits (`fit_unit = None`): the same surface
    /// whatever the input's units, full quadratic fits, fewer cells.
    pub fn scale_invariant() -> Self {
        Self {
            fit_unit: None,
            ..Self::paper()
        }
    }
}
