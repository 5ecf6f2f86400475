//! Metrics of a particle set against the points it was made from (issue 28): the local spacing
//! (the mean nearest-neighbour distance of the particles within 5 ceilings of a point), how far
//! input points lie from the particles in local spacings, spacing statistics over the particles
//! near flat-labelled points, and the per-level CV that `psi sample` reports.

use psi::DVec3;
use psi::octree::PointIndex;
use rayon::prelude::*;
use serde_json::{Value, json};

/// The default ceiling on spacing as a fraction of the input's bounding-box diagonal (used when
/// a report does not give `particles.max_spacing`).
pub(crate) const DEFAULT_CEILING: f64 = 0.025;

/// The local spacing is averaged over the particles within this many ceilings of a point.
pub(crate) const BALL_CEILINGS: f64 = 5.0;

/// Depth levels with fewer particles than this are left out of the largest per-level CV (a CV
/// of a handful of distances is mostly noise; `tables.rs` marks them the same way).
pub(crate) const LEVEL_MIN_PARTICLES: u64 = 30;

/// The ceiling on spacing of a run, world units, and where it came from: the report's
/// `particles.max_spacing`, else [`DEFAULT_CEILING`] × `input.bbox_diagonal` (the points psi
/// fitted).
pub(crate) fn spacing_ceiling(report: &Value) -> (f64, &'static str) {
    match report["particles"]["max_spacing"].as_f64() {
        Some(s) if s > 0.0 && s.is_finite() => (s, "report"),
        _ => (
            DEFAULT_CEILING
                * report["input"]["bbox_diagonal"]
                    .as_f64()
                    .unwrap_or(f64::NAN),
            "0.025 D",
        ),
    }
}

/// The per-level nearest-neighbour statistics of `report["particles"]["after"]["levels"]`: the
/// largest CV over the levels of at least [`LEVEL_MIN_PARTICLES`] particles (NaN when none),
/// and every level as `depth:cv` (a level of few particles with its count), for the table.
pub(crate) fn level_cv(report: &Value) -> (f64, String) {
    let levels = report["particles"]["after"]["levels"]
        .as_array()
        .cloned()
        .unwrap_or_default();
    let mut worst = f64::NAN;
    let mut text = Vec::new();
    for l in &levels {
        let count = l["spacing"]["count"].as_u64().unwrap_or(0);
        let cv = l["spacing"]["cv"].as_f64().unwrap_or(f64::NAN);
        if count >= LEVEL_MIN_PARTICLES {
            worst = if worst.is_nan() { cv } else { worst.max(cv) };
            text.push(format!("{}:{cv:.3}", l["depth"]));
        } else {
            text.push(format!("{}:{cv:.3}(n={count})", l["depth"]));
        }
    }
    (worst, text.join(" "))
}

/// Distance from each particle (shape: N, world units) to its nearest other particle (shape: N,
/// world units; ∞ for a particle alone).
pub(crate) fn nearest_neighbour_distances(particles: &[DVec3]) -> Vec<f64> {
    psi::particles::nearest_neighbour_distances(particles)
}

/// The local spacing at each of `at` (shape: M, world units): the mean of the finite
/// nearest-neighbour distances `nn` (shape: N) of the particles (indexed by `index`) within
/// `radius` of the point; `fallback` where there is none (no particle in the ball, or only
/// particles alone). Shape: M, world units.
pub(crate) fn local_spacings(
    index: &PointIndex,
    nn: &[f64],
    at: &[DVec3],
    radius: f64,
    fallback: f64,
) -> Vec<f64> {
    at.par_iter()
        .map_init(Vec::new, |found, x| {
            found.clear();
            index.within(*x, radius, found);
            let (sum, n) = found
                .iter()
                .map(|&k| nn[k as usize])
                .filter(|d| d.is_finite())
                .fold((0.0, 0usize), |(s, n), d| (s + d, n + 1));
            if n == 0 { fallback } else { sum / n as f64 }
        })
        .collect()
}

