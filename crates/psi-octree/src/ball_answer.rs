//! A ball query's answer kept for a later version of the same index: after a brush the MPU
//! fits the same cells again, at the same centres, while only the moved points changed. The
//! later query reads the earlier answer instead of the base tree. It keeps the earlier
//! entries not moved since the base tree was built (an entry moved since then is set aside,
//! and the set of such entries only grows until the base is built again) within the new
//! radius, and adds the moved entries' current ones. A base entry not moved now was not
//! moved then either, so it was in the earlier answer if and only if it is within the radius
//! now: the answer is the same set, with the same squared distances (the base tree's own),
//! as a query of the tree. An answer of another base tree, centre or a smaller radius is not
//! used.

use std::sync::Weak;

use glam::DVec3;

use crate::PointIndex;
use crate::point_index::Tree;

/// The points within `radius` of `center` (local to whoever asked) as
/// [`PointIndex::within_distances`] answered them: `(id, squared distance)`, in no order until
/// [`BallAnswer::sort_by_id`]; an answer read from a sorted one is sorted too.
#[derive(Clone, Debug)]
pub struct BallAnswer {
    base: Option<Weak<Tree>>,
    center: DVec3,
    radius: f64,
    near: Vec<(u32, f64)>,
    /// Whether it was read from an earlier answer.
    from_earlier: bool,
    /// Whether `near` ascends by id.
    sorted: bool,
}

impl BallAnswer {
    /// The answer's `(id, squared distance)` pairs.
    pub fn near(&self) -> &[(u32, f64)] {
        &self.near
    }

    /// Orders the pairs by id (once: an answer read from a sorted one comes sorted, merged
    /// in time linear in its length).
    pub fn sort_by_id(&mut self) {
        if !self.sorted {
            self.near.sort_unstable_by_key(|p| p.0);
            self.sorted = true;
        }
    }

    /// The query's radius (as given).
    pub fn radius(&self) -> f64 {
        self.radius
    }

    /// Makes this an answer of `index`, which must have been built over the positions the
    /// answer was made at (no point moved in between: an index built again, afresh, after
    /// the edit that made the answer). Its pairs are then what `index` answers, with the same
    /// squared distances (the same coordinates, the same arithmetic).
    pub fn rebase(&mut self, index: &PointIndex) {
        self.base = index.base_weak();
    }

    /// Whether it was read from an earlier answer (else from the tree).
    pub fn from_earlier(&self) -> bool {
        self.from_earlier
    }
}

impl PointIndex {
    /// [`PointIndex::within_distances`] of `x` and `radius`, kept as an answer. With `earlier`
    /// (an answer of an earlier version of this index, [`PointIndex::with_moved`] of it or of
    /// a version derived from it) at the same `x` with a radius at least `radius`, it is read
    /// instead of the base tree; either way the answer is the same set of pairs. `memory`:
    /// room for the pairs (cleared first).
    pub fn ball_answer(
        &self,
        x: DVec3,
        radius: f64,
        earlier: Option<&BallAnswer>,
        memory: Vec<(u32, f64)>,
    ) -> BallAnswer {
        let r2 = radius * radius;
        let mut near = memory;
        near.clear();
        let usable = earlier.filter(|e| {
            e.base.as_ref().is_some_and(|b| self.has_base(b)) && e.center == x && e.radius >= radius
        });
        let from_earlier = usable.is_some();
        let mut sorted = false;
        match usable {
            Some(e) => {
                let kept = e
                    .near
                    .iter()
                    .filter(|&&(id, d2)| d2 <= r2 && !self.is_stale(id));
                let mut moved = Vec::new();
                self.each_within_overlay(x, r2, |id, d2| moved.push((id, d2)));
                if e.sorted {
                    // (A stale id is in the overlay alone: the two lists share no id.)
                    moved.sort_unstable_by_key(|p| p.0);
                    near.reserve(e.near.len() + moved.len());
                    merge_by_id(kept, moved, &mut near);
                    sorted = true;
                } else {
                    near.extend(kept);
                    near.extend(moved);
                }
            }
            None => self.each_within(x, r2, |id, d2| near.push((id, d2))),
        }
        BallAnswer {
            base: self.base_weak(),
            center: x,
            radius,
            near,
            from_earlier,
            sorted,
        }
    }
}

