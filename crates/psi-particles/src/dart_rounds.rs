//! A maximal dart set over points that may come in parts (the ceiling on spacing,
//! `cover_data.rs`): in rounds, each one pass over the points still open (candidates farther
//! than the dart radius r from every dart so far). A pass keeps, per cube of a grid of edge
//! r / [`CELLS_PER_RADIUS`], the open point of least rank (a seeded hash of its input index,
//! as the sequential throw this replaced ordered its candidates: a translated input gets the
//! same darts); the round then takes those representatives in rank order and keeps each one no
//! dart lies within r of. A round keeps at least its first representative, and the rounds end
//! when no point is open: every candidate lies within r of a dart, and darts lie at least r
//! apart, as a sequential dart throw gives (random sequential adsorption over the cubes'
//! representatives).
//!
//! The darts are a function of the candidates as a set of indexed points: a pass may visit
//! them in parts, in any order, a point more than once, on any number of threads, because a
//! cube keeps the least rank. So a sampling in memory, one out of core (a pass over the tile
//! files) and one on a cluster give the same darts; a sequential throw in a hashed input order
//! (what this replaced) cannot stream.

use std::collections::HashMap;

use glam::DVec3;
use psi_octree::OrientedPoint;

use crate::dart_grid::DartGrid;
use crate::seed::spread_hash;

/// The representatives' cubes have edge r / this (r the dart radius): four cubes a radius,
/// about 50 representatives in a dart's disc on a plane, so that a round is close to a throw
/// over every point and few rounds remain.
pub const CELLS_PER_RADIUS: f64 = 4.0;

/// The grid a pass takes one point a cube from, and the ranks.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DartCells {
    /// Where cube (0, 0, 0) starts (world units; the MPU's frame origin).
    pub origin: DVec3,
    /// The cubes' edge (world units).
    pub edge: f64,
    /// The seed of the ranks.
    pub seed: u64,
}

impl DartCells {
    /// Cubes of edge `radius` / [`CELLS_PER_RADIUS`] from `origin` (world units), ranks seeded
    /// by `seed`.
    pub fn for_radius(origin: DVec3, radius: f64, seed: u64) -> Self {
        DartCells {
            origin,
            edge: radius / CELLS_PER_RADIUS,
            seed,
        }
    }

    fn cube(&self, p: DVec3) -> [i64; 3] {
        let k = ((p - self.origin) / self.edge).floor();
        [k.x as i64, k.y as i64, k.z as i64]
    }
}

/// A point's place in the throw: the hash of its input index the sequential throw ordered
/// its candidates by ([`spread_hash`] of the index and the seed), then the index (distinct
/// points, distinct ranks).
type Rank = (u64, u64);

fn rank(index: u64, seed: u64) -> Rank {
    (spread_hash((index ^ seed) as usize), index)
}

/// Per cube of a [`DartCells`] grid, the offered point of least rank.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Representatives {
    cubes: HashMap<[i64; 3], (Rank, OrientedPoint)>,
}

impl Representatives {
    /// Offers the point of input index `index` at `p` (world units) for its cube of `cells`
    /// (a point that is not finite is never a dart).
    pub fn offer(&mut self, cells: &DartCells, index: u64, p: OrientedPoint) {
        if !p.p.is_finite() {
            return;
        }
        let r = rank(index, cells.seed);
        self.cubes
            .entry(cells.cube(p.p))
            .and_modify(|held| {
                if r < held.0 {
                    *held = (r, p);
                }
            })
            .or_insert((r, p));
    }

    /// These and `other`'s, the least rank per cube (the same in any order of merging).
    pub fn merge(mut self, other: Representatives) -> Representatives {
        let (mut big, small) = match self.cubes.len() >= other.cubes.len() {
            true => (std::mem::take(&mut self.cubes), other.cubes),
            false => (other.cubes, std::mem::take(&mut self.cubes)),
        };
        for (cube, held) in small {
            big.entry(cube)
                .and_modify(|b| {
                    if held.0 < b.0 {
                        *b = held;
                    }
                })
                .or_insert(held);
        }
        Representatives { cubes: big }
    }

    /// Whether no point was offered.
    pub fn is_empty(&self) -> bool {
        self.cubes.is_empty()
    }

    /// The representatives by rank.
    fn in_rank_order(self) -> Vec<OrientedPoint> {
        let mut all: Vec<(Rank, OrientedPoint)> = self.cubes.into_values().collect();
        all.sort_unstable_by_key(|a| a.0);
        all.into_iter().map(|(_, p)| p).collect()
    }
}

/// Where a dart throw's candidate points come from: the input in memory, or a tile store read
/// tile by tile.
pub trait CoverPoints: Sync {
    /// What a pass can fail with (a file's error out of core).
    type Error;

