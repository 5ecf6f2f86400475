//! An MPU's upkeep between edits. After each brush its kd-trees are derived from the earlier
//! ones (a shared base tree and a small tree of the moved points), and its leaves' functions are
//! the earlier chunks shared plus a new one; once the moved points or the chunks are many, a
//! rebuild rebuilds the trees or copies the live functions into one chunk, inside a stroke's
//! frame. An editor calls [`Mpu::compact`] when a stroke is complete (its relaxation settled) to
//! do that work between frames.

use std::sync::Arc;

use psi_octree::PointIndex;

use crate::Mpu;
use crate::coarse_index::CoarseIndex;
use crate::eval_nodes::NO_FIT;
use crate::fit_store::{FitStoreBuilder, MAX_CHUNKS};

impl Mpu {
    /// Builds the kd-trees of all points and of the coarse points afresh when the versions
    /// derived after edits keep more than half the moved points at which a derivation would
    /// ([`PointIndex::is_crowded`]), and copies the leaves' live functions into one chunk when
    /// the store holds half the chunks at which a rebuild would. The MPU answers the same
    /// (the same trees' sets, the same functions bit for bit). Returns whether it did either.
    pub fn compact(&mut self) -> bool {
        let crowded = self.index.is_crowded();
        if crowded {
            let positions = self.octree.positions();
            let (index, coarse) = rayon::join(
                || PointIndex::new(positions),
                || CoarseIndex::new(positions),
            );
            // The brush's ball answers were made at these positions: they serve the new
            // index too (a copy shared with a clone is dropped instead).
            match Arc::get_mut(&mut self.trial_balls) {
                Some(balls) => balls.rebase(&index),
                None => self.trial_balls = Arc::default(),
            }
            self.index = Arc::new(index);
            self.coarse = Arc::new(coarse);
        }
        let chunky = 2 * self.fits.chunk_count() >= MAX_CHUNKS;
        if chunky {
            let live = self.cell_fit.iter().filter(|&&f| f != NO_FIT).count();
            let mut fits = FitStoreBuilder::new(Some(&self.fits), false, live);
            for (id, node) in self.cell_fit.iter_mut().zip(&mut self.nodes) {
                if *id != NO_FIT {
                    *id = fits.reuse(*id);
                    node.fit = *id;
                }
            }
            self.fits = fits.finish();
        }
        crowded || chunky
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::MpuParams;
    use glam::DVec3;

    /// A store of many chunks and a crowded kd-tree (as after many strokes) are compacted, and
    /// the MPU answers bit for bit as before: f and ∇f everywhere, the trees' balls as sets.
    #[test]
    fn compacting_changes_no_answer() {
        let points = psi_shapes::sample_builtin(8000, 3);
        let mpu = crate::Mpu::build(&points, &MpuParams::paper()).unwrap();
        let mut many = mpu.clone();
        // Five chunks, each round's moving a third of the leaves' functions into a new one (what
        // local rebuilds leave: the refitted leaves' functions in the new chunk, the others
        // shared).
        for round in 0..4 {
            let old = many.fits.clone();
            let mut fits = FitStoreBuilder::new(Some(&old), true, 0);
            let ids = many.cell_fit.iter_mut().zip(&mut many.nodes);
            for (k, (id, node)) in ids.enumerate().filter(|(_, (id, _))| **id != NO_FIT) {
                *id = if (k + round) % 3 == 0 {
                    fits.push(old.load(*id), old.kind(*id), old.fallback(*id))
                } else {
                    fits.reuse(*id)
                };
                node.fit = *id;
            }
            many.fits = fits.finish();
        }
        assert_eq!(many.fits.chunk_count(), 5);
        // Every point "moved" in place: the derived tree keeps them all beside its base.
        let positions = many.octree.positions().to_vec();
        let all: Vec<u32> = (0..positions.len() as u32).step_by(2).collect();
        many.index = Arc::new(many.index.with_moved(&all, &positions, |_| true));
        assert!(many.index.is_crowded());
        let before = many.clone();
        assert!(many.compact());
        assert_eq!(many.fits.chunk_count(), 1);
        assert!(!many.index.is_crowded());
        let c = mpu.frame.origin;
        for k in 0..2000 {
            let t = k as f64 * 0.618_033_988_75;
            let x =
                c + 0.6 * mpu.diagonal() * DVec3::new(t.sin(), (2.0 * t).cos(), (3.0 * t).sin());
            let (f0, g0) = before.value_and_gradient(x);
            let (f1, g1) = many.value_and_gradient(x);
            assert_eq!(
                (f0.to_bits(), g0.to_array().map(f64::to_bits)),
                (f1.to_bits(), g1.to_array().map(f64::to_bits))
            );
            let ball = |m: &crate::Mpu| {
                let mut out = Vec::new();
                m.index.within(x - c, 0.03 * mpu.diagonal(), &mut out);
                out.sort_unstable();
                out
            };
            assert_eq!(ball(&before), ball(&many));
        }
        // Nothing to do a second time.
        assert!(!many.compact());
    }
}
