//! The `Mpu` type and its queries: the octree and its leaves, the input points, the frame, and
//! where the data lies. The build is in `build.rs`, the evaluation of f in `evaluate.rs`.

use std::sync::{Arc, OnceLock};

use glam::DVec3;
use psi_octree::{Aabb, Octree, OrientedPoint, PointIndex};

use crate::coarse_index::CoarseIndex;
use crate::data_footprint::{DataFootprint, FootprintTest};
use crate::eval_nodes::{EvalNode, NO_FIT};
use crate::fit_store::FitStore;
use crate::input_local::InputData;
use crate::point_footprint::PointFootprint;
use crate::trial_balls::TrialBalls;
use crate::{BuildReport, DataAnchor, FitKind, LocalFunction, MpuFrame, MpuParams};

/// A multi-level partition of unity implicit: f(x) = Σ w_i(x) Q_i(x) / Σ w_i(x) over the leaves
/// whose support contains x. f > 0 outside, f < 0 inside, close to a signed distance near the
/// surface; finite and positive where no support reaches.
#[derive(Clone, Debug)]
pub struct Mpu {
    pub(crate) octree: Octree,
    /// The leaves' functions; `cell_fit` names each leaf's.
    pub(crate) fits: FitStore,
    /// Per cell: its function's id in `fits`, [`NO_FIT`] for an inner cell.
    pub(crate) cell_fit: Vec<u32>,
    /// Per cell: the radius its fit used, world units.
    pub(crate) fit_radius: Vec<f64>,
    /// Per cell: fitted by this build (false where a local rebuild reused the earlier record).
    pub(crate) fitted: Vec<bool>,
    /// Per depth: the largest fit radius of the cells at that depth or below, world units
    /// (`fit_reach`).
    pub(crate) reach_by_depth: Vec<f64>,
    pub(crate) nodes: Vec<EvalNode>,
    /// Per cell: the leaves whose support meets its cube, built on first use (for leaves and,
    /// as the source of their lists, inner cells).
    pub(crate) leaf_candidates: Arc<Vec<OnceLock<Box<[u32]>>>>,
    pub(crate) frame: MpuFrame,
    pub(crate) points: Vec<OrientedPoint>,
    pub(crate) bounds: Aabb,
    pub(crate) params: MpuParams,
    pub(crate) report: BuildReport,
    /// A kd-tree over the octree's (local-frame) positions.
    pub(crate) index: Arc<PointIndex>,
    /// The coarse points' kd-tree (kept for the next local rebuild to derive its own).
    pub(crate) coarse: Arc<CoarseIndex>,
    pub(crate) footprint: DataFootprint,
    /// After a brush, its refits' ball answers, which the next brush's refits read.
    pub(crate) trial_balls: Arc<TrialBalls>,
}

impl Mpu {
    /// The radius (world units) within which input points influenced cell `cell`'s fit (R1 ≥
    /// the support radius R); an edit farther than this from the centre cannot change the cell.
    pub fn fit_radius(&self, cell: u32) -> f64 {
        self.fit_radius[cell as usize]
    }

    /// Whether cell `cell` was fitted by the build that made this MPU (false where a local
    /// rebuild reused the earlier record: [`crate::BuildOptions::reuse`]).
    pub fn was_refit(&self, cell: u32) -> bool {
        self.fitted[cell as usize]
    }

    /// Per cell: [`Mpu::was_refit`] (shape: one per cell of [`Mpu::octree`]).
    pub fn refit_flags(&self) -> &[bool] {
        &self.fitted
    }

    /// The frame (origin, root cube, D) the MPU was built in.
    pub fn frame(&self) -> &MpuFrame {
        &self.frame
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
        self.frame.origin
    }

    /// The input points, world units, unit normals (shape: N).
    pub fn points(&self) -> &[OrientedPoint] {
        &self.points
    }

    /// The input's bounding box, world units.
    pub fn bounds(&self) -> &Aabb {
        &self.bounds
    }

    /// The length scale D, world units: the input's bounding-box diagonal at the frame's first
    /// build (kept through local edits).
    pub fn diagonal(&self) -> f64 {
        self.frame.diagonal
    }

