//! What a picture looks like: size, viewpoint, background, splat style, framing, legend.

use glam::DVec3;

use crate::Legend;

/// The direction the model is seen from. The camera is orthographic; the model's +y is up in
/// every view but [`View::Top`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum View {
    /// From +z looking towards −z: +x to the right, +y up.
    #[default]
    Front,
    /// From +x looking towards −x: −z to the right, +y up.
    Side,
    /// From +y looking down: +x to the right, −z up (the model's front at the bottom).
    Top,
    /// From the (1, 1, 1) direction (isometric), +y up.
    Iso,
}

impl View {
    /// The unit vector from the model towards the viewer, world frame.
    ///
    /// ```
    /// use psi_render::View;
    /// assert_eq!(View::Front.toward_viewer(), glam::DVec3::Z);
    /// ```
    pub fn toward_viewer(self) -> DVec3 {
        match self {
            View::Front => DVec3::Z,
            View::Side => DVec3::X,
            View::Top => DVec3::Y,
            View::Iso => DVec3::ONE.normalize(),
        }
    }

    /// The world direction that points up on screen (unit, orthogonal to
    /// [`View::toward_viewer`]).
    pub fn up(self) -> DVec3 {
        match self {
            View::Top => DVec3::NEG_Z,
            other => {
                let e = other.toward_viewer();
                (DVec3::Y - DVec3::Y.dot(e) * e).normalize()
            }
        }
    }
}

/// What happens to splats and triangles whose normal points away from the viewer.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Backfaces {
    /// Drawn, shaded as seen from behind and darkened (open surfaces show their inside).
    #[default]
    Darken,
    /// Not drawn.
    Cull,
}

/// How particles are drawn by [`crate::render_splats`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum SplatStyle {
    /// Each particle a shaded disk of its radius × [`RenderParams::splat_scale`] in its
    /// colour: with radii that cover the gaps between particles, a closed surface.
    #[default]
    Disks,
    /// The surface drawn first, from disks of radius × `splat_scale` in the neutral colour
    /// `surface`; then each *visible* particle as a shaded dot of radius × `dot` in its own
    /// colour. The dots show the sampling density.
    Dots {
        /// Dot radius as a fraction of the particle's radius (e.g. 0.5).
        dot: f64,
        /// The surface colour (sRGB).
        surface: [u8; 3],
    },
}

/// The parameters of a picture.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderParams {
    /// Width and height of the square image, pixels.
    pub size: u32,
    /// Where the model is seen from.
    pub view: View,
    /// Background colour, sRGB and alpha (255: opaque).
    pub background: [u8; 4],
    /// Free space around the model on each side, as a fraction of the drawing area's shorter
    /// side (the area is the image minus the legend strip).
    pub margin: f64,
    /// Multiplies every splat radius (1: the radii as given).
    pub splat_scale: f64,
    /// Disks, or dots on a neutral surface.
    pub style: SplatStyle,
    /// Splats and triangles facing away from the viewer.
    pub backfaces: Backfaces,
    /// The world box `[min, max]` the camera frames; `None`: the positions' (or vertices')
    /// bounding box. Give one box to several pictures to frame them identically.
    pub bounds: Option<[DVec3; 2]>,
    /// A colour bar with labels in a strip on the right of the image.
    pub legend: Option<Legend>,
}

impl RenderParams {
    /// 800 × 800 pixels, front view, white background, 5 % margin, disks of the given radii,
    /// back faces darkened, framed on the model, no legend.
    ///
    /// ```
    /// let p = psi_render::RenderParams::standard();
    /// assert_eq!((p.size, p.view), (800, psi_render::View::Front));
    /// ```
    pub fn standard() -> Self {
        Self {
            size: 800,
            view: View::Front,
            background: [255, 255, 255, 255],
            margin: 0.05,
            splat_scale: 1.0,
            style: SplatStyle::Disks,
            backfaces: Backfaces::Darken,
            bounds: None,
            legend: None,
        }
    }

    /// [`RenderParams::standard`] for psi's particles, whose radii are σ_i (about half the
    /// spacing): a light grey surface from disks of 1.6 σ_i, and on it each visible particle
    /// a dot of 0.55 σ_i, so the sampling density shows.
    ///
    /// ```
    /// let p = psi_render::RenderParams::particles();
    /// assert!(matches!(p.style, psi_render::SplatStyle::Dots { .. }));
    /// ```
    pub fn particles() -> Self {
        Self {
            splat_scale: 1.6,
            style: SplatStyle::Dots {
                dot: 0.55,
                surface: [208, 208, 204],
            },
            ..Self::standard()
        }
    }
}
