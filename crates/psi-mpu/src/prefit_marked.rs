//! The first step of a local rebuild after an edit: the kd-trees (derived from the earlier
//! MPU's after a brush, else built) and the fits of the earlier octree's marked cells, all in
//! one parallel batch. After a brush each refit reads its cell's earlier ball answer and keeps
//! its own for the next brush (`trial_balls.rs`).

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

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

/// The kd-trees of a build and the fits of the earlier MPU's marked cells (empty without
/// reuse), in the order of `marked`.
pub(crate) struct Prefit {
    pub(crate) index: Arc<PointIndex>,
    pub(crate) coarse: Arc<CoarseIndex>,
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

/// Fits the marked cells of the earlier octree up front, in one parallel batch: a fit depends
/// only on its cell and the points, and level by level the coarse levels hold a few expensive
/// fits that keep threads idle. (A marked cell below one that no longer splits is not in the
/// new octree: skipped when that is known before its fit starts, else fitted for nothing.
/// Cells new to the octree are fitted as met.) The large cells among them that split
/// are fitted from the coarse points alone while the kd-tree of all points is being built.
///
/// `positions` (local frame) and `points` (shape: N each): the build's input; `earlier`: the
/// earlier MPU, with the points a brush moved (`None` for other edits); `marked`: its marked
/// cells.
pub(crate) fn prefit_marked(
    (positions, points): (&[DVec3], &[OrientedPoint]),
    params: &MpuParams,
    eps0: f64,
    earlier: Option<(&Mpu, Option<&[u32]>)>,
    marked: &[u32],
    monitor: &Monitor<'_>,
) -> Result<Prefit, Interrupted> {
    let old = || earlier.expect("marked cells come with reuse").0;
    let old_cell = |c: u32| *old().octree.cell(c);
    // After a brush the earlier MPU's kd-trees are brought up to date (no early fits needed).
    let derived = earlier.and_then(|(old, moved)| {
        let moved = moved?;
        Some(rayon::join(
            || Arc::new(old.index.with_moved(moved, positions, |_| true)),
            || Arc::new(old.coarse.with_moved(moved, positions)),
        ))
    });
    // After a brush the refits read their cells' earlier ball answers and keep their own.
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
                let early: Vec<Option<CellFit>> = marked
                    .par_iter()
                    .map(|&c| {
                        if monitor.stopped() {
                            return None;
                        }
                        let cell = old_cell(c);
                        try_fit_octree_cell(&input, &cell, eps0)
                    })
                    .collect();
                (coarse, early)
            },
        ),
    };
    let input = FitInput {
        coarse: &coarse,
        positions,
        points,
        index: Some(&index),
        params,
        population: positions.len(),
    };
    monitor.check()?;
    // The answers kept stop at a budget of pairs (which cells keep theirs may vary with the
    // threads' timing; the fits never do).
    let budget = KEPT_PAIRS_PER_POINT * positions.len();
    let kept_pairs = AtomicUsize::new(0);
    // Whether each marked cell is known to keep its function (fitted, and not splitting): a
    // marked cell below one that does is not in the new octree, and is skipped when that fit
    // is known before its own starts (which cells are skipped depends on the threads' timing;
    // the octree never reads their fits).
    let keeps: Vec<AtomicBool> = marked.iter().map(|_| AtomicBool::new(false)).collect();
    let gone = |c: u32| {
        let mut a = old_cell(c).parent;
        while a != NO_CELL {
            if let Ok(k) = marked.binary_search(&a)
                && keeps[k].load(Ordering::Relaxed)
            {
                return true;
            }
            a = old_cell(a).parent;
        }
        false
    };
    // (A stop part-way leaves `None`s, and the whole is dropped.)
    let fits: Option<Vec<Refit>> = marked
        .par_iter()
        .zip(early)
        .zip(&keeps)
        .map(|((&c, early), keeps)| {
            if monitor.stopped() {
                return None;
            }
            let (fit, answer, read) = match early {
                Some(fit) => (fit, None, false),
                None if gone(c) => return Some((None, None, false)),
                None => {
                    let cell = old_cell(c);
                    let earlier = Earlier {
                        r1: Some(old().fit_radius[c as usize]),
                        ball: keep_balls
                            .then(|| old().trial_balls.get(cell.depth, cell.key))
                            .flatten(),
                        keep_ball: keep_balls,
                    };
                    let (fit, answer) = refit_octree_cell(&input, &cell, eps0, earlier);
                    let read = answer.as_ref().is_some_and(BallAnswer::from_earlier);
                    let answer = answer.filter(|a| {
                        let n = a.near().len();
                        kept_pairs.fetch_add(n, Ordering::Relaxed) + n <= budget
                    });
                    (fit, answer, read)
                }
            };
            keeps.store(
                !fit.splits(&old_cell(c), eps0, params.max_depth),
                Ordering::Relaxed,
            );
            Some((Some(fit), answer, read))
        })
        .collect();
    let fits = fits.ok_or(Interrupted)?;
    let from_earlier = fits.iter().filter(|f| f.2).count();
    let skipped = fits.iter().filter(|f| f.0.is_none()).count();
    let (fits, answers): (Vec<Option<CellFit>>, Vec<Option<BallAnswer>>) =
        fits.into_iter().map(|(f, a, _)| (f, a)).unzip();
    let balls = if keep_balls {
        let addresses = marked.iter().map(|&c| {
            let cell = old_cell(c);
            (cell.depth, cell.key)
        });
        TrialBalls::new(addresses, answers)
    } else {
        TrialBalls::default()
    };
    Ok(Prefit {
        index,
        coarse,
        fits,
        balls,
        from_earlier,
        skipped,
    })
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
