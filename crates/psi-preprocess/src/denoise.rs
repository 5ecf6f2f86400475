//! Noise taken out of the positions before the fit: each point moved along the normal onto a
//! least-squares surface of its neighbours on the same sheet (one step of moving least squares,
//! after Alexa et al. 2001, with a quadric so that curvature is kept), the neighbourhood about
//! 4.5 noise deviations across. A full quadric over k points places its middle with a variance
//! several times σ²/k (its curvature terms are estimated from the same points), so the
//! curvature comes from three times as many points and only the offset and tilt from the k
//! nearest. The normals become the quadric's normals there. The constants were chosen on the
//! bunny with noise of 0.25 % and 0.5 % of D (`cargo xtask scans`; docs/notes/2026-11-24-real-scans.md).
//!
//! Everything a point's move reads is a function of the points and their input order: the
//! neighbourhood's size comes from the median reach of every ⌈N/256⌉-th point by input index
//! ([`DenoiseScale`]), and a point's neighbours are taken in (distance, input index) order. So
//! a part of the points with a halo around it (a tile) moves its own points bitwise as the
//! whole does ([`part_denoise_samples`], [`part_denoise`]; the in-core [`denoise`] is the
//! whole as one part).

use std::sync::atomic::{AtomicBool, Ordering};

use glam::DVec3;
use psi_octree::{Monitor, MortonIndex, OrientedPoint, PointIndex};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::local_fit::QuadricFit;
use crate::median::median;
use crate::orient_by_parts::{IncompletePart, certified};

/// The neighbourhood's radius in noise deviations.
const REACH_PER_SIGMA: f64 = 4.5;

/// Neighbours per fit: at least …
const MIN_NEIGHBOURS: usize = 24;

/// … and at most.
const MAX_NEIGHBOURS: usize = 200;

/// The quadric's curvature is fitted to this many times the neighbours whose offset and tilt
/// place the point.
const CURVATURE_SPAN: usize = 3;

/// The ball searched for the wide neighbourhood: this multiple of its median radius.
const WIDE_BALL: f64 = 1.15;

/// Points whose reach sets the neighbourhood's size: at most this many, evenly by input index.
const SCALE_SAMPLES: usize = 256;

/// What [`denoise`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct DenoiseReport {
    /// Neighbours per fit.
    pub neighbours: usize,
    /// Points moved.
    pub moved: usize,
    /// The root mean square of the moves, world units.
    pub rms_move: f64,
}

impl DenoiseReport {
    /// The report of a denoising with `neighbours` neighbours per fit that moved `moved`
    /// points, the squares of their moves summed to `sum2` (world units², in input order).
    pub fn of_sum(neighbours: usize, moved: usize, sum2: f64) -> Self {
        DenoiseReport {
            neighbours,
            moved,
            rms_move: (sum2 / moved.max(1) as f64).sqrt(),
        }
    }
}

/// The neighbourhoods of a denoising of N points with noise σ, from the reach of its samples
/// ([`DenoiseScale::of`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct DenoiseScale {
    /// N, the points of the whole set.
    pub population: usize,
    /// k: the nearest neighbours whose offset and tilt place a point (24 to 200, at most N).
    pub neighbours: usize,
    /// The nearest neighbours its curvature is fitted to (3k, at most N).
    pub wide: usize,
    /// The median distance of a sample to its `wide`-th nearest point (world units): the ball
    /// searched first for a point's wide neighbourhood.
    pub wide_reach: f64,
}

/// The samples of the scale among `population` points: those whose input index is a multiple
/// of this.
fn sample_stride(population: usize) -> usize {
    population.div_ceil(SCALE_SAMPLES).max(1)
}

/// How many nearest distances a sample gives: enough for the widest neighbourhood.
fn sample_depth(population: usize) -> usize {
    (CURVATURE_SPAN * MAX_NEIGHBOURS).min(population)
}

