//! The relaxation's data when the input does not fit: a thinned subset of the input points that
//! carries what the whole input says of each ([`PointFootprint`]: its spacing, whether it is
//! interior, the centroid of its neighbours, its hops from the data's edge), so that the
//! footprint test on the subset accepts where the whole test would (`psi_mpu`'s
//! `thinned_test`; docs/notes/2026-11-27-carried-footprint.md).
//!
//! Each region of the seeding holds the points of its leaves with a margin, so it measures the
//! footprint of its own points on the whole input there. It keeps every point within two hops
//! of the data's edge (where the test reads the input at its own resolution) and the others
//! whose position hash lies below the rate their place needs, or below the uniform share of
//! the budget the needs leave (`thinning.rs`): where the particles' data floor
//! is only a few input spacings (the finest levels of a dense input), a subset thinned alike
//! everywhere has gaps the whole input lacks, and its test refuses moves the whole test
//! accepts ([`needed_rate`]). A region of a random sampling, whose seeming edge
//! points are too many for a band, is not measured: its kept points take the whole test on the
//! subset's own points when the subset holds [`OWN_TEST_POINTS_PER_PARTICLE`] points a particle
//! or more, else the lenient test (docs/notes/2026-11-28-unmeasured-own-test.md). The
//! relaxation takes the regions' points in the seeding's order and thins them to its budget.

use glam::DVec3;
use psi_mpu::{DEEP, Mpu, PointFootprint};
use psi_octree::OrientedPoint;
use serde::{Deserialize, Serialize};

use crate::point_source::position_hash;
use crate::thinning::{Thinning, needed_rate};

/// A thinned subset of the input with the whole input's footprint at each point, in the order
/// of the seeding (octant, region, leaf, then input order: a function of the input and the
/// tiling, not of the threads or the workers).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ThinnedData {
    /// The points, world frame (shape: N).
    pub points: Vec<OrientedPoint>,
    /// What the whole input says of each (shape: N).
    pub footprints: Vec<PointFootprint>,
    /// The rate each point's place needs (`needed_rate`, scaled, in [0, 1]; shape: N): kept before
    /// the others when the budget is short (`ThinnedData::at_most`).
    pub need: Vec<f64>,
}

impl ThinnedData {
    /// Number of points.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Appends the points of `leaves` of `mpu` (an MPU over the points around them, its leaf
    /// indices the whole octree's; one region of the seeding) that lie in a band along the
    /// data's edge or whose position hash is below `thin.uniform` or below their need (the
    /// rate their place needs, [`needed_rate`] for the particles' floor at their leaf's depth,
    /// times `thin.need_scale`), with their footprint on `mpu`'s points and their need. The
    /// band is the points within two hops of the edge, or one, the widest that fits the
    /// region's share of the budget (`thin.rate` × its points), else none
    /// (an irregular sampling whose every tenth point looks like an edge point, or a tiny
    /// share: its points carry the median spacing of a sample of them): a bound on what the
    /// seeding carries. Each footprint records the hops tested exactly
    /// ([`PointFootprint::thinned_to`]); the relaxation narrows the bands alike everywhere
    /// ([`ThinnedData::at_most`]).
    /// `complete` as [`Mpu::point_footprints`]'.
    pub(crate) fn keep_from_region(
        &mut self,
        mpu: &mut Mpu,
        leaves: &[u32],
        thin: &Thinning,
        complete: &dyn Fn(DVec3, f64) -> bool,
    ) {
        let input = mpu.points();
        let tree = mpu.octree();
        // Each point with its leaf's data floor (leaf by leaf, in the leaves' order).
        let (qs, floors): (Vec<u32>, Vec<f64>) = leaves
            .iter()
            .flat_map(|&l| {
                let floor = thin.floors.at(tree.cell(l).depth);
                tree.points_in(l).iter().map(move |&q| (q, floor))
            })
            .unzip();
        let share = thin.rate * qs.len() as f64;
        let need = |spacing: f64, floor: f64| thin.need_scale * needed_rate(spacing, floor);
        // Measuring every point costs a 9-nearest query each; where the sample says that even
        // the one-hop band would not fit (an irregular sampling's many seeming edge points),
        // nothing is measured and every kept point takes the lenient test, or the whole test
        // on the kept points when they are many a particle (`ThinnedData::at_most`).
        let sample: Vec<u32> = qs.iter().copied().step_by(SAMPLE_STRIDE).collect();
        let seeming_edges = sample
            .iter()
            .filter(|&&q| {
                let x = input[q as usize].p;
                mpu.input_near_edge(q) && complete(x, 2.0 * mpu.input_spacing(q))
            })
            .count();
        let edge_share = seeming_edges as f64 / sample.len().max(1) as f64;
        if edge_share * ONE_HOP_PER_EDGE_POINT * qs.len() as f64 > share {
            // The region's input spacing: the median over the sample (its 9 nearest were read for
            // the edge test above).
            let mut spacings: Vec<f64> = sample.iter().map(|&q| mpu.input_spacing(q)).collect();
            spacings.sort_by(f64::total_cmp);
            let spacing = spacings.get(spacings.len() / 2).copied().unwrap_or(0.0);
            for (&q, &floor) in qs.iter().zip(&floors) {
                let p = input[q as usize];
                let need = need(spacing, floor);
                if position_hash(p.p) < thin.uniform.max(need) {
                    self.points.push(p);
                    self.footprints.push(PointFootprint::unmeasured(spacing));
                    self.need.push(need);
                }
            }
            return;
        }
        mpu.fill_footprint();
        let input = mpu.points();
        let footprints = mpu.point_footprints(&qs, complete);
        let within = |k: u8| footprints.iter().filter(|f| f.hops() < k).count() as f64;
        let band = [DEEP, DEEP - 1]
            .into_iter()
            .find(|&k| within(k) <= share)
            .unwrap_or(0);
        let exact = band.saturating_sub(1);
        for ((&q, f), &floor) in qs.iter().zip(footprints).zip(&floors) {
            let p = input[q as usize];
            let need = need(f.spacing(), floor);
            if f.hops() < band || position_hash(p.p) < thin.uniform.max(need) {
                self.points.push(p);
                self.footprints.push(f.thinned_to(thin.rate, exact));
                self.need.push(need);
            }
        }
    }

