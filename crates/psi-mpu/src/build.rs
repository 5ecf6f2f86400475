//! `Mpu::build`: error-driven adaptive subdivision with a local fit per leaf, in parallel level
//! by level (bitwise identical for any thread count), in a local frame centred on the data so
//! that coordinates offset by 1e6 lose no precision.

use std::borrow::Cow;
use std::time::Instant;

use glam::DVec3;

use psi_octree::{Aabb, Octree, OctreeParams, OrientedPoint, PointIndex, root_cube};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::fit_cell::{CellFit, FitInput, fit_cell, try_fit_cell};
use crate::fit_store::{FitStore, FitStoreBuilder};
use crate::{BuildReport, FitKind, LocalFunction, MpuError, MpuParams};

/// Marks an inner cell in [`Mpu`]'s cell-to-fit table.
pub(crate) const NO_FIT: u32 = u32::MAX;

/// A multi-level partition of unity implicit: f(x) = Σ w_i(x) Q_i(x) / Σ w_i(x) over the leaves
/// whose support contains x. f > 0 outside, f < 0 inside, close to a signed distance near the
/// surface; finite and positive where no support reaches.
#[derive(Clone, Debug)]
pub struct Mpu {
    pub(crate) octree: Octree,
    /// The leaves' functions; `cell_fit` names each leaf's.
    pub(crate) fits: FitStore,
    pub(crate) cell_fit: Vec<u32>,
    pub(crate) fit_radius: Vec<f64>,
    /// Per cell: fitted by this build (false where a local rebuild reused the earlier record).
    pub(crate) fitted: Vec<bool>,
    pub(crate) nodes: Vec<crate::evaluate::EvalNode>,
    /// Per cell: the leaves whose support meets its cube, built on first use (for leaves and,
    /// as the source of their lists, inner cells).
    pub(crate) leaf_candidates: std::sync::Arc<Vec<std::sync::OnceLock<Box<[u32]>>>>,
    pub(crate) frame: MpuFrame,
    pub(crate) points: Vec<OrientedPoint>,
    pub(crate) bounds: Aabb,
    pub(crate) params: MpuParams,
    pub(crate) report: BuildReport,
    pub(crate) index: std::sync::Arc<PointIndex>,
    /// Per input point, computed on first use: its spacing, whether it is interior and the
    /// centroid of its 8 nearest points ([`InputLocal`]).
    pub(crate) input_local: std::sync::Arc<Vec<InputLocalSlot>>,
}

/// What an input point's 9 nearest points (itself and 8 neighbours) say about the data around
/// it: a pure function of the input, cached per point by [`Mpu`]. 56 bytes, so that with its
/// once-flag an entry of the table fills one cache line ([`InputLocalSlot`]): the footprint
/// test reads one line a point instead of two.
#[derive(Clone, Copy, Debug)]
pub(crate) struct InputLocal {
    /// Centroid of the point's 8 nearest input points (itself included) minus the point, local
    /// frame (f32: a fraction of a spacing, to about 1e-7 of it).
    centroid_offset: [f32; 3],
    /// The distance to the 9th nearest (to the last, when there are fewer), world units.
    last: f64,
    /// The point's nearest input points other than itself (its 9 nearest but itself; the
    /// first 8 of them in a cluster of 9 or more coincident points that leaves it out), the
    /// first `near_len` valid.
    near: [u32; 8],
    near_len: u8,
    /// Whether the point's 9 nearest are 9 (the input has more points than that).
    full: bool,
    /// [`Mpu::input_is_interior`].
    interior: bool,
}

impl InputLocal {
    /// d₈·√(π/8), world units ([`Mpu::input_spacing`]).
    #[inline]
    fn spacing(&self) -> f64 {
        spacing_of(self.last)
    }

    /// Every input point but the point and `near` is at least this far from the point, world
    /// units (the 9th nearest's distance; ∞ when there are no more points).
    #[inline]
    fn beyond(&self) -> f64 {
        if self.full { self.last } else { f64::INFINITY }
    }
}

