//! Why a picture could not be made (invalid arguments; rendering itself cannot fail).

use thiserror::Error;

/// An invalid argument to a render function.
#[derive(Clone, Debug, PartialEq, Eq, Error)]
pub enum RenderError {
    /// The image would be empty or too large for a pixmap.
    ///
    /// ```
    /// use psi_render::{render_splats, RenderError, RenderParams};
    /// let params = RenderParams { size: 0, ..RenderParams::standard() };
    /// let err = render_splats(&[], &[], &[], &[], &params).unwrap_err();
    /// assert!(matches!(err, RenderError::InvalidSize { .. }));
    /// ```
    #[error("cannot make a {width} x {height} pixel image")]
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
    #[error("{what} has {got} entries, but there are {expected} positions")]
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
    #[error("triangle {face} refers to vertex {vertex}, but there are {vertices} vertices")]
    IndexOutOfRange {
        /// 0-based triangle index.
        face: usize,
        /// The offending vertex index.
        vertex: u32,
        /// Number of vertices.
        vertices: usize,
    },
    /// [`crate::side_by_side`] was given no panels.
    #[error("no panels to put side by side")]
    NoPanels,
}
