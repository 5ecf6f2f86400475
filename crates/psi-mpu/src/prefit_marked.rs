//! The first steps of a local rebuild after an edit: the kd-trees (derived from the earlier
//! MPU's after a brush, else built), then the fits of the earlier octree's marked cells in one
//! parallel batch beside the octree's rebuild, which takes each as it meets the cell. After a
//! brush each refit reads its cell's earlier ball answer and keeps its own for the next brush
//! (`trial_balls.rs`).

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, OnceLock};

use glam::DVec3;
use psi_octree::{BallAnswer, Interrupted, Monitor, NO_CELL, OrientedPoint, PointIndex};
use rayon::prelude::*;

use crate::coarse_index::CoarseIndex;
use crate::fit_cell::{CellFit, FitInput, refit_octree_cell, try_fit_octree_cell};
use crate::fit_radius::Earlier;
use crate::trial_balls::TrialBalls;
use crate::{Mpu, MpuParams};

/// A marked cell's fit (`None`: skipped), its ball answer to keep, and whether it read its
/// ball from the earlier answer.
type Refit = (Option<CellFit>, Option<BallAnswer>, bool);

/// A brush keeps at most this many ball-answer pairs (16 bytes each) a point for the next: a
/// brush over most of a model keeps some answers, not a copy of every refitted cell's ball
/// (docs/notes/2026-11-27-edit-balls.md).
const KEPT_PAIRS_PER_POINT: usize = 8;

/// The kd-trees of a local rebuild, and the fits of the large marked cells that were made
/// while they were built (shape: one per marked cell; `None` for the others).
pub(crate) struct MarkedIndexes {
    pub(crate) index: Arc<PointIndex>,
    pub(crate) coarse: Arc<CoarseIndex>,
    early: Vec<Option<CellFit>>,
    /// Whether the refits read and keep ball answers (after a brush).
    keep_balls: bool,
}

/// The kd-trees of a build: after a brush, the earlier MPU's brought up to date; else built
/// afresh, while the large marked cells that split are fitted from the coarse points alone.
///
/// `positions` (local frame) and `points` (shape: N each): the build's input; `earlier`: the
/// earlier MPU, with the points a brush moved (`None` for other edits); `marked`: its marked
/// cells.
pub(crate) fn marked_indexes(
    (positions, points): (&[DVec3], &[OrientedPoint]),
    params: &MpuParams,
    eps0: f64,
    earlier: Option<(&Mpu, Option<&[u32]>)>,
    marked: &[u32],
    monitor: &Monitor<'_>,
) -> Result<MarkedIndexes, Interrupted> {
    let derived = earlier.and_then(|(old, moved)| {
        let moved = moved?;
        Some(rayon::join(
            || Arc::new(old.index.with_moved(moved, positions, |_| true)),
            || Arc::new(old.coarse.with_moved(moved, positions)),
        ))
    });
    let keep_balls = derived.is_some();
    let (index, (coarse, early)) = match derived {
        Some((index, coarse)) => (index, (coarse, vec![None; marked.len()])),
        None => rayon::join(
            || Arc::new(PointIndex::new(positions)),
            || {
                let coarse = Arc::new(CoarseIndex::new(positions));
                let input = FitInput {
                    coarse: &coarse,
                    positions,
                    points,
                    index: None,
                    params,
                    population: positions.len(),
                };
                let old = earlier.map(|e| e.0);
                let early: Vec<Option<CellFit>> = marked
                    .par_iter()
                    .map(|&c| {
                        if monitor.stopped() {
                            return None;
                        }
                        let cell = old.expect("marked cells come with reuse").octree.cell(c);
                        try_fit_octree_cell(&input, cell, eps0)
                    })
                    .collect();
                (coarse, early)
            },
        ),
    };
    monitor.check()?;
    Ok(MarkedIndexes {
        index,
        coarse,
        early,
        keep_balls,
    })
}

