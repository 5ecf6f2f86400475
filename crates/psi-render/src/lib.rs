//! # psi-render
//!
//! Pictures of psi's particles and meshes, drawn in software with
//! [tiny-skia](https://docs.rs/tiny-skia): no GPU, no window, no file IO. Every function returns
//! a [`Pixmap`]; `pixmap.encode_png()` gives PNG bytes, and the caller writes them (the `psi`
//! facade writes through a temporary file).
//!
//! * [`render_splats`]: each particle an oriented disk (its normal, its radius σ), seen as an
//!   ellipse, painted back to front, Lambert-shaded from a fixed light; or, with
//!   [`SplatStyle::Dots`], coloured dots on a neutral surface so the sampling density shows.
//! * [`render_mesh`]: flat-shaded triangles in a light grey, painted back to front.
//! * [`RenderParams`]: size, [`View`] (front, side, top, isometric; orthographic), background,
//!   margin, [`SplatStyle`], [`Backfaces`], a fixed framing box and an optional [`Legend`].
//! * Colour maps: [`depth_colors`] (shallow green to deep red, as in the paper's Fig. 5),
//!   [`sigma_colors`] (a sequential ramp), [`normal_colors`], and [`scalar_colors`] for any
//!   [`Ramp`] and range; [`Coloring`] chooses one (depth, σ or normal) with its legend.
//! * [`Legend`]: a colour bar with tick labels drawn in a built-in 5 × 7 bitmap font (capital
//!   letters, digits, σ, `. , : - + = / ( ) %`; lower case is drawn as capitals).
//! * [`side_by_side`] and [`append_legend`] compose panels for figures.
//!
//! Coordinates: world units in, pixels out (x right, y down), square images of
//! `params.size` pixels. The output is a function of the input alone.
//!
//! ```
//! use glam::DVec3;
//! use psi_render::{depth_colors, render_splats, Legend, RenderParams, View};
//!
//! // 2000 particles on a unit sphere, "deeper" towards +y.
//! let n = 2000;
//! let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
//! let positions: Vec<DVec3> = (0..n)
//!     .map(|i| {
//!         let y = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
//!         let r = (1.0 - y * y).sqrt();
//!         let phi = golden * i as f64;
//!         DVec3::new(r * phi.cos(), y, r * phi.sin())
//!     })
//!     .collect();
//! let depth: Vec<f64> = positions.iter().map(|p| (6.0 + 2.0 * p.y).round()).collect();
//! let radius = vec![0.05; n]; // world units
//! let params = RenderParams {
//!     size: 300,
//!     view: View::Iso,
//!     legend: Some(Legend::depth(&depth)),
//!     ..RenderParams::standard()
//! };
//! let image = render_splats(&positions, &positions, &depth_colors(&depth), &radius, &params).unwrap();
//! assert_eq!((image.width(), image.height()), (300, 300));
//! let png = image.encode_png().unwrap();
//! assert_eq!(&png[1..4], b"PNG");
//! ```

mod camera;
mod canvas;
mod coloring;
mod colormap;
mod error;
mod font;
mod legend;
mod mesh;
mod panel;
mod params;
mod radius;
mod shading;
mod splat;
mod splats;
mod surface;

pub use camera::Camera;
pub use coloring::Coloring;
pub use colormap::{MISSING, Ramp, depth_colors, normal_colors, scalar_colors, sigma_colors};
pub use error::RenderError;
pub use legend::{Legend, append_legend};
pub use mesh::render_mesh;
pub use panel::side_by_side;
pub use params::{Backfaces, RenderParams, SplatStyle, View};
pub use radius::{splat_radii, uniform_radius};
pub use splats::render_splats;
/// The image type every function returns (re-exported so callers need no tiny-skia
/// dependency of their own): `width()`, `height()`, `pixel(x, y)`, `encode_png()`.
pub use tiny_skia::Pixmap;
