//! The MPU build: error-driven adaptive subdivision with a local fit per leaf, in parallel level
//! by level (bitwise identical for any thread count), in a local frame centred on the data so
//! that coordinates offset by 1e6 lose no precision; a local rebuild reuses the cells no edit
//! reached.

use std::borrow::Cow;
use std::sync::{Arc, OnceLock};
use std::time::Instant;

use glam::DVec3;
use psi_octree::{
    Aabb, KnownPartitions, Monitor, Octree, OctreeBuild, OctreeParams, OrientedPoint,
};
use rayon::prelude::*;

use crate::cell_table::CellTable;
use crate::data_footprint::DataFootprint;
use crate::eval_nodes::{NO_FIT, eval_nodes_into};
use crate::fit_cell::{CellFit, FitInput, fit_cell, fit_octree_cell};
use crate::fit_reach::reach_by_depth;
use crate::fit_store::FitStoreBuilder;
use crate::frame::check_input_size;
use crate::point_footprint::PointFootprint;
use crate::prefit_marked::{MarkedFits, Prefit, marked_indexes};
use crate::select_fit::LeafFit;
use crate::surface_leaf::holds_surface;
use crate::{BuildReport, FitKind, Mpu, MpuBuffers, MpuError, MpuFrame, MpuParams};

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
    /// When the edit kept every index and the number of points (a brush): the indices of the
    /// points whose position it changed. The kd-trees are then derived from `old`'s in the
    /// time of the points moved instead of built again over all points.
    pub moved: Option<&'a [u32]>,
}

impl<'a> Reuse<'a> {
    /// [`Reuse::moved`] when the rebuild has as many points (`n`) as `old`: a brush's.
    fn moved_of(&self, n: usize) -> Option<&'a [u32]> {
        self.moved.filter(|_| self.old.points.len() == n)
    }
}

/// How [`Mpu::build_with`] runs beyond its parameters. `BuildOptions::default()` is a plain
/// build: the frame Ohtake's set-up gives the points, every cell fitted, fresh memory, no
/// progress reports.
#[derive(Default)]
pub struct BuildOptions<'a> {
    /// The frame to build in (local regeneration keeps the first build's, so that cells keep
    /// their identity); default [`MpuFrame::for_points`].
    pub frame: Option<MpuFrame>,
    /// Cells an earlier MPU fitted that the build may take instead of fitting them again (a
    /// local rebuild). The result equals a build in the same frame without reuse (to rounding
    /// in the order of summation), because a cell's fit depends only on the points within its
    /// fit radius and a cell is unmarked only when no changed point lies there.
    pub reuse: Option<Reuse<'a>>,
    /// Memory for the arrays ([`MpuBuffers`]): a local rebuild of a large model notices.
    pub buffers: MpuBuffers,
    /// The normals are an MPU's own ([`Mpu::points`]: made unit by its build): used as they
    /// are, not divided by their length again (which can move a bit), so that a build from
    /// them reproduces that MPU bit for bit. A normal that is not unit is still refused by
    /// nothing: give only an MPU's own points.
    pub unit_normals: bool,
    /// Decisions made already for every cell, by address (the tiles' [`crate::fit_region`]s
    /// merged): the build takes each cell's split and fit from the table and fits nothing; a
    /// cell the table lacks is an error ([`MpuError::BadParameter`]). The result is the build
    /// the table's regions were decided for, bitwise.
    pub known_cells: Option<&'a CellTable>,
    /// With [`BuildOptions::known_cells`]: the cube (centre in the build's local frame, half
    /// edge; world units) where the build is used. A known cell whose support ball does not
    /// meet it is not split and has no function (it adds nothing to f): for α ≥ 0.5 the
    /// supports of a cell's descendants lie within its own, so f and ∇f in the cube, the
    /// leaves meeting it and their points are those of the whole build, in the time of the
    /// cells near the cube (a tile's seeding builds one tile's part of a large octree).
    /// Ignored without known cells or for α < 0.5.
    pub known_within: Option<(DVec3, f64)>,
    /// The points given and the buffers' positions are those of the MPU the buffers came
    /// from ([`Mpu::into_buffers`]) but at these indices (ascending): only they are checked
    /// and moved to the local frame, in the time of the points changed (an editor's stroke,
    /// its buffers one stroke behind: the last stroke's moves and this one's). `None`: every
    /// point afresh.
    pub synced: Option<&'a [u32]>,
    /// The caller moves an earlier MPU's footprint table in afterwards
    /// ([`Mpu::carry_footprint`], which it must call): the build leaves the table empty
    /// instead of filling a fresh one (64 bytes a point).
    pub carry_footprint: bool,
    /// The points are a thinned subset of an input, and these (shape: N, one per point given)
    /// are what the whole input says of each ([`Mpu::point_footprints`] on an MPU over the
    /// whole input, or over the points around, then [`PointFootprint::thinned_to`]): the
    /// footprint test ([`Mpu::near_data_from`]) reads the whole input's spacing and edges from
    /// them instead of the subset's, except at unmeasured points marked
    /// [`PointFootprint::with_own_test`], which take the whole test on the subset's own points.
    /// The subset must hold every input point fewer than `exact_hops` + 1 hops from the data's
    /// edge, for those take the whole test. `None`: the points are the input.
    pub whole_footprint: Option<&'a [PointFootprint]>,
    /// Progress (stage `"mpu"`: octree levels decided of `max_depth + 1`) and interruption:
    /// once its stop flag is set, no cell splits any more and the build returns
    /// [`MpuError::Interrupted`].
    pub monitor: Monitor<'a>,
}