/// The input spacing d₈·√(π/8) for a distance d₈ to the 8th neighbour (world units).
#[inline]
fn spacing_of(d8: f64) -> f64 {
    d8 * (std::f64::consts::PI / 8.0).sqrt()
}

/// A table entry: an [`InputLocal`] filled on first use, aligned to a cache line.
#[derive(Debug, Default)]
#[repr(align(64))]
pub(crate) struct InputLocalSlot(std::sync::OnceLock<InputLocal>);

/// An input point a particle was near, with what [`Mpu::near_data_from`] reads of it: kept by
/// the particle between moves.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DataAnchor {
    point: u32,
    /// The point's position, local frame.
    position: DVec3,
    /// Within this distance of `position` (world units) a position is on the data without a
    /// search: half the point's spacing when it is interior, else −1 (never).
    fast_radius: f64,
}

impl DataAnchor {
    /// The input point's index.
    pub fn point(&self) -> u32 {
        self.point
    }
}

/// Memory for an MPU build to fill instead of allocating: the largest arrays of an earlier MPU
/// ([`Mpu::into_buffers`]) or fresh ones touched once ([`MpuBuffers::like`]). Memory the
/// process already maps costs nothing to write; fresh memory costs a page fault per 4 KiB
/// (thousands for a bunny-sized rebuild).
#[derive(Debug, Default)]
pub struct MpuBuffers {
    points: Vec<OrientedPoint>,
    positions: Vec<DVec3>,
    octree: psi_octree::OctreeBuffers,
    nodes: Vec<crate::evaluate::EvalNode>,
    candidates: Vec<std::sync::OnceLock<Box<[u32]>>>,
    input_local: Vec<InputLocalSlot>,
}

/// Buffers hold no content, only memory: a clone is empty (it allocates when used).
impl Clone for MpuBuffers {
    fn clone(&self) -> Self {
        Self::default()
    }
}

impl MpuBuffers {
    /// Buffers sized for an MPU like `mpu` (about its cells, its number of points), their
    /// memory touched once.
    pub fn like(mpu: &Mpu) -> Self {
        let n = mpu.points.len();
        let blank = OrientedPoint {
            p: DVec3::ZERO,
            n: DVec3::ZERO,
        };
        let mut points = vec![blank; n];
        points.clear();
        let mut positions = vec![DVec3::ZERO; n];
        positions.clear();
        let cells = mpu.octree.cells().len() + 1024;
        let mut b = Self {
            points,
            positions,
            octree: psi_octree::OctreeBuffers::with_capacity(cells, n),
            nodes: Vec::with_capacity(cells),
            candidates: Vec::with_capacity(cells),
            input_local: Vec::with_capacity(n),
        };
        // Touched once, then emptied (capacity kept).
        b.nodes.extend(mpu.nodes.iter().copied());
        b.nodes.clear();
        b.candidates.resize_with(cells, std::sync::OnceLock::new);
        b.candidates.clear();
        b.input_local.resize_with(n, Default::default);
        b.input_local.clear();
        b
    }

    /// The buffer for the next build's points (empty; its capacity kept).
    pub fn take_points(&mut self) -> Vec<OrientedPoint> {
        let mut p = std::mem::take(&mut self.points);
        p.clear();
        p
    }
}

/// The fixed frame of an MPU: where the local coordinates are centred, the root cube, and the
/// length scale. Local regeneration keeps the frame of the first build so that cells keep their
/// identity (depth and integer key) across edits.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct MpuFrame {
    /// World position of the local frame's origin.
    pub origin: DVec3,
    /// Root cube centre, local frame.
    pub root_center: DVec3,
    /// Root cube half-edge, world units.
    pub root_half: f64,
    /// The length scale D (input bounding-box diagonal at the first build), world units.
    pub diagonal: f64,
}

