//! The whole sampling job: seed from the octree, fix the density field, relax, measure.

use std::time::Instant;

use psi_mpu::{Mpu, PolygonizeParams, polygonize_with};
use psi_octree::{Interrupted, Monitor};
use serde::{Deserialize, Serialize};

use crate::cover_data::{cover_data, spacing_ceiling};
use crate::seed::{quotas, seed};
use crate::seed_poisson::poisson_seeds;
use crate::{
    DensityField, DensityMode, ParticleParams, Particles, Quality, RelaxOptions, RelaxRegion,
    SeparationReport, measure_quality, relax, separate_close_pairs,
};

/// What a sampling run did.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SampleReport {
    /// Particles.
    pub count: usize,
    /// Surface-containing leaves the particles were seeded from.
    pub seeded_leaves: usize,
    /// Seconds spent seeding (including the density set-up).
    pub init_seconds: f64,
    /// Seconds spent relaxing (in uniform mode also separating close pairs). Nothing is evaluated
    /// at the seeds before the clock starts, so the per-leaf and per-point tables the MPU has
    /// not filled yet are built inside it.
    pub simulate_seconds: f64,
    /// Relaxation iterations.
    pub iterations: usize,
    /// The density field used.
    pub density: DensityField,
    /// Quality of the seeds.
    pub before: Quality,
    /// Quality after relaxation.
    pub after: Quality,
    /// Uniform mode's separation pass (its time is included in `simulate_seconds`); `None` in
    /// adaptive mode.
    #[serde(default)]
    pub separation: Option<SeparationReport>,
    /// Particles the ceiling added where the data had none near (0: the relaxed particles
    /// covered every input point; their time is included in `simulate_seconds`).
    #[serde(default)]
    pub added_by_ceiling: usize,
    /// Particles of shallow, flat cells the ceiling replaced by its own (`added_by_ceiling`
    /// counts those).
    #[serde(default)]
    pub replaced_by_ceiling: usize,
}

/// The seeds of a run and the density field they fix.
#[derive(Clone, Debug)]
pub struct Seeding {
    /// The seeded particles, their targets and σ set to σ̂.
    pub particles: Particles,
    /// The density field (target spacing per depth, or uniform).
    pub density: DensityField,
    /// Surface-containing leaves seeded from.
    pub seeded_leaves: usize,
}

/// Particles and the report of a run.
#[derive(Clone, Debug)]
pub struct Sampling {
    /// The particles.
    pub particles: Particles,
    /// The report.
    pub report: SampleReport,
}

/// Total triangle area of the polygonized surface, world units² (uniform mode's area).
pub fn surface_area(mpu: &Mpu) -> f64 {
    surface_area_with(mpu, &Monitor::silent()).expect("a silent monitor never stops")
}

/// [`surface_area`], `None` once `monitor`'s flag is set (the polygonization checks it).
fn surface_area_with(mpu: &Mpu, monitor: &Monitor<'_>) -> Option<f64> {
    let params = PolygonizeParams {
        resolution: 128,
        newton_steps: 2,
        max_data_distance: f64::INFINITY,
    };
    let mesh = polygonize_with(mpu, &params, monitor).ok()?;
    Some(
        mesh.faces
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| mesh.vertices[i as usize]);
                0.5 * (b - a).cross(c - a).length()
            })
            .sum(),
    )
}

/// Seeds particles from `mpu`'s surface leaves and returns them with their density field
/// (targets and σ set). Deterministic for a given `params.seed`.
pub fn initialize(mpu: &Mpu, params: &ParticleParams) -> Seeding {
    initialize_with(mpu, params, &Monitor::silent())
}

/// [`initialize`], the dart throwing of exact counts and uniform mode stopping early once
/// `monitor`'s flag is set (the caller checks and discards the seeds).
fn initialize_with(mpu: &Mpu, params: &ParticleParams, monitor: &Monitor<'_>) -> Seeding {
    let leaves: Vec<u32> = mpu.surface_leaves().collect();
    let (d_min, d_max) = crate::depth_range(leaves.iter().map(|&l| mpu.octree().cell(l).depth));
    let mut field = DensityField {
        d_min,
        d_max,
        root_edge: mpu.octree().root().edge(),
        scale: 1.0,
        uniform: None,
        cap: None,
        ceiling: None,
    };
    let uniform = params.density == DensityMode::Uniform;
    // The paper's seeding (k per leaf) unless an exact count or uniform spacing is asked for;
    // those throw darts over the input points with the target spacing's shape. Uniform mode's
    // area (a polygonization) is measured beside the darts, which mostly keep one thread.
    let throw = || match (params.count, uniform) {
        (None, false) => seed(mpu, &leaves, &quotas(mpu, &leaves, params), params),
        (count, _) => {
            let n = count.unwrap_or(leaves.len());
            let shape = |d: u8| if uniform { 1.0 } else { field.target_sigma(d) };
            poisson_seeds(mpu, n, &shape, params.seed, monitor).unwrap_or_else(|| {
                seed(
                    mpu,
                    &leaves,
                    &quotas(
                        mpu,
                        &leaves,
                        &ParticleParams {
                            count: Some(n),
                            ..*params
                        },
                    ),
                    params,
                )
            })
        }
    };
    let (seeds, area) = if uniform {
        // (Interrupted, the area is `None` and the caller discards the seeds.)
        rayon::join(throw, || surface_area_with(mpu, &monitor.quiet()))
    } else {
        (throw(), None)
    };
    if monitor.stopped() {
        // The caller checks the flag and discards this.
        return Seeding {
            particles: Particles::default(),
            density: field,
            seeded_leaves: leaves.len(),
        };
    }
    let per_leaf = seeds.len() as f64 / leaves.len().max(1) as f64;
    field.scale = 1.0 / per_leaf.max(1e-12).sqrt();
    if let Some(area) = area {
        // Hexagonal packing: spacing a = sqrt(2A / (√3 N)), σ̂ = a/2.
        let a = (2.0 * area / (3f64.sqrt() * seeds.len().max(1) as f64)).sqrt();
        field.uniform = Some(0.5 * a);
    }
    let mut particles = Particles::default();
    for s in &seeds {
        particles.push(s.p, s.n, s.depth, field.target_sigma(s.depth));
    }
    Seeding {
        particles,
        density: field,
        seeded_leaves: leaves.len(),
    }
}