impl DenoiseScale {
    /// The neighbourhoods for `population` points with noise deviation `sigma` (world units),
    /// from `samples` (each sample's distances to its nearest points, itself first, ascending,
    /// world units: what [`part_denoise_samples`] gives over all parts, in any order): k such
    /// that the neighbourhood's radius is about 4.5 σ (16 neighbours reach the samples' median
    /// distance to their 17th nearest, and the count grows with the area). `None` when there is
    /// nothing to denoise (fewer than 24 points, σ not positive).
    pub fn of(population: usize, sigma: f64, samples: &[Vec<f64>]) -> Option<Self> {
        let n = population;
        if n < MIN_NEIGHBOURS || sigma.is_nan() || sigma <= 0.0 {
            return None;
        }
        // The median distance to the `count`-th nearest (the farthest found, for fewer).
        let reach = |count: usize| {
            let mut r: Vec<f64> = samples
                .iter()
                .map(|s| s.get(count - 1).or(s.last()).copied().unwrap_or(0.0))
                .collect();
            median(&mut r)
        };
        let reach16 = reach(17);
        let wanted = 16.0 * (REACH_PER_SIGMA * sigma / reach16.max(f64::MIN_POSITIVE)).powi(2);
        let neighbours = (wanted.ceil() as usize)
            .clamp(MIN_NEIGHBOURS, MAX_NEIGHBOURS)
            .min(n);
        let wide = (CURVATURE_SPAN * neighbours).min(n);
        Some(DenoiseScale {
            population: n,
            neighbours,
            wide,
            wide_reach: reach(wide),
        })
    }
}

/// A neighbour (local index `j`, squared distance `d2` ≥ 0) as one key that orders by
/// distance, then index (a non-negative float's bits order as the numbers): sorting keys is
/// several times quicker than sorting pairs by a comparison.
fn neighbour_key(j: u32, d2: f64) -> u128 {
    (u128::from(d2.to_bits()) << 32) | u128::from(j)
}

/// The squared distance of a neighbour's key.
fn key_distance2(key: u128) -> f64 {
    f64::from_bits((key >> 32) as u64)
}

/// The reach (world units) of `found` neighbours whose farthest lies at squared distance `d2`,
/// sought `count` at a time among `held` of `population` points: its distance, or infinite
/// when fewer were found than sought while some points are not held (they may be nearer).
fn reach_of(d2: f64, found: usize, count: usize, (held, population): (usize, usize)) -> f64 {
    if found < count && held < population {
        f64::INFINITY
    } else {
        d2.sqrt()
    }
}

/// The scale's samples among a part's own points: `positions` (shape: M, world units) its own
/// points and its halo, `ids` (shape: M) their input indices, ascending, `own` (shape: M)
/// which are its own, `population` the points of the whole set; `complete(x, r)` tells whether
/// every point of the whole set within `r` of `x` is among `positions`. Per own point whose
/// input index is a multiple of ⌈N/256⌉: its distances to its nearest points (itself first, up
/// to 600; world units, ascending), in no particular order; or the uncertain sample whose
/// neighbours reach farthest.
///
/// # Panics
///
/// When the lengths differ or `ids` do not ascend.
pub fn part_denoise_samples(
    positions: &[DVec3],
    ids: &[u32],
    own: &[bool],
    complete: &(dyn Fn(DVec3, f64) -> bool + Sync),
    population: usize,
) -> Result<Vec<Vec<f64>>, IncompletePart> {
    assert!(positions.len() == ids.len() && ids.len() == own.len());
    assert!(ids.is_sorted(), "ids ascend");
    let (stride, depth) = (sample_stride(population), sample_depth(population));
    let samples: Vec<usize> = (0..positions.len())
        .filter(|&i| own[i] && (ids[i] as usize).is_multiple_of(stride))
        .collect();
    if samples.is_empty() {
        return Ok(Vec::new());
    }
    let index = MortonIndex::new(positions);
    let rows = samples
        .par_iter()
        .map(|&i| {
            let near = index.nearest(positions[i], depth);
            let farthest = near.last().map_or(0.0, |n| n.1);
            let reach = reach_of(farthest, near.len(), depth, (positions.len(), population));
            if !complete(positions[i], reach) {
                return Err(IncompletePart {
                    id: ids[i],
                    neighbours: depth,
                    reach,
                });
            }
            Ok(near.iter().map(|n| n.1.sqrt()).collect())
        })
        .collect();
    certified(rows)
}