/// The fits of the earlier octree's marked cells, made up front in one parallel batch
/// ([`MarkedFits::run`]) while the octree is rebuilt beside it: a fit depends only on its cell
/// and the points, the coarse levels hold a few expensive fits that would keep threads idle
/// level by level, and the octree's serial passes run meanwhile. The octree takes each fit as
/// it meets the cell ([`MarkedFits::get`]): made already, or being made (it waits), or made
/// then and there. (A marked cell below one that no longer splits is not in the new octree:
/// skipped when that is known before its fit starts, else fitted for nothing. Cells new to the
/// octree are fitted by the octree.)
pub(crate) struct MarkedFits<'a> {
    input: FitInput<'a>,
    eps0: f64,
    old: Option<&'a Mpu>,
    marked: &'a [u32],
    early: Vec<Option<CellFit>>,
    keep_balls: bool,
    /// The answers kept stop at a budget of pairs (which cells keep theirs may vary with the
    /// threads' timing; the fits never do).
    budget: usize,
    kept_pairs: AtomicUsize,
    /// Whether each marked cell is known to keep its function (fitted, and not splitting): a
    /// marked cell below one that does is not in the new octree, and is skipped when that fit
    /// is known before its own starts (which cells are skipped depends on the threads' timing;
    /// the octree never reads their fits).
    keeps: Vec<AtomicBool>,
    /// Whether a thread took each cell's fit on.
    claimed: Vec<AtomicBool>,
    /// Set until [`MarkedFits::run`] is done (when there are marked cells).
    running: AtomicBool,
    slots: Vec<OnceLock<Refit>>,
}

/// Sets a claimed cell's slot to "no fit" unless the claim set it (a cell found gone, or a fit
/// that unwinds), so that no thread waits for it (the octree then fits such a cell itself).
struct Claim<'s>(&'s OnceLock<Refit>);

impl Drop for Claim<'_> {
    fn drop(&mut self) {
        let _ = self.0.set((None, None, false));
    }
}

impl<'a> MarkedFits<'a> {
    /// The marked cells `marked` of `old` (none without reuse), to be fitted over `input`
    /// (whose kd-trees are `indexes`').
    pub(crate) fn new(
        input: FitInput<'a>,
        eps0: f64,
        old: Option<&'a Mpu>,
        marked: &'a [u32],
        indexes: MarkedIndexes,
    ) -> Self {
        let each = |_| Default::default();
        Self {
            input,
            eps0,
            old,
            marked,
            early: indexes.early,
            keep_balls: indexes.keep_balls,
            budget: KEPT_PAIRS_PER_POINT * input.positions.len(),
            kept_pairs: AtomicUsize::new(0),
            keeps: marked.iter().map(each).collect(),
            claimed: marked.iter().map(each).collect(),
            running: AtomicBool::new(!marked.is_empty()),
            slots: marked.iter().map(|_| OnceLock::new()).collect(),
        }
    }

    fn old_cell(&self, c: u32) -> psi_octree::Cell {
        *self
            .old
            .expect("marked cells come with reuse")
            .octree
            .cell(c)
    }

    /// Whether the `k`-th marked cell lies below a marked one known to keep its function.
    fn gone(&self, k: usize) -> bool {
        let mut a = self.old_cell(self.marked[k]).parent;
        while a != NO_CELL {
            if let Ok(j) = self.marked.binary_search(&a)
                && self.keeps[j].load(Ordering::Relaxed)
            {
                return true;
            }
            a = self.old_cell(a).parent;
        }
        false
    }

    /// Takes the `k`-th marked cell's fit on unless a thread has, and makes it; with
    /// `skip_gone`, a cell found gone is left unfitted (its slot says "no fit").
    fn make(&self, k: usize, skip_gone: bool) {
        if self.claimed[k].swap(true, Ordering::AcqRel) {
            return;
        }
        let _claim = Claim(&self.slots[k]);
        let c = self.marked[k];
        let cell = self.old_cell(c);
        let (fit, answer, read) = match &self.early[k] {
            Some(fit) => (fit.clone(), None, false),
            None if skip_gone && self.gone(k) => return,
            None => {
                let old = self.old.expect("marked cells come with reuse");
                let earlier = Earlier {
                    r1: Some(old.fit_radius[c as usize]),
                    ball: self
                        .keep_balls
                        .then(|| old.trial_balls.get(cell.depth, cell.key))
                        .flatten(),
                    keep_ball: self.keep_balls,
                };
                let (fit, answer) = refit_octree_cell(&self.input, &cell, self.eps0, earlier);
                let read = answer.as_ref().is_some_and(BallAnswer::from_earlier);
                let answer = answer.filter(|a| {
                    let n = a.near().len();
                    self.kept_pairs.fetch_add(n, Ordering::Relaxed) + n <= self.budget
                });
                (fit, answer, read)
            }
        };
        let max_depth = self.input.params.max_depth;
        self.keeps[k].store(!fit.splits(&cell, self.eps0, max_depth), Ordering::Relaxed);
        let _ = self.slots[k].set((Some(fit), answer, read));
    }