/// Seeds `params.k` particles in each of `leaves` (surface-containing leaves of `mpu`) with
/// targets from an existing density field (local regeneration reseeds marked leaves this way).
pub fn seed_leaves(
    mpu: &Mpu,
    leaves: &[u32],
    field: &DensityField,
    params: &ParticleParams,
) -> Particles {
    let quota = vec![params.k.max(1); leaves.len()];
    let mut particles = Particles::default();
    for s in seed(mpu, leaves, &quota, params) {
        particles.push(s.p, s.n, s.depth, field.target_sigma(s.depth));
    }
    particles
}

/// Seeds, relaxes (in uniform mode also separates close pairs) and measures (the paper's
/// pipeline): [`sample_with`] without progress reports.
pub fn sample(mpu: &Mpu, params: &ParticleParams) -> Sampling {
    sample_with(mpu, params, &Monitor::silent()).expect("a silent monitor never stops")
}

/// [`sample`], reporting its stages to `monitor` (`"seed"`, `"relax"` by iteration, `"cover"`
/// (the ceiling on spacing), `"separate"` in uniform mode, `"measure"`) and stopping with [`Interrupted`] once its stop
/// flag is set. A run that completes equals [`sample`]'s bit for bit.
pub fn sample_with(
    mpu: &Mpu,
    params: &ParticleParams,
    monitor: &Monitor<'_>,
) -> Result<Sampling, Interrupted> {
    let t0 = Instant::now();
    let seeding = tracing::info_span!("seeding").entered();
    monitor.report("seed", 0, 1);
    let Seeding {
        mut particles,
        density,
        seeded_leaves,
    } = initialize_with(mpu, params, monitor);
    monitor.check()?;
    monitor.report("seed", 1, 1);
    drop(seeding);
    let init_seconds = t0.elapsed().as_secs_f64();
    // The seeds are measured after the simulation, so that its clock starts with nothing
    // evaluated at them: measuring first would build the evaluation's per-leaf candidate lists
    // of the seeds' leaves off the clock.
    let seeds = particles.clone();
    let t1 = Instant::now();
    let options = RelaxOptions {
        region: RelaxRegion::default(),
        monitor: *monitor,
    };
    relax(mpu, &mut particles, &density, params, options);
    monitor.check()?;
    // The ceiling on spacing (adaptive mode with k per leaf): particles where input points are
    // left uncovered.
    let mut density = density;
    let max_spacing = (params.density == DensityMode::Adaptive && params.count.is_none())
        .then(|| spacing_ceiling(mpu, params.max_spacing))
        .filter(|s| s.is_finite());
    density.ceiling = max_spacing;
    let (mut added_by_ceiling, mut replaced_by_ceiling) = (0, 0);
    if let Some(s) = max_spacing {
        monitor.report("cover", 0, 1);
        (added_by_ceiling, replaced_by_ceiling) =
            cover_data(mpu, &mut particles, 0, &mut density, s, None, params);
        monitor.report("cover", 1, 1);
    }
    // Uniform mode only (`None` otherwise).
    let separation = if density.uniform.is_some() {
        monitor.report("separate", 0, 1);
        let s = separate_close_pairs(
            mpu,
            &mut particles,
            &density,
            params,
            RelaxRegion::default(),
        );
        monitor.check()?;
        monitor.report("separate", 1, 1);
        s
    } else {
        None
    };
    let simulate_seconds = t1.elapsed().as_secs_f64();
    monitor.report("measure", 0, 2);
    let before = measure_quality(mpu, &seeds);
    monitor.check()?;
    monitor.report("measure", 1, 2);
    let after = measure_quality(mpu, &particles);
    monitor.check()?;
    monitor.report("measure", 2, 2);
    let report = SampleReport {
        count: particles.len(),
        seeded_leaves,
        init_seconds,
        simulate_seconds,
        iterations: params.iterations,
        density,
        before,
        after,
        separation,
        added_by_ceiling,
        replaced_by_ceiling,
    };
    Ok(Sampling { particles, report })
}
