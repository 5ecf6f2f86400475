//! The fixed frame of an MPU: the origin of its local coordinates, its root cube and its length
//! scale D.

use glam::DVec3;
use psi_octree::{Aabb, OrientedPoint, RootCube, root_cube};
use serde::{Deserialize, Serialize};

use crate::{MpuError, MpuParams};

/// The fixed frame of an MPU: where the local coordinates are centred, the root cube, and the
/// length scale. Local regeneration keeps the frame of the first build so that cells keep their
/// identity (depth and integer key) across edits.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct MpuFrame {
    /// World position of the local frame's origin.
    pub origin: DVec3,
    /// Root cube centre, local frame.
    pub root_center: DVec3,
    /// Root cube half-edge, world units.
    pub root_half: f64,
    /// The length scale D (input bounding-box diagonal at the first build), world units.
    pub diagonal: f64,
}

impl MpuFrame {
    /// The frame Ohtake's set-up gives `points` (shape: N, world units): origin at the bounding
    /// box's centre, root cube `box_scale` × the largest extent, D the box's diagonal.
    ///
    /// Errors: a parameter out of range, fewer than N_min + 1 points, a non-finite coordinate,
    /// or all points coinciding.
    pub fn for_points(points: &[OrientedPoint], params: &MpuParams) -> Result<Self, MpuError> {
        let need = check_input_size(points, params)?;
        let bounds = Aabb::from_points(points.iter().map(|p| p.p))
            .ok_or(MpuError::TooFewPoints { got: 0, need })?;
        if !bounds.min.is_finite() || !bounds.max.is_finite() {
            let index = points.iter().position(|p| !p.p.is_finite()).unwrap_or(0);
            return Err(MpuError::BadPoint { index });
        }
        Self::for_bounds(&bounds, points.len(), params)
    }

    /// [`MpuFrame::for_points`] from what a pass over the points gathers: their bounding box
    /// `bounds` (world units, finite) and their count (a streamed input's frame).
    pub fn for_bounds(bounds: &Aabb, count: usize, params: &MpuParams) -> Result<Self, MpuError> {
        params.validate()?;
        let need = params.n_min + 1;
        if count < need {
            return Err(MpuError::TooFewPoints { got: count, need });
        }
        if !bounds.min.is_finite() || !bounds.max.is_finite() {
            return Err(MpuError::BadParameter(format!(
                "the bounding box {bounds:?} is not finite"
            )));
        }
        let origin = bounds.center();
        let local = Aabb {
            min: bounds.min - origin,
            max: bounds.max - origin,
        };
        let RootCube { center, half } = root_cube(&local, params.box_scale)?;
        Ok(Self {
            origin,
            root_center: center,
            root_half: half,
            diagonal: bounds.diagonal(),
        })
    }

    /// The root cube, local frame.
    pub fn root(&self) -> RootCube {
        RootCube {
            center: self.root_center,
            half: self.root_half,
        }
    }
}

/// Checks the parameters and that there are more than N_min points; returns N_min + 1.
pub(crate) fn check_input_size(
    points: &[OrientedPoint],
    params: &MpuParams,
) -> Result<usize, MpuError> {
    params.validate()?;
    let need = params.n_min + 1;
    if points.len() < need {
        return Err(MpuError::TooFewPoints {
            got: points.len(),
            need,
        });
    }
    Ok(need)
}
