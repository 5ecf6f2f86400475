//! # psi — point-set implicits
//!
//! The facade of the psi workspace: it re-exports the layer crates and wires them to files.
//! It holds no algorithm. The layers, in dependency order:
//!
//! * [`octree`] (`psi-octree`): the adaptive octree, its point queries, oriented points;
//! * [`io`] (`psi-io`): PLY/OBJ/XYZ parsing and PLY writing, on bytes;
//! * [`preprocess`] (`psi-preprocess`): what a scan needs before the fit (outliers, normals,
//!   noise);
//! * [`mpu`] (`psi-mpu`): the MPU implicit (Ohtake et al. 2003) and its polygonizer;
//! * [`particles`] (`psi-particles`): octree-seeded, depth-adaptive particle sampling;
//! * [`regen`] (`psi-regen`): local regeneration after shape edits;
//! * [`render`] (`psi-render`, beside the chain): pictures of particles and meshes (PNG);
//! * [`shapes`] (`psi-shapes`, beside the chain): the built-in model, analytic shapes, tolerances.
//!
//! ```
//! use psi::{Mpu, MpuParams, ParticleParams};
//!
//! // The built-in procedural model: no file needed.
//! let points = psi::builtin_model();
//! let mpu = Mpu::build(&points, &MpuParams::paper()).unwrap();
//! let run = psi::sample(&mpu, &ParticleParams { iterations: 2, ..ParticleParams::paper() });
//! assert_eq!(run.particles.len(), run.report.count);
//! ```

mod budget;
mod error;
mod files;
mod given_stages;
mod input_points;
mod memory_estimate;
mod out_of_core;
mod partition;
mod partition_preprocessed;
mod prepare;
mod read_ahead;
mod read_file;
pub mod render;
pub mod report;
mod store_checks;
mod tile_clumps;
mod tile_denoise;
mod tile_level_normals;
mod tile_noise;
mod tile_normals;
mod tile_outliers;
mod tile_parts;
mod two_at_a_time;

pub use psi_io as io;
pub use psi_mpu as mpu;
pub use psi_octree as octree;
pub use psi_particles as particles;
pub use psi_preprocess as preprocess;
pub use psi_regen as regen;
pub use psi_shapes as shapes;
pub use psi_tiles as tiles;

pub use budget::OutOfCore;
pub use error::PsiError;
pub use files::{
    ParticleColumns, load_mesh, load_particles, load_points, load_points_as, same_file, save_json,
    save_mesh, save_particle_columns, save_particles, save_points, write_atomically,
};
pub use given_stages::GivenStage;
pub use glam::DVec3;
pub use memory_estimate::{
    available_memory_bytes, check_fits_in_memory, estimate_in_core_bytes, estimate_points,
};
pub use out_of_core::{
    OutOfCoreRun, decisions_failure, out_of_core_json, out_of_core_tiles, parse_memory_size,
    sample_file_out_of_core, sample_files_out_of_core,
};
pub use partition::{
    Partition, PartitionStart, has_normals, partition_assemble, partition_files, partition_part,
    partition_start,
};
pub use partition_preprocessed::{
    OutOfCorePreprocessing, PreprocessedPartition, check_out_of_core_store,
    out_of_core_preprocessing, partition_preprocessed,
};
pub use prepare::{
    ERROR_RANK_POINTS, PreparedInput, RANKED_NOISE, builtin_file, builtin_file_with, prepare_input,
    prepare_points,
};
pub use psi_io::{MeshSampling, PointCloudFile, ReadOptions, TriangleMesh};
pub use psi_mpu::{
    BuildReport, Mpu, MpuError, MpuParams, PolygonizeParams, TriangleSoup, polygonize,
};
pub use psi_octree::{Aabb, OrientedPoint};
pub use psi_particles::{
    DensityMode, NeighbourSearch, ParticleParams, Particles, SampleReport, Sampling, sample,
};
pub use psi_shapes::{AnalyticShape, builtin_model};
pub use render::{render_particles_png, save_png};
pub use store_checks::{
    CHECKS_VERSION, ChecksWanted, OutOfCoreMpu, StoreChecks, out_of_core_store,
};
pub use tile_outliers::{
    StrayTally, stray_join, stray_standings, stray_stats, stray_verdicts_of_batch,
};
