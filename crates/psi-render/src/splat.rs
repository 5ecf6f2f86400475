//! A particle on screen: where its disk lands and the ellipse it is seen as.

use glam::{DVec2, DVec3};

/// Smallest drawn minor/major axis ratio: a disk seen edge-on stays a thin ellipse.
const MIN_ASPECT: f64 = 0.2;
/// Smallest drawn semi-axis, pixels.
const MIN_RADIUS_PX: f64 = 0.5;

/// One particle on screen.
pub(crate) struct Splat {
    /// Centre in pixels (x right, y down).
    pub(crate) center: DVec2,
    /// Depth, world units, larger = nearer.
    pub(crate) depth: f64,
    /// Normal in the camera frame (right, up, toward viewer), unit.
    pub(crate) normal: DVec3,
    /// Radius, world units (scaled by `splat_scale`).
    pub(crate) radius: f64,
    /// Lambert brightness (back faces darkened).
    pub(crate) light: f64,
    pub(crate) index: usize,
}

impl Splat {
    /// The screen ellipse of the particle's disk drawn with radius `r` world units at `scale`
    /// pixels per world unit.
    pub(crate) fn ellipse(&self, r: f64, scale: f64) -> ScreenEllipse {
        let major = (r * scale).max(MIN_RADIUS_PX);
        let minor = (major * self.normal.z.abs().max(MIN_ASPECT)).max(MIN_RADIUS_PX);
        let minor_axis = DVec2::new(self.normal.x, -self.normal.y)
            .try_normalize()
            .unwrap_or(DVec2::X);
        ScreenEllipse {
            minor_axis,
            major,
            minor,
        }
    }
}

/// An ellipse on screen (pixels, y down).
#[derive(Clone, Copy, Debug)]
pub(crate) struct ScreenEllipse {
    /// Unit direction of the minor axis.
    pub(crate) minor_axis: DVec2,
    /// Semi-major axis, pixels.
    pub(crate) major: f64,
    /// Semi-minor axis, pixels.
    pub(crate) minor: f64,
}
