//! # psi-tiles
//!
//! Out of core (issue "Beyond one machine"): the octree's cells above a tile depth (and each
//! tile's first levels) are decided once, and every tile — a cell at the tile depth with its
//! subtree — from the points in its cube and a halo around it; a cell whose fit reads beyond
//! the halo fetches its whole ball. A cell's fit reads only the points within its fit radius,
//! in increasing index order, plus the frame, ε0 and the point count, so each tile's decisions
//! are bitwise those of the build over all points, and the MPU assembled from them
//! ([`psi_mpu::BuildOptions::known_cells`]) equals it. In memory: [`decide_tiled`],
//! [`build_tiled`]; on disk: [`TileWriter`] and [`TileStore`] (checksummed tile files, written
//! whole or in parts side by side: [`StorePlan`], [`StorePart`]),
//! [`decide_store`] (one decisions file per tile, so a run resumes; its tasks for a cluster
//! [`decide_store_top_upper`], [`decide_store_top_group`], [`decide_store_top_keys`] and
//! [`decide_store_tiles`]); particles:
//! [`sample_tiled`] (seeds exactly the whole sampling's, region by region; one relaxation of
//! them all, on the decisions and the points the memory allows; then the ceiling on spacing,
//! its passes reading the input tile by tile).
//!
//! ```
//! use psi_mpu::MpuParams;
//! use psi_octree::Monitor;
//! use psi_shapes::AnalyticShape;
//! use psi_tiles::{TileParams, decide_tiled};
//!
//! let points = AnalyticShape::Torus { major: 1.0, minor: 0.4 }.sample(5000, 3);
//! let d = decide_tiled(&points, &MpuParams::paper(), &TileParams::at_depth(2), &Monitor::silent()).unwrap();
//! assert!(d.report.count >= 8 && d.report.crossing_cells > 0);
//! ```

mod arena_order;
mod cover_parts;
mod decide_store;
mod decide_tile;
mod decide_tiles;
mod error;
mod input_order;
mod kept_bounds;
mod kth_distance;
mod leaf_cover;
mod point_source;
mod record_file;
mod run_digests;
mod sample_tiles;
mod seed_store;
mod store_plan;
mod sub_cells;
mod thinned_data;
mod thinning;
mod tile_buckets;
mod tile_halo;
mod tile_params;
mod tile_records;
mod tile_report;
mod tile_store;
mod tile_writer;
mod write_atomically;

pub use decide_store::{
    TOP_GROUP_DEPTH, decide_store, decide_store_tiles, decide_store_top_group,
    decide_store_top_keys, decide_store_top_upper,
};
pub use decide_tiles::{TiledDecisions, build_tiled, decide_tiled};
pub use error::TileError;
pub use point_source::{PointSource, PointsInMemory};
pub use sample_tiles::{
    OctantSeeds, SEED_MARGIN, TileCover, TileSampleReport, TiledSampling, sample_tiled,
    sample_tiled_from, seed_octant, seed_octants,
};
pub use seed_store::seed_store_octant;
pub use store_plan::{StorePart, StorePlan, WrittenPart};
pub use thinned_data::ThinnedData;
pub use tile_halo::TileWithHalo;
pub use tile_params::TileParams;
pub use tile_report::TileReport;
pub use tile_store::{StoreManifest, StoredTile, TileStore};
pub use tile_writer::TileWriter;
use write_atomically::write_atomically;
