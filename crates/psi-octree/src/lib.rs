//! # psi-octree
//!
//! The lowest layer of psi: the adaptive octree that MPU fitting, particle seeding, neighbour
//! search and local regeneration share, plus the geometric vocabulary ([`OrientedPoint`],
//! [`Aabb`]), the workspace's one tolerance policy ([`assert_near!`]) and analytic test shapes
//! ([`AnalyticShape`], [`builtin_model`]).
//!
//! * [`Octree::build_with`] subdivides level by level, in parallel, as a caller's decision
//!   function says (psi-mpu plugs its fit-error test in), up to a maximum depth.
//! * Every input point lies in exactly one leaf ([`Octree::leaf_of_point`]).
//! * Queries: [`Octree::leaf_containing`], [`Octree::for_each_support_cell`] (cells whose support
//!   ball, radius α × cell diagonal, contains x), [`Octree::points_within`], and a kiddo kd-tree
//!   twin [`PointIndex`].
//!
//! ```
//! use glam::DVec3;
//! use psi_octree::{AnalyticShape, Octree, OctreeParams};
//!
//! let points = AnalyticShape::Sphere { radius: 1.0 }.sample(2000, 7);
//! let positions: Vec<DVec3> = points.iter().map(|p| p.p).collect();
//! // Split every cell holding more than 32 points.
//! let tree = Octree::build(&positions, &OctreeParams::mpu(), |v| v.points.len() > 32).unwrap();
//! let leaf = tree.leaf_containing(positions[0]).unwrap();
//! assert_eq!(leaf, tree.leaf_of_point(0));
//! assert!(tree.points_in(leaf).len() <= 32 || tree.cell(leaf).depth == 12);
//! ```

mod analytic_shapes;
mod builtin_model;
mod cell_at;
mod error;
mod geometry;
mod leaf_containing;
mod octree;
mod orient_normals;
mod point_index;
mod points_within;
mod support_cells;
pub mod tolerance;

pub use analytic_shapes::AnalyticShape;
pub use builtin_model::{BUILTIN_MODEL_POINTS, BUILTIN_MODEL_SEED, builtin_model, sample_builtin};
pub use error::OctreeError;
pub use geometry::{Aabb, OrientedPoint};
pub use octree::{
    Cell, CellView, DEPTH_LIMIT, KnownPartitions, NO_CELL, Octree, OctreeBuffers, OctreeParams,
    root_cube,
};
pub use orient_normals::{NormalConsistency, check_normal_consistency, orient_normals};
pub use point_index::PointIndex;
