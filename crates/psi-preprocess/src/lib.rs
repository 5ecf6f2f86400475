//! # psi-preprocess
//!
//! What happens to a point set between reading it and fitting the MPU: the repairs a real scan
//! needs. Each step is a function on borrowed slices, usable on its own.
//!
//! * [`mesh_coarseness`], [`densify_mesh`]: whether a mesh's triangles are large against the
//!   implicit's tolerance, and more points on them when they are;
//! * [`find_outliers`]: stray points that no surface supports; [`find_clumps`]: small groups
//!   of them lying apart, off the surface (which support themselves); [`part_standings`],
//!   [`median_of_passes`] and [`part_outliers`] the outlier step from parts of the points;
//! * [`estimate_normals`]: normals for a cloud of positions only, from plane fits over an
//!   adaptive neighbourhood;
//! * [`orient_normals`] (propagation over a neighbour graph, after Hoppe et al. 1992) and
//!   [`orient_toward`] (a range scan's sensor position) give normals a consistent side;
//!   [`part_orientation_edges`] and [`orient_by_parts`] give `orient_normals`' sides bitwise
//!   from parts of the points (tiles with a halo), [`part_normals`] the level-0 estimate
//!   ([`noise_level`]), [`part_noise_samples`] with [`noise_by_rounds`] the noise estimate;
//!   [`check_normal_consistency`] counts the neighbours whose normals oppose
//!   ([`part_normal_consistency`] by parts);
//! * [`estimate_noise`]: the noise level of the positions, from quadric fits, and
//!   [`error_threshold_for_noise`], the MPU error threshold it suggests; [`denoise`] takes it
//!   out of the positions (moving least squares with quadrics; [`part_denoise_samples`],
//!   [`DenoiseScale`] and [`part_denoise`] by parts);
//! * [`preprocess`]: all of it in order, each step on or off ([`PreprocessParams`]), with a
//!   [`PreprocessReport`].
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

mod clumps_by_parts;
mod consistency_by_parts;
mod denoise;
mod densify_mesh;
mod disjoint_sets;
mod drop_repeated;
mod drop_strays;
mod estimate_noise;
mod estimate_normals;
mod find_clumps;
mod find_outliers;
#[cfg(test)]
mod grid_parts;
mod inward_normals;
mod level_by_parts;
mod local_fit;
mod median;
mod neighbour_graph;
mod noise_by_parts;
mod normals_by_parts;
mod orient_by_parts;
mod orient_from_level;
mod orient_normals;
mod outlier_verdicts_by_parts;
mod outliers_by_parts;
mod point_spread;
mod preprocess;
mod spanning_forest;
mod symmetric_eigen3;

pub use clumps_by_parts::{
    Candidates, ClumpCubes, ClumpScale, clump_spacing_in_cube, clumps_of_candidates,
};
pub use consistency_by_parts::{CONSISTENCY_QUERIES, part_normal_consistency};
pub use denoise::{
    DenoiseReport, DenoiseScale, denoise, denoise_with, part_denoise, part_denoise_samples,
};
pub use densify_mesh::{MeshCoarseness, densify_mesh, densify_mesh_with_sources, mesh_coarseness};
pub use drop_strays::OutlierReport;
pub use estimate_noise::{
    NoiseEstimate, NoiseRound, WideNeighbourhood, estimate_noise, noise_by_rounds, wide_residuals,
    widest_round,
};
pub use estimate_normals::{
    LEVEL_POINTS, estimate_normals, estimate_normals_with, in_level, noise_level,
};
pub use find_clumps::{CLUMP_GAP, CLUMP_POINTS, Clumps, find_clumps, find_clumps_with};
pub use find_outliers::{Outliers, find_outliers, find_outliers_with};
pub use inward_normals::{InwardEvidence, InwardVotes, inward_flip_notice, inward_votes};
pub use level_by_parts::LevelIndex;
pub use median::median_of_passes;
pub use noise_by_parts::{PartNoise, part_noise_reading_wide, part_noise_samples};
pub use normals_by_parts::part_normals;
pub use orient_by_parts::{
    IncompletePart, OrientEdge, OrientationJoin, PartEdges, merge_across, orient_by_parts,
    orientation_flips, part_orientation_edges,
};
pub use orient_normals::{
    NormalConsistency, check_normal_consistency, orient_normals, orient_normals_with, orient_toward,
};
pub use outlier_verdicts_by_parts::{part_outliers, settled_verdicts};
pub use outliers_by_parts::{OutlierStats, OwnStanding, StrayVerdict, part_standings};
pub use point_spread::{Spread, point_spread};
pub use preprocess::{
    ErrorThreshold, INCONSISTENT_NORMALS, MeshRef, MeshReport, NOISE_ERROR_FACTOR, NormalTreatment,
    PAPER_ERROR_REL, PointOrigin, PreprocessError, PreprocessParams, PreprocessReport,
    Preprocessed, ScanInput, StepSeconds, ThresholdSource, error_threshold_for_noise, preprocess,
    preprocess_with,
};