/// The moves of a part's own points: `points` (shape: M, world units, unit normals
/// consistently oriented) its own points and its halo, `ids`, `own` and `complete` as
/// [`part_denoise_samples`] takes them, `scale` the whole set's. Per own point, in the order
/// of `points`: where it moves to with its new normal (`None`: it stays, its same-side
/// neighbours give no fit, or `monitor`'s flag was set), bitwise what [`denoise`] of the whole
/// set gives it; or the uncertain point whose neighbours reach farthest.
///
/// # Panics
///
/// When the lengths differ or `ids` do not ascend.
pub fn part_denoise(
    points: &[OrientedPoint],
    ids: &[u32],
    own: &[bool],
    complete: &(dyn Fn(DVec3, f64) -> bool + Sync),
    scale: &DenoiseScale,
    monitor: &Monitor<'_>,
) -> Result<Vec<Option<OrientedPoint>>, IncompletePart> {
    assert!(points.len() == ids.len() && ids.len() == own.len());
    assert!(ids.is_sorted(), "ids ascend");
    let positions: Vec<DVec3> = points.iter().map(|p| p.p).collect();
    // Ties among neighbours go to the lower local index, which is the lower input index.
    let index = MortonIndex::new(&positions);
    let slot_ids = index.ids();
    // (Ball queries on a kd-tree: about twice as quick as on the Morton index here.)
    let balls = PointIndex::new(&positions);
    let (k, wide) = (scale.neighbours, scale.wide);
    let incomplete = AtomicBool::new(false);
    // The `count` nearest points to `at` as keys (chosen in (distance, index) order; in no
    // order), and the farthest's squared distance: from the ball of `radius` about `at` when
    // it holds that many well inside (a ball query cut to the nearest is cheaper than a
    // k-nearest query for such counts, notes: 2026-11-24-real-scans.md; the distances are
    // taken again here, so that the choice does not depend on the tree's arithmetic), else
    // from the k-nearest query.
    let nearest = |at: DVec3, count: usize, radius: f64| -> (Vec<u128>, f64) {
        let mut ball = Vec::new();
        balls.within(at, radius, &mut ball);
        if ball.len() >= count {
            let mut near: Vec<u128> = ball
                .iter()
                .map(|&j| neighbour_key(j, (positions[j as usize] - at).length_squared()))
                .collect();
            near.select_nth_unstable(count - 1);
            near.truncate(count);
            let farthest = key_distance2(near[count - 1]);
            if farthest < radius * radius * (1.0 - 1e-9) {
                return (near, farthest);
            }
        }
        let near = index.nearest(at, count);
        let farthest = near.last().map_or(0.0, |n| n.1);
        let keys = near
            .iter()
            .map(|&(s, d2)| neighbour_key(slot_ids[s as usize], d2))
            .collect();
        (keys, farthest)
    };
    // The positions of the points `keys` on the side of `normal`, in index order (the fits'
    // sums then do not depend on how the neighbours were found).
    let same_side = |keys: &[u128], normal: DVec3| {
        let mut ids: Vec<u32> = keys.iter().map(|&k| k as u32).collect();
        ids.sort_unstable();
        ids.iter()
            .map(|&j| j as usize)
            .filter(|&j| points[j].n.dot(normal) > 0.0)
            .map(|j| positions[j])
            .collect::<Vec<DVec3>>()
    };
    // The move of own point `i`: the quadric of its neighbourhood, curvature from its 3k
    // nearest on its side, offset and tilt from its k nearest (of the former); the position
    // from the refined fit, the normal from the wide one (its tilt is averaged over more
    // points).
    let move_of = |i: usize| -> Result<Option<OrientedPoint>, IncompletePart> {
        let p = &points[i];
        let (mut near, farthest) = nearest(p.p, wide, WIDE_BALL * scale.wide_reach);
        let reach = reach_of(farthest, near.len(), wide, (points.len(), scale.population));
        if !complete(p.p, reach) {
            incomplete.store(true, Ordering::Relaxed);
            return Err(IncompletePart {
                id: ids[i],
                neighbours: wide,
                reach,
            });
        }
        // (Once a point is uncertain the part is tried again: the others' reaches alone are
        // wanted now, for the halo.)
        if monitor.stopped() || incomplete.load(Ordering::Relaxed) {
            return Ok(None);
        }
        let Some(fit) = QuadricFit::of(&same_side(&near, p.n), farthest.sqrt()) else {
            return Ok(None);
        };
        let k = k.min(near.len());
        if k < near.len() {
            near.select_nth_unstable(k - 1);
        }
        let refined = fit.refined(&same_side(&near[..k], p.n));
        let q = p.p - refined.height(p.p) * refined.normal();
        let normal = fit.normal_at(q);
        if !q.is_finite() || normal == DVec3::ZERO {
            return Ok(None);
        }
        let n = if normal.dot(p.n) < 0.0 {
            -normal
        } else {
            normal
        };
        Ok(Some(OrientedPoint { p: q, n }))
    };
    // In Morton order (neighbouring points share cache), then back in the points' order.
    let by_slot: Vec<Result<(u32, Option<OrientedPoint>), IncompletePart>> = slot_ids
        .par_iter()
        .filter(|&&i| own[i as usize])
        .map(|&i| Ok((i, move_of(i as usize)?)))
        .collect();
    let mut moved = vec![None; points.len()];
    for (i, m) in certified(by_slot)? {
        moved[i as usize] = m;
    }
    Ok((0..points.len())
        .filter(|&i| own[i])
        .map(|i| moved[i])
        .collect())
}