/// Appends to `out` the pairs of `a` and `b` (each ascending by id, no id in both) in
/// ascending order of id.
fn merge_by_id<'a>(
    a: impl Iterator<Item = &'a (u32, f64)>,
    b: Vec<(u32, f64)>,
    out: &mut Vec<(u32, f64)>,
) {
    let mut b = b.into_iter().peekable();
    for &p in a {
        while let Some(q) = b.next_if(|q| q.0 < p.0) {
            out.push(q);
        }
        out.push(p);
    }
    out.extend(b);
}

#[cfg(test)]
mod tests {
    use glam::DVec3;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64Mcg;

    use crate::PointIndex;

    fn sorted(mut v: Vec<(u32, f64)>) -> Vec<(u32, u64)> {
        v.sort_unstable_by_key(|p| p.0);
        v.into_iter().map(|(i, d)| (i, d.to_bits())).collect()
    }

    /// Brute-force twin: over rounds of moves (some rebuilding the base, some followed by a
    /// fresh index and the answers rebased), every answer read from an earlier one equals a
    /// fresh query of the current index, bitwise; and some were read from earlier answers.
    #[test]
    fn an_answer_from_an_earlier_one_is_the_query_of_the_tree() {
        let mut rng = Pcg64Mcg::seed_from_u64(5);
        let mut positions: Vec<DVec3> = (0..3000)
            .map(|_| DVec3::new(rng.random(), rng.random(), rng.random()))
            .collect();
        let centres: Vec<DVec3> = (0..40)
            .map(|_| DVec3::new(rng.random(), rng.random(), rng.random()))
            .collect();
        let mut index = PointIndex::new(&positions);
        let mut earlier: Vec<_> = centres
            .iter()
            .enumerate()
            .map(|(k, &c)| {
                let mut a = index.ball_answer(c, 0.2, None, Vec::new());
                if k % 2 == 0 {
                    a.sort_by_id();
                }
                a
            })
            .collect();
        let mut reused = 0;
        for round in 0..12 {
            // Move a clump of points (a brush), sometimes many (the base is built again).
            let at = DVec3::new(rng.random(), rng.random(), rng.random());
            let reach = if round % 5 == 4 { 0.6 } else { 0.15 };
            let moved: Vec<u32> = (0..positions.len() as u32)
                .filter(|&i| (positions[i as usize] - at).length() < reach)
                .collect();
            for &i in &moved {
                positions[i as usize] += 0.05 * DVec3::new(rng.random(), rng.random(), 0.0);
            }
            index = index.with_moved(&moved, &positions, |_| true);
            for (k, c) in centres.iter().enumerate() {
                // Radii at, below and (not used) above the earlier one.
                let radius = [0.2, 0.13, 0.25][(k + round) % 3];
                let got = index.ball_answer(*c, radius, Some(&earlier[k]), Vec::new());
                let mut want = Vec::new();
                index.within_distances(*c, radius, &mut want);
                assert_eq!(
                    sorted(got.near().to_vec()),
                    sorted(want),
                    "round {round}, centre {k}"
                );
                reused += usize::from(got.from_earlier());
                if got.sorted {
                    assert!(got.near().is_sorted_by_key(|p| p.0));
                }
                // The next round reads this one (its radius 0.2 only every third round); half
                // the centres' answers sorted.
                if radius >= 0.2 {
                    earlier[k] = got;
                } else {
                    earlier[k] = index.ball_answer(*c, 0.2, Some(&earlier[k]), Vec::new());
                }
            }
            if round % 4 == 1 {
                // Built again afresh over the positions the answers were made at: they are
                // rebased.
                index = PointIndex::new(&positions);
                for e in &mut earlier {
                    e.rebase(&index);
                }
            }
        }
        assert!(reused > 100, "{reused} answers read earlier ones");
    }
}
