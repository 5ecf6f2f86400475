//! Errors of scene construction and edits.

use psi_mpu::MpuError;
use psi_octree::Interrupted;
use thiserror::Error;

/// Why a scene could not be built or an edit applied. The scene is unchanged after an error.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum RegenError {
    /// The edit's parameters are unusable.
    ///
    /// ```
    /// use glam::DVec3;
    /// use psi_regen::{Edit, RegenError};
    /// let e = Edit::Brush { center: DVec3::ZERO, radius: -1.0, displacement: DVec3::X };
    /// assert!(matches!(e.apply(&[]), Err(RegenError::BadEdit(_))));
    /// ```
    #[error("bad edit: {0}")]
    BadEdit(String),
    /// The edited points no longer make an MPU (too few, say).
    ///
    /// ```
    /// use psi_regen::{RegenError, Scene};
    /// use psi_octree::OrientedPoint;
    /// let pts = vec![OrientedPoint { p: glam::DVec3::ZERO, n: glam::DVec3::Z }; 3];
    /// let r = Scene::new(pts, &psi_mpu::MpuParams::paper(), &psi_particles::ParticleParams::paper());
    /// assert!(matches!(r, Err(RegenError::Mpu(_))));
    /// ```
    #[error(transparent)]
    Mpu(MpuError),
    /// The caller stopped the work ([`psi_octree::Monitor`]).
    #[error("interrupted")]
    Interrupted(#[from] Interrupted),
}

impl From<MpuError> for RegenError {
    /// An MPU error, but a stopped build is the scene's interruption.
    fn from(e: MpuError) -> Self {
        match e {
            MpuError::Interrupted(i) => RegenError::Interrupted(i),
            other => RegenError::Mpu(other),
        }
    }
}
