//! The arena octree: cells with centre, half-edge, depth and children (u32 indices), input points
//! bucketed per cell, and the level-by-level adaptive build driven by a caller's decision.

use std::borrow::Cow;
use std::sync::atomic::{AtomicBool, Ordering};

use glam::DVec3;
use rayon::prelude::*;

use crate::octree_buffers::OctreeBuffers;
use crate::root_cube::{RootCube, root_cube};
use crate::{Aabb, Cell, NO_CELL, OctreeError};

/// The deepest level a cell may have (integer keys stay exact up to 2^21 per axis).
pub const DEPTH_LIMIT: u8 = 21;

/// Parameters of the octree's geometry. Build with [`OctreeParams::mpu`] for Ohtake's values.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OctreeParams {
    /// Root cube edge as a multiple of the largest bounding-box extent (Ohtake's `Box` = 1.2).
    pub box_scale: f64,
    /// Support radius as a multiple of the cell's main diagonal: R = α·2√3·half (Ohtake: 0.75).
    pub alpha: f64,
    /// No cell is deeper than this (root depth 0); at most [`DEPTH_LIMIT`].
    pub max_depth: u8,
}

impl OctreeParams {
    /// Ohtake's MPU values: box 1.2, α = 0.75, maximum depth 12
    /// (`../shared/reference/algorithms.md` §1.1 and §5).
    pub fn mpu() -> Self {
        Self {
            box_scale: 1.2,
            alpha: 0.75,
            max_depth: 12,
        }
    }
}

/// What the build's decision function sees of a cell: its geometry and the indices of the input
/// points inside its cube.
#[derive(Clone, Copy, Debug)]
pub struct CellView<'a> {
    /// The cell's index in the arena (stable once created).
    pub index: u32,
    /// The cell itself.
    pub cell: &'a Cell,
    /// Indices (into the build's `points`) of the points inside the cube.
    pub points: &'a [u32],
    /// All the build's point positions (shape: N, as given).
    pub positions: &'a [DVec3],
    /// With [`OctreeBuild::known`]: the earlier octree's cell at the same address, if any.
    pub old: Option<u32>,
}

/// A split's child counts and the points' new arrangement in its segment (`None`: the
/// segment holds it already).
type Partition<'a> = ([u32; 8], Option<Cow<'a, [u32]>>);

/// Partitions a rebuild may take from an earlier octree (see [`OctreeBuild::known`]; its methods in `known_partitions.rs`).
#[derive(Clone, Copy, Debug)]
pub struct KnownPartitions<'a> {
    /// The earlier octree: same root cube, and every point it shares with the new build has
    /// the same index in both.
    pub old: &'a Octree,
    /// Per cell of `old`: whether its points may have changed (a point entered or left its
    /// cube); an unflagged cell holds exactly the same points in the new build.
    pub changed: &'a [bool],
    /// When only some points moved and every index and the count were kept (a brush): their
    /// indices, ascending. The build then takes the earlier arrangement of all points with
    /// only these moved between leaves, and every earlier split with its counts corrected,
    /// instead of partitioning again the cells they passed through.
    pub moved: Option<&'a [u32]>,
}

/// An adaptive octree over a point set, with each input point bucketed in exactly one leaf.
#[derive(Clone, Debug)]
pub struct Octree {
    pub(crate) cells: Vec<Cell>,
    pub(crate) order: Vec<u32>,
    pub(crate) positions: Vec<DVec3>,
    pub(crate) params: OctreeParams,
    pub(crate) root_edge: f64,
}

/// An octree built over borrowed points ([`Octree::build_over`]), waiting for them.
#[derive(Debug)]
pub struct Unplaced(Octree);

impl Unplaced {
    /// The octree, given the points it was built over (shape: N, the same values).
    ///
    /// Panics when `positions` has another length than the points the tree was built over.
    pub fn with_positions(self, positions: Vec<DVec3>) -> Octree {
        let mut tree = self.0;
        assert_eq!(
            positions.len(),
            tree.cells[0].end as usize,
            "the build's points"
        );
        tree.positions = positions;
        tree
    }
}

