//! The footprint table carried from one MPU to the next after a brush: only the entries the
//! brush can have changed are emptied, instead of a table of 64 bytes a point filled afresh.
//!
//! An entry is a function of the point's 9 nearest input points. A point q's entry can change
//! only if a changed position x (a moved point's old or new one) lies within d₉(q), the distance
//! to its 9th nearest point. And d₉(q) ≤ R1 + |q − c| for q's leaf (centre c, fit radius R1):
//! the fit ball B(c, R1) holds at least min(N_min + 1, N) ≥ 9 points, all within that distance
//! of q. With |q − c| ≤ √3·half, x lies within R1 + 2√3·half of the leaf's centre (at most
//! 3·R1 for α ≥ 0.5). The leaves within that reach are visited, and each filled entry of their
//! points is emptied when a changed position lies within its own d₉.

use glam::DVec3;
use psi_octree::PointIndex;
use rayon::prelude::*;

use crate::Mpu;
use crate::data_footprint::DataFootprint;
use crate::fit_reach::CellReach;
use crate::input_local::InputLocalSlot;

/// The entries of an MPU's footprint table that an edit may have changed
/// ([`Mpu::stale_footprint`]): what [`Mpu::carry_stale_footprint`] empties.
#[derive(Clone, Debug, Default)]
pub struct StaleFootprint {
    /// Input point indices whose filled entry a changed position lies within d₉ of.
    entries: Vec<u32>,
    /// The table's length when they were found.
    len: usize,
}

impl Mpu {
    /// Moves `old`'s footprint table into this MPU, built after an edit that kept every point's
    /// index and the count, `changed` holding every position the edit changed (old and new,
    /// world units). Entries the edit cannot have changed stay filled. The result equals a
    /// fresh table's answers. When `old`'s table is shared (a clone of that MPU lives on), has
    /// another length, or the bound above does not hold (N_min + 1 < 9, fewer than 9 points),
    /// this MPU keeps a fresh table. `old` is left with an empty one.
    pub fn carry_footprint(&mut self, old: &mut Mpu, changed: &[DVec3]) {
        let stale = old.stale_footprint(changed);
        self.carry_stale_footprint(old, stale);
    }

    /// The entries of this MPU's footprint table that the positions `changed` (world units; an
    /// edit's old and new ones) may have changed: the first half of
    /// [`Mpu::carry_footprint`], which reads this MPU only, so that it can run while the next
    /// MPU is built. No entry may be filled between this call and
    /// [`Mpu::carry_stale_footprint`] (query neither MPU in between).
    pub fn stale_footprint(&self, changed: &[DVec3]) -> StaleFootprint {
        let n = self.points.len();
        let table = self.footprint.table().filter(|t| t.len() == n);
        let Some(table) = table.filter(|_| self.params.n_min + 1 >= 9 && n >= 9) else {
            return StaleFootprint::default();
        };
        StaleFootprint {
            entries: stale_entries(self, table, changed),
            len: n,
        }
    }

    /// The second half of [`Mpu::carry_footprint`]: moves `old`'s table into this MPU with the
    /// entries `stale` (from `old.stale_footprint(changed)`) emptied.
    pub fn carry_stale_footprint(&mut self, old: &mut Mpu, stale: StaleFootprint) {
        let n = self.points.len();
        // (`stale` has the length only where `old.stale_footprint` found the bound to hold.)
        let table = (old.points.len() == n && stale.len == n)
            .then(|| old.footprint.take_table(n))
            .flatten();
        let Some(mut table) = table else {
            if self.footprint.len() != n {
                self.footprint = DataFootprint::new_in(Vec::new(), n);
            }
            return;
        };
        for q in stale.entries {
            table[q as usize].clear();
        }
        self.footprint = DataFootprint::from_table(table);
    }
}