    /// Room for `more` points.
    pub(crate) fn reserve_exact(&mut self, more: usize) {
        self.points.reserve_exact(more);
        self.footprints.reserve_exact(more);
        self.need.reserve_exact(more);
    }

    /// Appends `other`'s points.
    pub(crate) fn extend(&mut self, other: ThinnedData) {
        self.points.extend(other.points);
        self.footprints.extend(other.footprints);
        self.need.extend(other.need);
    }

    /// The points of `parts` in their order, at most `at_most` of them: every point of the
    /// bands along the data's edge, then the points their place needs ([`ThinnedData::need`]),
    /// then the others of the lowest position hash (the regions kept those below `uniform`).
    /// The bands are the regions', narrowed alike everywhere (two hops wide, one, or none)
    /// until they take at most half the budget: a survey's edges are a small share of its
    /// points, a small scan's or an irregular sampling's may not be. Each footprint records the
    /// rate at which its place was kept and the hops tested exactly
    /// ([`PointFootprint::thinned_to`]). Unmeasured points take the whole test on the subset's
    /// own points when the subset holds at least [`OWN_TEST_POINTS_PER_PARTICLE`] points for
    /// each of the `particles` ([`PointFootprint::with_own_test`]). Which points are kept
    /// depends on the points and their needs, not on their order. The parts are taken one by
    /// one into the result, never joined first (the seeding's points are the run's largest
    /// array at that moment).
    pub(crate) fn at_most(
        parts: Vec<ThinnedData>,
        at_most: usize,
        uniform: f64,
        particles: usize,
    ) -> ThinnedData {
        assert!(
            parts
                .iter()
                .all(|p| p.need.len() == p.len() && p.footprints.len() == p.len()),
            "a thinned part's points, footprints and needs are as many"
        );
        let widest = [DEEP - 1, 1, 0];
        // A footprint with its band narrowed to at most `cap` hops tested exactly.
        let narrowed = |f: &PointFootprint, cap: u8| f.thinned_to(1.0, f.exact_hops().min(cap));
        let band_at = |cap: u8| {
            parts
                .iter()
                .flat_map(|p| &p.footprints)
                .filter(|f| in_band(&narrowed(f, cap)))
                .count()
        };
        let cap = widest
            .into_iter()
            .find(|&c| band_at(c) <= at_most / 2)
            .unwrap_or(0);
        let band = band_at(cap);
        // Each point's hash, need and whether it is in a band.
        let each = || {
            parts.iter().flat_map(|p| {
                let at = p.points.iter().zip(&p.footprints).zip(&p.need);
                at.map(|((q, f), &need)| (position_hash(q.p), need, in_band(&narrowed(f, cap))))
            })
        };
        // The others, those the regions kept (a narrowed band's outer points, kept whatever
        // their hash, are thinned alike): first those their place needs, then by hash.
        let others = each()
            .filter(|&(h, need, banded)| !banded && h < uniform.max(need))
            .map(|(h, need, _)| (h, need));
        let keep = KeepRates::within(others, uniform, at_most.saturating_sub(band));
        let kept = |(h, need, banded): (f64, f64, bool)| banded || keep.keeps(h, need);
        let count = each().filter(|&e| kept(e)).count();
        let own_test = count >= OWN_TEST_POINTS_PER_PARTICLE * particles;
        let mut out = ThinnedData {
            points: Vec::with_capacity(count),
            footprints: Vec::with_capacity(count),
            need: Vec::with_capacity(count),
        };
        for part in parts {
            let at = part.points.into_iter().zip(part.footprints).zip(part.need);
            for ((q, f), need) in at {
                let f = narrowed(&f, cap);
                if !kept((position_hash(q.p), need, in_band(&f))) {
                    continue;
                }
                // A rate of 0 (no deep point kept) would make the lenient test's reach
                // infinite.
                let f = f.thinned_to(keep.rate_for(need).clamp(1e-6, 1.0), f.exact_hops());
                out.points.push(q);
                out.footprints
                    .push(if own_test { f.with_own_test() } else { f });
                out.need.push(need);
            }
        }
        out
    }
}

