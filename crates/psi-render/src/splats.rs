//! The splat renderer: each particle an oriented disk, seen as an ellipse, painted back to
//! front.

use glam::{DVec2, DVec3};
use tiny_skia::{Color, Paint, PathBuilder, Pixmap, Rect, Transform};

use crate::camera::Camera;
use crate::canvas::{canvas, finish};
use crate::shading::{back_factor, brightness, shade};
use crate::splat::{ScreenEllipse, Splat};
use crate::surface::draw_surface;
use crate::{Backfaces, RenderError, RenderParams, SplatStyle};

/// Renders particles as shaded, oriented disks ("splats").
///
/// * `positions`: N disk centres, world units.
/// * `normals`: N disk normals (any length; zero means facing the viewer).
/// * `colors`: N sRGB colours (see [`crate::depth_colors`] and friends).
/// * `radius`: N disk radii, world units (psi's particles: σ_i, half the spacing); multiplied
///   by `params.splat_scale`.
///
/// The orthographic camera looks from `params.view` and fits the positions' bounding box (or
/// `params.bounds`) into the image less the margin and the legend strip. Each disk is drawn
/// as the anti-aliased ellipse it projects to, back to front by the depth of its centre
/// (painter's algorithm, ties by index), shaded by a fixed light from the upper left front
/// (Lambert); disks facing away are darkened or culled (`params.backfaces`). With
/// [`SplatStyle::Dots`] a smooth neutral surface is drawn first (the disks blended in a
/// depth buffer, shading averaged among the nearest, at twice the resolution) and only the
/// visible particles get dots, painted back to front. Splats with a non-finite
/// position or normal, or a radius that is not finite and positive, are skipped.
///
/// Returns the `params.size` × `params.size` image; the output is a function of the input
/// alone (same input, same pixels).
///
/// # Errors
///
/// [`RenderError::LengthMismatch`] when an array's length differs from `positions.len()`,
/// [`RenderError::InvalidSize`] for a size of 0 or above 16384.
///
/// ```
/// use glam::DVec3;
/// use psi_render::{render_splats, RenderParams};
/// let p = [DVec3::ZERO, DVec3::new(1.0, 0.0, 0.0)];
/// let image = render_splats(&p, &[DVec3::Z; 2], &[[200, 0, 0]; 2], &[0.5; 2], &RenderParams::standard())
///     .unwrap();
/// assert_eq!(image.width(), 800);
/// ```
pub fn render_splats(
    positions: &[DVec3],
    normals: &[DVec3],
    colors: &[[u8; 3]],
    radius: &[f64],
    params: &RenderParams,
) -> Result<Pixmap, RenderError> {
    let n = positions.len();
    for (what, got) in [
        ("normals", normals.len()),
        ("colors", colors.len()),
        ("radius", radius.len()),
    ] {
        if got != n {
            return Err(RenderError::LengthMismatch {
                what,
                expected: n,
                got,
            });
        }
    }
    let (mut pixmap, area) = canvas(params, 1)?;
    let usable = |i: usize| {
        positions[i].is_finite()
            && normals[i].is_finite()
            && radius[i].is_finite()
            && radius[i] > 0.0
    };
    let frame: Vec<DVec3> = match params.bounds {
        Some([lo, hi]) => corners(lo, hi).to_vec(),
        None => (0..n)
            .filter(|&i| usable(i))
            .map(|i| positions[i])
            .collect(),
    };
    let camera = Camera::fit(params.view, frame, area, params.margin);
    let scale = camera.pixels_per_unit();
    let cull = params.backfaces == Backfaces::Cull;
    let splat_scale = if params.splat_scale.is_finite() && params.splat_scale > 0.0 {
        params.splat_scale
    } else {
        1.0
    };
    let mut splats: Vec<Splat> = (0..n)
        .filter(|&i| usable(i))
        .filter_map(|i| {
            let normal = camera
                .direction(normals[i])
                .try_normalize()
                .unwrap_or(DVec3::Z);
            let light = brightness(normal, cull)?;
            let p = camera.project(positions[i]);
            Some(Splat {
                center: DVec2::new(p.x, p.y),
                depth: p.z,
                normal,
                radius: radius[i] * splat_scale,
                light,
                index: i,
            })
        })
        .collect();
    splats.sort_by(|a, b| a.depth.total_cmp(&b.depth).then(a.index.cmp(&b.index)));

    match params.style {
        SplatStyle::Disks => {
            for s in &splats {
                let e = s.ellipse(s.radius, scale);
                fill_ellipse(&mut pixmap, s.center, e, shade(colors[s.index], s.light));
            }
        }
        SplatStyle::Dots { dot, surface } => {
            let visible = draw_surface(&mut pixmap, &splats, scale, surface);
            let dot = if dot.is_finite() && dot > 0.0 {
                dot
            } else {
                0.5
            };
            for (s, _) in splats.iter().zip(&visible).filter(|(_, v)| **v) {
                let e = s.ellipse(s.radius / splat_scale * dot, scale);
                // Dots keep their colour (as in the legend); the surface carries the shading.
                let k = back_factor(s.normal.z);
                fill_ellipse(&mut pixmap, s.center, e, shade(colors[s.index], k));
            }
        }
    }
    finish(&mut pixmap, params);
    Ok(pixmap)
}

/// The eight corners of a box.
pub(crate) fn corners(lo: DVec3, hi: DVec3) -> [DVec3; 8] {
    std::array::from_fn(|k| {
        DVec3::new(
            if k & 1 == 0 { lo.x } else { hi.x },
            if k & 2 == 0 { lo.y } else { hi.y },
            if k & 4 == 0 { lo.z } else { hi.z },
        )
    })
}

/// Fills `ellipse` centred at `center` (pixels).
fn fill_ellipse(pixmap: &mut Pixmap, center: DVec2, ellipse: ScreenEllipse, color: Color) {
    let ScreenEllipse {
        minor_axis: dir,
        major,
        minor,
    } = ellipse;
    let (a, b) = (major as f32, minor as f32);
    let Some(rect) = Rect::from_ltrb(-b, -a, b, a) else {
        return;
    };
    let Some(path) = PathBuilder::from_oval(rect) else {
        return;
    };
    let (dx, dy) = (dir.x as f32, dir.y as f32);
    let transform = Transform::from_row(dx, dy, -dy, dx, center.x as f32, center.y as f32);
    let mut paint = Paint::default();
    paint.set_color(color);
    paint.anti_alias = true;
    pixmap.fill_path(&path, &paint, tiny_skia::FillRule::Winding, transform, None);
}
