//! The ceiling on spacing: particles where the data has none near (issue 28). Particle density
//! follows octree depth and a plane is fitted exactly by one big cell, so a flat region gets a
//! single particle. After relaxation every input point farther than [`COVER_RADIUS`] × the
//! ceiling s from every particle is uncovered; a maximal set of darts over the uncovered points
//! (none within [`DART_RADIUS`] × s of another; thrown in rounds that read the points pass by
//! pass, `dart_rounds.rs`) become new particles, projected onto the surface and not relaxed,
//! σ̂ is capped at their spacing (the
//! particles whose σ̂ the cap lowers are replaced by darts too, so that a flat region is
//! spaced by one rule). Where every input point is covered nothing changes, as on the paper's
//! models (measured in docs/notes/2026-11-25-spacing-ceiling.md).

use glam::DVec3;
use psi_mpu::Mpu;
use psi_octree::Aabb;
use rayon::prelude::*;

use crate::dart_rounds::{CoverPoints, DartCells, PointsInMemory, throw_darts_in_rounds};
use crate::project::project_to_surface;
use crate::sigma_scale::SigmaScale;
use crate::{DensityField, ParticleGrid, ParticleParams, Particles};

/// The default ceiling on spacing, a fraction of the bounding-box diagonal D (issue 28: above
/// the paper's models' coarsest levels, so that it leaves them as they are).
pub const MAX_SPACING: f64 = 0.025;

/// An input point farther than this multiple of the ceiling from every particle is uncovered.
/// A hexagonal lattice of spacing s leaves no point farther than s/√3 ≈ 0.58 s from a particle;
/// 0.7 leaves room for the irregular packing of relaxed particles.
pub const COVER_RADIUS: f64 = 0.7;

/// Darts over the uncovered points keep at least this multiple of the ceiling apart. A maximal
/// random dart set of radius r relaxes to a hexagonal spacing of about 1.29 r (random sequential
/// adsorption packs disks of radius r/2 to 55 % of the area: N ≈ 0.70 A/r², and a lattice of
/// spacing a holds 1.15 A/a²) and has nearest-neighbour distances of about 1.06 r (a seeded
/// trial in docs/notes/2026-11-25-spacing-ceiling.md): 0.8 gives a nearest-neighbour spacing
/// of about 0.85 × the ceiling.
const DART_RADIUS: f64 = 0.8;

/// At Witkin–Heckbert's target energy Ê = 0.8α, six neighbours at spacing a each contribute
/// exp(−a²/2σ²) = 0.8/6: a = 2.007σ. The added particles' σ̂ cap is the ceiling's spacing
/// × [`DART_SPACING`] over this.
const SPACING_PER_SIGMA: f64 = 2.007;

/// The nearest-neighbour spacing of darts [`DART_RADIUS`] apart, a multiple of the ceiling
/// (see there).
const DART_SPACING: f64 = 0.85;

/// The ceiling on spacing for `mpu`, world units: `max_spacing` when it is a positive number
/// (∞ for none), else [`MAX_SPACING`] × D.
pub fn spacing_ceiling(mpu: &Mpu, max_spacing: Option<f64>) -> f64 {
    match max_spacing {
        Some(s) if s > 0.0 => s,
        _ => MAX_SPACING * mpu.diagonal(),
    }
}

/// What [`cover_from`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Covered {
    /// Particles added (darts).
    pub added: usize,
    /// Particles taken out (those whose σ̂ the cap lowered).
    pub removed: usize,
    /// Passes over the candidate points (one when every one is covered).
    pub passes: usize,
}

/// Covers the input points `candidates` (indices into [`Mpu::points`], ascending; `None`: all)
/// under the ceiling `ceiling` (world units), changing only the particles from `first` on (the
/// ones before are kept as they are, and set the scale c). Where a candidate lies farther than
/// [`COVER_RADIUS`] × the ceiling from every particle: `field`'s σ̂ is capped (a cap it already
/// has is kept); the changeable particles whose σ̂ the cap lowers (those of shallow, flat cells,
/// spaced by their cells rather than the ceiling) are taken out; darts are thrown over the
/// candidates the rest leave uncovered ([`throw_darts_in_rounds`]), projected onto the surface
/// (Newton, `params`' tolerance) and placed at `first`, before the changeable particles left,
/// with σ = c·σ̂ under the capped field. The darts are final: a maximal dart set is already
/// even (measured in docs/notes/2026-11-25-spacing-ceiling.md), where a relaxation would pile
/// particles onto creases (a particle pushed over a convex edge is projected back onto it). Returns how many particles were added and how many taken out
/// ((0, 0): nothing changed).
pub fn cover_data(
    mpu: &Mpu,
    particles: &mut Particles,
    first: usize,
    field: &mut DensityField,
    ceiling: f64,
    candidates: Option<&[u32]>,
    params: &ParticleParams,
) -> (usize, usize) {
    let points = mpu.points();
    let source = PointsInMemory { points, candidates };
    // Only the particles near the candidates are indexed (a stroke's leaves).
    let near = candidates.and_then(|c| Aabb::from_points(c.iter().map(|&q| points[q as usize].p)));
    match cover_from(mpu, &source, near, particles, first, field, ceiling, params) {
        Ok(c) => (c.added, c.removed),
        Err(never) => match never {},
    }
}

