//! Neighbour search over the current particle positions: a uniform grid, a kd-tree or the
//! octree as an adaptive grid, interchangeable (benches/neighbours.rs compares them).

use glam::DVec3;
use psi_mpu::Mpu;
use psi_octree::{Aabb, PointIndex};

use crate::NeighbourSearch;
use crate::octree_buckets::OctreeBuckets;
use crate::particle_grid::ParticleGrid;

/// The particles that do not move during a relaxation (local regeneration's fixed neighbours),
/// indexed once.
#[derive(Clone)]
pub(crate) struct FixedSet {
    grid: ParticleGrid,
    ids: Vec<u32>,
}

impl FixedSet {
    /// Indexes the particles with `movable[i] == false` (those in `within` when given) in a
    /// grid of cubes of edge about `edge` (world units).
    pub(crate) fn new(
        positions: &[DVec3],
        movable: &[bool],
        within: Option<Aabb>,
        edge: f64,
    ) -> Self {
        let ids: Vec<u32> = (0..positions.len() as u32)
            .filter(|&i| {
                !movable[i as usize] && within.is_none_or(|b| b.contains(positions[i as usize]))
            })
            .collect();
        let pts: Vec<DVec3> = ids.iter().map(|&i| positions[i as usize]).collect();
        Self {
            grid: ParticleGrid::new(&pts, edge),
            ids,
        }
    }
}

/// A neighbour index over particle positions (world units).
pub(crate) enum NeighbourIndex<'a> {
    /// Fixed particles indexed once, the moving ones per iteration.
    Split {
        fixed: &'a FixedSet,
        moving: ParticleGrid,
        moving_ids: &'a [u32],
    },
    Kd(PointIndex),
    Grid(ParticleGrid),
    Octree {
        buckets: OctreeBuckets<'a>,
        origin: DVec3,
    },
}

impl<'a> NeighbourIndex<'a> {
    /// The index of `positions` (world units) of kind `kind`; `grid_edge` is the grid's cube
    /// edge (about the queries' radius; world units).
    pub(crate) fn new(
        kind: NeighbourSearch,
        mpu: &'a Mpu,
        positions: &[DVec3],
        grid_edge: f64,
    ) -> Self {
        match kind {
            NeighbourSearch::Grid => Self::Grid(ParticleGrid::new(positions, grid_edge)),
            NeighbourSearch::KdTree => Self::Kd(PointIndex::new(positions)),
            NeighbourSearch::Octree => {
                let origin = mpu.frame_origin();
                let local: Vec<DVec3> = positions.iter().map(|p| *p - origin).collect();
                Self::Octree {
                    buckets: OctreeBuckets::new(mpu.octree(), &local),
                    origin,
                }
            }
        }
    }

    /// The index of a relaxation where only the particles `moving` (indices into `positions`)
    /// move: the fixed set indexed once (`fixed`), the moving particles now.
    pub(crate) fn split(
        fixed: &'a FixedSet,
        positions: &[DVec3],
        moving: &'a [u32],
        edge: f64,
    ) -> Self {
        let pts: Vec<DVec3> = moving.iter().map(|&i| positions[i as usize]).collect();
        Self::Split {
            fixed,
            moving: ParticleGrid::new(&pts, edge),
            moving_ids: moving,
        }
    }

    /// As [`Self::for_each_within`], visiting only the particles that move (all of them
    /// unless this is a split index).
    pub(crate) fn for_each_moving_within(
        &self,
        x: DVec3,
        radius: f64,
        scratch: &mut Vec<u32>,
        visit: impl FnMut(u32),
    ) {
        if let Self::Split {
            moving, moving_ids, ..
        } = self
        {
            scratch.clear();
            append_mapped(moving, moving_ids, x, radius, scratch);
            scratch.sort_unstable();
            scratch.iter().copied().for_each(visit);
        } else {
            self.for_each_within(x, radius, scratch, visit);
        }
    }

    /// Calls `visit(j)` for every particle within `radius` of world position `x` (itself too).
    pub(crate) fn for_each_within(
        &self,
        x: DVec3,
        radius: f64,
        scratch: &mut Vec<u32>,
        mut visit: impl FnMut(u32),
    ) {
        scratch.clear();
        match self {
            Self::Split {
                fixed,
                moving,
                moving_ids,
            } => {
                append_mapped(&fixed.grid, &fixed.ids, x, radius, scratch);
                append_mapped(moving, moving_ids, x, radius, scratch);
            }
            Self::Grid(grid) => grid.append_within(x, radius, scratch),
            Self::Kd(index) => index.within(x, radius, scratch),
            Self::Octree { buckets, origin } => {
                buckets.for_each_within(x - *origin, radius, |j| scratch.push(j));
            }
        }
        // Each structure lists neighbours in an order of its own: sorted, every search sums the
        // forces in the same order and gives the same result.
        scratch.sort_unstable();
        scratch.iter().for_each(|&j| visit(j));
    }
}

/// Appends to `out` the particles of `grid` (built over a subset, `ids` naming each of its
/// points' particle) within `radius` of `x`, as particle indices.
fn append_mapped(grid: &ParticleGrid, ids: &[u32], x: DVec3, radius: f64, out: &mut Vec<u32>) {
    let from = out.len();
    grid.append_within(x, radius, out);
    for j in &mut out[from..] {
        *j = ids[*j as usize];
    }
}
