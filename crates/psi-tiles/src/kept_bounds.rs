//! The bounding box of the stored points a test keeps (by input index), read from the
//! sub-cells at its six extremes only: a run out of core that leaves the outlier step's strays
//! out needs the kept points' frame before it stores them, and reading the whole input again
//! for it cost a pass over every point (docs/notes/2026-12-03-out-of-core-ratio.md).
//!
//! For each side of each axis the non-empty sub-cells are taken in the order of their box's
//! face on that side, outermost first, and read until the next one's box (grown by one
//! sub-cell edge, far more than the rounding of a key: `TileStore::keys_around` bounds keys
//! exactly) lies wholly inside the extreme found so far. The answer is the minimum and
//! maximum over every kept point, as a pass over all of them in input order finds it (to the
//! sign of a zero: a tie goes to the later point).

use std::collections::HashMap;

use glam::DVec3;
use psi_octree::Aabb;

use crate::sub_cells::{SUB, SUB_LEVELS, occupied_sub_cells, sub_cell_box};
use crate::tile_records::{RECORD, record_position};
use crate::tile_store::tile_path;
use crate::{TileError, TileStore};

/// A coordinate of a point and the point's input index.
type Valued = (f64, u64);

/// Per axis, the lowest and the highest coordinate of some points.
type Extremes = ([Valued; 3], [Valued; 3]);

/// The lower of two coordinates as a pass in input order takes it (glam's `min`, as
/// `Aabb::from_points` folds it: on a tie, as of −0 and +0, the later point's).
fn lower(a: Valued, b: Valued) -> Valued {
    if b.0 < a.0 || (b.0 == a.0 && b.1 > a.1) {
        b
    } else {
        a
    }
}

/// The higher of two coordinates, as [`lower`].
fn upper(a: Valued, b: Valued) -> Valued {
    if b.0 > a.0 || (b.0 == a.0 && b.1 > a.1) {
        b
    } else {
        a
    }
}

impl TileStore {
    /// The bounds (world units) of the stored points whose input index `keep` accepts, reading
    /// only the sub-cells that may hold an extreme; `Ok(None)` when it keeps none, or when
    /// a file has no sub-cell runs (then the caller reads every point).
    ///
    /// Errors: a tile file that is missing, truncated or corrupted (named); `keep`'s error.
    pub fn bounds_where(
        &self,
        keep: &dyn Fn(u64) -> Result<bool, String>,
    ) -> Result<Option<Aabb>, TileError> {
        let m = self.manifest();
        let cells = (SUB * SUB * SUB) as usize;
        if m.tiles.iter().any(|t| t.runs.len() != cells + 1) {
            return Ok(None);
        }
        let edge = 2.0 * m.frame.root_half / f64::from(1u32 << (m.depth + SUB_LEVELS));
        // Every non-empty sub-cell: (tile, sub-cell, its box grown by one sub-cell edge).
        let mut boxes: Vec<(usize, usize, DVec3, DVec3)> = Vec::new();
        for (i, t) in m.tiles.iter().enumerate() {
            for (s, sub) in occupied_sub_cells(&t.runs) {
                let (lo, hi) = sub_cell_box(&m.frame, m.depth, t.key, sub);
                boxes.push((i, s, lo - DVec3::splat(edge), hi + DVec3::splat(edge)));
            }
        }
        // The extremes of each sub-cell's kept points (None: it keeps none), read once.
        let mut read: HashMap<(usize, usize), Option<Extremes>> = HashMap::new();
        let mut kept_in = |i: usize, s: usize| -> Result<Option<Extremes>, TileError> {
            if let Some(b) = read.get(&(i, s)) {
                return Ok(*b);
            }
            let t = &m.tiles[i];
            let path = tile_path(self.dir(), t.key);
            let bytes = self.read_ranges(&path, t, Some(&[(t.runs[s], t.runs[s + 1])]))?;
            let mut b: Option<Extremes> = None;
            for r in bytes.chunks_exact(RECORD) {
                let index = u64::from_le_bytes(r[..8].try_into().expect("8 bytes"));
                if keep(index).map_err(TileError::Store)? {
                    let p = record_position(r);
                    let at: [Valued; 3] = std::array::from_fn(|a| (p[a], index));
                    b = Some(b.map_or((at, at), |(lo, hi)| {
                        let lows = std::array::from_fn(|a| lower(lo[a], at[a]));
                        (lows, std::array::from_fn(|a| upper(hi[a], at[a])))
                    }));
                }
            }
            read.insert((i, s), b);
            Ok(b)
        };
        let mut min = [(f64::INFINITY, 0); 3];
        let mut max = [(f64::NEG_INFINITY, 0); 3];
        for a in 0..3 {
            // The low side: the sub-cells by their grown box's low face, lowest first.
            boxes.sort_by(|x, y| x.2[a].total_cmp(&y.2[a]));
            for &(i, s, lo, _) in &boxes {
                if lo[a] > min[a].0 {
                    break;
                }
                if let Some(b) = kept_in(i, s)? {
                    min[a] = lower(min[a], b.0[a]);
                }
            }
            boxes.sort_by(|x, y| y.3[a].total_cmp(&x.3[a]));
            for &(i, s, _, hi) in &boxes {
                if hi[a] < max[a].0 {
                    break;
                }
                if let Some(b) = kept_in(i, s)? {
                    max[a] = upper(max[a], b.1[a]);
                }
            }
        }
        let (min, max) = (DVec3::from(min.map(|v| v.0)), DVec3::from(max.map(|v| v.0)));
        Ok(min.is_finite().then_some(Aabb { min, max }))
    }
}

