//! Why a picture could not be made (invalid arguments; rendering itself cannot fail).

use std::fmt;

/// An invalid argument to a render function.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum RenderError {
    /// The image would be empty or too large for a pixmap.
    ///
    /// ```
    /// use psi_render::{render_splats, RenderError, RenderParams};
    /// let params = RenderParams { size: 0, ..RenderParams::standard() };
    /// let err = render_splats(&[], &[], &[], &[], &params).unwrap_err();
    /// assert!(matches!(err, RenderError::InvalidSize { .. }));
    /// ```
    InvalidSize {
        /// Width asked for, pixels.
        width: u32,
        /// Height asked for, pixels.
        height: u32,
    },
    /// A per-splat array does not have one entry per position.
    ///
    /// ```
    /// use glam::DVec3;
    /// use psi_render::{render_splats, RenderError, RenderParams};
    /// let err = render_splats(&[DVec3::ZERO], &[DVec3::Z], &[], &[1.0], &RenderParams::standard())
    ///     .unwrap_err();
    /// assert_eq!(err, RenderError::LengthMismatch { what: "colors", expected: 1, got: 0 });
    /// ```
    LengthMismatch {
        /// Which array: `normals`, `colors` or `radius`.
        what: &'static str,
        /// Number of positions.
        expected: usize,
        /// Length of the offending array.
        got: usize,
    },
    /// A triangle refers to a vertex that does not exist.
    ///
    /// ```
    /// use glam::DVec3;
    /// use psi_render::{render_mesh, RenderError, RenderParams};
    /// let err = render_mesh(&[DVec3::ZERO; 3], &[[0, 1, 3]], &RenderParams::standard()).unwrap_err();
    /// assert_eq!(err, RenderError::IndexOutOfRange { face: 0, vertex: 3, vertices: 3 });
    /// ```
    IndexOutOfRange {
        /// 0-based triangle index.
        face: usize,
        /// The offending vertex index.
        vertex: u32,
        /// Number of vertices.
        vertices: usize,
    },
    /// [`crate::side_by_side`] was given no panels.
    NoPanels,
}

impl fmt::Display for RenderError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RenderError::InvalidSize { width, height } => {
                write!(f, "cannot make a {width} x {height} pixel image")
            }
            RenderError::LengthMismatch {
                what,
                expected,
                got,
            } => write!(
                f,
                "{what} has {got} entries, but there are {expected} positions"
            ),
            RenderError::IndexOutOfRange {
                face,
                vertex,
                vertices,
            } => write!(
                f,
                "triangle {face} refers to vertex {vertex}, but there are {vertices} vertices"
            ),
            RenderError::NoPanels => write!(f, "no panels to put side by side"),
        }
    }
}

impl std::error::Error for RenderError {}
