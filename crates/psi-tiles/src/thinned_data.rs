//! The relaxation's data when the input does not fit: a thinned subset of the input points that
//! carries what the whole input says of each ([`PointFootprint`]: its spacing, whether it is
//! interior, the centroid of its neighbours, its hops from the data's edge), so that the
//! footprint test on the subset accepts where the whole test would (`psi_mpu`'s
//! `thinned_test`; docs/notes/2026-11-27-carried-footprint.md).
//!
//! Each region of the seeding holds the points of its leaves with a margin, so it measures the
//! footprint of its own points on the whole input there. It keeps every point within two hops
//! of the data's edge (where the test reads the input at its own resolution) and the others
//! whose position hash lies below the rate. A region of a random sampling, whose seeming edge
//! points are too many for a band, is not measured: its kept points take the whole test on the
//! subset's own points when the subset holds [`OWN_TEST_POINTS_PER_PARTICLE`] points a particle
//! or more, else the lenient test (docs/notes/2026-11-28-unmeasured-own-test.md). The
//! relaxation takes the regions' points in the seeding's order and thins them to its budget.

use glam::DVec3;
use psi_mpu::{DEEP, Mpu, PointFootprint};
use psi_octree::OrientedPoint;
use serde::{Deserialize, Serialize};

use crate::point_source::position_hash;

/// A thinned subset of the input with the whole input's footprint at each point, in the order
/// of the seeding (octant, region, leaf, then input order: a function of the input and the
/// tiling, not of the threads or the workers).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ThinnedData {
    /// The points, world frame (shape: N).
    pub points: Vec<OrientedPoint>,
    /// What the whole input says of each (shape: N).
    pub footprints: Vec<PointFootprint>,
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
    /// data's edge or whose position hash is below `rate` (in [0, 1]), with their footprint
    /// on `mpu`'s points. The band is the points within two hops of the edge, or one, the
    /// widest that fits the region's share of the budget (`rate` × its points), else none
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
        rate: f64,
        complete: &dyn Fn(DVec3, f64) -> bool,
    ) {
        let input = mpu.points();
        let tree = mpu.octree();
        let qs: Vec<u32> = leaves
            .iter()
            .flat_map(|&l| tree.points_in(l).iter().copied())
            .collect();
        let share = rate * qs.len() as f64;
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
            for &q in &qs {
                let p = input[q as usize];
                if position_hash(p.p) < rate {
                    self.points.push(p);
                    self.footprints.push(PointFootprint::unmeasured(spacing));
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
        for (&q, f) in qs.iter().zip(footprints) {
            let p = input[q as usize];
            if f.hops() < band || position_hash(p.p) < rate {
                self.points.push(p);
                self.footprints.push(f.thinned_to(rate, exact));
            }
        }
    }

    /// Appends `other`'s points.
    pub(crate) fn extend(&mut self, other: ThinnedData) {
        self.points.extend(other.points);
        self.footprints.extend(other.footprints);
    }

    /// The points in the order given, about `at_most` of them (a hash threshold keeps the expected number): every point of the bands along
    /// the data's edge, and the others of the lowest position hash (kept at `rate`, so that
    /// their hashes lie below it). The bands are the regions', narrowed alike everywhere (two
    /// hops wide, one, or none) until they take at most half the budget: a survey's edges are
    /// a small share of its points, a small scan's or an irregular sampling's may not be.
    /// Each footprint records the rate of the points outside the bands and the hops tested
    /// exactly ([`PointFootprint::thinned_to`]).
    /// Unmeasured points take the whole test on the subset's own points when the subset holds
    /// at least [`OWN_TEST_POINTS_PER_PARTICLE`] points for each of the `particles`
    /// ([`PointFootprint::with_own_test`]).
    pub(crate) fn at_most(self, at_most: usize, rate: f64, particles: usize) -> ThinnedData {
        let widest = [DEEP - 1, 1, 0];
        // A footprint with its band narrowed to at most `cap` hops tested exactly.
        let narrowed = |f: &PointFootprint, cap: u8| f.thinned_to(1.0, f.exact_hops().min(cap));
        let band_at = |cap: u8| {
            self.footprints
                .iter()
                .filter(|f| in_band(&narrowed(f, cap)))
                .count()
        };
        let cap = widest
            .into_iter()
            .find(|&c| band_at(c) <= at_most / 2)
            .unwrap_or(0);
        let footprints: Vec<PointFootprint> =
            self.footprints.iter().map(|f| narrowed(f, cap)).collect();
        let hashes: Vec<f64> = self.points.iter().map(|p| position_hash(p.p)).collect();
        let band = footprints.iter().filter(|f| in_band(f)).count();
        // The others: those kept at `rate`, and a narrowed band's outer points (kept whatever
        // their hash), which the same threshold thins alike.
        let eligible = (0..self.len())
            .filter(|&i| !in_band(&footprints[i]) && hashes[i] < rate)
            .count();
        let left = at_most.saturating_sub(band);
        let deep_rate = if eligible <= left {
            rate
        } else {
            rate * left as f64 / eligible as f64
        };
        let order: Vec<usize> = (0..self.len())
            .filter(|&i| in_band(&footprints[i]) || hashes[i] < deep_rate)
            .collect();
        // A rate of 0 (no deep point kept) would make the lenient test's reach infinite.
        let deep_rate = deep_rate.clamp(1e-6, 1.0);
        let own_test = order.len() >= OWN_TEST_POINTS_PER_PARTICLE * particles;
        ThinnedData {
            points: order.iter().map(|&i| self.points[i]).collect(),
            footprints: order
                .iter()
                .map(|&i| {
                    let f = footprints[i].thinned_to(deep_rate, footprints[i].exact_hops());
                    if own_test { f.with_own_test() } else { f }
                })
                .collect(),
        }
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
        };
        // Every point fits (rate 1): all kept, whatever the particles.
        let own_tests = |particles: usize| {
            let thinned = data.clone().at_most(n, 1.0, particles);
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
}