/// The points of `old` whose filled entry in `table` a position of `changed` (world units)
/// lies within d₉ of (with a margin for rounding): the points of the leaves within
/// R1 + 2√3·half of one.
fn stale_entries(old: &Mpu, table: &[InputLocalSlot], changed: &[DVec3]) -> Vec<u32> {
    let origin = old.frame.origin;
    let local: Vec<DVec3> = changed.iter().map(|p| *p - origin).collect();
    if local.is_empty() {
        return Vec::new();
    }
    let index = PointIndex::new(&local);
    let tree = &old.octree;
    // The leaves within R1 + 2√3·half of a changed position, with the distance from the centre
    // to the nearest one (only the cells near the changed positions are visited).
    let reach = CellReach {
        factor: 1.0,
        halves: 2.0 * 3f64.sqrt(),
    };
    let leaves = old.cells_reaching_local(&local, &index, reach, true);
    let stale_in = |(l, to_centre): (u32, f64)| {
        let c = tree.cell(l);
        let index = &index;
        // No changed position is nearer a point q than the nearest one's distance to the
        // centre less q's offset from it, which spares most queries.
        tree.points_in(l).iter().copied().filter(move |&q| {
            table[q as usize].reach().is_some_and(|d9| {
                let d9 = d9 * (1.0 + 1e-9);
                let y = tree.positions()[q as usize];
                to_centre - (y - c.center).length() <= d9
                    && index.nearest_one(y).is_some_and(|(_, d2)| d2 <= d9 * d9)
            })
        })
    };
    leaves.par_iter().flat_map_iter(|&l| stale_in(l)).collect()
}

#[cfg(test)]
mod tests {
    use glam::DVec3;
    use psi_shapes::AnalyticShape;

    use crate::{BuildOptions, Mpu, MpuParams};

    /// A table carried across a move of some points (every entry filled before it) answers
    /// as the table of a build from scratch of the moved points, bitwise; and a table shared
    /// with a clone is not taken.
    #[test]
    fn a_carried_table_answers_as_a_fresh_one() {
        let params = MpuParams::paper();
        let mut points = AnalyticShape::Torus {
            major: 1.0,
            minor: 0.4,
        }
        .sample(8000, 3);
        let mut old = Mpu::build(&points, &params).unwrap();
        let frame = *old.frame();
        for round in 0..4 {
            let n = points.len() as u32;
            for q in 0..n {
                old.input_spacing(q);
            }
            // A small brush-like move near a point of the outer equator.
            let a = 0.7 * round as f64;
            let centre = DVec3::new(1.4 * a.cos(), 1.4 * a.sin(), 0.0);
            let mut changed = Vec::new();
            for p in points.iter_mut() {
                let d = (p.p - centre).length();
                if d < 0.2 {
                    changed.push(p.p);
                    p.p += DVec3::new(0.0, 0.0, 0.02 * (1.0 - d / 0.2));
                    changed.push(p.p);
                }
            }
            assert!(!changed.is_empty());
            let options = |carry| BuildOptions {
                frame: Some(frame),
                carry_footprint: carry,
                ..Default::default()
            };
            let mut carried = Mpu::build_with(&points[..], &params, options(true)).unwrap();
            carried.carry_footprint(&mut old, &changed);
            let fresh = Mpu::build_with(&points[..], &params, options(false)).unwrap();
            for q in 0..n {
                assert_eq!(
                    carried.input_spacing(q).to_bits(),
                    fresh.input_spacing(q).to_bits(),
                    "round {round}, point {q}"
                );
                assert_eq!(carried.input_is_interior(q), fresh.input_is_interior(q));
            }
            old = carried;
        }
        // Shared with a clone: not taken, a fresh table instead.
        let clone = old.clone();
        let mut next = Mpu::build_with(
            &points[..],
            &params,
            BuildOptions {
                frame: Some(frame),
                carry_footprint: true,
                ..Default::default()
            },
        )
        .unwrap();
        next.carry_footprint(&mut old, &[]);
        assert!(next.input_spacing(0) > 0.0 && clone.input_spacing(0) > 0.0);
    }
}