/// A cell's decision in a build: fitted now, or taken from a cell of the earlier MPU that no
/// edit reached (its index there). Small, because a local rebuild reuses most cells and the
/// records pass through several vectors.
enum CellRecord {
    Fitted(Box<FittedCell>),
    Reused(u32),
    /// Left out ([`BuildOptions::known_within`]): a leaf without a function.
    Void,
}

/// A cell fitted by this build.
struct FittedCell {
    /// A leaf's fit (`None` for a cell that splits).
    fit: Option<LeafFit>,
    /// The radius the fit used (R1 ≥ R): only points within it influence the cell.
    fit_radius: f64,
}

/// A leaf's function as the assembled MPU names it: its id in the store, kind and fallback flag.
struct StoredLeaf {
    id: u32,
    kind: FitKind,
    fallback: bool,
}

/// The validated input: local-frame positions and the points with unit normals.
pub(crate) struct Prepared {
    pub(crate) positions: Vec<DVec3>,
    pub(crate) points: Vec<OrientedPoint>,
}

/// Validates the input and returns local-frame positions (written into `positions`) and the
/// points with unit normals (owned points are normalised in place, borrowed ones copied).
fn prepare(
    points: Cow<'_, [OrientedPoint]>,
    params: &MpuParams,
    frame: &MpuFrame,
    mut positions: Vec<DVec3>,
    unit_normals: bool,
    fits_known: bool,
    synced: Option<&[u32]>,
) -> Result<Prepared, MpuError> {
    // A build that takes every decision from a table fits nothing: any non-empty part of an
    // input will do (a tile's points).
    if !fits_known || points.is_empty() {
        check_input_size(&points, params)?;
    }
    let bad = |p: &OrientedPoint| {
        let len = p.n.length();
        !p.p.is_finite() || !len.is_finite() || len <= 0.0
    };
    if let Some(changed) = synced.filter(|_| positions.len() == points.len()) {
        // Only the changed points differ from the buffers' MPU, which checked the others.
        if let Some(&index) = changed.iter().find(|&&i| bad(&points[i as usize])) {
            return Err(MpuError::BadPoint {
                index: index as usize,
            });
        }
        let mut points = points.into_owned();
        for &i in changed {
            let p = &mut points[i as usize];
            if !unit_normals {
                p.n /= p.n.length();
            }
            positions[i as usize] = p.p - frame.origin;
        }
        return Ok(Prepared { positions, points });
    }
    // Each pass over the points in parallel, the copies' page faults included
    // (docs/results/2026-11-29-orientation/).
    if let Some(index) = points.par_iter().position_first(bad) {
        return Err(MpuError::BadPoint { index });
    }
    let mut points = match points {
        Cow::Owned(points) => points,
        Cow::Borrowed(points) => points.par_iter().copied().collect(),
    };
    if !unit_normals {
        points.par_iter_mut().for_each(|p| p.n /= p.n.length());
    }
    positions.clear();
    positions.par_extend(points.par_iter().map(|p| p.p - frame.origin));
    Ok(Prepared { positions, points })
}