/// The thresholds of [`ThinnedData::at_most`]: a point outside the bands, of position hash h
/// and need r, is kept when h < `uniform`, or when h < r and h/r < `scale` (the needed
/// points, by the one key they are ranked by).
#[derive(Clone, Copy, Debug, PartialEq)]
struct KeepRates {
    uniform: f64,
    scale: f64,
}

impl KeepRates {
    /// The thresholds that keep at most `room` of `points` (each its position hash and the
    /// rate its place needs; those the regions kept, below `max(uniform, need)`): every needed
    /// point (h < need) and the lowest hashes of the others up to `uniform` when they fit;
    /// else, when the needed points alone do not fit, those of the lowest h/need. Exactly
    /// `room` when there are more, unless hashes repeat (repeated positions) or h/need keys tie.
    fn within(points: impl Iterator<Item = (f64, f64)>, uniform: f64, room: usize) -> KeepRates {
        let (needed, rest): (Vec<_>, Vec<_>) = points.partition(|&(h, need)| h < need);
        if needed.len() > room {
            let mut keys: Vec<f64> = needed.iter().map(|&(h, need)| h / need).collect();
            let (_, &mut scale, _) = keys.select_nth_unstable_by(room, f64::total_cmp);
            return KeepRates {
                uniform: 0.0,
                scale,
            };
        }
        let left = room - needed.len();
        let mut hashes: Vec<f64> = rest.iter().map(|&(h, _)| h).collect();
        let uniform = if hashes.len() <= left {
            uniform
        } else {
            *hashes.select_nth_unstable_by(left, f64::total_cmp).1
        };
        KeepRates {
            uniform,
            scale: f64::INFINITY,
        }
    }

    /// Whether a point of position hash `h` whose place needs the rate `need` is kept.
    fn keeps(&self, h: f64, need: f64) -> bool {
        h < self.uniform || (h < need && h / need < self.scale)
    }

    /// The rate at which a point whose place needs the rate `need` was kept (the share of
    /// the input points around it that the subset holds).
    fn rate_for(&self, need: f64) -> f64 {
        self.uniform.max(need * self.scale.min(1.0))
    }
}

/// A thinned subset with at least this many points a particle is dense enough for the whole
/// test on its own points at its unmeasured points: its gaps, about the particles' spacing over
/// √64, lie far below the particles'. On subsets of a few points a particle the own test made
/// the spacing less even than the lenient one (measured: docs/notes/2026-11-28-unmeasured-own-test.md).
pub(crate) const OWN_TEST_POINTS_PER_PARTICLE: usize = 64;

/// One point in this many of a region is asked whether it is interior, to estimate its share
/// of edge points before measuring them all.
const SAMPLE_STRIDE: usize = 16;

/// Points within one hop of an edge per edge point, about (an isolated one and its 8 nearest;
/// fewer along an edge, where they share neighbours).
const ONE_HOP_PER_EDGE_POINT: f64 = 5.0;

