//! Lambert shading with one fixed light from the upper left front, in the camera frame.

use glam::DVec3;
use tiny_skia::Color;

/// Light direction in the camera frame (right, up, toward viewer), unit.
fn light() -> DVec3 {
    DVec3::new(-0.35, 0.55, 0.76).normalize()
}

const AMBIENT: f64 = 0.38;
const DIFFUSE: f64 = 0.62;
/// Brightness factor of a surface seen from behind.
const BACK: f64 = 0.55;

/// The darkening of a surface whose unit normal has component `nz` towards the viewer: 1 when
/// it faces the viewer, [`BACK`] from 30° behind edge-on, linear in between (so splats seen
/// nearly edge-on at a silhouette are not darkened into a dark rim).
pub(crate) fn back_factor(nz: f64) -> f64 {
    if nz >= 0.0 {
        1.0
    } else {
        1.0 - (1.0 - BACK) * (-nz / 0.5).min(1.0)
    }
}

/// Brightness in [AMBIENT, 1] of a surface with unit normal `n` (camera frame).
pub(crate) fn lambert(n: DVec3) -> f64 {
    AMBIENT + DIFFUSE * n.dot(light()).max(0.0)
}

/// `rgb` scaled by `k` (clamped to [0, 1]), opaque.
pub(crate) fn shade(rgb: [u8; 3], k: f64) -> Color {
    let k = k.clamp(0.0, 1.0);
    let c = |v: u8| (f64::from(v) * k).round() as u8;
    Color::from_rgba8(c(rgb[0]), c(rgb[1]), c(rgb[2]), 255)
}

/// The brightness of a splat or face with camera-frame normal `n`: `None` when it faces away
/// and back faces are culled.
pub(crate) fn brightness(n: DVec3, cull: bool) -> Option<f64> {
    let n = if n.length_squared() > 0.0 {
        n.normalize()
    } else {
        DVec3::Z
    };
    if n.z >= 0.0 {
        Some(lambert(n))
    } else if cull {
        None
    } else {
        Some(back_factor(n.z) * lambert(-n))
    }
}