    /// The [`Representatives`] on `cells` of the candidates whose world position `open`
    /// accepts: every candidate offered at least once, with its input index.
    fn representatives(
        &self,
        cells: &DartCells,
        open: &(dyn Fn(DVec3) -> bool + Sync),
    ) -> Result<Representatives, Self::Error>;
}

/// Darts over the candidates of `source` that `candidate` accepts (world position), at least
/// `cells.edge × CELLS_PER_RADIUS` = r apart, every such candidate within r of one (|p − d| <
/// r): in the order kept (round by round, by rank). `first`, when given, is the first pass's
/// result (the representatives of every accepted candidate), already made by the caller.
/// Returns the darts and the passes made.
///
/// Errors: the source's.
pub fn throw_darts_in_rounds<S: CoverPoints + ?Sized>(
    source: &S,
    candidate: &(dyn Fn(DVec3) -> bool + Sync),
    cells: &DartCells,
    first: Option<Representatives>,
) -> Result<(Vec<OrientedPoint>, usize), S::Error> {
    let radius = cells.edge * CELLS_PER_RADIUS;
    let r2 = radius * radius;
    let mut grid = DartGrid::new(radius, 1024);
    let mut darts: Vec<OrientedPoint> = Vec::new();
    let mut passes = 0;
    let mut given = first;
    loop {
        let reps = match given.take() {
            Some(reps) => reps,
            None => {
                passes += 1;
                let open = |p: DVec3| {
                    candidate(p) && !grid.any_around(p, |_, d| d.distance_squared(p) < r2)
                };
                source.representatives(cells, &open)?
            }
        };
        if reps.is_empty() {
            return Ok((darts, passes));
        }
        for p in reps.in_rank_order() {
            if !grid.any_around(p.p, |_, d| d.distance_squared(p.p) < r2) {
                grid.insert(darts.len() as u32, p.p);
                darts.push(p);
            }
        }
    }
}

/// Points in memory (shape N, world units) as a dart throw's candidates: `candidates` of them
/// (indices), or all.
pub(crate) struct PointsInMemory<'a> {
    pub(crate) points: &'a [OrientedPoint],
    pub(crate) candidates: Option<&'a [u32]>,
}

