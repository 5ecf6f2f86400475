//! Normals of a point cloud that has none: a least-squares plane per point over an adaptive
//! neighbourhood. Among its 12, 16, 24, 32 and 48 nearest points, the neighbourhood with the
//! smallest surface variation λ0/(λ0+λ1+λ2) is taken (after Pauly et al. 2002 and Mitra and
//! Nguyen 2003): noise favours larger neighbourhoods (its share of the variance falls with the
//! radius), curvature and a nearby second sheet (a thin part) smaller ones, and counting
//! neighbours rather than a fixed radius follows changes of density.
//!
//! Counting neighbours alone would let the noise decide at high density: ten times the points
//! of the same noisy surface shrink every neighbourhood by √10 while the noise stays (measured
//! on the dragon in the note below). Where the estimated
//! noise exceeds a tenth of the radius of the 48 nearest points, the planes are fitted among
//! one point in 4^L (L the least level that brings the noise under a tenth of that subset's
//! radius; a hash of the position picks the points), and each point takes the plane of the
//! nearest of those around it in Morton order (notes: docs/notes/2026-11-29-surface-leaves.md). The normals come out
//! unoriented; `orient_normals` or `orient_toward` give them a side.

use glam::DVec3;
use psi_octree::{Monitor, MortonIndex};
use rayon::prelude::*;

use crate::estimate_noise::{NEIGHBOURS, noise_and_reach_in};

use crate::local_fit::Moments;

/// The neighbourhood sizes tried, ascending.
const SIZES: [usize; 5] = [12, 16, 24, 32, 48];

/// Unit normals of `positions` (shape: N, world units) from plane fits over adaptive
/// neighbourhoods (shape of the result: N; each sign arbitrary). A point whose neighbourhood
/// is degenerate (all neighbours on a line, or fewer than 3 points in all) gets the zero vector.
/// Deterministic and independent of the thread count.
///
/// ```
/// use glam::DVec3;
/// use psi_preprocess::estimate_normals;
///
/// // A grid in the plane z = x: normals ±(−1, 0, 1)/√2.
/// let grid: Vec<DVec3> = (0..400)
///     .map(|i| DVec3::new((i % 20) as f64, (i / 20) as f64, (i % 20) as f64))
///     .collect();
/// for n in estimate_normals(&grid) {
///     assert!((n.dot(DVec3::new(-1.0, 0.0, 1.0)).abs() - 2f64.sqrt()).abs() < 1e-9);
/// }
/// ```
pub fn estimate_normals(positions: &[DVec3]) -> Vec<DVec3> {
    estimate_normals_with(positions, &Monitor::silent())
}

/// [`estimate_normals`], stopping early once `monitor`'s flag is set (checked per cell of a
/// few dozen points, before their searches; the caller then discards the result).
pub fn estimate_normals_with(positions: &[DVec3], monitor: &Monitor<'_>) -> Vec<DVec3> {
    // The points in Morton order (slots), each with its nearest others in one sweep.
    let index = MortonIndex::new(positions);
    let (noise, reach) = noise_and_reach_in(positions, &index);
    let level = noise_level(noise.sigma, reach);
    estimate_normals_in(positions.len(), &index, level, monitor)
}

/// The coarseness level at which [`estimate_normals`] fits its planes, for points with noise
/// `sigma` whose 32 nearest lie within `reach` (medians, world units: what
/// [`crate::noise_by_rounds`] gives): the least L ≥ 0 at which `sigma` is at most
/// 0.1 times the radius of the 48 nearest points among one in 4^L (radii
/// grow as 2^L), at most 6. At level 0 every point's plane is its own
/// neighbourhood's ([`crate::part_normals`] computes those by parts).
pub fn noise_level(sigma: f64, reach: f64) -> u32 {
    // The radius of the k nearest on a surface grows as √k.
    let largest = SIZES[SIZES.len() - 1];
    let radius = reach * (largest as f64 / NEIGHBOURS as f64).sqrt();
    (0..MAX_LEVEL)
        .find(|&l| sigma <= NOISE_PER_RADIUS * radius * f64::from(1u32 << l))
        .unwrap_or(MAX_LEVEL)
}

/// The noise the planes' neighbourhoods tolerate, as a share of their radius: a plane over 48
/// points ten noise deviations around tilts by about 3° from the noise (its slope's standard
/// error, σ/r·√(4/k) for points spread evenly over a disc of radius r).
const NOISE_PER_RADIUS: f64 = 0.1;

/// The coarsest level: one point in 4^6 (radii 64 times the full cloud's).
const MAX_LEVEL: u32 = 6;

