//! A kd-tree over point positions (kiddo 6), the alternative to [`crate::Octree::points_within`].
//!
//! All kiddo calls of the workspace live in this file, so a change of kiddo's API touches only it.

use std::num::NonZeroUsize;

use glam::DVec3;
use kiddo::{ImmutableKdTree, SquaredEuclidean};

/// Point counts from which the tree is built in parallel (kiddo's default is 262 144). The
/// resulting tree does not depend on the thread count (checked bitwise on 70k- and 480k-point
/// models with 1 and 2 threads).
const PARALLEL_FROM: usize = 32_768;

/// An immutable kd-tree over positions (shape: N, world units); items are indices into them.
pub struct PointIndex {
    tree: Option<ImmutableKdTree<f64, 3>>,
}

impl std::fmt::Debug for PointIndex {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PointIndex")
            .field("len", &self.len())
            .finish()
    }
}

impl PointIndex {
    /// Builds the index. Non-finite positions are indexed as given; an empty slice gives an
    /// empty index whose queries return nothing.
    pub fn new(points: &[DVec3]) -> Self {
        // Built straight from the positions (no coordinate copy: 1.7 MB for the bunny, which a
        // local regeneration would page in afresh).
        let tree = if points.is_empty() || points.len() >= u32::MAX as usize {
            None
        } else {
            ImmutableKdTree::builder()
                .with_parallel_construction_threshold(PARALLEL_FROM)
                .build_from_source(points, |p: &DVec3, d| p[d], |i, _| i as u32)
                .ok()
        };
        Self { tree }
    }

    /// Number of indexed points.
    pub fn len(&self) -> usize {
        self.tree.as_ref().map_or(0, |t| t.size())
    }

    /// Whether nothing is indexed.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Appends to `out` the indices of points with |p − x| ≤ `radius` (plain radius; kiddo is
    /// given the squared radius), in no particular order.
    pub fn within(&self, x: DVec3, radius: f64, out: &mut Vec<u32>) {
        if let Some(t) = &self.tree {
            let found = t
                .query(&x.to_array())
                .within::<SquaredEuclidean<f64>>(radius * radius)
                .unsorted()
                .execute();
            out.extend(found.iter().map(|n| n.item));
        }
    }

    /// The nearest point to `x` as `(index, squared distance)`; `None` for an empty index.
    pub fn nearest_one(&self, x: DVec3) -> Option<(u32, f64)> {
        let t = self.tree.as_ref()?;
        let n = t
            .query(&x.to_array())
            .nearest_one::<SquaredEuclidean<f64>>()
            .execute();
        Some((n.item, n.distance))
    }

    /// The `k` nearest points to `x` as `(index, squared distance)`, nearest first.
    pub fn nearest(&self, x: DVec3, k: usize) -> Vec<(u32, f64)> {
        match (&self.tree, NonZeroUsize::new(k)) {
            (Some(t), Some(k)) => t
                .query(&x.to_array())
                .nearest_n::<SquaredEuclidean<f64>>(k)
                .execute()
                .iter()
                .map(|n| (n.item, n.distance))
                .collect(),
            _ => Vec::new(),
        }
    }
}
