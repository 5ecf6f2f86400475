//! What one edit cost and touched ([`RegenReport`]).

use serde::{Deserialize, Serialize};

/// What one edit cost and touched.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct RegenReport {
    /// Cells of the previous octree whose fit radius holds a changed point.
    pub marked_cells: usize,
    /// Cells of the new octree that were fitted again (marked or newly created).
    pub refit_cells: usize,
    /// Particles removed (they were in marked leaves).
    pub particles_removed: usize,
    /// Particles seeded and relaxed in the marked region.
    pub particles_regenerated: usize,
    /// Control points after the edit.
    pub points: usize,
    /// Whether the edit left the root cube and forced a full rebuild in a new frame.
    pub full_rebuild: bool,
    /// Seconds marking and rebuilding the MPU (from the start of the edit).
    pub mpu_seconds: f64,
    /// Of which: editing the points (and checking they stay in the root cube).
    pub edit_seconds: f64,
    /// Of which: marking the cells.
    pub mark_seconds: f64,
    /// Seconds regenerating particles (seeding and the relaxation iterations run in this call,
    /// the finish included when none is left).
    pub particle_seconds: f64,
    /// Seconds spent first finishing the previous stroke's relaxation (its iterations left to
    /// settle: [`Scene::apply_deferred`](crate::Scene::apply_deferred)); part of `seconds`.
    pub settle_seconds: f64,
    /// Total seconds (wall clock) of the call.
    pub seconds: f64,
    /// CPU seconds of the whole process over the call (every thread).
    pub cpu_seconds: f64,
    /// The part of `cpu_seconds` spent finishing the previous stroke's relaxation.
    pub settle_cpu_seconds: f64,
    /// Relaxation iterations this stroke's particles still have to run ([`Scene::settle`](crate::Scene::settle));
    /// 0 for an eager edit.
    pub pending_iterations: usize,
}
