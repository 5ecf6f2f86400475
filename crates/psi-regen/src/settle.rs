//! A stroke's particles settling over the frames after it: the relaxation of the regenerated
//! particles ([`Relaxation`]) kept between calls, run a few iterations at a time, and finished
//! (polish, uniform mode's separation, attributes) exactly as an eager edit finishes it.

use glam::DVec3;
use psi_mpu::Mpu;
use psi_octree::{Aabb, Monitor, PointAttributes};
use psi_particles::{
    DensityField, ParticleParams, Particles, RelaxOptions, RelaxRegion, Relaxation,
    separate_close_pairs, transfer_attributes,
};

/// Iterations of its relaxation a deferred stroke runs in its own frame
/// ([`crate::Scene::apply_deferred`]'s usual value): the rest of `ParticleParams::iterations`
/// is left to [`crate::Scene::settle`].
pub const FRAME_ITERATIONS: usize = 4;

/// What settling cost.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SettleReport {
    /// Relaxation iterations run.
    pub iterations: usize,
    /// Iterations still left afterwards (0: settled and finished).
    pub pending_iterations: usize,
    /// Wall-clock seconds.
    pub seconds: f64,
    /// CPU seconds of the whole process over the call (every thread).
    pub cpu_seconds: f64,
}

/// The relaxation of a stroke's regenerated particles, in progress.
#[derive(Clone)]
pub(crate) struct Pending {
    relaxation: Relaxation,
    /// Per particle: whether it was regenerated (it moves; the rest are fixed).
    movable: Vec<bool>,
    /// Per cell of the current MPU: whether it was refitted (a move must stay in such a leaf).
    refit: Vec<bool>,
    /// The refitted leaves' box, world units.
    bounds: Option<Aabb>,
    /// Particles kept from before the stroke (the regenerated ones follow them).
    kept: usize,
}

impl std::fmt::Debug for Pending {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Pending")
            .field("relaxation", &self.relaxation)
            .field("kept", &self.kept)
            .finish()
    }
}

/// The region a stroke's particles relax in: the regenerated ones move, only into refitted
/// leaves.
fn region<'a>(
    movable: &'a [bool],
    accept: &'a (dyn Fn(DVec3) -> bool + Sync),
    bounds: Option<Aabb>,
) -> RelaxRegion<'a> {
    RelaxRegion {
        movable: Some(movable),
        accept: Some(accept),
        bounds,
    }
}

impl Pending {
    /// Starts relaxing the particles from index `kept` on (the regenerated ones) in the leaves
    /// `refit` marks of `mpu`, inside `bounds` (world units).
    pub(crate) fn start(
        mpu: &Mpu,
        particles: &mut Particles,
        field: &DensityField,
        params: &ParticleParams,
        refit: Vec<bool>,
        bounds: Option<Aabb>,
        kept: usize,
    ) -> Pending {
        let movable: Vec<bool> = (0..particles.len()).map(|i| i >= kept).collect();
        let accept = |x: DVec3| mpu.leaf_containing(x).is_some_and(|l| refit[l as usize]);
        let relaxation = Relaxation::start(
            mpu,
            particles,
            field,
            params,
            region(&movable, &accept, bounds),
        );
        Pending {
            relaxation,
            movable,
            refit,
            bounds,
            kept,
        }
    }

    /// Iterations left.
    pub(crate) fn remaining(&self, params: &ParticleParams) -> usize {
        self.relaxation.remaining(params)
    }

    /// Runs up to `iterations` more iterations; returns how many ran.
    pub(crate) fn run(
        &mut self,
        mpu: &Mpu,
        particles: &mut Particles,
        field: &DensityField,
        params: &ParticleParams,
        iterations: usize,
        monitor: &Monitor<'_>,
    ) -> usize {
        let refit = &self.refit;
        let accept = |x: DVec3| mpu.leaf_containing(x).is_some_and(|l| refit[l as usize]);
        let options = RelaxOptions {
            region: region(&self.movable, &accept, self.bounds),
            monitor: *monitor,
        };
        self.relaxation
            .run(mpu, particles, field, params, options, iterations)
    }

    /// Finishes as an eager edit does: the polish, uniform mode's close pairs pushed apart, and
    /// the regenerated particles' attributes taken from the `points`' (replacing the defaults
    /// `particle_attributes` held for them).
    pub(crate) fn finish(
        self,
        mpu: &Mpu,
        particles: &mut Particles,
        field: &DensityField,
        params: &ParticleParams,
        points: &PointAttributes,
        particle_attributes: &mut PointAttributes,
    ) {
        let Pending {
            relaxation,
            movable,
            refit,
            bounds,
            kept,
        } = self;
        relaxation.finish(mpu, particles, field, params);
        let accept = |x: DVec3| mpu.leaf_containing(x).is_some_and(|l| refit[l as usize]);
        separate_close_pairs(
            mpu,
            particles,
            field,
            params,
            region(&movable, &accept, bounds),
        );
        if !points.is_empty() {
            // (The movable particles are those from `kept` on.)
            let fresh = particles.range(kept..particles.len());
            let transferred = transfer_attributes(mpu, &fresh, points);
            let ids: Vec<u32> = (0..kept as u32).collect();
            let mut all = particle_attributes.select(&ids);
            all.extend(kept, &transferred, fresh.len());
            *particle_attributes = all;
        }
    }
}

/// Process CPU seconds so far (every thread).
pub(crate) fn cpu_now() -> f64 {
    cpu_time::ProcessTime::now().as_duration().as_secs_f64()
}