    /// Indices of all leaves (each holds a local fit), arena order.
    pub fn leaves(&self) -> impl Iterator<Item = u32> + '_ {
        self.octree.leaves()
    }

    /// Leaves that hold the surface (particles are seeded in these), arena order: whose cube
    /// holds an input point, or for a noisy point cloud ([`MpuParams::error_rank`]) a point
    /// moved onto the leaf's fit by one Newton step.
    pub fn surface_leaves(&self) -> impl Iterator<Item = u32> + '_ {
        self.octree.leaves().filter(|&l| self.is_surface_leaf(l))
    }

    /// Whether `cell` is a leaf of [`Mpu::surface_leaves`].
    pub fn is_surface_leaf(&self, cell: u32) -> bool {
        let fit = self.cell_fit.get(cell as usize).copied().unwrap_or(NO_FIT);
        let project = self.params.error_rank.is_some();
        fit != NO_FIT
            && crate::surface_leaf::holds_surface(
                &self.octree,
                project.then_some((&self.fits, fit)),
                cell,
            )
    }

    /// The local function of leaf `cell`, `None` for an inner cell.
    pub fn leaf_function(&self, cell: u32) -> Option<LocalFunction> {
        let f = *self.cell_fit.get(cell as usize)?;
        (f != NO_FIT).then(|| self.fits.load(f))
    }

    /// The fit kind of leaf `cell`, `None` for an inner cell.
    pub fn leaf_kind(&self, cell: u32) -> Option<FitKind> {
        let f = *self.cell_fit.get(cell as usize)?;
        (f != NO_FIT).then(|| self.fits.kind(f))
    }

    /// The leaf containing world position `x`, `None` outside the root cube.
    pub fn leaf_containing(&self, x: DVec3) -> Option<u32> {
        self.octree.leaf_containing(x - self.frame.origin)
    }

    /// [`Mpu::leaf_containing`] for world position `x` with a guess (a particle's leaf before
    /// its last move): `hint` itself when `x` lies inside that leaf's cube by a margin larger
    /// than the rounding of the cube centres (1e-9 of its half-edge plus 64 ulps of the root's
    /// half-edge) — where the octant descent cannot answer otherwise — else the lookup. The
    /// answer always equals the lookup's (`None` for a non-finite `x`).
    pub fn leaf_containing_from(&self, x: DVec3, hint: Option<u32>) -> Option<u32> {
        let y = x - self.frame.origin;
        if let Some(h) = hint
            && y.is_finite()
            && let Some(cell) = self.octree.cells().get(h as usize)
            && cell.is_leaf()
        {
            let margin = 1e-9 * cell.half + 64.0 * f64::EPSILON * self.octree.root().half;
            if (y - cell.center).abs().max_element() < cell.half - margin {
                return Some(h);
            }
        }
        self.octree.leaf_containing(y)
    }

    /// The input as the footprint queries read it.
    fn input_data(&self) -> InputData<'_> {
        InputData {
            positions: self.octree.positions(),
            points: &self.points,
            index: &self.index,
        }
    }

    /// Whether world position `x` lies inside the data's footprint: within `reach` local input
    /// spacings of the nearest input point q, and not beyond the edge of the data (a hole or a
    /// scan's border). The spacing at q is [`Mpu::input_spacing`], read by this distance rule
    /// as at least `floor` (world units; the caller's resolution, e.g. a fraction of a
    /// particle's σ: a gap of the sampling narrower than it is not a hole; 0 reads the input's
    /// own; the edge rule's reach reads it too, up to 4 spacings, the fast path below does
    /// not); x is past an edge when the input points within 2 spacings of it do not surround it
    /// in the tangent plane of q: their directions from x leave a gap of half a turn or more.
    /// On a straight edge that holds x on the edge line or beyond it; a hole's rim, read within
    /// 2 spacings, does not wrap around a position inside the hole. Range-scan rows and seams
    /// between denser and sparser views, where q's 8 nearest lie to one side of it, do not
    /// read as edges
    /// (docs/notes/2026-11-27-multiview-level-cv.md). When q and its cached 8 nearest already
    /// surround x, no kd-tree query is made (the same answer: more points cannot open a gap).
    ///
    /// Within half a spacing of an interior input point (its own neighbours surround it,
    /// [`Mpu::input_is_interior`]) x is inside without the edge test (an interior point can lie
    /// about half a spacing from the edge; a one-spacing shortcut let particles leave the data).
    /// `anchor` is an input point that was near x before (a particle's previous nearest point,
    /// carried with what this test reads of it, so that the common case reads no shared table);
    /// when x is that close to an interior anchor the answer is yes without a search. Returns
    /// the answer and the new anchor (the input point nearest x).
    pub fn near_data_from(
        &self,
        x: DVec3,
        reach: f64,
        floor: f64,
        anchor: Option<DataAnchor>,
    ) -> FootprintTest {
        self.footprint.near_data_from(
            self.input_data(),
            x - self.frame.origin,
            reach,
            floor,
            anchor,
        )
    }

    /// What the input says about each of its points `qs` (the spacing, whether it is
    /// interior, the centroid of its 8 nearest, its hops from the data's edge): to carry with
    /// the points into an MPU over a thinned subset of the input
    /// (`BuildOptions::whole_footprint`). Shape: as `qs`. Reads the footprint's cache (fill it
    /// first with [`Mpu::fill_footprint`] when `qs` are most points).
    /// `complete(x, r)` tells whether every input point within `r` (world units) of world
    /// position `x` is among this MPU's points (false: the point's neighbours may be cut off,
    /// and it is not taken for an edge point on their account).
    pub fn point_footprints(
        &self,
        qs: &[u32],
        complete: &dyn Fn(DVec3, f64) -> bool,
    ) -> Vec<PointFootprint> {
        let origin = self.frame.origin;
        let world = |x: DVec3, r: f64| complete(x + origin, r);
        self.footprint
            .point_footprints(self.input_data(), qs, &world)
    }

    /// Fills the footprint's cache for every input point at once (a grid's 9 nearest instead
    /// of a kd-tree query each: `psi_octree::all_k_nearest`).
    pub fn fill_footprint(&mut self) {
        let data = InputData {
            positions: self.octree.positions(),
            points: &self.points,
            index: &self.index,
        };
        self.footprint.fill_all(data);
    }

    /// Whether input point `q` lies at or near the data's edge as [`Mpu::point_footprints`]
    /// counts it: not interior, or its 8 nearest points' centroid more than
    /// [`crate::BAND_EDGE_OFFSET`] of a spacing from it in its tangent plane.
    pub fn input_near_edge(&self, q: u32) -> bool {
        self.footprint.near_edge(self.input_data(), q)
    }

    /// Whether input point `q` lies well inside the data: its own 8 nearest points (itself
    /// included) have their centroid within half a spacing of it in its tangent plane (an edge
    /// point's is about 0.95 spacing away for a dense random sampling; a point on the straight
    /// border of a regular grid's is only about 0.45 away and passes, corners fail:
    /// `tests/input_spacing.rs`). Cached: a pure function of the input.
    pub fn input_is_interior(&self, q: u32) -> bool {
        self.footprint.is_interior(self.input_data(), q)
    }

    /// The input spacing at input point `q`: d₈·√(π/8), d₈ the distance to its 8th nearest
    /// neighbour (world units). Cached: it is a pure function of the input.
    pub fn input_spacing(&self, q: u32) -> f64 {
        self.footprint.spacing(self.input_data(), q)
    }

    /// Indices of the input points ([`Mpu::points`]) within `radius` of world `x` (world
    /// units), into `out` (cleared first), in increasing order.
    pub fn inputs_within(&self, x: DVec3, radius: f64, out: &mut Vec<u32>) {
        out.clear();
        self.index.within(x - self.frame.origin, radius, out);
        out.sort_unstable();
    }

    /// The input point nearest to world `x` (world units, unit normal); `None` for an empty input.
    pub fn nearest_input(&self, x: DVec3) -> Option<OrientedPoint> {
        Some(self.points[self.nearest_input_index(x)? as usize])
    }

    /// The index ([`Mpu::points`]) of the input point nearest to world `x`; `None` for an
    /// empty input.
    pub fn nearest_input_index(&self, x: DVec3) -> Option<u32> {
        Some(self.index.nearest_one(x - self.frame.origin)?.0)
    }

    /// Distance from world `x` to the nearest input point, in units of the local input spacing
    /// there ([`Mpu::input_spacing`]); ∞ for an empty input.
    pub fn distance_in_spacings(&self, x: DVec3) -> f64 {
        let Some((q, d2)) = self.index.nearest_one(x - self.frame.origin) else {
            return f64::INFINITY;
        };
        d2.sqrt() / self.input_spacing(q).max(f64::MIN_POSITIVE)
    }

    /// Distance from world position `x` to the nearest input point, world units (plain).
    pub fn distance_to_data(&self, x: DVec3) -> f64 {
        self.index
            .nearest_one(x - self.frame.origin)
            .map_or(f64::INFINITY, |(_, d2)| d2.sqrt())
    }

    /// Edge length of a cell at `depth`, world units.
    pub fn cell_edge(&self, depth: u8) -> f64 {
        self.octree.edge_at_depth(depth)
    }
}
