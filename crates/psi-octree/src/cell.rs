//! The octree's cell: a cube with its address (depth, integer key), its family links in the
//! arena and its points' range, and the octant rule that assigns points to children.

use glam::DVec3;

use crate::Aabb;

/// Sentinel index meaning "no cell".
pub const NO_CELL: u32 = u32::MAX;

/// One cube of the octree. Cells are stored in an arena and named by `u32` index; the 8 children
/// of a cell are contiguous, in octant order (bit 0: +x, bit 1: +y, bit 2: +z).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cell {
    /// Cube centre, world units.
    pub center: DVec3,
    /// Half of the cube's edge, world units.
    pub half: f64,
    /// Depth (root = 0).
    pub depth: u8,
    /// Integer coordinates of the cube at its depth: the cube spans
    /// `root_min + key * edge .. root_min + (key + 1) * edge` per axis.
    pub key: [u32; 3],
    /// Parent index, or [`NO_CELL`] for the root.
    pub parent: u32,
    /// Index of the first of the 8 children, or [`NO_CELL`] for a leaf.
    pub first_child: u32,
    /// The cell's points are `order[start..end]` (see [`Octree::points_in`]).
    pub(crate) start: u32,
    pub(crate) end: u32,
}

impl Cell {
    /// Whether the cell has no children.
    pub fn is_leaf(&self) -> bool {
        self.first_child == NO_CELL
    }

    /// Edge length of the cube, world units.
    pub fn edge(&self) -> f64 {
        2.0 * self.half
    }

    /// Support radius R = α · (main diagonal) = α·2√3·half, world units (plain, not squared).
    pub fn support_radius(&self, alpha: f64) -> f64 {
        alpha * 2.0 * 3f64.sqrt() * self.half
    }

    /// Octant of `x` relative to the centre (bit 0: x ≥ cx, bit 1: y ≥ cy, bit 2: z ≥ cz).
    /// This comparison is the single rule that assigns points to children and leaves.
    #[inline]
    pub fn octant(&self, x: DVec3) -> usize {
        (x.x >= self.center.x) as usize
            | (((x.y >= self.center.y) as usize) << 1)
            | (((x.z >= self.center.z) as usize) << 2)
    }

    /// Whether `x` lies in the closed cube.
    pub fn contains(&self, x: DVec3) -> bool {
        (x - self.center).abs().max_element() <= self.half
    }

    /// The cube as a box.
    pub fn aabb(&self) -> Aabb {
        Aabb {
            min: self.center - DVec3::splat(self.half),
            max: self.center + DVec3::splat(self.half),
        }
    }
}