    /// Fits every marked cell no thread has taken on, in parallel; stops early (`Err`) once
    /// `monitor` is stopped.
    pub(crate) fn run(&self, monitor: &Monitor<'_>) -> Result<(), Interrupted> {
        // From the last cell back: the octree takes the cells from the first on, so the two
        // meet instead of one waiting behind the other.
        let done = (0..self.marked.len())
            .into_par_iter()
            .rev()
            .try_for_each(|k| {
                if monitor.stopped() {
                    return Err(Interrupted);
                }
                self.make(k, true);
                Ok(())
            });
        self.running.store(false, Ordering::Release);
        done
    }

    /// Set while [`MarkedFits::run`] runs.
    pub(crate) fn running(&self) -> &AtomicBool {
        &self.running
    }

    /// The fit of the earlier octree's marked cell `c` (which is in the new octree): made
    /// already, or waited for, or made now. `None` when `c` is not marked, or when its fit
    /// failed on another thread.
    pub(crate) fn get(&self, c: u32) -> Option<CellFit> {
        let k = self.marked.binary_search(&c).ok()?;
        if self.slots[k].get().is_none() {
            self.make(k, false);
        }
        self.slots[k].wait().0.clone()
    }

    /// The fits, in the order of the marked cells (`None`: skipped), with the ball answers kept.
    pub(crate) fn finish(self) -> Prefit {
        let refits: Vec<Refit> = self
            .slots
            .into_iter()
            .map(|s| s.into_inner().unwrap_or((None, None, false)))
            .collect();
        let from_earlier = refits.iter().filter(|f| f.2).count();
        let skipped = refits.iter().filter(|f| f.0.is_none()).count();
        let (fits, answers): (Vec<Option<CellFit>>, Vec<Option<BallAnswer>>) =
            refits.into_iter().map(|(f, a, _)| (f, a)).unzip();
        let balls = if self.keep_balls {
            let old = self.old.expect("marked cells come with reuse");
            let addresses = self.marked.iter().map(|&c| {
                let cell = old.octree.cell(c);
                (cell.depth, cell.key)
            });
            TrialBalls::new(addresses, answers)
        } else {
            TrialBalls::default()
        };
        Prefit {
            fits,
            balls,
            from_earlier,
            skipped,
        }
    }
}

/// What the marked fits leave the build, in the order of the marked cells.
pub(crate) struct Prefit {
    /// `None` for a cell skipped because a marked ancestor no longer splits (it is not in the
    /// new octree).
    pub(crate) fits: Vec<Option<CellFit>>,
    /// After a brush, the refits' ball answers (for the next brush).
    pub(crate) balls: TrialBalls,
    /// How many refits read their balls from the earlier answers.
    pub(crate) from_earlier: usize,
    /// How many marked cells were skipped.
    pub(crate) skipped: usize,
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use psi_octree::OrientedPoint;

    use crate::{BuildOptions, Mpu, MpuParams, Reuse};

    /// The local rebuild of `old` after `moved` points of `points` moved, every cell marked.
    fn rebuild_all_marked(old: &Mpu, points: &[OrientedPoint], moved: &[u32]) -> Mpu {
        let marked = vec![true; old.octree().cells().len()];
        let options = BuildOptions {
            frame: Some(*old.frame()),
            reuse: Some(Reuse {
                old,
                marked: &marked,
                indices_kept: true,
                moved: Some(moved),
            }),
            ..Default::default()
        };
        Mpu::build_with(points, &MpuParams::paper(), options).unwrap()
    }

