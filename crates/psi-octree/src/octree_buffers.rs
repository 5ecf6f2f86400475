//! The arrays of an octree kept for a later build to fill ([`OctreeBuffers`]): memory the
//! process already maps costs no new pages.

use glam::DVec3;

use crate::{Cell, NO_CELL};

/// The arrays of an octree, for a later build to fill instead of allocating its own
/// ([`crate::Octree::into_buffers`], [`OctreeBuffers::with_capacity`]).
#[derive(Clone, Debug, Default)]
pub struct OctreeBuffers {
    pub(crate) cells: Vec<Cell>,
    pub(crate) order: Vec<u32>,
}

impl OctreeBuffers {
    /// Buffers for an octree of about `cells` cells over `points` points, their memory touched
    /// once (so that the build that fills them finds it mapped).
    pub fn with_capacity(cells: usize, points: usize) -> Self {
        let blank = Cell {
            center: DVec3::ZERO,
            half: 0.0,
            depth: 0,
            key: [0; 3],
            parent: NO_CELL,
            first_child: NO_CELL,
            start: 0,
            end: 0,
        };
        let touched = |v: &mut Vec<u32>| {
            v.resize(points, 0);
            v.clear();
        };
        let mut b = Self {
            cells: vec![blank; cells],
            order: Vec::new(),
        };
        b.cells.clear();
        touched(&mut b.order);
        b
    }
}
