//! The root cube of an octree: centred on the points' bounding box, its edge a multiple of the
//! box's largest extent.

use glam::DVec3;

use crate::{Aabb, OctreeError};

/// The root cube of an octree, in the frame of its points.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RootCube {
    /// Centre.
    pub center: DVec3,
    /// Half of the edge (plain length, same units as the points).
    pub half: f64,
}

/// The root cube for a bounding box: centred on the box, edge `box_scale` × the largest extent.
/// Errors when the box is empty, flat to a point or not finite.
pub fn root_cube(bounds: &Aabb, box_scale: f64) -> Result<RootCube, OctreeError> {
    let largest = bounds.extent().max_element();
    if !largest.is_finite() || !bounds.center().is_finite() {
        return Err(OctreeError::NonFinite);
    }
    if largest <= 0.0 {
        return Err(OctreeError::DegenerateBounds);
    }
    Ok(RootCube {
        center: bounds.center(),
        half: 0.5 * box_scale * largest,
    })
}