impl MpuFrame {
    /// The frame Ohtake's set-up gives `points`: origin at the bounding box's centre, root cube
    /// `box_scale` × the largest extent.
    pub fn for_points(points: &[OrientedPoint], params: &MpuParams) -> Result<Self, MpuError> {
        let need = check_input_size(points, params)?;
        let bounds = Aabb::from_points(points.iter().map(|p| p.p))
            .ok_or(MpuError::TooFewPoints { got: 0, need })?;
        if !bounds.min.is_finite() || !bounds.max.is_finite() {
            let index = points.iter().position(|p| !p.p.is_finite()).unwrap_or(0);
            return Err(MpuError::BadPoint { index });
        }
        let origin = bounds.center();
        let local = Aabb {
            min: bounds.min - origin,
            max: bounds.max - origin,
        };
        let (root_center, root_half) = root_cube(&local, params.box_scale)?;
        Ok(Self {
            origin,
            root_center,
            root_half,
            diagonal: bounds.diagonal(),
        })
    }
}

/// Progress of an MPU build, reported after each octree level.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BuildProgress {
    /// The level just decided.
    pub depth: u8,
    /// The deepest level allowed.
    pub max_depth: u8,
    /// Cells created so far.
    pub cells: usize,
}

/// A cell's decision in a build: fitted now, or taken from a cell of the earlier MPU that no
/// edit reached (its index there). Small, because a local rebuild reuses most cells and the
/// records pass through several vectors.
enum CellRecord {
    Fitted(Box<FittedCell>),
    Reused(u32),
}

/// A cell fitted by this build.
struct FittedCell {
    /// A leaf's fit (`None` for a cell that splits).
    fit: Option<(LocalFunction, FitKind, bool)>,
    /// The radius the fit used (R1 ≥ R): only points within it influence the cell.
    fit_radius: f64,
}

/// What a local rebuild may take from an earlier MPU: the records of its cells that no edit
/// reached (`marked[cell]` false), looked up by depth and integer key.
#[derive(Clone, Copy, Debug)]
pub struct Reuse<'a> {
    /// The earlier MPU (same frame and parameters).
    pub old: &'a Mpu,
    /// Per cell of `old`: whether an edit reached it (its fit must be recomputed). Every cell
    /// whose fit radius holds a changed position (old or new) must be marked — in particular
    /// every cell whose cube holds one, which the copied partitions rely on.
    pub marked: &'a [bool],
    /// Whether every point the edit left unchanged kept its index (a brush or an insertion;
    /// a removal renumbers): then unmarked cells' partitions are taken from `old` too.
    pub indices_kept: bool,
}

/// Checks the parameters and that there are more than N_min points; returns N_min + 1.
fn check_input_size(points: &[OrientedPoint], params: &MpuParams) -> Result<usize, MpuError> {
    params.validate()?;
    let need = params.n_min + 1;
    if points.len() < need {
        return Err(MpuError::TooFewPoints {
            got: points.len(),
            need,
        });
    }
    Ok(need)
}

/// Validates the input and returns local-frame positions and the points with unit normals
/// (owned points are normalised in place, borrowed ones copied).
fn prepare(
    points: Cow<'_, [OrientedPoint]>,
    params: &MpuParams,
    frame: &MpuFrame,
    mut positions: Vec<DVec3>,
) -> Result<(Vec<DVec3>, Vec<OrientedPoint>), MpuError> {
    check_input_size(&points, params)?;
    for (index, p) in points.iter().enumerate() {
        let len = p.n.length();
        if !p.p.is_finite() || !len.is_finite() || len <= 0.0 {
            return Err(MpuError::BadPoint { index });
        }
    }
    let mut points = points.into_owned();
    for p in &mut points {
        p.n /= p.n.length();
    }
    positions.clear();
    positions.extend(points.iter().map(|p| p.p - frame.origin));
    Ok((positions, points))
}

impl Mpu {
    /// Builds the MPU of `points` (shape: N oriented points, world units, unit or non-unit
    /// outward normals) with `params`.
    ///
    /// Errors: a parameter out of range, fewer than N_min + 1 points, a non-finite coordinate or
    /// zero normal, or all points coinciding. Degenerate local fits fall back (counted in
    /// [`Mpu::report`]).
    pub fn build(points: &[OrientedPoint], params: &MpuParams) -> Result<Mpu, MpuError> {
        let frame = MpuFrame::for_points(points, params)?;
        Self::build_in_frame(points, params, &frame, None)
    }