#[cfg(test)]
mod tests {
    use psi_mpu::{MpuFrame, MpuParams};
    use psi_octree::OrientedPoint;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64Mcg;

    use super::*;
    use crate::TileWriter;

    /// A box's bounds as their IEEE bits (−0 and +0 apart).
    fn bits(b: Option<Aabb>) -> Option<[[u64; 3]; 2]> {
        b.map(|b| [b.min, b.max].map(|v| v.to_array().map(f64::to_bits)))
    }

    /// A slab whose lowest z is 0, reached by points at −0 and +0 spread over many sub-cells:
    /// the box's low z has the sign of the last of them in input order that the test keeps, as
    /// a pass over the input folds it (oracle: `Aabb::from_points` in index order, by bits).
    #[test]
    fn a_tie_between_zeros_goes_to_the_later_point() {
        let mut rng = Pcg64Mcg::seed_from_u64(5);
        let points: Vec<OrientedPoint> = (0..6000)
            .map(|i| {
                let mut p = DVec3::new(rng.random(), rng.random(), rng.random()) * 4.0;
                if i % 50 == 7 {
                    p.z = if rng.random::<bool>() { -0.0 } else { 0.0 };
                }
                OrientedPoint { p, n: DVec3::Z }
            })
            .collect();
        let store = store_of(&points, 2, "zeros");
        let zeros: Vec<u64> = (0..6000).filter(|i| i % 50 == 7).collect();
        // Each test's last kept zero is another of them.
        for last in zeros.iter().rev().take(12) {
            let keep = |i: u64| i % 50 != 7 || i <= *last;
            let expected = Aabb::from_points(
                (0..points.len() as u64)
                    .filter(|&i| keep(i))
                    .map(|i| points[i as usize].p),
            );
            let got = store.bounds_where(&|i| Ok(keep(i))).expect("read");
            assert_eq!(
                bits(got),
                bits(expected),
                "the last zero kept is point {last}"
            );
        }
        let _ = std::fs::remove_dir_all(store.dir());
    }

    /// A store of `points` at `depth` in a fresh directory.
    fn store_of(points: &[OrientedPoint], depth: u8, name: &str) -> TileStore {
        let dir =
            std::env::temp_dir().join(format!("psi-kept-bounds-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let bounds = Aabb::from_points(points.iter().map(|p| p.p)).expect("points");
        let frame =
            MpuFrame::for_bounds(&bounds, points.len(), &MpuParams::paper()).expect("frame");
        let mut w = TileWriter::create(&dir, frame, depth, 1 << 12, "test").expect("writer");
        w.push(points).expect("push");
        w.finish().expect("store")
    }

    /// Oracle: the box of the kept points by brute force (every point tested), bitwise; on a
    /// cloud whose extremes are the points left out (so the sweep must read on), with tests
    /// that keep most, few and no points.
    #[test]
    fn the_kept_points_bounds_are_those_of_every_kept_point() {
        let mut rng = Pcg64Mcg::seed_from_u64(11);
        let mut points: Vec<OrientedPoint> = (0..20_000)
            .map(|_| {
                let u = DVec3::new(rng.random(), rng.random(), rng.random()) * 2.0 - DVec3::ONE;
                OrientedPoint {
                    p: u.normalize_or(DVec3::X) * 3.0 + DVec3::new(1.0, -2.0, 0.5),
                    n: u.normalize_or(DVec3::X),
                }
            })
            .collect();
        // Far points on every side, each left out by the tests below (index ≥ 20 000).
        for a in 0..3 {
            for sign in [-1.0, 1.0] {
                let mut p = DVec3::new(1.0, -2.0, 0.5);
                p[a] += sign * rng.random_range(5.0..9.0);
                points.push(OrientedPoint { p, n: DVec3::Z });
            }
        }
        let store = store_of(&points, 3, "sides");
        let tests: [(&str, &dyn Fn(u64) -> bool); 4] = [
            ("all but the far", &|i| i < 20_000),
            ("every third", &|i| i % 3 == 0 && i < 20_000),
            ("a few", &|i| i % 997 == 5),
            ("all", &|_| true),
        ];
        for (name, keep) in tests {
            let expected = Aabb::from_points(
                (0..points.len() as u64)
                    .filter(|&i| keep(i))
                    .map(|i| points[i as usize].p),
            );
            let got = store.bounds_where(&|i| Ok(keep(i))).expect("read");
            assert_eq!(bits(got), bits(expected), "{name}");
        }
        assert!(store.bounds_where(&|_| Ok(false)).expect("read").is_none());
        let _ = std::fs::remove_dir_all(store.dir());
    }
}