    /// Asserts that `new` answers as a build of `points` from scratch in the same frame.
    fn assert_as_from_scratch(new: &Mpu, points: &[OrientedPoint], step: usize) {
        let options = BuildOptions {
            frame: Some(*new.frame()),
            ..Default::default()
        };
        let scratch = Mpu::build_with(points, &MpuParams::paper(), options).unwrap();
        assert_eq!(new.octree().cells().len(), scratch.octree().cells().len());
        for p in points.iter().step_by(step) {
            let x = p.p + 0.01 * p.n;
            assert_eq!(new.value_and_gradient(x), scratch.value_and_gradient(x));
        }
    }

    /// A brush that flattens a bump, every cell marked: the cells over the bump stop splitting,
    /// and on one thread (the batch then runs in cell order, ancestors first) their marked
    /// descendants are skipped; the build is a build from scratch's.
    #[test]
    fn cells_below_one_that_stops_splitting_are_skipped() {
        let params = MpuParams::paper();
        let bump = |x: f64, y: f64| 0.3 * (-(x * x + y * y) / 0.05).exp();
        let mut points = Vec::new();
        for i in 0..150 {
            for j in 0..150 {
                let (x, y) = (i as f64 / 74.5 - 1.0, j as f64 / 74.5 - 1.0);
                let z = bump(x, y);
                let (dx, dy) = (-2.0 * x / 0.05 * z, -2.0 * y / 0.05 * z);
                points.push(OrientedPoint {
                    p: DVec3::new(x, y, z),
                    n: DVec3::new(-dx, -dy, 1.0).normalize(),
                });
            }
        }
        let old = Mpu::build(&points, &params).unwrap();
        let moved: Vec<u32> = (0..points.len() as u32)
            .filter(|&i| points[i as usize].p.z > 1e-6)
            .collect();
        for &i in &moved {
            let p = &mut points[i as usize];
            (p.p.z, p.n) = (0.0, DVec3::Z);
        }
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let new = pool.install(|| rebuild_all_marked(&old, &points, &moved));
        assert!(new.report().refits_skipped > 0);
        assert_as_from_scratch(&new, &points, 37);
    }

    /// The octree rebuilt beside the refits takes each fit from whichever thread made it: on 1,
    /// 2 and 3 threads a brush's rebuild (every cell marked, so that the octree and the refits
    /// meet over every cell) is a build from scratch's.
    #[test]
    fn the_rebuild_beside_the_refits_is_exact_on_any_thread_count() {
        let mut points = psi_shapes::sample_builtin(12_000, 9);
        let old = Mpu::build(&points, &MpuParams::paper()).unwrap();
        let moved: Vec<u32> = (0..1500).map(|k| k * 8).collect();
        for &i in &moved {
            points[i as usize].p += DVec3::new(0.0, 2e-3, 0.0);
        }
        for threads in 1..=3 {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let new = pool.install(|| rebuild_all_marked(&old, &points, &moved));
            assert_as_from_scratch(&new, &points, 53);
        }
    }

    /// A brush over the whole model (every cell marked) keeps ball answers within the budget,
    /// and the next such brush reads some of them and builds what a build from scratch
    /// builds.
    #[test]
    fn a_whole_model_brush_keeps_answers_within_the_budget() {
        let params = MpuParams::paper();
        let mut points = psi_shapes::sample_builtin(20_000, 5);
        let mut old = Mpu::build(&points, &params).unwrap();
        // Every cell marked; 3 000 points moved (few enough that the kd-tree is derived, not
        // built again, so that the second brush can read the first one's answers).
        let moved: Vec<u32> = (0..3000).map(|k| k * 6).collect();
        for round in 0..2 {
            for &i in &moved {
                let dz = 1e-3 * if round == 0 { 1.0 } else { -1.0 };
                points[i as usize].p += DVec3::new(0.0, 0.0, dz);
            }
            let new = rebuild_all_marked(&old, &points, &moved);
            let kept = new.trial_balls.pairs();
            assert!(
                kept > 0 && kept <= super::KEPT_PAIRS_PER_POINT * points.len(),
                "{kept}"
            );
            if round == 1 {
                assert!(new.report().balls_from_earlier > 0);
            }
            assert_as_from_scratch(&new, &points, 97);
            old = new;
        }
    }
}
