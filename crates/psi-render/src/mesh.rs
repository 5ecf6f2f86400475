//! The mesh renderer: flat-shaded triangles painted back to front, supersampled.

use glam::DVec3;
use tiny_skia::{FillRule, FilterQuality, Paint, PathBuilder, Pixmap, PixmapPaint, Transform};

use crate::camera::Camera;
use crate::canvas::{background, canvas, finish};
use crate::shading::{brightness, shade};
use crate::splats::corners;
use crate::{Backfaces, RenderError, RenderParams};

/// The material colour: a light grey.
const MATERIAL: [u8; 3] = [214, 212, 206];
/// Triangles are drawn without anti-aliasing (no seams between neighbours) at this many
/// times the resolution, then averaged down.
const SUPERSAMPLE: u32 = 2;

/// Renders a triangle mesh, flat-shaded in a light grey.
///
/// * `vertices`: V positions, world units.
/// * `faces`: F triangles as indices into `vertices`; the normal is
///   (b − a) × (c − a), so counter-clockwise triangles seen from outside face outwards.
///
/// The camera is fitted as in [`crate::render_splats`] (to the vertices used by a face, or
/// `params.bounds`). Triangles are sorted by the depth of their centroid and painted back to
/// front (painter's algorithm, ties by index), each in one Lambert shade of the material from
/// the fixed light; triangles facing away are darkened or culled (`params.backfaces`).
/// Degenerate or non-finite triangles are skipped. The image is drawn at twice the
/// resolution without anti-aliasing and averaged down, so shared edges leave no seams.
/// `params.style` and `params.splat_scale` do not apply.
///
/// # Errors
///
/// [`RenderError::IndexOutOfRange`] when a face refers to a missing vertex,
/// [`RenderError::InvalidSize`] for a size of 0 or above 16384.
///
/// ```
/// use glam::DVec3;
/// use psi_render::{render_mesh, RenderParams};
/// let v = [DVec3::ZERO, DVec3::X, DVec3::Y];
/// let image = render_mesh(&v, &[[0, 1, 2]], &RenderParams { size: 64, ..RenderParams::standard() })
///     .unwrap();
/// assert_eq!(image.height(), 64);
/// ```
pub fn render_mesh(
    vertices: &[DVec3],
    faces: &[[u32; 3]],
    params: &RenderParams,
) -> Result<Pixmap, RenderError> {
    for (face, f) in faces.iter().enumerate() {
        if let Some(&vertex) = f.iter().find(|&&i| i as usize >= vertices.len()) {
            return Err(RenderError::IndexOutOfRange {
                face,
                vertex,
                vertices: vertices.len(),
            });
        }
    }
    let (mut big, area) = canvas(params, SUPERSAMPLE)?;
    let triangle = |f: &[u32; 3]| f.map(|i| vertices[i as usize]);
    let frame: Vec<DVec3> = match params.bounds {
        Some([lo, hi]) => corners(lo, hi).to_vec(),
        None => faces.iter().flat_map(triangle).collect(),
    };
    let camera = Camera::fit(params.view, frame, area, params.margin);
    let cull = params.backfaces == Backfaces::Cull;

    let mut order: Vec<(f64, usize, f64)> = faces
        .iter()
        .enumerate()
        .filter_map(|(k, f)| {
            let [a, b, c] = triangle(f);
            let normal = (b - a).cross(c - a).try_normalize()?;
            let light = brightness(camera.direction(normal), cull)?;
            let depth = camera.project((a + b + c) / 3.0).z;
            depth.is_finite().then_some((depth, k, light))
        })
        .collect();
    order.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));

    let mut paint = Paint {
        anti_alias: false,
        ..Paint::default()
    };
    for &(_, k, light) in &order {
        let [a, b, c] = triangle(&faces[k]).map(|p| camera.project(p));
        let mut path = PathBuilder::new();
        path.move_to(a.x as f32, a.y as f32);
        path.line_to(b.x as f32, b.y as f32);
        path.line_to(c.x as f32, c.y as f32);
        path.close();
        let Some(path) = path.finish() else {
            continue;
        };
        paint.set_color(shade(MATERIAL, light));
        big.fill_path(
            &path,
            &paint,
            FillRule::Winding,
            Transform::identity(),
            None,
        );
    }

    let (mut pixmap, _) = canvas(params, 1)?;
    pixmap.fill(background(params.background));
    let scale = 1.0 / SUPERSAMPLE as f32;
    pixmap.draw_pixmap(
        0,
        0,
        big.as_ref(),
        &PixmapPaint {
            quality: FilterQuality::Bilinear,
            ..PixmapPaint::default()
        },
        Transform::from_scale(scale, scale),
        None,
    );
    finish(&mut pixmap, params);
    Ok(pixmap)
}
