//! The ball answers of a brush's refits, kept in the MPU for the next brush: a drag refits
//! mostly the cells the stroke before refitted, at the same centres, while only the moved
//! points changed, so each refit reads its cell's earlier answer instead of the kd-tree
//! ([`psi_octree::PointIndex::ball_answer`]; the same sets, so the same fits).

use std::collections::HashMap;

use psi_octree::{BallAnswer, PointIndex};

/// Per cell address (depth, key): the answer of its last refit's ball query.
#[derive(Clone, Debug, Default)]
pub(crate) struct TrialBalls(HashMap<(u8, [u32; 3]), BallAnswer>);

impl TrialBalls {
    /// The answers of the cells at `addresses` (pairs of the same length; `None` where a fit
    /// queried no ball).
    pub(crate) fn new(
        addresses: impl IntoIterator<Item = (u8, [u32; 3])>,
        answers: impl IntoIterator<Item = Option<BallAnswer>>,
    ) -> Self {
        let map = addresses
            .into_iter()
            .zip(answers)
            .filter_map(|(a, b)| Some((a, b?)))
            .collect();
        Self(map)
    }

    /// Makes the answers answers of `index`, built afresh over the positions they were made
    /// at ([`BallAnswer::rebase`]).
    pub(crate) fn rebase(&mut self, index: &PointIndex) {
        for answer in self.0.values_mut() {
            answer.rebase(index);
        }
    }

    /// Pairs held in all answers (tests: the budget).
    #[cfg(test)]
    pub(crate) fn pairs(&self) -> usize {
        self.0.values().map(|a| a.near().len()).sum()
    }

    /// The answer of the cell at depth `depth` and key `key`, if one was kept.
    pub(crate) fn get(&self, depth: u8, key: [u32; 3]) -> Option<&BallAnswer> {
        self.0.get(&(depth, key))
    }
}