/// Moves each of `points` (shape: N, world units, unit normals consistently oriented) along the
/// normal of its neighbourhood onto the least-squares quadratic height field of its k nearest
/// points whose normals face its own side (n_i·n_j > 0: the other face of a thin part is left
/// out); its normal becomes the height field's there. k is chosen so that the neighbourhood's
/// radius is about 4.5 noise deviations `sigma` (world units), between 24 and 200
/// ([`DenoiseScale`]). A point whose same-side neighbours give no fit is left as it is. Every
/// point moves from the old positions (the result does not depend on the thread count).
///
/// ```
/// use glam::DVec3;
/// use psi_octree::OrientedPoint;
/// use psi_preprocess::denoise;
///
/// // The plane z = 0 sampled every 1 with heights ±0.3 alternating: pulled flat.
/// let mut points: Vec<OrientedPoint> = (0..2500)
///     .map(|i| OrientedPoint {
///         p: DVec3::new((i % 50) as f64, (i / 50) as f64, if i % 2 == 0 { 0.3 } else { -0.3 }),
///         n: DVec3::Z,
///     })
///     .collect();
/// denoise(&mut points, 0.3);
/// let mean = points.iter().map(|p| p.p.z.abs()).sum::<f64>() / 2500.0;
/// assert!(mean < 0.05, "{mean}");
/// assert!(points.iter().all(|p| p.n.z > 0.9));
/// ```
pub fn denoise(points: &mut [OrientedPoint], sigma: f64) -> DenoiseReport {
    denoise_with(points, sigma, &Monitor::silent())
}