/// A point of a finer level takes the normal of the nearest of the coarser level's this many
/// points before it and this many after it in Morton order: nearly the exact nearest point's
/// normals in a third of its time (docs/notes/2026-11-29-surface-leaves.md).
const AROUND: usize = 4;

/// Levels above 0 keep at least this many points, else level 0 is used.
pub const LEVEL_POINTS: usize = 4 * SIZES[SIZES.len() - 1];

/// [`estimate_normals_with`] of the `n` points that `index` indexes (ids 0..n; a point left
/// out of it gets no normal), at coarseness `level` ([`noise_level`]): above 0, the normals
/// of the level's points ([`in_level`]) are estimated among them, and each other point takes
/// that of the nearest of the level's [`AROUND`] points on either side in Morton order.
pub(crate) fn estimate_normals_in(
    n: usize,
    index: &MortonIndex,
    level: u32,
    monitor: &Monitor<'_>,
) -> Vec<DVec3> {
    let by_slot = index.points();
    // The level's points, indexed alone: the order below is theirs, whatever `index`'s frame.
    // They are taken in input order, so that ties among their neighbours go to the lower input
    // index, as a part of the points sees them (`level_by_parts.rs`).
    let coarse = (level > 0)
        .then(|| {
            let mut chosen: Vec<(u32, DVec3)> = index
                .ids()
                .par_iter()
                .zip(by_slot)
                .filter(|(_, p)| in_level(**p, level))
                .map(|(&i, &p)| (i, p))
                .collect();
            chosen.par_sort_unstable_by_key(|c| c.0);
            let points: Vec<DVec3> = chosen.into_iter().map(|c| c.1).collect();
            MortonIndex::new(&points)
        })
        .filter(|sub| sub.len() >= LEVEL_POINTS);
    let normals = match &coarse {
        None => slot_normals(index, monitor),
        Some(sub) => slot_normals(sub, monitor).map(|of_sub| {
            by_slot
                .par_iter()
                .map(|&p| nearest_in_level(sub, p).map_or(DVec3::ZERO, |t| of_sub[t]))
                .collect()
        }),
    };
    let Ok(normals) = normals else {
        return vec![DVec3::ZERO; n];
    };
    // Back to the caller's order (a point with a non-finite coordinate has no normal): each
    // point's slot (4 bytes a point written at random, on one core), then the normals gathered
    // in parallel.
    let mut slot_of = vec![u32::MAX; n];
    for (s, &i) in index.ids().iter().enumerate() {
        slot_of[i as usize] = s as u32;
    }
    slot_of
        .into_par_iter()
        .map(|s| normals.get(s as usize).copied().unwrap_or(DVec3::ZERO))
        .collect()
}

/// The slot in `level`'s Morton order (an index of a level's points alone) of the nearest of
/// its points among the [`AROUND`] on either side of `p`'s place in that order (the first on a
/// tie; a point of the level finds itself; world units): a point's nearest is there but for
/// the order's jumps. `None` for an empty level.
pub(crate) fn nearest_in_level(level: &MortonIndex, p: DVec3) -> Option<usize> {
    let of = level.points();
    let at = level.rank_of(p);
    let d2 = |t: usize| (of[t] - p).length_squared();
    (at.saturating_sub(AROUND)..(at + AROUND).min(of.len()))
        .min_by(|&x, &y| d2(x).total_cmp(&d2(y)))
}

/// Whether a point at `p` (world units) belongs to coarseness `level`: one point in 4^level,
/// nested (a point of a level belongs to every finer one), by a hash of its coordinates' bits,
/// so the levels depend on the positions alone, not on their order.
pub fn in_level(p: DVec3, level: u32) -> bool {
    let mut h = 0x9E37_79B9_7F4A_7C15u64;
    for c in [p.x, p.y, p.z] {
        h = mix(h ^ c.to_bits());
    }
    level == 0 || h >> (64 - 2 * level) == 0
}