/// How [`Octree::build_with`] runs beyond its parameters. `OctreeBuild::default()` is a plain
/// build: the root cube from the points' bounding box, everything partitioned afresh, fresh
/// memory, no progress reports.
#[derive(Default)]
pub struct OctreeBuild<'a> {
    /// The root cube, which must hold every point (local regeneration keeps an earlier
    /// build's); default [`root_cube`] of the points' bounding box.
    pub root: Option<RootCube>,
    /// Partitions an earlier octree computed: a splitting cell that the earlier octree also
    /// split, over the same points, takes that partition instead of computing it. With them,
    /// the decisions of cells the earlier octree had are taken in order on the calling thread
    /// (the caller has them at hand), and only the new cells' are made in parallel.
    pub known: Option<KnownPartitions<'a>>,
    /// Memory for the arrays (an earlier octree's, [`Octree::into_buffers`]: memory already in
    /// use needs no new pages).
    pub buffers: OctreeBuffers,
    /// Called after each level is decided with the level's depth and the cells so far.
    pub on_level: Option<&'a (dyn Fn(u8, usize) + Sync)>,
    /// Set while other parallel work runs beside the build: its parallel steps then stay on
    /// the calling thread (a parallel step's wait would join that work until it is done).
    pub beside: Option<&'a AtomicBool>,
}