    /// Builds in a given frame, taking the records of unmarked cells from `reuse` when given.
    /// The result equals a build in the same frame without reuse (to rounding in the order of
    /// summation), because a cell's fit depends only on the points within its fit radius and
    /// a cell is unmarked only when no changed point lies there.
    ///
    /// Errors as [`Mpu::build`], plus [`MpuError::Octree`] when a point leaves the root cube.
    pub fn build_in_frame(
        points: &[OrientedPoint],
        params: &MpuParams,
        frame: &MpuFrame,
        reuse: Option<Reuse<'_>>,
    ) -> Result<Mpu, MpuError> {
        Self::build_observed(points, params, frame, reuse, &|_| {})
    }

    /// [`Mpu::build_in_frame`] taking the points by value: they are kept (normals made unit in
    /// place) instead of copied, and the arrays are built in `buffers` (see [`MpuBuffers`]),
    /// which a local rebuild of a large model notices.
    pub fn build_in_frame_owned(
        points: Vec<OrientedPoint>,
        params: &MpuParams,
        frame: &MpuFrame,
        reuse: Option<Reuse<'_>>,
        buffers: MpuBuffers,
    ) -> Result<Mpu, MpuError> {
        Self::build_impl(Cow::Owned(points), params, frame, reuse, buffers, &|_| {})
    }

    /// [`Mpu::build_in_frame`], calling `observe` after each octree level (progress reporting).
    pub fn build_observed(
        points: &[OrientedPoint],
        params: &MpuParams,
        frame: &MpuFrame,
        reuse: Option<Reuse<'_>>,
        observe: &(dyn Fn(BuildProgress) + Sync),
    ) -> Result<Mpu, MpuError> {
        let buffers = MpuBuffers::default();
        Self::build_impl(
            Cow::Borrowed(points),
            params,
            frame,
            reuse,
            buffers,
            observe,
        )
    }

