//! # psi-preprocess
//!
//! What happens to a point set between reading it and fitting the MPU: the repairs a real scan
//! needs. Each step is a function on borrowed slices, usable on its own.
//!
//! * [`check_normal_consistency`], [`orient_normals`]: flipped normals detected and made
//!   consistent by propagation over a neighbour graph (Hoppe et al. 1992).
//!
//! ```
//! use psi_preprocess::{check_normal_consistency, orient_normals};
//! use psi_shapes::AnalyticShape;
//!
//! let truth = AnalyticShape::Sphere { radius: 1.0 }.sample(2000, 3);
//! let mut points = truth.clone();
//! for p in points.iter_mut().step_by(7) {
//!     p.n = -p.n; // every 7th normal flipped
//! }
//! assert!(check_normal_consistency(&points, usize::MAX).opposed > 0);
//! orient_normals(&mut points);
//! assert_eq!(points, truth);
//! ```

mod orient_normals;

pub use orient_normals::{NormalConsistency, check_normal_consistency, orient_normals};