impl Octree {
    /// Builds an octree over `points` (shape: N positions, any frame; the tree keeps them),
    /// splitting every cell for which `decide` says so (and whose depth is below
    /// `params.max_depth`), as `options` say.
    ///
    /// Cells are processed level by level; the cells of one level are decided in parallel and
    /// the result does not depend on the number of threads. `decide` sees each cell with the
    /// indices of its points and all positions ([`CellView`]) and returns "split?" and a payload
    /// `T` (for MPU: the local fit); the payloads come back in arena order, one per cell. Every
    /// leaf lists its points in increasing index order, whether or not partitions were copied
    /// from an earlier octree.
    ///
    /// Errors: no points, non-finite positions, a point outside the given root cube, a flat
    /// bounding box, too many points, or `max_depth` beyond [`DEPTH_LIMIT`].
    pub fn build_with<T, F>(
        points: Vec<DVec3>,
        params: &OctreeParams,
        options: OctreeBuild<'_>,
        decide: F,
    ) -> Result<(Octree, Vec<T>), OctreeError>
    where
        T: Send,
        F: Fn(CellView<'_>) -> (bool, T) + Sync,
    {
        let (tree, payloads) = Self::build_over(&points, params, options, decide)?;
        Ok((tree.with_positions(points), payloads))
    }

    /// [`Octree::build_with`] over borrowed `points` (shape: N), which others may read while
    /// the build runs: the tree comes without them, and [`Unplaced::with_positions`] gives it
    /// the same points.
    pub fn build_over<T, F>(
        points: &[DVec3],
        params: &OctreeParams,
        options: OctreeBuild<'_>,
        decide: F,
    ) -> Result<(Unplaced, Vec<T>), OctreeError>
    where
        T: Send,
        F: Fn(CellView<'_>) -> (bool, T) + Sync,
    {
        let OctreeBuild {
            root,
            known,
            buffers,
            on_level,
            beside,
        } = options;
        let serial = || beside.is_some_and(|b| b.load(Ordering::Acquire));
        let RootCube { center, half } = match root {
            Some(r) => r,
            None => {
                let bounds = Aabb::from_points(points.iter().copied()).ok_or(OctreeError::Empty)?;
                root_cube(&bounds, params.box_scale)?
            }
        };
        if params.max_depth > DEPTH_LIMIT {
            return Err(OctreeError::TooDeep {
                max_depth: params.max_depth,
                limit: DEPTH_LIMIT,
            });
        }
        if points.len() >= NO_CELL as usize {
            return Err(OctreeError::TooManyPoints(points.len()));
        }
        if !(half > 0.0 && half.is_finite() && center.is_finite()) {
            return Err(OctreeError::DegenerateBounds);
        }
        let root = Cell {
            center,
            half,
            depth: 0,
            key: [0; 3],
            parent: NO_CELL,
            first_child: NO_CELL,
            start: 0,
            end: points.len() as u32,
        };
        let end = root.end;
        // After a brush only the moved points can be new (the earlier build checked the rest).
        let patch = known.and_then(|k| k.moved.map(|m| (k, m)));
        let patch = patch.filter(|(k, _)| k.old.positions.len() == points.len());
        let checked: Box<dyn Iterator<Item = &DVec3>> = match patch {
            Some((_, moved)) => Box::new(moved.iter().map(|&i| &points[i as usize])),
            None => Box::new(points.iter()),
        };
        for p in checked {
            if !p.is_finite() {
                return Err(OctreeError::NonFinite);
            }
            if !root.contains(*p) {
                return Err(OctreeError::OutsideRoot);
            }
        }
        let OctreeBuffers {
            mut cells,
            mut order,
        } = buffers;
        cells.clear();
        cells.push(root);
        // Freshly, the root lists the points in index order; after a brush, the earlier
        // arrangement with the moved points moved between leaves, every earlier cell's
        // segment then in place with its count corrected by `gained`.
        let gained = match patch {
            Some((k, moved)) => k.patch_order(moved, points, &mut order),
            None => {
                order.clear();
                order.extend(0..end);
                Default::default()
            }
        };
        let mut tree = Octree {
            cells,
            order,
            positions: Vec::new(),
            params: *params,
            root_edge: 2.0 * half,
        };
        // (An earlier octree's size is a good guess at this one's.)
        let expected = known.map_or(0, |k| k.old.cells.len());
        tree.cells.reserve(expected);
        let mut payloads: Vec<T> = Vec::with_capacity(expected);
        // Per cell, with known partitions: the earlier octree's cell at its address, and
        // whether its segment of `order` already holds that cell's final arrangement (then its
        // subtree's partitions are in place and nothing is copied).
        let mut old_of: Vec<u32> = Vec::with_capacity(expected.max(1));
        old_of.push(if known.is_some() { 0 } else { NO_CELL });
        let mut in_place: Vec<bool> = Vec::with_capacity(expected.max(1));
        in_place.push(patch.is_some());
        let mut level = 0..1usize;
        while !level.is_empty() {
            let decisions: Vec<(bool, T)> = {
                let t = &tree;
                let old_of = &old_of;
                let view = |i: usize| {
                    decide(CellView {
                        index: i as u32,
                        cell: &t.cells[i],
                        points: t.points_in(i as u32),
                        positions: points,
                        old: Some(old_of[i]).filter(|&o| o != NO_CELL),
                    })
                };
                match known {
                    // A rebuild after an edit: the cells new to this octree are decided in
                    // parallel (each is a fit), and the earlier octree's, whose decisions the
                    // caller has at hand (taken over, or fitted before the build), in order on
                    // this thread (handing them out would cost more than deciding them).
                    Some(_) => {
                        let new: Vec<usize> =
                            level.clone().filter(|&i| old_of[i] == NO_CELL).collect();
                        let new: Vec<(bool, T)> = match serial() {
                            true => new.iter().map(|&i| view(i)).collect(),
                            false => new.par_iter().map(|&i| view(i)).collect(),
                        };
                        let mut new = new.into_iter();
                        level
                            .clone()
                            .map(|i| {
                                if old_of[i] == NO_CELL {
                                    new.next().expect("one decision per new cell")
                                } else {
                                    view(i)
                                }
                            })
                            .collect()
                    }
                    None if serial() => (level.start..level.end).map(view).collect(),
                    None => (level.start..level.end).into_par_iter().map(view).collect(),
                }
            };
            let next_start = tree.cells.len();
            let mut to_split = Vec::new();
            for (offset, (split, payload)) in decisions.into_iter().enumerate() {
                let i = level.start + offset;
                payloads.push(payload);
                let c = tree.cells[i];
                if split && c.depth < params.max_depth {
                    to_split.push(i);
                } else if !(in_place[i]
                    && known
                        .as_ref()
                        .is_some_and(|k| k.old.cell(old_of[i]).is_leaf()))
                {
                    // A leaf (its segment is final): in increasing index order, as a build from
                    // scratch leaves it. A partition copied from an earlier octree keeps that
                    // octree's order below, which differs only under a cell whose subtree
                    // changed; a leaf in place that was a leaf before too is sorted already.
                    let r = &mut tree.order[c.start as usize..c.end as usize];
                    if !r.is_sorted() {
                        r.sort_unstable();
                    }
                }
            }
            // The cells' point ranges are disjoint: partition them in parallel, then append the
            // children in cell order (the arena stays level by level, whatever the threads).
            // A partition known and already in place costs nothing; known, it is copied once
            // for its whole subtree. (Only the cells partitioned afresh are handed out: the
            // others cost less than the handing.)
            let parts: Vec<Partition<'_>> = {
                let t = &tree;
                let (old_of, in_place, gained) = (&old_of, &in_place, &gained);
                let known_part = |i: usize| -> Option<Partition<'_>> {
                    let c = &t.cells[i];
                    let k = known.as_ref()?;
                    if let (Some(_), true) = (patch, in_place[i])
                        && let Some(children) = k.old.children(old_of[i])
                    {
                        let mut counts = [0u32; 8];
                        for (slot, ch) in counts.iter_mut().zip(children) {
                            let was = k.old.cell(ch);
                            let plus = gained.get(&ch).copied().unwrap_or(0);
                            *slot = (i64::from(was.end - was.start) + plus) as u32;
                        }
                        return Some((counts, None));
                    }
                    match k.partition_at(old_of[i], c.end - c.start)? {
                        (counts, _) if in_place[i] => Some((counts, None)),
                        (counts, order) => Some((counts, Some(Cow::Borrowed(order)))),
                    }
                };
                let afresh = |i: usize| -> Partition<'_> {
                    let (counts, order) = t.partition(i, points);
                    (counts, Some(Cow::Owned(order)))
                };
                if known.is_some() {
                    let known_parts: Vec<Option<Partition<'_>>> =
                        to_split.iter().map(|&i| known_part(i)).collect();
                    let unknown: Vec<usize> = to_split
                        .iter()
                        .zip(&known_parts)
                        .filter(|(_, p)| p.is_none())
                        .map(|(&i, _)| i)
                        .collect();
                    let mut unknown = match serial() {
                        true => unknown.iter().map(|&i| afresh(i)).collect::<Vec<_>>(),
                        false => unknown.par_iter().map(|&i| afresh(i)).collect(),
                    }
                    .into_iter();
                    known_parts
                        .into_iter()
                        .map(|p| p.unwrap_or_else(|| unknown.next().expect("one per cell")))
                        .collect()
                } else if serial() {
                    to_split.iter().map(|&i| afresh(i)).collect()
                } else {
                    to_split.par_iter().map(|&i| afresh(i)).collect()
                }
            };
            for (&i, (counts, order)) in to_split.iter().zip(parts) {
                let c = tree.cells[i];
                let kept = match order {
                    Some(Cow::Owned(order)) => {
                        tree.order[c.start as usize..c.end as usize].copy_from_slice(&order);
                        false
                    }
                    Some(Cow::Borrowed(order)) => {
                        tree.order[c.start as usize..c.end as usize].copy_from_slice(order);
                        true
                    }
                    None => true,
                };
                tree.push_children(i, counts);
                for child in 0..8 {
                    old_of.push(
                        known
                            .as_ref()
                            .map_or(NO_CELL, |k| k.child_of(old_of[i], child)),
                    );
                    in_place.push(kept);
                }
            }
            if let Some(on_level) = on_level {
                on_level(tree.cells[level.start].depth, tree.cells.len());
            }
            level = next_start..tree.cells.len();
        }
        Ok((Unplaced(tree), payloads))
    }

    /// [`Octree::build_with`] with a plain split predicate (no payload) and default options,
    /// over a copy of `points`.
    pub fn build<F>(
        points: &[DVec3],
        params: &OctreeParams,
        split: F,
    ) -> Result<Octree, OctreeError>
    where
        F: Fn(CellView<'_>) -> bool + Sync,
    {
        Self::build_with(points.to_vec(), params, OctreeBuild::default(), |v| {
            (split(v), ())
        })
        .map(|(t, _)| t)
    }

    /// The points of cell `i` partitioned by octant (counting sort, stable, so the order is
    /// deterministic): the count per octant and the reordered point indices. The cell's points
    /// are taken in increasing index order (a range copied from an earlier octree may hold them
    /// otherwise), so each child's segment is increasing too.
    fn partition(&self, i: usize, positions: &[DVec3]) -> ([u32; 8], Vec<u32>) {
        let parent = self.cells[i];
        let range = &self.order[parent.start as usize..parent.end as usize];
        let sorted;
        let points = if range.is_sorted() {
            range
        } else {
            let mut v = range.to_vec();
            v.sort_unstable();
            sorted = v;
            &sorted[..]
        };
        let octants: Vec<u8> = points
            .iter()
            .map(|&p| parent.octant(positions[p as usize]) as u8)
            .collect();
        let mut counts = [0u32; 8];
        for &o in &octants {
            counts[o as usize] += 1;
        }
        let mut cursor = [0u32; 8];
        let mut acc = 0;
        for o in 0..8 {
            cursor[o] = acc;
            acc += counts[o];
        }
        let mut out = vec![0u32; points.len()];
        for (&p, &o) in points.iter().zip(&octants) {
            out[cursor[o as usize] as usize] = p;
            cursor[o as usize] += 1;
        }
        (counts, out)
    }

    /// Appends the 8 children of cell `i`, whose points (already partitioned by
    /// [`Octree::partition`]) number `counts` per octant.
    fn push_children(&mut self, i: usize, counts: [u32; 8]) {
        let parent = self.cells[i];
        let first = self.cells.len() as u32;
        let h = 0.5 * parent.half;
        let mut start = parent.start;
        for o in 0..8u32 {
            let bit = |k: u32| ((o >> k) & 1) as f64 * 2.0 - 1.0;
            let center = parent.center + h * DVec3::new(bit(0), bit(1), bit(2));
            let key = [
                parent.key[0] * 2 + (o & 1),
                parent.key[1] * 2 + ((o >> 1) & 1),
                parent.key[2] * 2 + ((o >> 2) & 1),
            ];
            self.cells.push(Cell {
                center,
                half: h,
                depth: parent.depth + 1,
                key,
                parent: i as u32,
                first_child: NO_CELL,
                start,
                end: start + counts[o as usize],
            });
            start += counts[o as usize];
        }
        self.cells[i].first_child = first;
    }

    /// The octree's arrays for a later build to reuse, and its positions.
    pub fn into_buffers(self) -> (OctreeBuffers, Vec<DVec3>) {
        let buffers = OctreeBuffers {
            cells: self.cells,
            order: self.order,
        };
        (buffers, self.positions)
    }

    /// All cells, in arena order (root first, then level by level).
    pub fn cells(&self) -> &[Cell] {
        &self.cells
    }

    /// One cell by index. Panics if `index` is out of range (indices come from this tree).
    pub fn cell(&self, index: u32) -> &Cell {
        &self.cells[index as usize]
    }

    /// Indices of the 8 children of `index`, or `None` for a leaf.
    pub fn children(&self, index: u32) -> Option<std::ops::Range<u32>> {
        let c = &self.cells[index as usize];
        (!c.is_leaf()).then(|| c.first_child..c.first_child + 8)
    }

    /// Indices of the input points inside cell `index`'s cube (for a leaf: exactly its bucket).
    pub fn points_in(&self, index: u32) -> &[u32] {
        let c = &self.cells[index as usize];
        &self.order[c.start as usize..c.end as usize]
    }

    /// The leaf holding input point `point` (an index into the build's `points`): the leaf
    /// containing its position, found by descending the tree (no table per point is kept, so
    /// a rebuild after an edit does no work per point for it).
    pub fn leaf_of_point(&self, point: u32) -> u32 {
        self.leaf_containing(self.positions[point as usize])
            .expect("an input point lies in the root cube")
    }

    /// The input positions the tree was built on (shape: N, world units).
    pub fn positions(&self) -> &[DVec3] {
        &self.positions
    }

    /// The parameters the tree was built with.
    pub fn params(&self) -> &OctreeParams {
        &self.params
    }

    /// The root cell (index 0).
    pub fn root(&self) -> &Cell {
        &self.cells[0]
    }

    /// Edge length of a cell at `depth`: root edge / 2^depth, world units.
    pub fn edge_at_depth(&self, depth: u8) -> f64 {
        self.root_edge / f64::from(1u32 << depth.min(31))
    }

    /// Indices of all leaves, in arena order.
    pub fn leaves(&self) -> impl Iterator<Item = u32> + '_ {
        self.cells
            .iter()
            .enumerate()
            .filter(|(_, c)| c.is_leaf())
            .map(|(i, _)| i as u32)
    }

    /// The deepest depth of any cell.
    pub fn max_depth_reached(&self) -> u8 {
        self.cells.iter().map(|c| c.depth).max().unwrap_or(0)
    }
}
