//! `psi.render` and `psi.render_mesh`: pictures of particles and meshes as `psi render` draws
//! them, written to a PNG file or returned as an (H, W, 4) uint8 RGBA array.

use std::path::PathBuf;

use psi::DVec3;
use psi::render::{Coloring, Pixmap, RenderParams, SplatStyle, View, render_splats};
use pyo3::prelude::*;

use crate::arrays::{image_array, vectors};
use crate::errors::{bounded, detached, psi_error, value_error};
use crate::sample::Particles;

fn view(name: &str) -> PyResult<View> {
    Ok(match name {
        "front" => View::Front,
        "side" => View::Side,
        "top" => View::Top,
        "iso" => View::Iso,
        _ => {
            return Err(value_error(format!(
                "view: {name:?} is not one of \"front\", \"side\", \"top\", \"iso\""
            )));
        }
    })
}

/// `psi render`'s parameters: `RenderParams::particles()` with the size, view, style and splat
/// scale asked for.
fn params(size: i128, view_name: &str, style: &str, splat_scale: f64) -> PyResult<RenderParams> {
    let size: u32 = bounded("size", size, 16, 8192)?;
    if !(splat_scale.is_finite() && splat_scale > 0.0) {
        return Err(value_error("splat_scale must be a positive number"));
    }
    let base = RenderParams::particles();
    let style = match style {
        "dots" => base.style,
        "disks" => SplatStyle::Disks,
        _ => {
            return Err(value_error(format!(
                "style: {style:?} is not one of \"dots\", \"disks\""
            )));
        }
    };
    Ok(RenderParams {
        size,
        view: view(view_name)?,
        splat_scale: base.splat_scale * splat_scale,
        style,
        ..base
    })
}

/// The picture to `path` (then `None`) or as an (H, W, 4) uint8 array of straight RGBA.
fn deliver<'py>(
    py: Python<'py>,
    image: Pixmap,
    path: Option<PathBuf>,
) -> PyResult<Bound<'py, PyAny>> {
    if let Some(path) = path {
        detached(py, || psi::save_png(&path, &image))?.map_err(|e| psi_error(py, e, None))?;
        return Ok(py.None().into_bound(py));
    }
    let (w, h) = (image.width() as usize, image.height() as usize);
    let rgba: Vec<u8> = image
        .pixels()
        .iter()
        .flat_map(|p| {
            let c = p.demultiply();
            [c.red(), c.green(), c.blue(), c.alpha()]
        })
        .collect();
    Ok(image_array(py, h, w, rgba).into_any())
}

/// Draws particles as `psi render` does with the same options: each a dot on a grey surface
/// made of their disks (`style="dots"`) or a closed surface of coloured disks (`"disks"`),
/// coloured by octree `depth` (shallow green to deep red, the paper's Fig. 5), `"sigma"` or
/// `"normal"`; `view` is `"front"` (+z), `"side"` (+x), `"top"` (+y) or `"iso"` (1, 1, 1);
/// `size` in pixels (16 to 8192), `splat_scale` multiplies the radii σ; `legend` adds the
/// colour bar. Writes a PNG to `path` (returns `None`; `OSError` when it cannot) or, without
/// `path`, returns the (size, size, 4) uint8 RGBA image.
#[pyfunction]
#[pyo3(signature = (particles, path=None, *, size=1024, view="front", color="depth",
    style="dots", splat_scale=1.0, legend=true))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn render<'py>(
    py: Python<'py>,
    particles: &Particles,
    path: Option<PathBuf>,
    size: i128,
    view: &str,
    color: &str,
    style: &str,
    splat_scale: f64,
    legend: bool,
) -> PyResult<Bound<'py, PyAny>> {
    let mut params = params(size, view, style, splat_scale)?;
    let p = &particles.particles;
    let coloring = Coloring::from_name(color).ok_or_else(|| {
        value_error(format!(
            "color: {color:?} is not one of \"depth\", \"sigma\", \"normal\", \"input\""
        ))
    })?;
    let depth: Vec<f64> = p.depth.iter().map(|&d| f64::from(d)).collect();
    let depth = particles.has_depth.then_some(&depth[..]);
    let sigma = particles.has_sigma.then_some(&p.sigma[..]);
    let input = particles.attributes.colors.as_deref();
    let (colors, legend_bar) = coloring
        .colors(depth, sigma, &p.normals, input)
        .ok_or_else(|| {
            value_error(format!(
                "color: these particles have no {} to colour by; try color=\"normal\"",
                coloring.name()
            ))
        })?;
    params.legend = legend_bar.filter(|_| legend);
    let image = detached(py, || {
        render_splats(&p.positions, &p.normals, &colors, &p.sigma, &params)
    })?
    .map_err(|e| value_error(e.to_string()))?;
    deliver(py, image, path)
}

/// Draws a triangle mesh (`vertices` (V, 3), `faces` (F, 3) integer indices, as `Mpu.mesh`
/// returns them) flat-shaded, as `psi render` does for a mesh file; `view`, `size` and `path`
/// as for `render`.
#[pyfunction]
#[pyo3(signature = (vertices, faces, path=None, *, size=1024, view="front"))]
pub(crate) fn render_mesh<'py>(
    py: Python<'py>,
    vertices: &Bound<'py, PyAny>,
    faces: &Bound<'py, PyAny>,
    path: Option<PathBuf>,
    size: i128,
    view: &str,
) -> PyResult<Bound<'py, PyAny>> {
    let params = params(size, view, "dots", 1.0)?;
    let vertices: Vec<DVec3> = vectors(vertices, "vertices")?;
    if let Some(i) = vertices.iter().position(|v| !v.is_finite()) {
        return Err(value_error(format!(
            "vertices: vertex {i} has a NaN or infinite position"
        )));
    }
    let corners = vectors(faces, "faces")?;
    let mut triangles = Vec::with_capacity(corners.len());
    for (face, c) in corners.iter().enumerate() {
        let ok = |i: f64| i.fract() == 0.0 && (0.0..u32::MAX as f64).contains(&i);
        if !(ok(c.x) && ok(c.y) && ok(c.z)) {
            return Err(value_error(format!(
                "faces: face {face} has an index that is not a vertex number"
            )));
        }
        triangles.push([c.x as u32, c.y as u32, c.z as u32]);
    }
    let image = detached(py, || {
        psi::render::render_mesh(&vertices, &triangles, &params)
    })?
    .map_err(|e| value_error(e.to_string()))?;
    deliver(py, image, path)
}
