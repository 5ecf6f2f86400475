//! The ceiling on spacing: particles where the data has none near (issue 28). Particle density
//! follows octree depth and a plane is fitted exactly by one big cell, so a flat region gets a
//! single particle. After relaxation every input point farther than [`COVER_RADIUS`] × the
//! ceiling s from every particle is uncovered; darts thrown over the uncovered points in a
//! hashed order (one kept when no kept dart lies within [`DART_RADIUS`] × s) become new
//! particles, projected onto the surface and not relaxed, σ̂ is capped at their spacing (the
//! particles whose σ̂ the cap lowers are replaced by darts too, so that a flat region is
//! spaced by one rule). Where every input point is covered nothing changes, as on the paper's
//! models (measured in docs/notes/2026-11-25-spacing-ceiling.md).

use glam::DVec3;
use psi_mpu::Mpu;
use psi_octree::Aabb;
use rayon::prelude::*;

use crate::dart_grid::DartGrid;
use crate::project::project_to_surface;
use crate::seed::spread_hash;
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

/// Those of `candidates` (input point indices, [`Mpu::points`], ascending; `None`: all) that
/// lie farther than `radius` (world units) from every one of `positions` (shape N, world
/// units), ascending. Only the positions within `radius` of the candidates' box are indexed.
pub(crate) fn uncovered_points(
    mpu: &Mpu,
    positions: &[DVec3],
    radius: f64,
    candidates: Option<&[u32]>,
) -> Vec<u32> {
    let points = mpu.points();
    let all: Vec<u32>;
    let candidates = match candidates {
        Some(c) => c,
        None => {
            all = (0..points.len() as u32).collect();
            &all
        }
    };
    let Some(b) = Aabb::from_points(candidates.iter().map(|&q| points[q as usize].p)) else {
        return Vec::new();
    };
    let (lo, hi) = (b.min - DVec3::splat(radius), b.max + DVec3::splat(radius));
    let near: Vec<DVec3> = positions
        .iter()
        .filter(|x| x.cmpge(lo).all() && x.cmple(hi).all())
        .copied()
        .collect();
    let grid = ParticleGrid::new(&near, radius);
    candidates
        .par_iter()
        .map_init(Vec::new, |found, &q| {
            found.clear();
            grid.append_within(points[q as usize].p, radius, found);
            found.is_empty().then_some(q)
        })
        .flatten_iter()
        .collect()
}

/// A maximal set of `candidates` (input point indices) at least `radius` apart (world units):
/// each candidate in a hashed order (seeded by `seed`) is kept when no kept one lies within
/// `radius`. Returns the kept indices ascending; the same for any thread count.
pub(crate) fn throw_darts(mpu: &Mpu, candidates: &[u32], radius: f64, seed: u64) -> Vec<u32> {
    let points = mpu.points();
    let mut order = candidates.to_vec();
    // (The keys are distinct, so an unstable sort gives the one order.)
    order.par_sort_unstable_by_key(|&q| (spread_hash(q as usize ^ seed as usize), q));
    let mut kept = DartGrid::new(radius, 1024);
    let mut out = Vec::new();
    let r2 = radius * radius;
    for q in order {
        let p = points[q as usize].p;
        if !kept.any_around(p, |_, k| k.distance_squared(p) < r2) {
            kept.insert(q, p);
            out.push(q);
        }
    }
    out.sort_unstable();
    out
}

/// Covers the input points `candidates` (indices into [`Mpu::points`], ascending; `None`: all)
/// under the ceiling `ceiling` (world units), changing only the particles from `first` on (the
/// ones before are kept as they are, and set the scale c). Where a candidate lies farther than
/// [`COVER_RADIUS`] × the ceiling from every particle: `field`'s σ̂ is capped (a cap it already
/// has is kept); the changeable particles whose σ̂ the cap lowers (those of shallow, flat cells,
/// spaced by their cells rather than the ceiling) are taken out; darts are thrown over the
/// candidates the rest leave uncovered, projected onto the surface (Newton, `params`'
/// tolerance) and placed at `first`, before the changeable particles left, with σ = c·σ̂ under
/// the capped field. The darts are final: a maximal dart set is already even (its
/// nearest-neighbour distances are 1.06 × the radius on average with a CV of 0.06), where a
/// relaxation would pile particles onto creases (a particle pushed over a convex edge is
/// projected back onto it). Returns how many particles were added and how many taken out
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
    let n = particles.len();
    if !(ceiling.is_finite() && ceiling > 0.0) || n == 0 || first > n {
        return (0, 0);
    }
    let radius = COVER_RADIUS * ceiling;
    let mut uncovered = uncovered_points(mpu, &particles.positions, radius, candidates);
    if uncovered.is_empty() {
        return (0, 0);
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
    if removed > 0 {
        uncovered = uncovered_points(mpu, &particles.positions, radius, candidates);
    }
    let darts = throw_darts(mpu, &uncovered, DART_RADIUS * ceiling, params.seed);
    let tol = params.newton_tolerance * mpu.diagonal();
    let placed: Vec<(DVec3, DVec3, u8)> = darts
        .par_iter()
        .map(|&q| {
            let p = mpu.points()[q as usize];
            let on = project_to_surface(mpu, p.p, tol, ceiling);
            let leaf = on.leaf.unwrap_or_else(|| mpu.octree().leaf_of_point(q));
            let depth = mpu.octree().cell(leaf).depth;
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
    (darts.len(), removed)
}

#[cfg(test)]
mod tests {
    use super::*;
    use psi_mpu::MpuParams;
    use psi_shapes::AnalyticShape;

    fn sphere() -> Mpu {
        let points = AnalyticShape::Sphere { radius: 1.0 }.sample(4000, 3);
        Mpu::build(&points, &MpuParams::paper()).unwrap()
    }

    #[test]
    fn uncovered_points_match_brute_force() {
        let mpu = sphere();
        let positions: Vec<DVec3> = mpu.points().iter().step_by(97).map(|p| p.p).collect();
        for radius in [0.05, 0.2, 0.4] {
            let fast = uncovered_points(&mpu, &positions, radius, None);
            let brute: Vec<u32> = (0..mpu.points().len() as u32)
                .filter(|&q| {
                    let p = mpu.points()[q as usize].p;
                    positions.iter().all(|x| x.distance(p) > radius)
                })
                .collect();
            assert_eq!(fast, brute, "radius {radius}");
            assert!(!brute.is_empty() || radius > 0.2);
        }
    }

    #[test]
    fn darts_are_apart_and_leave_no_candidate_uncovered() {
        let mpu = sphere();
        let all: Vec<u32> = (0..mpu.points().len() as u32).collect();
        let radius = 0.15;
        let kept = throw_darts(&mpu, &all, radius, 7);
        let at = |q: u32| mpu.points()[q as usize].p;
        for (i, &a) in kept.iter().enumerate() {
            for &b in &kept[i + 1..] {
                assert!(at(a).distance(at(b)) >= radius);
            }
        }
        // Maximal: every candidate lies within the radius of a kept one.
        for &q in &all {
            assert!(kept.iter().any(|&k| at(k).distance(at(q)) < radius));
        }
        assert_eq!(kept, throw_darts(&mpu, &all, radius, 7));
    }
}
