//! # psi-particles
//!
//! The paper's contribution (Proença, Jorge, Sousa, *Sampling Point-Set Implicits*): particles
//! seeded straight from the MPU octree — k per surface-containing leaf, so the count follows
//! the surface's complexity with no user parameter — then a short Witkin–Heckbert relaxation
//! whose target spacing comes from the octree depth (paper eq. 1) instead of curvature.
//!
//! * [`sample`]: seed, relax, measure; [`initialize`] and [`relax`] separately;
//! * [`ParticleParams::paper`]: k = 1, 20 iterations, WH constants;
//! * [`DensityField`]: depth → target radius σ̂; [`paper_weight`]: eq. 1's weight;
//! * [`measure_quality`]: |f|/|∇f| and nearest-neighbour statistics per depth level;
//! * [`separate_close_pairs`]: uniform mode's last step, pushing apart the pairs relaxation
//!   left closer than [`SEPARATION`] of the spacing;
//! * [`cover_data`]: the ceiling on spacing ([`MAX_SPACING`] of D by default), darts where the
//!   relaxed particles leave input points uncovered (flat regions); [`cover_from`] with the
//!   points from a [`CoverPoints`] source (a tile store), the darts thrown in rounds
//!   ([`throw_darts_in_rounds`]) that do not depend on how the points come.
//!
//! ```
//! use psi_mpu::{Mpu, MpuParams};
//! use psi_shapes::AnalyticShape;
//! use psi_particles::{ParticleParams, sample};
//!
//! let points = AnalyticShape::Torus { major: 1.0, minor: 0.4 }.sample(8000, 1);
//! let mpu = Mpu::build(&points, &MpuParams::paper()).unwrap();
//! let run = sample(&mpu, &ParticleParams::paper());
//! assert_eq!(run.particles.len(), run.report.count);
//! assert!(run.report.after.max_surface_distance <= 1e-4 + 1e-12);
//! ```

mod cover_data;
mod dart_grid;
mod dart_rounds;
mod density;
mod depth_range;
mod neighbours;
mod octree_buckets;
mod params;
mod particle_grid;
mod particles;
mod project;
mod quality;
mod relax;
mod repulsion;
mod sample;
mod seed;
mod seed_poisson;
mod separate;
mod sigma_scale;
mod transfer_attributes;

pub use cover_data::{COVER_RADIUS, Covered, MAX_SPACING, cover_data, cover_from, spacing_ceiling};
pub use dart_rounds::{
    CELLS_PER_RADIUS, CoverPoints, DartCells, Representatives, throw_darts_in_rounds,
};
pub use density::{DensityField, paper_weight};
pub use depth_range::depth_range;
pub use octree_buckets::OctreeBuckets;
pub use params::{DensityMode, NeighbourSearch, ParticleParams};
pub use particle_grid::{GRID_EDGE_FACTOR, ParticleGrid};
pub use particles::Particles;
pub use quality::{
    LevelStats, Quality, SpacingStats, measure_quality, nearest_neighbour_distances,
    quality_from_surface_distances, surface_distances,
};
pub use relax::{RelaxOptions, RelaxRegion, Relaxation, relax};
pub use sample::{
    SampleReport, Sampling, Seeding, initialize, sample, sample_with, seed_leaves, surface_area,
};
pub use separate::{SEPARATION, SeparationReport, separate_close_pairs};
pub use transfer_attributes::{TRANSFER_POINTS, TRANSFER_RADIUS_SIGMAS, transfer_attributes};