/// Value at quantile `q` (0..=1) of sorted `s` (nearest rank); NaN when empty.
fn quantile(s: &[f64], q: f64) -> f64 {
    if s.is_empty() {
        return f64::NAN;
    }
    s[((q * (s.len() - 1) as f64).round() as usize).min(s.len() - 1)]
}

/// How well `particles` (shape: N, world units) cover `inputs` (shape: M, world units): each
/// input point's distance to its nearest particle over the local spacing there (the ball of
/// [`BALL_CEILINGS`] × `ceiling`, world units; the ceiling where the ball has no spacing).
/// JSON: `p99`, `max`, `median` of that ratio, `beyond_1.5` (share), `beyond_2.5` (count), the
/// median local spacing (world units) and the inputs' largest distance to a particle (world).
pub(crate) fn coverage(particles: &[DVec3], nn: &[f64], inputs: &[DVec3], ceiling: f64) -> Value {
    let index = PointIndex::new(particles);
    let spacing = local_spacings(&index, nn, inputs, BALL_CEILINGS * ceiling, ceiling);
    let gaps: Vec<f64> = inputs
        .par_iter()
        .map(|x| {
            index
                .nearest_one(*x)
                .map_or(f64::INFINITY, |(_, d2)| d2.sqrt())
        })
        .collect();
    let mut ratio: Vec<f64> = gaps.iter().zip(&spacing).map(|(g, s)| g / s).collect();
    ratio.sort_by(f64::total_cmp);
    let mut sorted_spacing = spacing.clone();
    sorted_spacing.sort_by(f64::total_cmp);
    let n = ratio.len().max(1) as f64;
    json!({
        "p99": quantile(&ratio, 0.99),
        "max": ratio.last().copied().unwrap_or(f64::NAN),
        "median": quantile(&ratio, 0.5),
        "beyond_1.5": ratio.iter().filter(|r| **r > 1.5).count() as f64 / n,
        "beyond_2.5": ratio.iter().filter(|r| **r > 2.5).count(),
        "median_local_spacing": quantile(&sorted_spacing, 0.5),
        "largest_gap": gaps.iter().copied().fold(0.0, f64::max),
        "ceiling": ceiling,
    })
}

/// The share of a surface sampled by `points` (shape: M, world units) where `flagged` (shape:
/// M) holds, by area rather than by count: each point weighted by the inverse of the number of
/// points within `radius` of it (itself included), so a region sampled twice as densely counts
/// once, as the particles, spread by area, count it. 0 for no points.
pub(crate) fn share_by_area(points: &[DVec3], flagged: &[bool], radius: f64) -> f64 {
    let index = PointIndex::new(points);
    let (flagged_weight, total) = points
        .par_iter()
        .zip(flagged)
        .map_init(Vec::new, |found, (x, &f)| {
            found.clear();
            index.within(*x, radius, found);
            let w = 1.0 / found.len().max(1) as f64;
            (if f { w } else { 0.0 }, w)
        })
        .reduce(|| (0.0, 0.0), |a, b| (a.0 + b.0, a.1 + b.1));
    if total > 0.0 {
        flagged_weight / total
    } else {
        0.0
    }
}

/// Which particles (shape: N, world units) lie near a flat part: those whose nearest input point
/// (`inputs`, shape: M, with `labels`, shape: M) has a label whose `flat[label]` holds. Shape: N.
pub(crate) fn near_flat(
    particles: &[DVec3],
    inputs: &[DVec3],
    labels: &[u8],
    flat: &[bool],
) -> Vec<bool> {
    let index = PointIndex::new(inputs);
    particles
        .par_iter()
        .map(|p| {
            index.nearest_one(*p).is_some_and(|(k, _)| {
                flat.get(labels[k as usize] as usize)
                    .copied()
                    .unwrap_or(false)
            })
        })
        .collect()
}