/// Whether a point is in its region's band along the data's edge (kept whatever its hash).
fn in_band(f: &PointFootprint) -> bool {
    f.exact_hops() > 0 && f.hops() <= f.exact_hops()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Unmeasured points take the subset's own test exactly when the kept points are at least
    /// `OWN_TEST_POINTS_PER_PARTICLE` a particle, else the lenient one.
    #[test]
    fn unmeasured_points_take_the_own_test_when_the_subset_is_dense_enough() {
        let n = 6_400;
        let data = ThinnedData {
            points: (0..n)
                .map(|i| OrientedPoint {
                    p: DVec3::new((i % 80) as f64 * 1e-3, (i / 80) as f64 * 1e-3, 0.0),
                    n: DVec3::Z,
                })
                .collect(),
            footprints: vec![PointFootprint::unmeasured(1e-3).thinned_to(1.0, 0); n],
            need: vec![0.0; n],
        };
        // Every point fits (rate 1): all kept, whatever the particles.
        let own_tests = |particles: usize| {
            let thinned = ThinnedData::at_most(vec![data.clone()], n, 1.0, particles);
            assert_eq!(thinned.len(), n);
            thinned
                .footprints
                .iter()
                .filter(|f| **f == f.with_own_test())
                .count()
        };
        let most = n / OWN_TEST_POINTS_PER_PARTICLE;
        assert_eq!(own_tests(1), n);
        assert_eq!(own_tests(most), n);
        assert_eq!(own_tests(most + 1), 0);
    }

    /// Brute force: the points kept at the thresholds, counted one by one.
    fn kept(points: &[(f64, f64)], k: KeepRates) -> usize {
        points.iter().filter(|&&(h, n)| k.keeps(h, n)).count()
    }

    /// The thresholds keep the needed points first and then the lowest hashes, exactly as
    /// many as there is room for (against a count of the kept points), whatever the order of
    /// the points; when the needed points alone overflow, those of lowest hash/need. Needs
    /// drawn at random in (0, 1] for a fifth of the points (and 1 for a tenth), none for the
    /// rest: the ranking by h/need and the keep test must agree to the last rounding.
    #[test]
    fn keep_rates_fill_the_room_with_the_needed_points_first() {
        use rand::seq::SliceRandom;
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(11);
        let uniform = 0.25;
        // Those the regions kept (below max(uniform, need)).
        let mut points: Vec<(f64, f64)> = (0..40_000)
            .map(|i| {
                let need = match i % 10 {
                    0 => 1.0,
                    1 | 2 => 1.0 - rng.random::<f64>(),
                    _ => 0.0,
                };
                (rng.random::<f64>(), need)
            })
            .filter(|&(h, n)| h < f64::max(uniform, n))
            .collect();
        let needed = points.iter().filter(|&&(h, n)| h < n).count();
        let key = |&(h, n): &(f64, f64)| if h < n { (0, h / n) } else { (1, h) };
        for room in [
            points.len() + 10,
            points.len(),
            needed + 1_000,
            needed,
            needed / 3,
            1,
        ] {
            let k = KeepRates::within(points.iter().copied(), uniform, room);
            assert_eq!(kept(&points, k), room.min(points.len()), "room {room}");
            // The kept points rank before the others: needed before the rest, then by key.
            let (mut kept_keys, mut dropped) = (Vec::new(), Vec::new());
            for p in &points {
                match k.keeps(p.0, p.1) {
                    true => kept_keys.push(key(p)),
                    false => dropped.push(key(p)),
                }
            }
            let last = kept_keys
                .iter()
                .max_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)));
            let first = dropped
                .iter()
                .min_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)));
            if let (Some(l), Some(f)) = (last, first) {
                assert!(
                    l.0 < f.0 || (l.0 == f.0 && l.1 < f.1),
                    "room {room}: {l:?} {f:?}"
                );
            }
            points.shuffle(&mut rng);
            assert_eq!(KeepRates::within(points.iter().copied(), uniform, room), k);
        }
    }

    /// The trim of the octants' parts keeps what the trim of their points joined keeps, in
    /// the same order, for any split into parts: random points, a third with random needs,
    /// cut at random places, at budgets above, at and below the needed points.
    #[test]
    fn the_trim_of_parts_is_the_trim_of_the_joined_points() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(5);
        let n = 30_000;
        let uniform = 0.3;
        let mut joined = ThinnedData::default();
        for i in 0..n {
            let p = DVec3::new(rng.random(), rng.random(), rng.random());
            let need = if i % 3 == 0 { rng.random::<f64>() } else { 0.0 };
            if position_hash(p) < f64::max(uniform, need) {
                joined.points.push(OrientedPoint { p, n: DVec3::Z });
                joined.footprints.push(PointFootprint::unmeasured(1e-3));
                joined.need.push(need);
            }
        }
        let len = joined.len();
        for room in [len + 1, len * 2 / 3, len / 5, 3] {
            let whole = ThinnedData::at_most(vec![joined.clone()], room, uniform, 10);
            assert_eq!(whole.len(), room.min(len));
            let mut cuts: Vec<usize> = (0..6).map(|_| rng.random_range(0..=len)).collect();
            cuts.extend([0, len]);
            cuts.sort_unstable();
            let parts: Vec<ThinnedData> = cuts
                .windows(2)
                .map(|w| ThinnedData {
                    points: joined.points[w[0]..w[1]].to_vec(),
                    footprints: joined.footprints[w[0]..w[1]].to_vec(),
                    need: joined.need[w[0]..w[1]].to_vec(),
                })
                .collect();
            assert_eq!(ThinnedData::at_most(parts, room, uniform, 10), whole);
        }
    }
}
