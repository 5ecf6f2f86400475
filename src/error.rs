//! Errors of the facade's file operations: each names the file and says the layer's reason
//! (in its message, not again as a source, so a chain of contexts prints each cause once).

use std::path::PathBuf;

use thiserror::Error;

/// A file-level failure.
#[derive(Debug, Error)]
pub enum PsiError {
    /// The file could not be opened or read.
    ///
    /// ```
    /// let err = psi::load_points(std::path::Path::new("no/such/file.ply"), &psi::ReadOptions::paper()).unwrap_err();
    /// assert!(err.to_string().contains("no/such/file.ply"));
    /// ```
    #[error("{path}: {reason}")]
    Open {
        /// The file.
        path: PathBuf,
        /// The operating system's reason.
        reason: std::io::Error,
    },
    /// The file's contents are malformed.
    ///
    /// ```
    /// let dir = std::env::temp_dir().join(format!("psi-doc-{}", std::process::id()));
    /// std::fs::create_dir_all(&dir).unwrap();
    /// let path = dir.join("empty.ply");
    /// std::fs::write(&path, b"").unwrap();
    /// let err = psi::load_points(&path, &psi::ReadOptions::paper()).unwrap_err();
    /// assert!(matches!(err, psi::PsiError::Read { .. }));
    /// ```
    #[error("{path}: {reason}")]
    Read {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        reason: psi_io::ReadError,
    },
    /// A picture could not be made from these arguments (its size, or mismatched columns).
    ///
    /// ```
    /// let particles = psi::Particles::default();
    /// let params = psi::render::RenderParams { size: 0, ..psi::render::RenderParams::particles() };
    /// let err = psi::render_particles_png(std::path::Path::new("x.png"), &particles, &params).unwrap_err();
    /// assert!(matches!(err, psi::PsiError::Render { .. }));
    /// ```
    #[error("{path}: cannot render: {reason}")]
    Render {
        /// The output file.
        path: PathBuf,
        /// The reason.
        reason: psi_render::RenderError,
    },
    /// Writing the output failed; the previous file at `path`, if any, is untouched.
    ///
    /// ```
    /// let err = psi::write_atomically(std::path::Path::new("/no/such/dir/out.ply"), |_| Ok(())).unwrap_err();
    /// assert!(matches!(err, psi::PsiError::Write { .. }));
    /// ```
    #[error("{path}: cannot write: {reason}")]
    Write {
        /// The output file.
        path: PathBuf,
        /// The reason.
        reason: std::io::Error,
    },
    /// A run out of core could not be done as asked (the input lacks what it needs, the
    /// memory budget is too small, or its scratch files failed); the message says which.
    ///
    /// ```
    /// let err = psi::PsiError::OutOfCore { path: "big.las".into(), reason: "has no normals".into() };
    /// assert_eq!(err.to_string(), "big.las: has no normals");
    /// ```
    #[error("{path}: {reason}")]
    OutOfCore {
        /// The input file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
}