    fn build_impl(
        points: Cow<'_, [OrientedPoint]>,
        params: &MpuParams,
        frame: &MpuFrame,
        reuse: Option<Reuse<'_>>,
        buffers: MpuBuffers,
        observe: &(dyn Fn(BuildProgress) + Sync),
    ) -> Result<Mpu, MpuError> {
        let _span =
            tracing::info_span!("mpu_build", points = points.len(), local = reuse.is_some())
                .entered();
        let start = Instant::now();
        let MpuBuffers {
            positions,
            octree: octree_buffers,
            nodes: nodes_buffer,
            mut candidates,
            mut input_local,
            ..
        } = buffers;
        if let Some(r) = reuse
            && r.marked.len() != r.old.octree.cells().len()
        {
            return Err(MpuError::BadParameter(format!(
                "reuse: {} marks for an octree of {} cells",
                r.marked.len(),
                r.old.octree.cells().len()
            )));
        }
        let (positions, points) = prepare(points, params, frame, positions)?;
        let n = points.len();
        let eps0 = params.error_rel * frame.diagonal;
        // A local rebuild refits the marked cells of the earlier octree up front, in one parallel
        // batch: a fit depends only on its cell and the points, and level by level the coarse
        // levels hold a few expensive fits that keep threads idle. (A marked cell whose parent
        // no longer splits is fitted for nothing; cells new to the octree are fitted as met.)
        // The large cells among them that split are fitted from the coarse points alone while
        // the kd-tree of all points is being built.
        let marked_old: Vec<u32> = reuse.map_or_else(Vec::new, |r| {
            (0..r.marked.len() as u32)
                .filter(|&c| r.marked[c as usize])
                .collect()
        });
        let old_cell = |c: u32| {
            *reuse
                .expect("marked cells come with reuse")
                .old
                .octree
                .cell(c)
        };
        let (index, (coarse, early)) = rayon::join(
            || std::sync::Arc::new(PointIndex::new(&positions)),
            || {
                let coarse = crate::fit_cell::CoarseIndex::new(&positions);
                let input = FitInput {
                    coarse: &coarse,
                    positions: &positions,
                    points: &points,
                    index: None,
                    params,
                };
                let early: Vec<Option<CellFit>> = marked_old
                    .par_iter()
                    .map(|&c| {
                        let cell = old_cell(c);
                        try_fit_cell(&input, cell.center, cell.half, eps0)
                    })
                    .collect();
                (coarse, early)
            },
        );
        // The positions move into the octree, which hands them back to each decision.
        let input = FitInput {
            coarse: &coarse,
            positions: &[],
            points: &points,
            index: Some(&index),
            params,
        };
        let oparams = OctreeParams {
            box_scale: params.box_scale,
            alpha: params.alpha,
            max_depth: params.max_depth,
        };
        let on_level = |depth: u8, cells: usize| {
            observe(BuildProgress {
                depth,
                max_depth: params.max_depth,
                cells,
            })
        };
        let prefit: Vec<CellFit> = marked_old
            .par_iter()
            .zip(early)
            .map(|(&c, early)| {
                early.unwrap_or_else(|| {
                    let cell = old_cell(c);
                    fit_cell(&input.over(&positions), cell.center, cell.half, eps0)
                })
            })
            .collect();
        // An unmarked cell holds no changed position (its fit radius R1 ≥ R = α·2√3·half is at
        // least its circumradius √3·half for α ≥ 0.5, and marking adds a 1e-9 margin),
        // hence the same points: with the same indices, the same partition.
        let known = reuse
            .filter(|r| r.indices_kept)
            .map(|r| psi_octree::KnownPartitions {
                old: &r.old.octree,
                changed: r.marked,
            });
        let (octree, records) = Octree::build_in_cube_owned(
            positions,
            frame.root_center,
            frame.root_half,
            &oparams,
            known,
            octree_buffers,
            |v| {
                let old = reuse.and_then(|r| r.old.octree.cell_at(v.cell.depth, v.cell.key));
                if let (Some(r), Some(old)) = (reuse, old)
                    && !r.marked[old as usize]
                {
                    let split = r.old.cell_fit[old as usize] == NO_FIT;
                    return (split, CellRecord::Reused(old));
                }
                let CellFit {
                    function,
                    kind,
                    fallback,
                    error,
                    fit_radius,
                } = match old.and_then(|o| marked_old.binary_search(&o).ok()) {
                    Some(k) => prefit[k].clone(),
                    None => fit_cell(&input.over(v.positions), v.cell.center, v.cell.half, eps0),
                };
                let split = error > eps0 && v.cell.depth < params.max_depth;
                (
                    split,
                    CellRecord::Fitted(Box::new(FittedCell {
                        fit: (!split).then_some((function, kind, fallback)),
                        fit_radius,
                    })),
                )
            },
            &on_level,
        )?;
        // A local rebuild shares the earlier MPU's function store when it reuses most of it.
        let share = reuse.is_some_and(|r| 2 * marked_old.len() < r.old.octree.cells().len());
        let mut fits = FitStoreBuilder::new(
            reuse.map(|r| &r.old.fits),
            share,
            if share {
                prefit.len() + 64
            } else {
                octree.cells().len()
            },
        );
        let mut cell_fit = vec![NO_FIT; octree.cells().len()];
        let mut fit_radius = Vec::with_capacity(octree.cells().len());
        let mut fitted = Vec::with_capacity(octree.cells().len());
        let bounds = Aabb::from_points(points.iter().map(|p| p.p)).expect("non-empty");
        let mut report = BuildReport {
            points: points.len(),
            cells: octree.cells().len(),
            eps0,
            bbox_diagonal: frame.diagonal,
            ..Default::default()
        };
        let depth_slots = usize::from(octree.max_depth_reached()) + 1;
        report.leaves_per_depth = vec![0; depth_slots];
        report.surface_leaves_per_depth = vec![0; depth_slots];
        for (i, rec) in records.into_iter().enumerate() {
            let cell = octree.cell(i as u32);
            let fit = match rec {
                CellRecord::Fitted(f) => {
                    fit_radius.push(f.fit_radius);
                    fitted.push(true);
                    f.fit.map(|(function, kind, fallback)| {
                        (fits.push(function, kind, fallback), kind, fallback)
                    })
                }
                CellRecord::Reused(old) => {
                    let old_mpu = reuse.expect("reused records come from an earlier MPU").old;
                    fit_radius.push(old_mpu.fit_radius[old as usize]);
                    fitted.push(false);
                    let f = old_mpu.cell_fit[old as usize];
                    (f != NO_FIT).then(|| {
                        (
                            fits.reuse(f),
                            old_mpu.fits.kind(f),
                            old_mpu.fits.fallback(f),
                        )
                    })
                }
            };
            if !cell.is_leaf() {
                continue;
            }
            // A leaf always has a fit: the decision returns one whenever it does not split, and
            // the builder refuses a split only at the maximum depth, where none is asked for.
            let (id, kind, fallback) = fit.unwrap_or_else(|| {
                let f = fit_cell(
                    &input.over(octree.positions()),
                    cell.center,
                    cell.half,
                    eps0,
                );
                (
                    fits.push(f.function, f.kind, f.fallback),
                    f.kind,
                    f.fallback,
                )
            });
            cell_fit[i] = id;
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
        let fits = fits.finish();
        let mut nodes = nodes_buffer;
        crate::evaluate::eval_nodes_into(&octree, &cell_fit, params.alpha, &mut nodes);
        // The lazily filled tables start empty, in the buffers' memory when there is some.
        candidates.clear();
        candidates.resize_with(nodes.len(), std::sync::OnceLock::new);
        input_local.clear();
        input_local.resize_with(n, InputLocalSlot::default);
        let leaf_candidates = std::sync::Arc::new(candidates);
        Ok(Mpu {
            leaf_candidates,
            nodes,
            octree,
            fits,
            cell_fit,
            fit_radius,
            fitted,
            frame: *frame,
            points,
            bounds,
            params: *params,
            report,
            index,
            input_local: std::sync::Arc::new(input_local),
        })
    }

    /// The MPU's largest arrays, for a later build to reuse ([`MpuBuffers`]).
    pub fn into_buffers(self) -> MpuBuffers {
        let (octree, positions) = self.octree.into_buffers();
        // The lazily filled tables come back only when this MPU held the last reference.
        let mut candidates = std::sync::Arc::try_unwrap(self.leaf_candidates).unwrap_or_default();
        candidates.clear();
        MpuBuffers {
            points: self.points,
            positions,
            octree,
            nodes: self.nodes,
            candidates,
            input_local: std::sync::Arc::try_unwrap(self.input_local).unwrap_or_default(),
        }
    }

    /// The radius (world units) within which input points influenced cell `cell`'s fit (R1 ≥
    /// the support radius R); an edit farther than this from the centre cannot change the cell.
    pub fn fit_radius(&self, cell: u32) -> f64 {
        self.fit_radius[cell as usize]
    }

    /// Whether cell `cell` was fitted by the build that made this MPU (false where a local
    /// rebuild reused the earlier record: [`Mpu::build_in_frame`] with [`Reuse`]).
    pub fn was_refit(&self, cell: u32) -> bool {
        self.fitted[cell as usize]
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

    /// Leaves whose cube holds at least one input point (particles are seeded from these).
    pub fn surface_leaves(&self) -> impl Iterator<Item = u32> + '_ {
        self.octree
            .leaves()
            .filter(|&l| !self.octree.points_in(l).is_empty())
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

    /// Whether world position `x` lies inside the data's footprint: within `reach` local input
    /// spacings of the nearest input point q, and not beyond the edge of the data (a hole or a
    /// scan's border). The spacing at q is [`Mpu::input_spacing`]; x is past an edge when the
    /// centroid of q's 8 nearest input points (cached per point) is offset from x, in the tangent
    /// plane of q, by more than a spacing: inside the data that centroid lies a fraction of a
    /// spacing from q, on a straight edge about 0.95 spacing inward (the centroid of a half disc
    /// of radius √(2k/π) spacings), so x beyond q, or beside an edge point along the edge by more
    /// than about 0.3 spacing, is out.
    ///
    /// Within half a spacing of an interior input point (its own neighbours surround it,
    /// [`Mpu::input_is_interior`]) x is inside without the edge test. (An interior point can lie
    /// about half a spacing from the edge; a one-spacing shortcut let some of the bunny's
    /// particles leave the data: 99.72 % → 99.55 % within 2e-3 D of its mesh.) `anchor` is an
    /// input point that was near x before (a particle's previous nearest point, carried with
    /// what this test reads of it, so that the common case reads no shared table); when x is
    /// that close to an interior anchor the answer is yes without a search. Returns the answer
    /// and the new anchor.
    pub fn near_data_from(
        &self,
        x: DVec3,
        reach: f64,
        anchor: Option<DataAnchor>,
    ) -> (bool, Option<DataAnchor>) {
        let y = x - self.frame.origin;
        if let Some(a) = anchor
            && (a.position - y).length() <= a.fast_radius
        {
            return (true, Some(a));
        }
        let found = anchor
            .and_then(|a| self.nearest_among_neighbours_of(y, a.point))
            .or_else(|| self.index.nearest_one(y));
        let Some((q, d2)) = found else {
            return (false, None);
        };
        let local = self.input_local(q);
        let q_position = self.octree.positions()[q as usize];
        let new_anchor = Some(DataAnchor {
            point: q,
            position: q_position,
            fast_radius: if local.interior {
                0.5 * local.spacing()
            } else {
                -1.0
            },
        });
        let d = d2.sqrt();
        let spacing = local.spacing();
        if d > reach * spacing {
            return (false, new_anchor);
        }
        // Fast path: q lies well inside the data and x is within half a spacing of it.
        if d <= 0.5 * spacing && local.interior {
            return (true, new_anchor);
        }
        let n = self.points[q as usize].n;
        let [cx, cy, cz] = local.centroid_offset.map(f64::from);
        let offset = q_position + DVec3::new(cx, cy, cz) - y;
        let tangential = (offset - n * offset.dot(n)).length();
        (tangential <= spacing, new_anchor)
    }

    /// The input point nearest to world `x` (world units, unit normal); `None` for an empty input.
    pub fn nearest_input(&self, x: DVec3) -> Option<OrientedPoint> {
        let (q, _) = self.index.nearest_one(x - self.frame.origin)?;
        Some(self.points[q as usize])
    }

    /// Distance from world `x` to the nearest input point, in units of the local input spacing
    /// there ([`Mpu::input_spacing`]); ∞ for an empty input.
    pub fn distance_in_spacings(&self, x: DVec3) -> f64 {
        let Some((q, d2)) = self.index.nearest_one(x - self.frame.origin) else {
            return f64::INFINITY;
        };
        d2.sqrt() / self.input_spacing(q).max(f64::MIN_POSITIVE)
    }

    /// Whether input point `q` lies well inside the data: its own 8 nearest points (itself
    /// included) have their centroid within half a spacing of it in its tangent plane (an edge
    /// point's is about 0.95 spacing away for a dense random sampling; a point on the straight
    /// border of a regular grid's is only about 0.45 away and passes, corners fail:
    /// `tests/input_spacing.rs`). Cached: a pure function of the input.
    pub fn input_is_interior(&self, q: u32) -> bool {
        self.input_local(q).interior
    }

    /// The input spacing at input point `q`: d₈·√(π/8), d₈ the distance to its 8th nearest
    /// neighbour (world units). Cached: it is a pure function of the input.
    pub fn input_spacing(&self, q: u32) -> f64 {
        self.input_local(q).spacing()
    }

    /// The cached [`InputLocal`] of input point `q`, computed on first use from one query of its
    /// 9 nearest points (itself and 8 neighbours; the centroid is of the first 8).
    fn input_local(&self, q: u32) -> &InputLocal {
        self.input_local[q as usize].0.get_or_init(|| {
            let y = self.octree.positions()[q as usize];
            let around = self.index.nearest(y, 9);
            let last = around.last().map_or(0.0, |n| n.1.sqrt());
            let spacing = spacing_of(last);
            let first = &around[..around.len().min(8)];
            let positions = self.octree.positions();
            let centroid = first
                .iter()
                .map(|&(i, _)| positions[i as usize])
                .sum::<DVec3>()
                / first.len().max(1) as f64;
            let n = self.points[q as usize].n;
            let offset = centroid - y;
            let interior = (offset - n * offset.dot(n)).length() <= 0.5 * spacing;
            let mut near = [0u32; 8];
            let mut near_len = 0;
            for &(i, _) in &around {
                if i != q && near_len < near.len() {
                    near[near_len] = i;
                    near_len += 1;
                }
            }
            InputLocal {
                centroid_offset: [offset.x as f32, offset.y as f32, offset.z as f32],
                last,
                near,
                near_len: near_len as u8,
                full: around.len() >= 9,
                interior,
            }
        })
    }

    /// The input point nearest to local `y` and its squared distance, when the cached 9 nearest
    /// of input point `a` prove it: the closest of them is nearer to `y` than any other input
    /// point can be (those are at least `beyond` from `a`, so at least `beyond − |y − a|` from
    /// `y`). `None` when the proof fails; ties go to the lower index.
    fn nearest_among_neighbours_of(&self, y: DVec3, a: u32) -> Option<(u32, f64)> {
        let local = self.input_local(a);
        let positions = self.octree.positions();
        let bound = local.beyond() - (positions[a as usize] - y).length();
        if bound <= 0.0 {
            return None;
        }
        let mut best = (u32::MAX, f64::INFINITY);
        for &j in std::iter::once(&a).chain(&local.near[..usize::from(local.near_len)]) {
            let d2 = (positions[j as usize] - y).length_squared();
            if d2 < best.1 || (d2 == best.1 && j < best.0) {
                best = (j, d2);
            }
        }
        (best.1 < bound * bound).then_some(best)
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

#[cfg(test)]
mod tests {
    use super::*;
    use psi_shapes::AnalyticShape;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64Mcg;

    #[test]
    fn a_footprint_entry_is_one_cache_line() {
        assert_eq!(std::mem::size_of::<InputLocalSlot>(), 64);
        assert_eq!(std::mem::align_of::<InputLocalSlot>(), 64);
    }

    /// The certificate from an input point's cached neighbours against a brute-force nearest
    /// point: whenever it answers, the answer is the nearest; and it answers for most positions
    /// within a spacing of the point (else it would save nothing). Positions up to two
    /// spacings away are tried too, for the answers' sake.
    #[test]
    fn nearest_among_neighbours_is_the_brute_force_nearest() {
        let points = AnalyticShape::Torus {
            major: 1.0,
            minor: 0.3,
        }
        .sample(4000, 5);
        let mpu = Mpu::build(&points, &MpuParams::paper()).expect("torus builds");
        let positions = mpu.octree.positions();
        let mut rng = Pcg64Mcg::seed_from_u64(3);
        let (mut answered, trials) = (0, 2000);
        for t in 0..2 * trials {
            let a = (t * 7 % positions.len()) as u32;
            let s = mpu.input_spacing(a);
            let dir = DVec3::new(
                rng.random::<f64>() - 0.5,
                rng.random::<f64>() - 0.5,
                rng.random::<f64>() - 0.5,
            );
            let reach = if t < trials { 1.0 } else { 2.0 };
            let y = positions[a as usize] + reach * s * rng.random::<f64>() * dir.normalize();
            let brute = positions
                .iter()
                .map(|p| (p - y).length_squared())
                .fold(f64::INFINITY, f64::min);
            if let Some((q, d2)) = mpu.nearest_among_neighbours_of(y, a) {
                assert_eq!(d2, brute, "trial {t}");
                assert_eq!((positions[q as usize] - y).length_squared(), d2);
                answered += usize::from(t < trials);
            }
        }
        assert!(answered > trials / 2, "answered {answered} of {trials}");
    }
}