/// The bounding box of `points` (world units) from `old`'s, the points `moved` having moved:
/// grown by their new positions, or `None` when one of them left a face of the old box (then
/// the box may shrink and is measured again).
fn moved_bounds(old: &Mpu, moved: &[u32], points: &[OrientedPoint]) -> Option<Aabb> {
    let mut b = old.bounds;
    for &i in moved {
        let was = old.points[i as usize].p;
        let on_face = (0..3).any(|k| was[k] == old.bounds.min[k] || was[k] == old.bounds.max[k]);
        if on_face {
            return None;
        }
        let now = points[i as usize].p;
        b.min = b.min.min(now);
        b.max = b.max.max(now);
    }
    Some(b)
}

impl Mpu {
    /// Builds the MPU of `points` (shape: N oriented points, world units, unit or non-unit
    /// outward normals) with `params`: [`Mpu::build_with`] with default options.
    ///
    /// Errors: a parameter out of range, fewer than N_min + 1 points, a non-finite coordinate or
    /// zero normal, or all points coinciding. Degenerate local fits fall back (counted in
    /// [`Mpu::report`]).
    pub fn build(points: &[OrientedPoint], params: &MpuParams) -> Result<Mpu, MpuError> {
        Self::build_with(points, params, BuildOptions::default())
    }

