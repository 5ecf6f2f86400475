//! Pictures: the `psi-render` crate re-exported (`psi::render::render_splats`, ...) and wired to
//! psi's particles and to files. No rendering happens here.

use std::path::Path;

pub use psi_render::*;

use crate::PsiError;

/// Writes `image` as a PNG file through a temporary file renamed into place.
///
/// # Errors
///
/// [`PsiError::Write`] when the path does not end in `.png` (a picture must not be written
/// as PNG bytes under another format's name) or the file cannot be written (the previous file
/// is untouched).
pub fn save_png(path: &Path, image: &Pixmap) -> Result<(), PsiError> {
    let png = path
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("png"));
    if !png {
        return Err(PsiError::Write {
            path: path.to_path_buf(),
            reason: std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                "psi writes pictures as PNG only: give a path ending in .png",
            ),
        });
    }
    let png = image.encode_png().map_err(|e| PsiError::Write {
        path: path.to_path_buf(),
        reason: std::io::Error::other(e),
    })?;
    crate::write_atomically(path, |w| w.write_all(&png))
}

/// The picture of sampled particles as in the paper's Fig. 5: each particle a disk of radius
/// σ_i × `params.splat_scale` coloured by the octree depth of its leaf (shallow green to deep
/// red), with the depth legend (replacing `params.legend`).
///
/// # Errors
///
/// [`RenderError`] for an invalid `params.size`.
pub fn particles_image(
    particles: &psi_particles::Particles,
    params: &RenderParams,
) -> Result<Pixmap, RenderError> {
    let depth: Vec<f64> = particles.depth.iter().map(|&d| f64::from(d)).collect();
    let (colors, legend) = Coloring::Depth
        .colors(Some(&depth), None, &particles.normals, None)
        .expect("depth given");
    let params = RenderParams {
        legend,
        ..params.clone()
    };
    render_splats(
        &particles.positions,
        &particles.normals,
        &colors,
        &particles.sigma,
        &params,
    )
}

/// Writes [`particles_image`] of `particles` as a PNG file at `path` (through a temporary
/// file renamed into place).
///
/// ```
/// use psi::{Mpu, MpuParams, ParticleParams};
/// let points = psi::AnalyticShape::Sphere { radius: 1.0 }.sample(3000, 1);
/// let mpu = Mpu::build(&points, &MpuParams::paper()).unwrap();
/// let run = psi::sample(&mpu, &ParticleParams { iterations: 2, ..ParticleParams::paper() });
/// let path = std::env::temp_dir().join(format!("psi-doc-render-{}.png", std::process::id()));
/// let params = psi::render::RenderParams { size: 200, ..psi::render::RenderParams::particles() };
/// psi::render_particles_png(&path, &run.particles, &params).unwrap();
/// assert!(std::fs::read(&path).unwrap().starts_with(b"\x89PNG"));
/// ```
///
/// # Errors
///
/// [`PsiError::Render`] when `params.size` is invalid (0 or above 16384); [`PsiError::Write`]
/// when the file cannot be written.
pub fn render_particles_png(
    path: &Path,
    particles: &psi_particles::Particles,
    params: &RenderParams,
) -> Result<(), PsiError> {
    let image = particles_image(particles, params).map_err(|reason| PsiError::Render {
        path: path.to_path_buf(),
        reason,
    })?;
    save_png(path, &image)
}
