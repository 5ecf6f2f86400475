//! # psi-shapes
//!
//! Shapes with known answers, and the one tolerance policy for comparing against them. The other
//! crates use it in their tests; the facade re-exports the built-in model, every command's
//! default input.
//!
//! * [`AnalyticShape`]: sphere, ellipsoid, torus and box, with exact oriented samples and exact
//!   (or first-order) signed distances — the tests' independent oracle;
//! * [`builtin_model`], [`sample_builtin`]: the built-in procedural model (a bumpy,
//!   rounded-square torus with a thin neck), deterministic, no file involved;
//! * [`gaussian`], [`gaussian_vector`]: seeded Gaussian noise for making samples noisy;
//! * [`tolerance`]: named tolerances and [`assert_near!`], [`assert_rel_near!`].
//!
//! Every random choice comes from a seeded `rand_pcg` generator: the same seed gives the same
//! points on every machine.
//!
//! ```
//! use psi_shapes::{AnalyticShape, assert_near};
//!
//! let sphere = AnalyticShape::Sphere { radius: 2.0 };
//! let points = sphere.sample(100, 7);
//! assert_eq!(points, sphere.sample(100, 7)); // seeded
//! for p in &points {
//!     assert_near!(sphere.signed_distance(p.p), 0.0, 1e-12);
//!     assert_near!(p.n.length(), 1.0, 1e-12);
//! }
//! ```

mod analytic_shapes;
mod builtin_model;
mod gaussian_noise;
pub mod tolerance;

pub use analytic_shapes::AnalyticShape;
pub use builtin_model::{
    BUILTIN_MODEL_POINTS, BUILTIN_MODEL_SEED, builtin_model, sample_builtin, sample_builtin_with,
};
pub use gaussian_noise::{gaussian, gaussian_vector};
