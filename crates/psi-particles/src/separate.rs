//! Uniform mode's separation pass: the few pairs that relaxation leaves too close are pushed
//! apart along the surface. Where the surface turns within a spacing (the bunny's ear tips) 3D
//! distance falls far below the distance along the surface, and the tangent-plane repulsion,
//! mostly along the normal there, is too weak to fix it. Each member of a close pair instead
//! climbs away from its nearest neighbour (a max–min step search on the surface) while that
//! distance grows. The count stays exact; a Poisson-disk sampler gets its minimum distance by
//! rejecting darts, which an exact count rules out.
//!
//! Tried first and dropped: moving one particle of each pair to the largest gap — the gaps of a
//! relaxed set are too narrow for that (notes: relaxation).

use glam::DVec3;
use psi_mpu::Mpu;
use psi_octree::PointIndex;
use serde::{Deserialize, Serialize};

use crate::project::project_to_surface;
use crate::quality::nearest_other_distances;
use crate::{DensityField, ParticleParams, Particles, RelaxRegion};

/// A pair closer than this fraction of the hexagonal spacing 2σ̂ is pushed apart.
pub const SEPARATION: f64 = 0.8;

/// At most this many rounds (find the close pairs, push their members).
const ROUNDS: usize = 5;

/// First step of a push, × σ̂ (a failed trial halves the step).
const FIRST_STEP: f64 = 0.25;
/// Trials per push.
const STEPS: usize = 24;
/// A push moves a particle at most this far (× σ̂) from where the round found it, so its nearest
/// neighbour stays among the candidates gathered then (within [`CANDIDATES`] × σ̂): any other
/// particle is more than 5σ̂ away, while the close partner it started with (≤ 1.6σ̂, moved by
/// at most σ̂ itself) stays within 3.6σ̂.
const MAX_PUSH: f64 = 1.0;
/// Candidate neighbours of a pushed particle: those within this many σ̂ at the round's start.
const CANDIDATES: f64 = 6.0;

/// What the separation pass did.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SeparationReport {
    /// Rounds run (each: find the close pairs, push both members of each).
    pub rounds: usize,
    /// Members of close pairs that moved, over all rounds (a particle moved in two rounds counts
    /// twice).
    pub pushed: usize,
    /// Seconds the pass took (also counted in the sampling's `simulate_seconds`).
    pub seconds: f64,
    /// Smallest nearest-neighbour distance before and after, over the hexagonal spacing 2σ̂, of
    /// the particles the pass may move (all, outside local regeneration).
    pub min_spacing_before: f64,
    /// See `min_spacing_before`.
    pub min_spacing_after: f64,
}

/// Pushes apart the pairs of `particles` (uniform mode: one target radius σ̂ = `field.uniform`,
/// world units) closer than [`SEPARATION`] × 2σ̂: both members of each pair, in index order,
/// step along the surface away from their nearest neighbour while that distance grows (each
/// trial projected onto f = 0 to |f|/|∇f| ≤ the Newton tolerance and kept on the data, the step
/// halved when a trial fails, at most σ̂ from where the round found the particle), up to
/// five rounds. `region` restricts which particles may move and where, as for
/// [`crate::relax`] (local regeneration pushes only its new particles). Deterministic (sequential
/// pushes); the count never changes. `None` outside uniform mode or with fewer than two
/// particles.
pub fn separate_close_pairs(
    mpu: &Mpu,
    particles: &mut Particles,
    field: &DensityField,
    params: &ParticleParams,
    region: RelaxRegion<'_>,
) -> Option<SeparationReport> {
    let s = field.uniform?;
    if particles.len() < 2 {
        return None;
    }
    let start = std::time::Instant::now();
    let spacing = 2.0 * s;
    // The particles that may move: only their nearest-neighbour distances are needed.
    let movable: Vec<u32> = (0..particles.len() as u32)
        .filter(|&i| region.movable.is_none_or(|m| m[i as usize]))
        .collect();
    // One index of the positions per round gives the close pairs' members (a particle whose
    // nearest neighbour is within the limit is a member), the report's minimum and the pushes'
    // candidate neighbours.
    let mut index = PointIndex::new(&particles.positions);
    let mut nn = nearest_other_distances(&index, &particles.positions, &movable);
    let min_of = |nn: &[f64]| nn.iter().copied().fold(f64::INFINITY, f64::min) / spacing;
    let mut report = SeparationReport {
        min_spacing_before: min_of(&nn),
        ..Default::default()
    };
    report.min_spacing_after = report.min_spacing_before;
    for _ in 0..ROUNDS {
        let members: Vec<u32> = movable
            .iter()
            .zip(&nn)
            .filter(|&(_, &d)| d < SEPARATION * spacing)
            .map(|(&i, _)| i)
            .collect();
        if members.is_empty() {
            break;
        }
        report.pushed += push_apart(mpu, particles, &index, &members, s, params, region.accept);
        report.rounds += 1;
        index = PointIndex::new(&particles.positions);
        nn = nearest_other_distances(&index, &particles.positions, &movable);
        report.min_spacing_after = min_of(&nn);
    }
    report.seconds = start.elapsed().as_secs_f64();
    Some(report)
}

