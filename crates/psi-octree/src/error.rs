//! Errors of octree construction.

use thiserror::Error;

/// Why an octree could not be built.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum OctreeError {
    /// No points were given.
    ///
    /// ```
    /// use psi_octree::{Octree, OctreeParams, OctreeError};
    /// let err = Octree::build(&[], &OctreeParams::mpu(), |_| false).unwrap_err();
    /// assert_eq!(err, OctreeError::Empty);
    /// ```
    #[error("no points to build an octree on")]
    Empty,
    /// All points coincide, so the root cube would have zero size.
    ///
    /// ```
    /// use glam::DVec3;
    /// use psi_octree::{Octree, OctreeParams, OctreeError};
    /// let pts = [DVec3::ONE; 3];
    /// let err = Octree::build(&pts, &OctreeParams::mpu(), |_| false).unwrap_err();
    /// assert_eq!(err, OctreeError::DegenerateBounds);
    /// ```
    #[error("all points coincide: the bounding box has zero size")]
    DegenerateBounds,
    /// A coordinate is NaN or infinite.
    ///
    /// ```
    /// use glam::DVec3;
    /// use psi_octree::{Octree, OctreeParams, OctreeError};
    /// let pts = [DVec3::ZERO, DVec3::new(f64::NAN, 0.0, 0.0)];
    /// let err = Octree::build(&pts, &OctreeParams::mpu(), |_| false).unwrap_err();
    /// assert_eq!(err, OctreeError::NonFinite);
    /// ```
    #[error("a point coordinate is NaN or infinite")]
    NonFinite,
    /// A point lies outside the given root cube.
    #[error("a point lies outside the root cube")]
    OutsideRoot,
    /// More points than u32 indices can name.
    #[error("{0} points exceed the octree's u32 index range")]
    TooManyPoints(usize),
    /// The requested maximum depth exceeds what integer cell keys represent.
    ///
    /// ```
    /// use glam::DVec3;
    /// use psi_octree::{Octree, OctreeParams, OctreeError};
    /// let params = OctreeParams { max_depth: 40, ..OctreeParams::mpu() };
    /// let err = Octree::build(&[DVec3::ZERO, DVec3::ONE], &params, |_| false).unwrap_err();
    /// assert!(matches!(err, OctreeError::TooDeep { .. }));
    /// ```
    #[error("maximum depth {max_depth} exceeds the limit {limit}")]
    TooDeep {
        /// The requested depth.
        max_depth: u8,
        /// The largest supported depth.
        limit: u8,
    },
}
