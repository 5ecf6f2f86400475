//! `Mpu::build`: error-driven adaptive subdivision with a local fit per leaf, in parallel level
//! by level (bitwise identical for any thread count), in a local frame centred on the data so
//! that coordinates offset by 1e6 lose no precision.

use std::time::Instant;

use glam::DVec3;
use psi_octree::{Aabb, Octree, OctreeParams, OrientedPoint, PointIndex};

use crate::fit_cell::{CellFit, FitInput, fit_cell};
use crate::{BuildReport, FitKind, LocalFunction, MpuError, MpuParams};

/// Marks an inner cell in [`Mpu`]'s cell-to-fit table.
pub(crate) const NO_FIT: u32 = u32::MAX;

/// A multi-level partition of unity implicit: f(x) = Σ w_i(x) Q_i(x) / Σ w_i(x) over the leaves
/// whose support contains x. f > 0 outside, f < 0 inside, close to a signed distance near the
/// surface; finite and positive where no support reaches.
#[derive(Clone, Debug)]
pub struct Mpu {
    pub(crate) octree: Octree,
    pub(crate) fits: Vec<LocalFunction>,
    pub(crate) fit_kinds: Vec<FitKind>,
    pub(crate) cell_fit: Vec<u32>,
    pub(crate) frame_origin: DVec3,
    pub(crate) points: Vec<OrientedPoint>,
    pub(crate) bounds: Aabb,
    pub(crate) params: MpuParams,
    pub(crate) report: BuildReport,
    pub(crate) index: std::sync::Arc<PointIndex>,
}

/// Validates the input and returns local-frame positions and unit normals.
pub(crate) fn prepare(
    points: &[OrientedPoint],
    params: &MpuParams,
) -> Result<(Vec<DVec3>, Vec<DVec3>, DVec3, Aabb), MpuError> {
    let need = params.n_min + 1;
    if points.len() < need {
        return Err(MpuError::TooFewPoints {
            got: points.len(),
            need,
        });
    }
    let mut normals = Vec::with_capacity(points.len());
    for (index, p) in points.iter().enumerate() {
        let len = p.n.length();
        if !p.p.is_finite() || !(len.is_finite() && len > 0.0) {
            return Err(MpuError::BadPoint { index });
        }
        normals.push(p.n / len);
    }
    let bounds = Aabb::from_points(points.iter().map(|p| p.p))
        .ok_or(MpuError::TooFewPoints { got: 0, need })?;
    let origin = bounds.center();
    let positions = points.iter().map(|p| p.p - origin).collect();
    Ok((positions, normals, origin, bounds))
}

impl Mpu {
    /// Builds the MPU of `points` (shape: N oriented points, world units, unit or non-unit
    /// outward normals) with `params`.
    ///
    /// Errors: fewer than N_min + 1 points, a non-finite coordinate or zero normal, or all
    /// points coinciding. Degenerate local fits fall back (counted in [`Mpu::report`]).
    pub fn build(points: &[OrientedPoint], params: &MpuParams) -> Result<Mpu, MpuError> {
        Self::build_reusing(points, params, &|_, _, _| None)
    }