/// Moves each of `members`, one after the other, away from its nearest neighbour along the
/// surface while its distance to the nearest particle grows. `index` holds the positions at the
/// round's start; `s` is σ̂ (world units). Returns how many moved.
fn push_apart(
    mpu: &Mpu,
    particles: &mut Particles,
    index: &PointIndex,
    members: &[u32],
    s: f64,
    params: &ParticleParams,
    accept: Option<&(dyn Fn(DVec3) -> bool + Sync)>,
) -> usize {
    let tol = params.newton_tolerance * mpu.diagonal();
    let mut near = Vec::new();
    let mut moved = 0;
    for &i in members {
        let i = i as usize;
        near.clear();
        index.within(particles.positions[i], CANDIDATES * s, &mut near);
        near.retain(|&j| j as usize != i);
        near.sort_unstable();
        if near.is_empty() {
            continue;
        }
        let positions = &particles.positions;
        let nearest = |x: DVec3| -> (f64, DVec3) {
            near.iter()
                .map(|&j| positions[j as usize])
                .map(|p| ((p - x).length(), p))
                .min_by(|a, b| a.0.total_cmp(&b.0))
                .expect("non-empty")
        };
        let origin = positions[i];
        let mut x = origin;
        let mut n = particles.normals[i];
        let (mut best, mut from) = nearest(x);
        let mut step = FIRST_STEP * s;
        for _ in 0..STEPS {
            let away = x - from;
            let mut tangent = away - n * away.dot(n);
            if tangent.length_squared() <= 0.0 {
                // Coincident with its neighbour: the two leave in opposite directions.
                let sign = if i.is_multiple_of(2) { 1.0 } else { -1.0 };
                tangent = sign * n.any_orthonormal_vector();
            }
            let on = project_to_surface(mpu, x + step * tangent.normalize(), tol, s);
            let (y, f, g) = (on.position, on.f, on.gradient);
            let (d, p) = nearest(y);
            let on_surface = g.length_squared() > 0.0 && f.abs() <= tol * g.length();
            let ok = d > best
                && on_surface
                && (y - origin).length() <= MAX_PUSH * s
                && accept.is_none_or(|a| a(y))
                && mpu
                    .near_data_from(y, params.data_reach, params.data_floor * s, None)
                    .inside;
            if ok {
                (x, n, best, from) = (y, g.normalize(), d, p);
            } else {
                step *= 0.5;
            }
        }
        if x != origin {
            moved += 1;
            particles.positions[i] = x;
            particles.normals[i] = n;
            if let Some(l) = mpu.leaf_containing(x) {
                particles.depth[i] = mpu.octree().cell(l).depth;
            }
        }
    }
    moved
}
