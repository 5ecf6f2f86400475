//! Ball queries on a [`MortonIndex`]: every indexed point within a radius of a position, by a
//! descent of the Morton cells that meet the ball (a child module of `morton_index`, which owns
//! the fields).

use glam::DVec3;

use super::{BITS, MortonIndex, SCAN};

impl MortonIndex {
    /// Appends to `out` the original indices of the indexed points p with |p − x| ≤ `radius`
    /// (world units), tested as (p − x)·(p − x) ≤ radius², the rule and the arithmetic of
    /// [`crate::PointIndex::within`]: the same points. In slot order (Morton order), not by
    /// distance; nothing for a non-finite `x` or radius.
    pub fn within(&self, x: DVec3, radius: f64, out: &mut Vec<u32>) {
        self.each_within(x, radius * radius, |id, _| out.push(id));
    }

    /// [`MortonIndex::within`] with each point's squared distance (world units²): the figures
    /// [`crate::PointIndex::within_distances`] gives.
    pub fn within_distances(&self, x: DVec3, radius: f64, out: &mut Vec<(u32, f64)>) {
        self.each_within(x, radius * radius, |id, d2| out.push((id, d2)));
    }

    /// Calls `f(original index, squared distance)` for every indexed point with squared
    /// distance ≤ `r2` from `x`.
    fn each_within(&self, x: DVec3, r2: f64, mut f: impl FnMut(u32, f64)) {
        if self.is_empty() || !x.is_finite() || r2.is_nan() {
            return;
        }
        self.ball_in(x, r2, [0; 3], 0, (0, self.len()), &mut f);
    }

    /// [`MortonIndex::each_within`] over cell `c` of `level`, whose points are the slots
    /// `range`: the cell skipped when the ball misses it (its box grown by the slack), scanned
    /// when small, else split into its occupied children.
    fn ball_in(
        &self,
        x: DVec3,
        r2: f64,
        c: [u64; 3],
        level: u32,
        range: (usize, usize),
        f: &mut impl FnMut(u32, f64),
    ) {
        if range.0 == range.1 || self.cell_distance2(x, c, level) > r2 {
            return;
        }
        if range.1 - range.0 <= SCAN || level == BITS {
            for s in range.0..range.1 {
                let d2 = (self.points[s] - x).length_squared();
                if d2 <= r2 {
                    f(self.ids[s], d2);
                }
            }
            return;
        }
        for t in 0..8u64 {
            let (cc, r) = self.child(c, level, range, t);
            self.ball_in(x, r2, cc, level + 1, r, f);
        }
    }
}