/// [`cover_data`] with the candidates from `source` (all of them inside `near`, world units,
/// when given): a tile store's points out of core. `mpu` projects the darts (its f is the
/// whole input's; its points serve only where a projection stalls).
///
/// Errors: the source's.
#[allow(clippy::too_many_arguments)]
pub fn cover_from<S: CoverPoints + ?Sized>(
    mpu: &Mpu,
    source: &S,
    near: Option<Aabb>,
    particles: &mut Particles,
    first: usize,
    field: &mut DensityField,
    ceiling: f64,
    params: &ParticleParams,
) -> Result<Covered, S::Error> {
    let n = particles.len();
    if !(ceiling.is_finite() && ceiling > 0.0) || n == 0 || first > n {
        return Ok(Covered::default());
    }
    let radius = COVER_RADIUS * ceiling;
    let grid_of = |positions: &[DVec3]| match near {
        None => ParticleGrid::new(positions, radius),
        Some(b) => {
            let (lo, hi) = (b.min - DVec3::splat(radius), b.max + DVec3::splat(radius));
            let inside: Vec<DVec3> = positions
                .iter()
                .filter(|x| x.cmpge(lo).all() && x.cmple(hi).all())
                .copied()
                .collect();
            ParticleGrid::new(&inside, radius)
        }
    };
    let cells = DartCells::for_radius(mpu.frame_origin(), DART_RADIUS * ceiling, params.seed);
    let mut grid = grid_of(&particles.positions);
    let reps = source.representatives(&cells, &|p| !grid.any_within(p, radius))?;
    if reps.is_empty() {
        return Ok(Covered {
            passes: 1,
            ..Covered::default()
        });
    }
    let scale_from = if first > 0 { 0..first } else { 0..n };
    let c =
        SigmaScale::from_particles(field, &particles.depth, &particles.sigma, scale_from).scale();
    let cap = *field
        .cap
        .get_or_insert(DART_SPACING * ceiling / SPACING_PER_SIGMA / c);
    let uncapped = DensityField {
        cap: None,
        ..*field
    };
    let keep: Vec<bool> = (0..n)
        .map(|i| i < first || uncapped.target_sigma(particles.depth[i]) < cap)
        .collect();
    particles.retain_mask(&keep);
    let removed = n - particles.len();
    // The first pass's representatives are the first round's when no particle left.
    let reps = match removed {
        0 => Some(reps),
        _ => {
            drop(reps);
            grid = grid_of(&particles.positions);
            None
        }
    };
    let (darts, passes) =
        throw_darts_in_rounds(source, &|p| !grid.any_within(p, radius), &cells, reps)?;
    let tol = params.newton_tolerance * mpu.diagonal();
    let origin = mpu.frame_origin();
    let placed: Vec<(DVec3, DVec3, u8)> = darts
        .par_iter()
        .map(|p| {
            let on = project_to_surface(mpu, p.p, tol, ceiling);
            let tree = mpu.octree();
            let leaf = on.leaf.or_else(|| tree.leaf_containing(p.p - origin));
            let depth = tree.cell(leaf.unwrap_or(0)).depth;
            (on.position, on.gradient.normalize_or(p.n), depth)
        })
        .collect();
    let mut added = Particles::default();
    for &(x, normal, depth) in &placed {
        let target = field.target_sigma(depth);
        added.push(x, normal, depth, c * target);
        *added.target.last_mut().expect("pushed") = target;
    }
    let rest = particles.split_off(first);
    particles.extend(&added);
    particles.extend(&rest);
    Ok(Covered {
        added: darts.len(),
        removed,
        passes: passes + 1,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use psi_mpu::MpuParams;
    use psi_shapes::AnalyticShape;

    /// Every input point ends within the darts' radius of a particle, on a sheet whose one big
    /// cell gives a single particle.
    #[test]
    fn a_sheet_ends_covered() {
        let mut points = Vec::new();
        for i in 0..80 {
            for j in 0..80 {
                let p = DVec3::new(i as f64 / 79.0, j as f64 / 79.0, 0.0);
                points.push(psi_octree::OrientedPoint { p, n: DVec3::Z });
            }
        }
        let mpu = Mpu::build(&points, &MpuParams::paper()).unwrap();
        let params = ParticleParams::paper();
        let run = crate::sample(&mpu, &params);
        let ceiling = spacing_ceiling(&mpu, None);
        assert!(
            run.report.added_by_ceiling > 100,
            "{}",
            run.report.added_by_ceiling
        );
        for p in &points {
            let nearest = run
                .particles
                .positions
                .iter()
                .map(|x| x.distance(p.p))
                .fold(f64::INFINITY, f64::min);
            assert!(nearest < DART_RADIUS * ceiling * (1.0 + 1e-9), "{nearest}");
        }
    }

    /// A sphere's relaxed particles cover its points: nothing changes, in one pass.
    #[test]
    fn a_covered_surface_is_left_as_it_is() {
        let points = AnalyticShape::Sphere { radius: 1.0 }.sample(4000, 3);
        let mpu = Mpu::build(&points, &MpuParams::paper()).unwrap();
        let params = ParticleParams {
            max_spacing: Some(f64::INFINITY),
            ..ParticleParams::paper()
        };
        let run = crate::sample(&mpu, &params);
        let mut particles = run.particles;
        let before = particles.clone();
        let mut field = run.report.density;
        let source = PointsInMemory {
            points: mpu.points(),
            candidates: None,
        };
        let cover = |particles: &mut Particles, field: &mut DensityField, ceiling: f64| {
            cover_from(&mpu, &source, None, particles, 0, field, ceiling, &params)
        };
        let done = cover(&mut particles, &mut field, 0.5);
        assert_eq!(
            done,
            Ok(Covered {
                added: 0,
                removed: 0,
                passes: 1
            })
        );
        assert_eq!(particles, before);
        assert_eq!(field.cap, None);
        // A ceiling far below the spacing: darts everywhere.
        let done = cover(&mut particles, &mut field, 0.02);
        assert!(done.unwrap().added > before.len());
        assert!(field.cap.is_some());
    }
}
