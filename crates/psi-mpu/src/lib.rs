//! # psi-mpu
//!
//! Multi-level partition of unity implicits (Ohtake, Belyaev, Alexa, Turk, Seidel 2003) on the
//! psi octree: an adaptive, error-driven octree whose leaves each hold a local quadric fit
//! (general 3D quadric, bivariate quadratic, or sharp edge/corner pieces), blended by quadratic
//! B-spline weights into one implicit f with f > 0 outside, f < 0 inside, |∇f| ≈ 1 near the
//! surface. Formulas, constants and their sources: `../shared/reference/algorithms.md` §1 and
//! `docs/ARCHITECTURE.md`.
//!
//! * [`Mpu::build`] from oriented points and [`MpuParams::paper`];
//! * [`Mpu::value`], [`Mpu::gradient`], [`Mpu::value_and_gradient`] (world units);
//! * the octree, its leaves with depth, the surface-containing leaves and their points;
//! * a [`BuildReport`] (cells, leaves per depth, fit kinds, fallbacks, seconds);
//! * [`polygonize`]: the zero set as a triangle mesh near the data.
//!
//! ```
//! use glam::DVec3;
//! use psi_mpu::{Mpu, MpuParams};
//! use psi_shapes::AnalyticShape;
//!
//! let points = AnalyticShape::Sphere { radius: 1.0 }.sample(3000, 1);
//! let mpu = Mpu::build(&points, &MpuParams::paper()).unwrap();
//! let (f, grad) = mpu.value_and_gradient(DVec3::new(1.02, 0.0, 0.0));
//! assert!((f - 0.02).abs() < 1e-3);         // ≈ signed distance near the surface
//! assert!(grad.normalize().x > 0.99);       // along the outward normal
//! assert!(mpu.value(DVec3::ZERO) < 0.0);    // inside
//! ```

mod bspline_weight;
mod buffers;
mod build;
mod carry_footprint;
mod cell_table;
mod coarse_index;
mod compact;
mod crease_rescue;
mod data_coverage;
mod data_footprint;
mod error;
mod eval_nodes;
mod evaluate;
mod fit_bivariate;
mod fit_cell;
mod fit_fetched;
mod fit_general_quadric;
mod fit_radius;
mod fit_reach;
mod fit_region;
mod fit_sharp;
mod fit_store;
mod fit_top;
mod frame;
mod input_local;
mod least_squares;
mod local_function;
mod mpu;
mod params;
mod point_footprint;
mod polygonize;
mod prefit_marked;
mod quadric;
mod ranked_error;
mod region_points;
mod report;
mod select_fit;
mod surface_leaf;
mod surrounded;
mod trial_balls;

pub use buffers::MpuBuffers;
pub use build::{BuildOptions, Reuse};
pub use carry_footprint::StaleFootprint;
pub use cell_table::{CellAddress, CellDecision, CellTable};
pub use data_coverage::data_coverage;
pub use data_footprint::{DataAnchor, FootprintTest};
pub use error::MpuError;
pub use evaluate::{BACKGROUND_WEIGHT, LeafEvaluation};
pub use fit_fetched::{BallSource, FetchBall, KthDistance};
pub use fit_region::{FarBalls, Region, RegionFit, RegionPoints, fit_region};
pub use fit_top::{fit_top, fit_top_region, is_coarse_point};
pub use frame::MpuFrame;
pub use input_local::FOOTPRINT_SPARSE_ABOVE;
pub use local_function::{FitKind, LocalFunction};
pub use mpu::Mpu;
pub use params::MpuParams;
pub use point_footprint::{BAND_EDGE_OFFSET, DEEP, PointFootprint};
pub use polygonize::{PolygonizeParams, TriangleSoup, polygonize, polygonize_with};
pub use quadric::Quadric;
pub use report::{BuildPhases, BuildReport, FitCounts};
