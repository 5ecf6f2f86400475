//! The smooth surface under the dots of [`crate::SplatStyle::Dots`]: splats blended in a
//! depth buffer (surface splatting), supersampled, then composited over the background.

use glam::{DVec2, DVec3};
use tiny_skia::{Pixmap, PremultipliedColorU8};

use crate::shading::{back_factor, lambert};
use crate::splat::Splat;

/// The surface is resolved at this many times the image resolution, then averaged down.
const SUPERSAMPLE: usize = 2;
/// Surface brightness is rounded to this many levels: far smaller PNG files, and with the
/// dots on top no visible bands.
const LEVELS: f64 = 64.0;

/// The pixels of one splat's ellipse at the buffer's resolution: calls `f(index, z, q)` for
/// each pixel centre inside, with `z` the depth of the splat's tangent plane there and `q` the
/// squared elliptical distance from the centre (0 at the centre, 1 at the rim).
fn rasterize(
    s: &Splat,
    scale: f64,
    width: usize,
    height: usize,
    mut f: impl FnMut(usize, f64, f64),
) {
    let k = SUPERSAMPLE as f64;
    let ellipse = s.ellipse(s.radius, scale);
    let (dir, a, b) = (ellipse.minor_axis, ellipse.major, ellipse.minor);
    let (a, b, center) = (a * k, b * k, s.center * k);
    // Depth change per buffer pixel along x and y (y down) on the tangent plane.
    let nz = if s.normal.z >= 0.0 {
        s.normal.z.max(0.3)
    } else {
        s.normal.z.min(-0.3)
    };
    let (gx, gy) = (
        -s.normal.x / (scale * k * nz),
        s.normal.y / (scale * k * nz),
    );
    let x0 = (center.x - a).floor().max(0.0) as usize;
    let y0 = (center.y - a).floor().max(0.0) as usize;
    let x1 = ((center.x + a).ceil().max(0.0) as usize).min(width);
    let y1 = ((center.y + a).ceil().max(0.0) as usize).min(height);
    for y in y0..y1 {
        for x in x0..x1 {
            let d = DVec2::new(x as f64 + 0.5, y as f64 + 0.5) - center;
            let (u, v) = (d.dot(dir), d.perp_dot(dir));
            let q = (u / b).powi(2) + (v / a).powi(2);
            if q <= 1.0 {
                f(y * width + x, s.depth + gx * d.x + gy * d.y, q);
            }
        }
    }
}

/// Draws the surface of `splats` (radii already scaled) in the colour `rgb`: per sample, the
/// normals of the fragments within one radius of the nearest are blended with weights
/// (1 − q)² and Lambert-shaded (back faces darkened); returns for each splat whether it is visible (nothing nearer than its radius
/// in front of its centre).
pub(crate) fn draw_surface(
    pixmap: &mut Pixmap,
    splats: &[Splat],
    scale: f64,
    rgb: [u8; 3],
) -> Vec<bool> {
    let (w, h) = (pixmap.width() as usize, pixmap.height() as usize);
    let (bw, bh) = (w * SUPERSAMPLE, h * SUPERSAMPLE);
    let mut nearest = vec![f64::NEG_INFINITY; bw * bh];
    for s in splats {
        rasterize(s, scale, bw, bh, |i, z, _| {
            if z > nearest[i] {
                nearest[i] = z;
            }
        });
    }
    // Per sample: the blend weight, the weighted normal (turned towards the viewer) and the
    // weighted back-face factor.
    let mut weight = vec![0.0f64; bw * bh];
    let mut normal = vec![DVec3::ZERO; bw * bh];
    let mut back = vec![0.0f64; bw * bh];
    for s in splats {
        let n = if s.normal.z >= 0.0 {
            s.normal
        } else {
            -s.normal
        };
        let f = back_factor(s.normal.z);
        rasterize(s, scale, bw, bh, |i, z, q| {
            if z >= nearest[i] - s.radius {
                let wgt = (1.0 - q).powi(2) + 1e-6;
                weight[i] += wgt;
                normal[i] += wgt * n;
                back[i] += wgt * f;
            }
        });
    }
    // Average each SUPERSAMPLE² block: coverage is the fraction of covered samples.
    let pixels = pixmap.pixels_mut();
    for y in 0..h {
        for x in 0..w {
            let (mut covered, mut brightness) = (0.0, 0.0);
            for sy in 0..SUPERSAMPLE {
                for sx in 0..SUPERSAMPLE {
                    let i = (y * SUPERSAMPLE + sy) * bw + x * SUPERSAMPLE + sx;
                    if weight[i] > 0.0 {
                        covered += 1.0;
                        let n = normal[i].try_normalize().unwrap_or(DVec3::Z);
                        brightness += lambert(n) * back[i] / weight[i];
                    }
                }
            }
            if covered == 0.0 {
                continue;
            }
            let k = (brightness / covered * LEVELS).round() / LEVELS;
            // Source over: the surface's premultiplied colour plus the rest of the pixel.
            let alpha = covered / (SUPERSAMPLE * SUPERSAMPLE) as f64;
            let dst = pixels[y * w + x];
            let blend = |c: u8, d: u8| {
                (f64::from(c) * k * alpha + f64::from(d) * (1.0 - alpha))
                    .round()
                    .clamp(0.0, 255.0) as u8
            };
            let a = (255.0 * alpha + f64::from(dst.alpha()) * (1.0 - alpha))
                .round()
                .clamp(0.0, 255.0) as u8;
            let (r, g, b) = (
                blend(rgb[0], dst.red()).min(a),
                blend(rgb[1], dst.green()).min(a),
                blend(rgb[2], dst.blue()).min(a),
            );
            if let Some(c) = PremultipliedColorU8::from_rgba(r, g, b, a) {
                pixels[y * w + x] = c;
            }
        }
    }
    splats
        .iter()
        .map(|s| {
            let c = s.center * SUPERSAMPLE as f64;
            let (x, y) = (c.x.floor(), c.y.floor());
            if x < 0.0 || y < 0.0 || x >= bw as f64 || y >= bh as f64 {
                return false;
            }
            nearest[y as usize * bw + x as usize] <= s.depth + s.radius
        })
        .collect()
}