/// Nearest-neighbour statistics of the particles `chosen` (shape: N, from `nn`, shape: N, world
/// units), the spacing over `diag` (world units): `count`, `median` and `mean` (over D) and
/// `cv` (std/mean) of the finite distances; `alone` counts chosen particles without a neighbour.
pub(crate) fn spacing_stats(nn: &[f64], chosen: &[bool], diag: f64) -> Value {
    let mut d: Vec<f64> = nn
        .iter()
        .zip(chosen)
        .filter(|(_, c)| **c)
        .map(|(d, _)| *d)
        .filter(|d| d.is_finite())
        .collect();
    let alone = chosen.iter().filter(|c| **c).count() - d.len();
    d.sort_by(f64::total_cmp);
    let n = d.len() as f64;
    let mean = d.iter().sum::<f64>() / n;
    let var = d.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / n;
    json!({
        "count": d.len(),
        "alone": alone,
        "median": quantile(&d, 0.5) / diag,
        "mean": mean / diag,
        "cv": if mean > 0.0 { var.sqrt() / mean } else { f64::NAN },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A square lattice of spacing 1 covers its own points at ratio 0 and the cell centres at
    /// √½ spacing; the local spacing is the lattice's.
    #[test]
    fn a_lattice_has_its_spacing_and_covers_its_cells() {
        let particles: Vec<DVec3> = (0..40)
            .flat_map(|i| (0..40).map(move |j| DVec3::new(i as f64, j as f64, 0.0)))
            .collect();
        let nn = nearest_neighbour_distances(&particles);
        let inputs = vec![DVec3::new(20.5, 20.5, 0.0), DVec3::new(10.0, 10.0, 0.0)];
        let c = coverage(&particles, &nn, &inputs, 1.0);
        assert!((c["max"].as_f64().unwrap() - 0.5f64.sqrt()).abs() < 1e-12);
        assert!((c["median_local_spacing"].as_f64().unwrap() - 1.0).abs() < 1e-12);
        let s = spacing_stats(&nn, &vec![true; nn.len()], 10.0);
        assert!((s["median"].as_f64().unwrap() - 0.1).abs() < 1e-12);
        assert!(s["cv"].as_f64().unwrap().abs() < 1e-12);
    }

    /// One particle alone: its ball has no spacing, so the ceiling is the yardstick.
    #[test]
    fn a_lone_particle_is_judged_by_the_ceiling() {
        let particles = vec![DVec3::ZERO];
        let nn = nearest_neighbour_distances(&particles);
        let c = coverage(&particles, &nn, &[DVec3::new(3.0, 0.0, 0.0)], 0.5);
        assert!((c["max"].as_f64().unwrap() - 6.0).abs() < 1e-12);
        assert_eq!(c["beyond_2.5"], 1);
    }

    /// Two squares of side 4 side by side, sampled at random, the left one four times as
    /// densely: flagging the right one is a fifth of the points and half of the area (up to
    /// the rims, where the balls hold fewer points, and the spread of the counts).
    #[test]
    fn a_denser_half_counts_once_by_area() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(3);
        let mut square = |x0: f64, n: usize| -> Vec<DVec3> {
            (0..n)
                .map(|_| {
                    DVec3::new(
                        x0 + rng.random_range(0.0..4.0),
                        rng.random_range(0.0..4.0),
                        0.0,
                    )
                })
                .collect()
        };
        let mut points = square(0.0, 25_600);
        points.extend(square(4.0, 6_400));
        let flagged: Vec<bool> = (0..points.len()).map(|i| i >= 25_600).collect();
        let by_area = share_by_area(&points, &flagged, 0.12);
        assert!((by_area - 0.5).abs() < 0.03, "{by_area}");
    }

    #[test]
    fn level_cv_skips_small_levels() {
        let report = json!({"particles": {"after": {"levels": [
            {"depth": 5, "spacing": {"count": 100, "cv": 0.1}},
            {"depth": 6, "spacing": {"count": 400, "cv": 0.13}},
            {"depth": 8, "spacing": {"count": 4, "cv": 0.9}},
        ]}}});
        let (worst, text) = level_cv(&report);
        assert_eq!(worst, 0.13);
        assert_eq!(text, "5:0.100 6:0.130 8:0.900(n=4)");
    }
}
