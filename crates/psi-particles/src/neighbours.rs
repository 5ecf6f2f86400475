//! Neighbour search over the current particle positions: the octree-as-grid or a kd-tree, the
//! two interchangeable (benches/neighbours.rs compares them).

use glam::DVec3;
use psi_mpu::Mpu;
use psi_octree::PointIndex;

use crate::NeighbourSearch;
use crate::octree_buckets::OctreeBuckets;

/// A neighbour index over particle positions (world units).
pub(crate) enum NeighbourIndex<'a> {
    Kd {
        index: PointIndex,
        positions: Vec<DVec3>,
    },
    Octree {
        buckets: OctreeBuckets<'a>,
        origin: DVec3,
    },
}

impl<'a> NeighbourIndex<'a> {
    pub(crate) fn new(kind: NeighbourSearch, mpu: &'a Mpu, positions: &[DVec3]) -> Self {
        match kind {
            NeighbourSearch::KdTree => Self::Kd {
                index: PointIndex::new(positions),
                positions: positions.to_vec(),
            },
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

    /// Calls `visit(j)` for every particle within `radius` of world position `x` (itself too).
    pub(crate) fn for_each_within(
        &self,
        x: DVec3,
        radius: f64,
        scratch: &mut Vec<u32>,
        mut visit: impl FnMut(u32),
    ) {
        match self {
            Self::Kd { index, positions } => {
                scratch.clear();
                index.within(x, radius, scratch);
                // kiddo's unsorted order depends on its layout only; sort for a fixed summation
                // order in both searches.
                scratch.sort_unstable();
                let _ = positions;
                scratch.iter().for_each(|&j| visit(j));
            }
            Self::Octree { buckets, origin } => {
                scratch.clear();
                buckets.for_each_within(x - *origin, radius, |j| scratch.push(j));
                scratch.sort_unstable();
                scratch.iter().for_each(|&j| visit(j));
            }
        }
    }
}