    /// Builds like [`Mpu::build`], but takes a cell's fit from `reuse(depth, key, cell half)`
    /// when it returns one (local regeneration passes the fits of cells no edit can reach).
    #[doc(hidden)]
    pub fn build_reusing(
        points: &[OrientedPoint],
        params: &MpuParams,
        reuse: &(
             dyn Fn(u8, [u32; 3], f64) -> Option<(bool, Option<(LocalFunction, FitKind, bool)>)>
                 + Sync
         ),
    ) -> Result<Mpu, MpuError> {
        let start = Instant::now();
        let (positions, normals, frame_origin, bounds) = prepare(points, params)?;
        let diagonal = bounds.diagonal();
        let eps0 = params.error_rel * diagonal;
        let index = std::sync::Arc::new(PointIndex::new(&positions));
        let input = FitInput {
            positions: &positions,
            normals: &normals,
            index: &index,
            params,
        };
        let oparams = OctreeParams {
            box_scale: params.box_scale,
            alpha: params.alpha,
            max_depth: params.max_depth,
        };
        let (octree, payloads) = Octree::build_with(&positions, &oparams, |v| {
            if let Some(hit) = reuse(v.cell.depth, v.cell.key, v.cell.half) {
                return hit;
            }
            let CellFit {
                function,
                kind,
                fallback,
                error,
            } = fit_cell(&input, v.cell.center, v.cell.half);
            let split = error > eps0 && v.cell.depth < params.max_depth;
            (split, (!split).then_some((function, kind, fallback)))
        })?;
        let mut fits = Vec::new();
        let mut fit_kinds = Vec::new();
        let mut cell_fit = vec![NO_FIT; octree.cells().len()];
        let mut report = BuildReport {
            points: points.len(),
            cells: octree.cells().len(),
            eps0,
            bbox_diagonal: diagonal,
            ..Default::default()
        };
        let depth_slots = usize::from(octree.max_depth_reached()) + 1;
        report.leaves_per_depth = vec![0; depth_slots];
        report.surface_leaves_per_depth = vec![0; depth_slots];
        for (i, payload) in payloads.into_iter().enumerate() {
            let cell = octree.cell(i as u32);
            if !cell.is_leaf() {
                continue;
            }
            // A leaf always carries a payload: the closure returns one whenever it does not split
            // (and the builder only refuses a split at the maximum depth, where none is asked).
            let (function, kind, fallback) = payload.unwrap_or_else(|| {
                let f = fit_cell(&input, cell.center, cell.half);
                (f.function, f.kind, f.fallback)
            });
            cell_fit[i] = fits.len() as u32;
            fits.push(function);
            fit_kinds.push(kind);
            report.leaves += 1;
            report.leaves_per_depth[usize::from(cell.depth)] += 1;
            if !octree.points_in(i as u32).is_empty() {
                report.surface_leaves += 1;
                report.surface_leaves_per_depth[usize::from(cell.depth)] += 1;
            }
            report.fallbacks += usize::from(fallback);
            let counts = &mut report.fits;
            match kind {
                FitKind::GeneralQuadric => counts.general_quadric += 1,
                FitKind::Bivariate => counts.bivariate += 1,
                FitKind::Edge => counts.edge += 1,
                FitKind::Corner => counts.corner += 1,
                FitKind::Plane => counts.plane += 1,
            }
        }
        report.max_depth = octree.max_depth_reached();
        report.seconds = start.elapsed().as_secs_f64();
        let points = points
            .iter()
            .zip(&normals)
            .map(|(p, n)| OrientedPoint { p: p.p, n: *n })
            .collect();
        Ok(Mpu {
            octree,
            fits,
            fit_kinds,
            cell_fit,
            frame_origin,
            points,
            bounds,
            params: *params,
            report,
            index,
        })
    }

    /// The build's diagnostics.
    pub fn report(&self) -> &BuildReport {
        &self.report
    }

    /// The parameters the MPU was built with.
    pub fn params(&self) -> &MpuParams {
        &self.params
    }

    /// The octree, in the MPU's local frame (world position − [`Mpu::frame_origin`]).
    pub fn octree(&self) -> &Octree {
        &self.octree
    }

    /// World position of the local frame's origin (the input bounding box's centre).
    pub fn frame_origin(&self) -> DVec3 {
        self.frame_origin
    }

    /// The input points, world units, unit normals (shape: N).
    pub fn points(&self) -> &[OrientedPoint] {
        &self.points
    }

    /// The input's bounding box, world units.
    pub fn bounds(&self) -> &Aabb {
        &self.bounds
    }

    /// The input's bounding-box diagonal D, world units.
    pub fn diagonal(&self) -> f64 {
        self.bounds.diagonal()
    }

    /// Indices of all leaves (each holds a local fit), arena order.
    pub fn leaves(&self) -> impl Iterator<Item = u32> + '_ {
        self.octree.leaves()
    }

    /// Leaves whose cube holds at least one input point (particles are seeded from these).
    pub fn surface_leaves(&self) -> impl Iterator<Item = u32> + '_ {
        self.octree
            .leaves()
            .filter(|&l| !self.octree.points_in(l).is_empty())
    }

    /// The local function of leaf `cell`, `None` for an inner cell.
    pub fn leaf_function(&self, cell: u32) -> Option<&LocalFunction> {
        let f = *self.cell_fit.get(cell as usize)?;
        (f != NO_FIT).then(|| &self.fits[f as usize])
    }

    /// The fit kind of leaf `cell`, `None` for an inner cell.
    pub fn leaf_kind(&self, cell: u32) -> Option<FitKind> {
        let f = *self.cell_fit.get(cell as usize)?;
        (f != NO_FIT).then(|| self.fit_kinds[f as usize])
    }

    /// The leaf containing world position `x`, `None` outside the root cube.
    pub fn leaf_containing(&self, x: DVec3) -> Option<u32> {
        self.octree.leaf_containing(x - self.frame_origin)
    }

    /// Distance from world position `x` to the nearest input point, world units (plain).
    pub fn distance_to_data(&self, x: DVec3) -> f64 {
        self.index
            .nearest(x - self.frame_origin, 1)
            .first()
            .map_or(f64::INFINITY, |n| n.1.sqrt())
    }

    /// Edge length of a cell at `depth`, world units.
    pub fn cell_edge(&self, depth: u8) -> f64 {
        self.octree.edge_at_depth(depth)
    }
}
