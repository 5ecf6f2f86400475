//! The orthographic camera: a view direction and a scale fitted to a set of points.

use glam::{DVec2, DVec3};

use crate::View;

/// An orthographic camera mapping world points to pixels.
///
/// Screen coordinates are pixels with x to the right and y *down* (the pixmap's convention);
/// depth is in world units along the direction towards the viewer (larger = nearer).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    right: DVec3,
    up: DVec3,
    toward_viewer: DVec3,
    /// Screen-plane coordinates (world units along `right`, `up`) of the area's centre.
    center: DVec2,
    /// Pixel coordinates of the area's centre.
    center_px: DVec2,
    scale: f64,
}

impl Camera {
    /// Fits a camera looking from `view` so that the projections of the finite `points`
    /// (world units) fill the pixel rectangle `area = [x0, y0, x1, y1]` less `margin` × its
    /// shorter side on each side, centred. Without finite points, the world origin is at the
    /// centre at 1 pixel per unit; a single point (zero extent) is treated as extent 1.
    ///
    /// ```
    /// use glam::DVec3;
    /// use psi_render::{Camera, View};
    /// let cam = Camera::fit(View::Front, [DVec3::splat(-1.0), DVec3::ONE], [0.0, 0.0, 100.0, 100.0], 0.0);
    /// assert_eq!(cam.pixels_per_unit(), 50.0);
    /// let p = cam.project(DVec3::new(1.0, 1.0, 0.5));
    /// assert_eq!((p.x, p.y, p.z), (100.0, 0.0, 0.5)); // top right corner; y is down
    /// ```
    pub fn fit(
        view: View,
        points: impl IntoIterator<Item = DVec3>,
        area: [f64; 4],
        margin: f64,
    ) -> Camera {
        let toward_viewer = view.toward_viewer();
        let up = view.up();
        let right = up.cross(toward_viewer);
        let mut lo = DVec2::splat(f64::INFINITY);
        let mut hi = DVec2::splat(f64::NEG_INFINITY);
        for p in points.into_iter().filter(|p| p.is_finite()) {
            let s = DVec2::new(p.dot(right), p.dot(up));
            lo = lo.min(s);
            hi = hi.max(s);
        }
        let (width, height) = ((area[2] - area[0]).max(1.0), (area[3] - area[1]).max(1.0));
        let center_px = DVec2::new(0.5 * (area[0] + area[2]), 0.5 * (area[1] + area[3]));
        let (center, scale) = if lo.x.is_finite() {
            let extent = hi - lo;
            let extent = if extent.max_element() > 0.0 {
                extent
            } else {
                DVec2::ONE
            };
            let free = 2.0 * margin.clamp(0.0, 0.45) * width.min(height);
            let scale = ((width - free) / extent.x.max(f64::MIN_POSITIVE))
                .min((height - free) / extent.y.max(f64::MIN_POSITIVE));
            (0.5 * (lo + hi), scale)
        } else {
            (DVec2::ZERO, 1.0)
        };
        Camera {
            right,
            up,
            toward_viewer,
            center,
            center_px,
            scale,
        }
    }

    /// The pixel position (x right, y down) and depth (world units, larger = nearer) of the
    /// world point `p`.
    pub fn project(&self, p: DVec3) -> DVec3 {
        let s = DVec2::new(p.dot(self.right), p.dot(self.up)) - self.center;
        DVec3::new(
            self.center_px.x + self.scale * s.x,
            self.center_px.y - self.scale * s.y,
            p.dot(self.toward_viewer),
        )
    }

    /// A world direction in the camera frame: (along screen right, along screen up, towards
    /// the viewer). Unit vectors stay unit.
    pub fn direction(&self, v: DVec3) -> DVec3 {
        DVec3::new(v.dot(self.right), v.dot(self.up), v.dot(self.toward_viewer))
    }

    /// Pixels per world unit.
    pub fn pixels_per_unit(&self) -> f64 {
        self.scale
    }
}