impl CoverPoints for PointsInMemory<'_> {
    type Error = std::convert::Infallible;

    fn representatives(
        &self,
        cells: &DartCells,
        open: &(dyn Fn(DVec3) -> bool + Sync),
    ) -> Result<Representatives, Self::Error> {
        use rayon::prelude::*;
        let offer = |mut reps: Representatives, q: usize| {
            let p = self.points[q];
            if open(p.p) {
                reps.offer(cells, q as u64, p);
            }
            reps
        };
        let reps = match self.candidates {
            None => (0..self.points.len())
                .into_par_iter()
                .fold(Representatives::default, offer)
                .reduce(Representatives::default, Representatives::merge),
            Some(c) => c
                .par_iter()
                .fold(Representatives::default, |r, &q| offer(r, q as usize))
                .reduce(Representatives::default, Representatives::merge),
        };
        Ok(reps)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64Mcg;

    fn plane_points(n: usize, seed: u64) -> Vec<OrientedPoint> {
        let mut rng = Pcg64Mcg::seed_from_u64(seed);
        (0..n)
            .map(|_| OrientedPoint {
                p: DVec3::new(rng.random(), rng.random(), 0.01 * rng.random::<f64>()),
                n: DVec3::Z,
            })
            .collect()
    }

    /// Indexed points in parts.
    struct InParts {
        parts: Vec<Vec<(u64, OrientedPoint)>>,
    }

    impl CoverPoints for InParts {
        type Error = ();
        fn representatives(
            &self,
            cells: &DartCells,
            open: &(dyn Fn(DVec3) -> bool + Sync),
        ) -> Result<Representatives, ()> {
            let mut all = Representatives::default();
            for part in self.parts.iter().rev() {
                let mut r = Representatives::default();
                for (i, p) in part.iter().filter(|(_, p)| open(p.p)) {
                    r.offer(cells, *i, *p);
                }
                all = r.merge(all);
            }
            Ok(all)
        }
    }

    /// The brute-force twin of a pass: per cube, the least rank by a scan of every point.
    fn brute_rounds(
        points: &[OrientedPoint],
        cells: &DartCells,
        candidate: &dyn Fn(DVec3) -> bool,
    ) -> Vec<OrientedPoint> {
        let r = cells.edge * CELLS_PER_RADIUS;
        let mut darts: Vec<OrientedPoint> = Vec::new();
        loop {
            let open: Vec<usize> = (0..points.len())
                .filter(|&i| {
                    let p = points[i].p;
                    candidate(p) && darts.iter().all(|d| d.p.distance(p) >= r)
                })
                .collect();
            if open.is_empty() {
                return darts;
            }
            let mut cubes: Vec<[i64; 3]> = open.iter().map(|&i| cells.cube(points[i].p)).collect();
            cubes.sort_unstable();
            cubes.dedup();
            let mut reps: Vec<usize> = cubes
                .iter()
                .map(|c| {
                    *open
                        .iter()
                        .filter(|&&i| cells.cube(points[i].p) == *c)
                        .min_by_key(|&&i| rank(i as u64, cells.seed))
                        .expect("a point in the cube")
                })
                .collect();
            reps.sort_by_key(|&i| rank(i as u64, cells.seed));
            for i in reps {
                if darts.iter().all(|d| d.p.distance(points[i].p) >= r) {
                    darts.push(points[i]);
                }
            }
        }
    }

    #[test]
    fn darts_match_brute_force_and_cover_every_candidate() {
        for (seed, radius) in [(1, 0.05), (2, 0.12), (3, 0.3)] {
            let points = plane_points(3000, seed);
            let cells = DartCells::for_radius(DVec3::splat(-0.5), radius, seed);
            let candidate = |p: DVec3| p.x < 0.8;
            let source = PointsInMemory {
                points: &points,
                candidates: None,
            };
            let (darts, passes) = throw_darts_in_rounds(&source, &candidate, &cells, None).unwrap();
            assert_eq!(darts, brute_rounds(&points, &cells, &candidate));
            assert!(passes >= 2, "the last pass finds nothing open");
            for (i, a) in darts.iter().enumerate() {
                assert!(candidate(a.p));
                for b in &darts[i + 1..] {
                    assert!(a.p.distance(b.p) >= radius);
                }
            }
            for p in points.iter().filter(|p| candidate(p.p)) {
                assert!(darts.iter().any(|d| d.p.distance(p.p) < radius));
            }
        }
    }

    /// Parts, their order, points offered twice and a subset of indices give the same darts;
    /// so do the points moved by a million (the ranks follow the indices).
    #[test]
    fn darts_do_not_depend_on_how_the_points_come() {
        let points = plane_points(4000, 9);
        let cells = DartCells::for_radius(DVec3::ZERO, 0.08, 4);
        let all = |_: DVec3| true;
        let whole = PointsInMemory {
            points: &points,
            candidates: None,
        };
        let (want, _) = throw_darts_in_rounds(&whole, &all, &cells, None).unwrap();
        let mut shuffled: Vec<(u64, OrientedPoint)> = points
            .iter()
            .enumerate()
            .map(|(i, p)| (i as u64, *p))
            .collect();
        let mut rng = Pcg64Mcg::seed_from_u64(5);
        for i in (1..shuffled.len()).rev() {
            shuffled.swap(i, rng.random_range(0..=i));
        }
        let mut parts: Vec<Vec<(u64, OrientedPoint)>> =
            shuffled.chunks(700).map(|c| c.to_vec()).collect();
        parts[2].extend_from_slice(&shuffled[..300]);
        let (got, _) = throw_darts_in_rounds(&InParts { parts }, &all, &cells, None).unwrap();
        assert_eq!(got, want);
        let every: Vec<u32> = (0..points.len() as u32).collect();
        let indexed = PointsInMemory {
            points: &points,
            candidates: Some(&every),
        };
        assert_eq!(
            throw_darts_in_rounds(&indexed, &all, &cells, None)
                .unwrap()
                .0,
            want
        );
        // Translated by a million (the cubes from the translated origin): the same points.
        let shift = DVec3::splat(1e6);
        let moved: Vec<OrientedPoint> = points
            .iter()
            .map(|p| OrientedPoint {
                p: p.p + shift,
                n: p.n,
            })
            .collect();
        let far = PointsInMemory {
            points: &moved,
            candidates: None,
        };
        let far_cells = DartCells {
            origin: cells.origin + shift,
            ..cells
        };
        let (got, _) = throw_darts_in_rounds(&far, &all, &far_cells, None).unwrap();
        assert_eq!(got.len(), want.len());
        for (g, w) in got.iter().zip(&want) {
            assert!(
                (g.p - shift).distance(w.p) < 1e-9,
                "{} against {}",
                g.p,
                w.p
            );
        }
        // Another seed, other darts.
        let other = DartCells { seed: 5, ..cells };
        assert_ne!(
            throw_darts_in_rounds(&whole, &all, &other, None).unwrap().0,
            want
        );
    }
}
