//! # psi-octree
//!
//! The lowest layer of psi: the adaptive octree that MPU fitting, particle seeding, neighbour
//! search and local regeneration share, its point queries, and the geometric vocabulary every
//! crate uses ([`OrientedPoint`], [`Aabb`]).
//!
//! * [`Octree::build_with`] subdivides level by level, in parallel, as a caller's decision
//!   function says (psi-mpu plugs its fit-error test in), up to a maximum depth.
//! * Every input point lies in exactly one leaf ([`Octree::leaf_of_point`]).
//! * Queries: [`Octree::leaf_containing`], [`Octree::for_each_support_cell`] (cells whose support
//!   ball, radius α × cell diagonal, contains x), [`Octree::points_within`], and a kiddo kd-tree
//!   twin [`PointIndex`] (updated after points move, and answering a ball query again from an
//!   earlier version's answer: [`BallAnswer`]).
//! * Exact k nearest neighbours of any point, or of every point in one sweep: [`MortonIndex`].
//!
//! ```
//! use glam::DVec3;
//! use psi_octree::{Octree, OctreeParams};
//!
//! // 2000 points on the unit sphere (a Fibonacci spiral).
//! let positions: Vec<DVec3> = (0..2000)
//!     .map(|i| {
//!         let z = 1.0 - (2 * i + 1) as f64 / 2000.0;
//!         let a = 2.399_963 * i as f64;
//!         let r = (1.0 - z * z).sqrt();
//!         DVec3::new(r * a.cos(), r * a.sin(), z)
//!     })
//!     .collect();
//! // Split every cell holding more than 32 points.
//! let tree = Octree::build(&positions, &OctreeParams::mpu(), |v| v.points.len() > 32).unwrap();
//! let leaf = tree.leaf_containing(positions[0]).unwrap();
//! assert_eq!(leaf, tree.leaf_of_point(0));
//! assert!(tree.points_in(leaf).len() <= 32 || tree.cell(leaf).depth == 12);
//! ```

mod all_nearest;
mod ball_answer;
mod cell;
mod cell_at;
mod error;
mod geometry;
mod id_map;
mod known_partitions;
mod leaf_containing;
mod monitor;
mod morton_index;
mod octree;
mod octree_buffers;
mod point_attributes;
mod point_index;
mod points_within;
mod root_cube;
mod support_cells;

pub use all_nearest::all_k_nearest;
pub use ball_answer::BallAnswer;
pub use cell::{Cell, NO_CELL};
pub use error::OctreeError;
pub use geometry::{Aabb, OrientedPoint};
pub use id_map::IdHasher;
pub use monitor::{Interrupted, Monitor, Observer, StopFlag};
pub use morton_index::{MortonIndex, morton_code};
pub use octree::{
    CellView, DEPTH_LIMIT, KnownPartitions, Octree, OctreeBuild, OctreeParams, Unplaced,
};
pub use octree_buffers::OctreeBuffers;
pub use point_attributes::PointAttributes;
pub use point_index::PointIndex;
pub use root_cube::{RootCube, root_cube};