/// [`denoise`], stopping early once `monitor`'s flag is set (checked per point: the points
/// are then partly moved, and the caller discards them).
///
/// # Panics
///
/// When there are 2^32 − 1 points or more (indices are 32-bit).
pub fn denoise_with(
    points: &mut [OrientedPoint],
    sigma: f64,
    monitor: &Monitor<'_>,
) -> DenoiseReport {
    let n = points.len();
    if n < MIN_NEIGHBOURS || sigma.is_nan() || sigma <= 0.0 {
        return DenoiseReport::default();
    }
    // The whole set as its one part.
    let ids: Vec<u32> = (0..u32::try_from(n).expect("32-bit indices")).collect();
    let own = vec![true; n];
    let whole = |_: DVec3, _: f64| true;
    let positions: Vec<DVec3> = points.iter().map(|p| p.p).collect();
    let samples = part_denoise_samples(&positions, &ids, &own, &whole, n)
        .expect("the whole set holds every neighbour");
    drop(positions);
    let Some(scale) = DenoiseScale::of(n, sigma, &samples) else {
        return DenoiseReport::default();
    };
    let moved = part_denoise(points, &ids, &own, &whole, &scale, monitor)
        .expect("the whole set holds every neighbour");
    let (mut count, mut sum2) = (0, 0.0);
    for (p, m) in points.iter_mut().zip(moved) {
        if let Some(m) = m {
            sum2 += (m.p - p.p).length_squared();
            count += 1;
            *p = m;
        }
    }
    DenoiseReport::of_sum(scale.neighbours, count, sum2)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid_parts::{GridPart, grid_parts};
    use psi_shapes::{AnalyticShape, gaussian_vector};
    use rand::SeedableRng;
    use rand_pcg::Pcg64Mcg;

    /// `f` on each of the 27 grid parts of `positions`, each with the least halo (from 0.1,
    /// grown to the reach it asks for, or doubled) that certifies it; the results and how many parts grew.
    fn on_parts<T>(
        positions: &[DVec3],
        f: impl Fn(&GridPart) -> Result<T, IncompletePart>,
    ) -> (Vec<T>, usize) {
        let (mut out, mut grown) = (Vec::new(), 0);
        for c in 0..27 {
            let mut halo = 0.1;
            loop {
                let part = grid_parts(positions, 3, halo).swap_remove(c);
                match f(&part) {
                    Ok(t) => break out.push(t),
                    // (Fewer points held than sought: twice the halo.)
                    Err(e) => {
                        assert!(e.reach > halo, "{e:?}");
                        halo = if e.reach.is_finite() {
                            1.01 * e.reach
                        } else {
                            2.0 * halo
                        };
                        grown += 1;
                    }
                }
            }
        }
        (out, grown)
    }

    /// A noisy torus on 27 parts: the scale's samples and every point's move come out of the
    /// parts bit for bit as out of the whole set, some parts' halos grown to certify them.
    #[test]
    fn parts_move_the_points_bitwise_as_the_whole() {
        let torus = AnalyticShape::Torus {
            major: 1.0,
            minor: 0.35,
        };
        let n = 12_000;
        let spacing = (torus.area() / n as f64).sqrt();
        let sigma = 0.8 * spacing;
        let mut rng = Pcg64Mcg::seed_from_u64(11);
        let points: Vec<OrientedPoint> = torus
            .sample(n, 7)
            .iter()
            .map(|p| OrientedPoint {
                p: p.p + sigma * gaussian_vector(&mut rng),
                n: p.n,
            })
            .collect();
        let mut whole = points.clone();
        let report = denoise(&mut whole, sigma);
        assert!(report.neighbours > MIN_NEIGHBOURS && report.moved > n * 9 / 10);
        let positions: Vec<DVec3> = points.iter().map(|p| p.p).collect();
        let held = |part: &GridPart| -> Vec<OrientedPoint> {
            part.ids.iter().map(|&i| points[i as usize]).collect()
        };
        let (samples, _) = on_parts(&positions, |part| {
            let at: Vec<DVec3> = held(part).iter().map(|p| p.p).collect();
            let holds = |x: DVec3, r: f64| part.holds_ball(x, r);
            part_denoise_samples(&at, &part.ids, &part.own, &holds, n)
        });
        let samples: Vec<Vec<f64>> = samples.concat();
        assert_eq!(samples.len(), n.div_ceil(sample_stride(n)));
        let scale = DenoiseScale::of(n, sigma, &samples).unwrap();
        assert_eq!(scale.neighbours, report.neighbours);
        let (moves, grown) = on_parts(&positions, |part| {
            let holds = |x: DVec3, r: f64| part.holds_ball(x, r);
            let own_ids = part.ids.iter().zip(&part.own).filter(|o| *o.1);
            let moved = part_denoise(
                &held(part),
                &part.ids,
                &part.own,
                &holds,
                &scale,
                &Monitor::silent(),
            )?;
            Ok(own_ids.map(|(&i, _)| i).zip(moved).collect::<Vec<_>>())
        });
        assert!(grown > 0, "no part had to grow its halo");
        let mut by_parts = points.clone();
        for (i, m) in moves.into_iter().flatten() {
            if let Some(m) = m {
                by_parts[i as usize] = m;
            }
        }
        let differ = by_parts.iter().zip(&whole).filter(|(a, b)| a != b).count();
        assert_eq!(differ, 0, "{differ} points moved otherwise by parts");
    }

    /// A noisy torus comes out several times closer to the true surface, its normals closer to
    /// the true ones; a thin slab keeps both faces.
    #[test]
    fn noise_is_taken_out_and_sheets_kept_apart() {
        let torus = AnalyticShape::Torus {
            major: 1.0,
            minor: 0.35,
        };
        let truth = torus.sample(40_000, 3);
        let spacing = (torus.area() / 40_000.0).sqrt();
        let sigma = 0.7 * spacing;
        let mut rng = Pcg64Mcg::seed_from_u64(4);
        let mut points: Vec<OrientedPoint> = truth
            .iter()
            .map(|p| OrientedPoint {
                p: p.p + sigma * gaussian_vector(&mut rng),
                n: p.n,
            })
            .collect();
        let rms = |pts: &[OrientedPoint]| {
            (pts.iter()
                .map(|p| torus.signed_distance(p.p).powi(2))
                .sum::<f64>()
                / pts.len() as f64)
                .sqrt()
        };
        let before = rms(&points);
        denoise(&mut points, sigma);
        let after = rms(&points);
        assert!(after < 0.3 * before, "rms {before:.2e} -> {after:.2e}");
        let tilted = points
            .iter()
            .zip(&truth)
            .filter(|(p, t)| p.n.dot(t.n) < 10f64.to_radians().cos())
            .count();
        assert!(
            tilted * 10 < points.len(),
            "{tilted} normals off by more than 10°"
        );

        let slab = AnalyticShape::Box {
            half: DVec3::new(0.5, 0.5, 0.015),
        }
        .sample(30_000, 5);
        let mut thin = slab.clone();
        denoise(&mut thin, 0.5 * (2.1f64 / 30_000.0).sqrt());
        for (p, t) in thin.iter().zip(&slab) {
            if t.n.z.abs() > 0.99 && t.p.x.abs() < 0.45 && t.p.y.abs() < 0.45 {
                assert!((p.p.z - t.p.z).abs() < 2e-3, "{:?} -> {:?}", t.p, p.p);
            }
        }
    }
}