    /// Builds the MPU of `points` (shape: N oriented points, world units, unit or non-unit
    /// outward normals; borrowed, or owned and then kept — normals made unit in place — instead
    /// of copied) with `params`, as `options` say: in a given frame, reusing an earlier MPU's
    /// cells, in given memory, reporting progress.
    ///
    /// Errors as [`Mpu::build`], plus [`MpuError::Octree`] when a point leaves a given frame's
    /// root cube and [`MpuError::BadParameter`] when the reuse marks do not match its octree.
    pub fn build_with<'p>(
        points: impl Into<Cow<'p, [OrientedPoint]>>,
        params: &MpuParams,
        options: BuildOptions<'_>,
    ) -> Result<Mpu, MpuError> {
        let points = points.into();
        let BuildOptions {
            frame,
            reuse,
            buffers,
            unit_normals,
            known_cells,
            known_within,
            synced,
            carry_footprint,
            whole_footprint,
            monitor,
        } = options;
        if whole_footprint.is_some_and(|w| w.len() != points.len()) {
            return Err(MpuError::BadParameter(format!(
                "{} whole-input footprints for {} points",
                whole_footprint.map_or(0, <[PointFootprint]>::len),
                points.len()
            )));
        }
        let frame = match frame {
            Some(f) => f,
            None => MpuFrame::for_points(&points, params)?,
        };
        let _span =
            tracing::info_span!("mpu_build", points = points.len(), local = reuse.is_some())
                .entered();
        let start = Instant::now();
        let MpuBuffers {
            positions,
            octree: octree_buffers,
            mut nodes,
            mut candidates,
            input_local,
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
        let data = prepare(
            points,
            params,
            &frame,
            positions,
            unit_normals,
            known_cells.is_some(),
            synced,
        )?;
        let t_prepare = start.elapsed().as_secs_f64();
        let n = data.points.len();
        let eps0 = params.error_rel * frame.diagonal;
        let marked_old: Vec<u32> = reuse.map_or_else(Vec::new, |r| {
            (0..r.marked.len() as u32)
                .filter(|&c| r.marked[c as usize])
                .collect()
        });
        let indexes = marked_indexes(
            (&data.positions, &data.points),
            params,
            eps0,
            reuse.map(|r| (r.old, r.moved_of(n))),
            &marked_old,
            &monitor,
        )?;
        let (index, coarse) = (indexes.index.clone(), indexes.coarse.clone());
        let t_indexes = start.elapsed().as_secs_f64();
        let levels = u64::from(params.max_depth) + 1;
        monitor.report("mpu", 0, levels);
        let input = FitInput {
            coarse: &coarse,
            positions: &data.positions,
            points: &data.points,
            index: Some(&index),
            params,
            population: n,
        };
        let marked_fits = MarkedFits::new(input, eps0, reuse.map(|r| r.old), &marked_old, indexes);
        let oparams = OctreeParams {
            box_scale: params.box_scale,
            alpha: params.alpha,
            max_depth: params.max_depth,
        };
        let on_level = |depth: u8, _cells: usize| {
            monitor.report("mpu", u64::from(depth) + 1, levels);
        };
        // An unmarked cell holds no changed position (its fit radius R1 ≥ R = α·2√3·half is at
        // least its circumradius √3·half for α ≥ 0.5, and marking adds a 1e-9 margin),
        // hence the same points: with the same indices, the same partition.
        let known = reuse.filter(|r| r.indices_kept).map(|r| KnownPartitions {
            old: &r.old.octree,
            changed: r.marked,
            moved: r.moved_of(n),
        });
        let octree_options = OctreeBuild {
            root: Some(frame.root()),
            known,
            buffers: octree_buffers,
            on_level: Some(&on_level),
            // (Beside the marked fits: a parallel step would wait for all of them.)
            beside: Some(marked_fits.running()),
        };
        let missing = std::sync::Mutex::new(None);
        // The cube where a known-cells build is used.
        let within = known_within.filter(|_| params.alpha >= 0.5);
        let decide = |v: psi_octree::CellView<'_>| {
            if let Some(table) = known_cells {
                if let Some((c, h)) = within {
                    // The distance from the cell's centre to the cube, against its support
                    // (with a margin far above rounding: a cell kept in doubt costs nothing).
                    let gap = ((v.cell.center - c).abs() - DVec3::splat(h)).max(DVec3::ZERO);
                    if gap.length() > v.cell.support_radius(params.alpha) * (1.0 + 1e-9) {
                        return (false, CellRecord::Void);
                    }
                }
                let Some(d) = table.get(v.cell.depth, v.cell.key) else {
                    missing
                        .lock()
                        .expect("not poisoned")
                        .get_or_insert((v.cell.depth, v.cell.key));
                    return (false, CellRecord::Reused(0));
                };
                let fitted = FittedCell {
                    fit: d.leaf.clone(),
                    fit_radius: d.fit_radius,
                };
                return (d.split, CellRecord::Fitted(Box::new(fitted)));
            }
            if monitor.stopped() {
                // Stopped: nothing splits any more, and the check after the octree discards
                // this placeholder record.
                return (false, CellRecord::Reused(0));
            }
            // (With known partitions the octree tracks the address; else it is looked up.)
            let old = match known {
                Some(_) => v.old,
                None => reuse.and_then(|r| r.old.octree.cell_at(v.cell.depth, v.cell.key)),
            };
            if let (Some(r), Some(old)) = (reuse, old)
                && !r.marked[old as usize]
            {
                let split = r.old.cell_fit[old as usize] == NO_FIT;
                return (split, CellRecord::Reused(old));
            }
            let cell_fit = match old.and_then(|o| marked_fits.get(o)) {
                Some(fit) => fit,
                // (New to the octree; or, never in fact, a marked cell skipped because a marked
                // ancestor keeps its function, or whose fit unwound on another thread: fitted
                // here, to the same result.)
                None => fit_octree_cell(&input.over(v.positions), v.cell, eps0),
            };
            let split = cell_fit.splits(v.cell, eps0, params.max_depth);
            let CellFit {
                fit, fit_radius, ..
            } = cell_fit;
            (
                split,
                CellRecord::Fitted(Box::new(FittedCell {
                    fit: (!split).then_some(fit),
                    fit_radius,
                })),
            )
        };
        // The octree is rebuilt while the marked cells are fitted; it waits only for a fit it
        // needs that another thread is making.
        let (built, fitted) = rayon::join(
            || Octree::build_over(&data.positions, &oparams, octree_options, decide),
            || marked_fits.run(&monitor),
        );
        let (unplaced, records) = built?;
        fitted?;
        let Prefit {
            fits: prefit,
            balls,
            from_earlier,
            skipped,
        } = marked_fits.finish();
        let Prepared { positions, points } = data;
        let octree = unplaced.with_positions(positions);
        let t_octree = start.elapsed().as_secs_f64();
        monitor.check()?;
        if let Some((depth, key)) = missing.into_inner().expect("not poisoned") {
            return Err(MpuError::BadParameter(format!(
                "known cells: the table has no decision for the cell at depth {depth}, key {key:?}"
            )));
        }
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
        let bounds = reuse
            .filter(|_| synced.is_some())
            .and_then(|r| moved_bounds(r.old, r.moved_of(points.len())?, &points))
            .unwrap_or_else(|| Aabb::from_points(points.iter().map(|p| p.p)).expect("non-empty"));
        let mut report = BuildReport {
            points: points.len(),
            cells: octree.cells().len(),
            eps0,
            bbox_diagonal: frame.diagonal,
            balls_from_earlier: from_earlier,
            refits_skipped: skipped,
            ..Default::default()
        };
        let depth_slots = usize::from(octree.max_depth_reached()) + 1;
        report.leaves_per_depth = vec![0; depth_slots];
        report.surface_leaves_per_depth = vec![0; depth_slots];
        let input = FitInput {
            coarse: &coarse,
            positions: octree.positions(),
            points: &points,
            index: Some(&index),
            params,
            population: n,
        };
        let mut reach = vec![0.0f64; depth_slots];
        let project = params.error_rank.is_some();
        for (i, rec) in records.into_iter().enumerate() {
            let cell = octree.cell(i as u32);
            let leaf = match rec {
                CellRecord::Fitted(f) => {
                    fit_radius.push(f.fit_radius);
                    fitted.push(true);
                    f.fit.map(|l| StoredLeaf {
                        id: fits.push(l.function, l.kind, l.fallback),
                        kind: l.kind,
                        fallback: l.fallback,
                    })
                }
                CellRecord::Void => {
                    fit_radius.push(0.0);
                    fitted.push(false);
                    continue;
                }
                CellRecord::Reused(old) => {
                    let old_mpu = reuse.expect("reused records come from an earlier MPU").old;
                    fit_radius.push(old_mpu.fit_radius[old as usize]);
                    fitted.push(false);
                    let f = old_mpu.cell_fit[old as usize];
                    (f != NO_FIT).then(|| StoredLeaf {
                        id: fits.reuse(f),
                        kind: old_mpu.fits.kind(f),
                        fallback: old_mpu.fits.fallback(f),
                    })
                }
            };
            let slot = &mut reach[usize::from(cell.depth)];
            *slot = slot.max(fit_radius[i]);
            if !cell.is_leaf() {
                continue;
            }
            // A leaf always has a fit: the decision returns one whenever it does not split, and
            // the builder refuses a split only at the maximum depth, where none is asked for.
            let StoredLeaf { id, kind, fallback } = leaf.unwrap_or_else(|| {
                let l = fit_cell(&input, cell.center, cell.half, eps0, false).fit;
                StoredLeaf {
                    id: fits.push(l.function, l.kind, l.fallback),
                    kind: l.kind,
                    fallback: l.fallback,
                }
            });
            cell_fit[i] = id;
            // (A noisy cloud's surface leaves are counted once the fits are stored.)
            let holds = !project && holds_surface(&octree, None, i as u32);
            report.count_leaf(cell.depth, holds, kind, fallback);
        }
        report.max_depth = octree.max_depth_reached();
        report.seconds = start.elapsed().as_secs_f64();
        monitor.report("mpu", levels, levels);
        let fits = fits.finish();
        if project {
            for l in octree.leaves() {
                let id = cell_fit[l as usize];
                if id != NO_FIT && holds_surface(&octree, Some((&fits, id)), l) {
                    report.count_surface_leaf(octree.cell(l).depth);
                }
            }
        }
        eval_nodes_into(&octree, &cell_fit, params.alpha, &mut nodes);
        // The lazily filled tables start empty, in the buffers' memory when there is some.
        candidates.clear();
        candidates.resize_with(nodes.len(), OnceLock::new);
        let footprint = if carry_footprint {
            DataFootprint::default()
        } else {
            DataFootprint::new_in(input_local, n)
        };
        let footprint = match whole_footprint {
            Some(whole) => footprint.thinned(whole),
            None => footprint,
        };
        report.seconds = start.elapsed().as_secs_f64();
        report.phase_seconds = crate::BuildPhases {
            prepare: t_prepare,
            indexes: t_indexes - t_prepare,
            fits_and_octree: t_octree - t_indexes,
            assemble: report.seconds - t_octree,
        };
        Ok(Mpu {
            leaf_candidates: Arc::new(candidates),
            nodes,
            octree,
            fits,
            cell_fit,
            fit_radius,
            fitted,
            reach_by_depth: reach_by_depth(reach),
            frame,
            points,
            bounds,
            params: *params,
            report,
            index,
            coarse,
            footprint,
            trial_balls: Arc::new(balls),
        })
    }
}
