//! Errors of the MPU build. Numerically degenerate fits are not errors: they fall back and are
//! counted in the [`crate::BuildReport`].

use psi_octree::{Interrupted, OctreeError};
use thiserror::Error;

/// Why an MPU could not be built.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum MpuError {
    /// Fewer points than one local fit needs (more than N_min).
    ///
    /// ```
    /// use glam::DVec3;
    /// use psi_mpu::{Mpu, MpuError, MpuParams};
    /// use psi_octree::OrientedPoint;
    /// let pts = vec![OrientedPoint { p: DVec3::ZERO, n: DVec3::Z }; 3];
    /// assert!(matches!(Mpu::build(&pts, &MpuParams::paper()), Err(MpuError::TooFewPoints { .. })));
    /// ```
    #[error("{got} oriented points are too few for an MPU; at least {need} are needed")]
    TooFewPoints {
        /// Points given.
        got: usize,
        /// Points needed.
        need: usize,
    },
    /// A position or normal is NaN or infinite, or a normal has zero length.
    ///
    /// ```
    /// use glam::DVec3;
    /// use psi_mpu::{Mpu, MpuError, MpuParams};
    /// use psi_octree::OrientedPoint;
    /// use psi_shapes::AnalyticShape;
    /// let mut pts = AnalyticShape::Sphere { radius: 1.0 }.sample(100, 1);
    /// pts[7].n = DVec3::ZERO;
    /// assert_eq!(Mpu::build(&pts, &MpuParams::paper()).unwrap_err(), MpuError::BadPoint { index: 7 });
    /// ```
    #[error("point {index} has a non-finite coordinate or a zero normal")]
    BadPoint {
        /// Index of the offending point.
        index: usize,
    },
    /// A parameter is out of range.
    ///
    /// ```
    /// use psi_mpu::{Mpu, MpuError, MpuParams};
    /// use psi_shapes::AnalyticShape;
    /// let pts = AnalyticShape::Sphere { radius: 1.0 }.sample(100, 1);
    /// let params = MpuParams { error_rel: -1.0, ..MpuParams::paper() };
    /// assert!(matches!(Mpu::build(&pts, &params), Err(MpuError::BadParameter(_))));
    /// ```
    #[error("bad MPU parameter: {0}")]
    BadParameter(String),
    /// The octree could not be built (all points coincide).
    ///
    /// ```
    /// use glam::DVec3;
    /// use psi_mpu::{Mpu, MpuError, MpuParams};
    /// use psi_octree::OrientedPoint;
    /// let pts = vec![OrientedPoint { p: DVec3::ONE, n: DVec3::Z }; 20];
    /// assert!(matches!(Mpu::build(&pts, &MpuParams::paper()), Err(MpuError::Octree(_))));
    /// ```
    #[error(transparent)]
    Octree(#[from] OctreeError),
    /// The caller stopped the build ([`psi_octree::Monitor`]).
    #[error("the MPU build was interrupted")]
    Interrupted(#[from] Interrupted),
    /// A region would decide more cells than its bound ([`crate::RegionPoints::max_cells`]).
    ///
    /// ```
    /// use psi_mpu::{MpuError, MpuFrame, MpuParams, Region, RegionPoints, fit_region};
    /// use psi_octree::Monitor;
    /// use psi_shapes::AnalyticShape;
    /// let pts = AnalyticShape::Sphere { radius: 1.0 }.sample(2000, 1);
    /// let params = MpuParams::paper();
    /// let frame = MpuFrame::for_points(&pts, &params).unwrap();
    /// let input = RegionPoints { max_cells: Some(20), ..RegionPoints::new(&pts, pts.len()) };
    /// let out = fit_region(&input, &frame, &params, &Region::tile(0, [0; 3]), &Monitor::silent());
    /// assert_eq!(out.unwrap_err(), MpuError::TooManyCells { max: 20 });
    /// ```
    #[error("more than {max} cells")]
    TooManyCells {
        /// The bound.
        max: usize,
    },
    /// The points a fit needed could not be fetched (a region decided from files whose
    /// reading failed; the message names the file and the problem).
    #[error("fetching the points of a fit: {0}")]
    Fetch(String),
}