/// SplitMix64's finaliser (Steele, Lea and Flood 2014): a bijection of u64 whose output bits
/// each depend on every input bit.
fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Per slot of `index`, the unit normal of the plane of its least varied neighbourhood (zero
/// when none has a plane).
fn slot_normals(
    index: &MortonIndex,
    monitor: &Monitor<'_>,
) -> Result<Vec<DVec3>, psi_octree::Interrupted> {
    let by_slot = index.points();
    index.map_nearest_with(NEIGHBOURHOOD - 1, monitor, |s, near| {
        plane_normal(by_slot, s, near)
    })
}

/// The most neighbours a plane is fitted to (the point itself included).
pub(crate) const NEIGHBOURHOOD: usize = SIZES[SIZES.len() - 1];

/// The unit normal of the plane of slot `s`'s least varied neighbourhood among its `near`
/// others (slots and squared distances, nearest first; `by_slot` the index's points), zero
/// when none has a plane.
pub(crate) fn plane_normal(by_slot: &[DVec3], s: usize, near: &[(u32, f64)]) -> DVec3 {
    let p = by_slot[s];
    let mut moments = Moments::around(p);
    // The neighbourhoods by variation (eigenvalues only), then the plane of the least
    // varied one that has a plane (the closed form and the decomposition can disagree
    // at the flatness limit).
    // (A fixed array: no allocation per point.)
    let mut tried = [(f64::INFINITY, Moments::default()); SIZES.len()];
    let mut count = 0;
    let mut sizes = SIZES.iter().peekable();
    // The point itself, then its neighbours nearest first.
    let points = std::iter::once(p).chain(near.iter().map(|&(t, _)| by_slot[t as usize]));
    for q in points {
        moments.add(q);
        if sizes.peek() == Some(&&moments.count()) {
            sizes.next();
            if let Some(v) = moments.variation() {
                tried[count] = (v, moments);
                count += 1;
            }
        }
    }
    // Stable: equal variations keep the smaller neighbourhood first.
    let tried = &mut tried[..count];
    tried.sort_by(|a, b| a.0.total_cmp(&b.0));
    // None of the sizes (fewer points than the smallest): the plane of all of them.
    tried
        .iter()
        .find_map(|(_, m)| m.plane())
        .or_else(|| moments.plane())
        .map_or(DVec3::ZERO, |fit| fit.normal)
}

#[cfg(test)]
mod tests {
    use super::*;
    use psi_shapes::AnalyticShape;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64Mcg;

    /// A sphere's estimated normals against the analytic ones, clean and with noise of a
    /// third of the sample spacing along the normal.
    #[test]
    fn sphere_normals_match_the_analytic_ones() {
        let sphere = AnalyticShape::Sphere { radius: 1.0 };
        let points = sphere.sample(20_000, 3);
        let spacing = (4.0 * std::f64::consts::PI / 20_000.0).sqrt();
        let mut rng = Pcg64Mcg::seed_from_u64(9);
        for noise in [0.0, spacing / 3.0] {
            let positions: Vec<DVec3> = points
                .iter()
                .map(|p| p.p + noise * (rng.random::<f64>() * 2.0 - 1.0) * p.n)
                .collect();
            let normals = estimate_normals(&positions);
            let mut worst = 0.0f64;
            let mut mean = 0.0;
            for (n, p) in normals.iter().zip(&points) {
                let angle = n.dot(p.n).abs().min(1.0).acos().to_degrees();
                worst = worst.max(angle);
                mean += angle / points.len() as f64;
            }
            let (mean_limit, worst_limit) = if noise == 0.0 {
                (1.0, 6.0)
            } else {
                (3.0, 15.0)
            };
            assert!(
                mean < mean_limit && worst < worst_limit,
                "noise {noise}: mean {mean:.2}°, worst {worst:.2}°"
            );
        }
    }

    /// Two parallel sheets closer than the largest neighbourhood: the adaptive choice keeps
    /// each point's normal across the sheets (a fixed 48-neighbourhood would mix them).
    #[test]
    fn thin_slabs_keep_their_normals() {
        let slab = AnalyticShape::Box {
            half: DVec3::new(0.5, 0.5, 0.02),
        }
        .sample(20_000, 4);
        let positions: Vec<DVec3> = slab.iter().map(|p| p.p).collect();
        let normals = estimate_normals(&positions);
        let faces: Vec<usize> = (0..slab.len())
            .filter(|&i| {
                slab[i].n.z.abs() > 0.99 && slab[i].p.x.abs() < 0.45 && slab[i].p.y.abs() < 0.45
            })
            .collect();
        let bad = faces.iter().filter(|&&i| normals[i].z.abs() < 0.95).count();
        assert!(bad * 200 < faces.len(), "{bad} of {} tilted", faces.len());
    }

    /// The median angle (degrees) between `normals` and the unit sphere's at `points`.
    fn median_error(points: &[DVec3], normals: &[DVec3]) -> f64 {
        let mut angles: Vec<f64> = points
            .iter()
            .zip(normals)
            .map(|(p, n)| n.dot(p.normalize()).abs().min(1.0).acos().to_degrees())
            .collect();
        angles.sort_by(f64::total_cmp);
        angles[angles.len() / 2]
    }

    /// Ten times the points of the same noisy sphere: counting neighbours alone, the normals
    /// get worse with the density (the noise's share of a shrinking neighbourhood); with the
    /// coarser level the noise asks for they stay near the sparser sampling's (the oracle: the
    /// sphere's own normals).
    #[test]
    fn denser_noisy_samplings_keep_their_normals() {
        let sphere = AnalyticShape::Sphere { radius: 1.0 };
        let mut rng = Pcg64Mcg::seed_from_u64(5);
        let sigma = 0.005;
        let mut noisy = |n: usize, seed: u64| -> Vec<DVec3> {
            sphere
                .sample(n, seed)
                .iter()
                .map(|p| p.p + sigma * psi_shapes::gaussian_vector(&mut rng))
                .collect()
        };
        let sparse = noisy(20_000, 1);
        let dense = noisy(200_000, 2);
        let level = |points: &[DVec3]| {
            let index = MortonIndex::new(points);
            let (noise, reach) = noise_and_reach_in(points, &index);
            (noise_level(noise.sigma, reach), index)
        };
        let (sparse_level, _) = level(&sparse);
        let (dense_level, index) = level(&dense);
        assert_eq!((sparse_level, dense_level), (0, 1));
        let sparse_error = median_error(&sparse, &estimate_normals(&sparse));
        let dense_normals = estimate_normals(&dense);
        let dense_error = median_error(&dense, &dense_normals);
        // The normals are a function of the positions: an index in another frame (made with a
        // far point, then retained without it, as the preprocessing carries one) gives them.
        let mut with_far = dense.clone();
        with_far.push(DVec3::splat(40.0));
        let mut keep = vec![true; with_far.len()];
        keep[dense.len()] = false;
        let carried = MortonIndex::new(&with_far).retained(&keep);
        let silent = Monitor::silent();
        assert!(estimate_normals_in(dense.len(), &carried, 1, &silent) == dense_normals);
        let counted = estimate_normals_in(dense.len(), &index, 0, &silent);
        let counted_error = median_error(&dense, &counted);
        eprintln!(
            "median errors: sparse {sparse_error:.2}°, dense {dense_error:.2}°, dense at level 0 {counted_error:.2}°"
        );
        assert!(counted_error > 2.5 * sparse_error);
        assert!(dense_error < 0.6 * counted_error && dense_error < 2.0 * sparse_error);
    }

    #[test]
    fn the_level_is_the_least_that_brings_the_noise_under_a_tenth_of_the_radius() {
        // 32 nearest within 1: the 48 nearest within √1.5.
        let radius = 1.5f64.sqrt();
        assert_eq!(noise_level(0.0, 1.0), 0);
        assert_eq!(noise_level(0.1 * radius, 1.0), 0);
        assert_eq!(noise_level(0.1 * radius * 1.01, 1.0), 1);
        assert_eq!(noise_level(0.1 * radius * 2.0, 1.0), 1);
        assert_eq!(noise_level(0.1 * radius * 2.02, 1.0), 2);
        assert_eq!(noise_level(1e9, 1.0), MAX_LEVEL);
        // No neighbours measured (reach 0) with noise: the coarsest.
        assert_eq!(noise_level(1.0, 0.0), MAX_LEVEL);
    }

    #[test]
    fn levels_nest_and_keep_about_one_point_in_four_per_level() {
        let sphere = AnalyticShape::Sphere { radius: 1.0 }.sample(40_000, 7);
        for level in 1..4 {
            let kept = sphere.iter().filter(|p| in_level(p.p, level)).count();
            let expected = sphere.len() as f64 / 4f64.powi(level as i32);
            assert!(
                (kept as f64 / expected - 1.0).abs() < 0.1,
                "level {level}: {kept}"
            );
            assert!(
                sphere
                    .iter()
                    .all(|p| !in_level(p.p, level) || in_level(p.p, level - 1))
            );
        }
    }

    #[test]
    fn tiny_and_degenerate_inputs_do_not_panic() {
        assert!(estimate_normals(&[]).is_empty());
        assert_eq!(estimate_normals(&[DVec3::ZERO; 2]), vec![DVec3::ZERO; 2]);
        // Coincident points and a (slightly noisy) line have no plane: zero normals, not an
        // arbitrary direction.
        assert_eq!(estimate_normals(&[DVec3::ONE; 5]), vec![DVec3::ZERO; 5]);
        let line: Vec<DVec3> = (0..20)
            .map(|i| DVec3::new(i as f64, 1e-4 * (i % 3) as f64, 0.0))
            .collect();
        assert_eq!(estimate_normals(&line), vec![DVec3::ZERO; 20]);
        // A plane sampled along rows far apart still gets its normal once the neighbourhood
        // reaches across rows.
        let rows: Vec<DVec3> = (0..400)
            .map(|i| DVec3::new(0.01 * (i % 100) as f64, (i / 100) as f64 * 0.2, 0.0))
            .collect();
        for n in estimate_normals(&rows) {
            assert!(n.z.abs() > 0.999_999, "{n}");
        }
    }
}
