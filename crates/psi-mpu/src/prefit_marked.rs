//! The first step of a local rebuild after an edit: the kd-trees (derived from the earlier
//! MPU's after a brush, else built) and the fits of the earlier octree's marked cells, all in
//! one parallel batch. After a brush each refit reads its cell's earlier ball answer and keeps
//! its own for the next brush (`trial_balls.rs`).

use std::sync::Arc;

use glam::DVec3;
use psi_octree::{BallAnswer, Interrupted, Monitor, OrientedPoint, PointIndex};
use rayon::prelude::*;

use crate::coarse_index::CoarseIndex;
use crate::fit_cell::{CellFit, FitInput, refit_octree_cell, try_fit_octree_cell};
use crate::fit_radius::Earlier;
use crate::trial_balls::TrialBalls;
use crate::{Mpu, MpuParams};

/// The kd-trees of a build and the fits of the earlier MPU's marked cells (empty without
/// reuse), in the order of `marked`.
pub(crate) struct Prefit {
    pub(crate) index: Arc<PointIndex>,
    pub(crate) coarse: Arc<CoarseIndex>,
    pub(crate) fits: Vec<CellFit>,
    /// After a brush, the refits' ball answers (for the next brush).
    pub(crate) balls: TrialBalls,
    /// How many of them were read from the earlier answers.
    pub(crate) from_earlier: usize,
}

/// Fits the marked cells of the earlier octree up front, in one parallel batch: a fit depends
/// only on its cell and the points, and level by level the coarse levels hold a few expensive
/// fits that keep threads idle. (A marked cell whose parent no longer splits is fitted for
/// nothing; cells new to the octree are fitted as met.) The large cells among them that split
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
    // (A stop part-way leaves `None`s, and the whole is dropped.)
    let fits: Option<Vec<(CellFit, Option<BallAnswer>)>> = marked
        .par_iter()
        .zip(early)
        .map(|(&c, early)| {
            if monitor.stopped() {
                return None;
            }
            Some(match early {
                Some(fit) => (fit, None),
                None => {
                    let cell = old_cell(c);
                    let earlier = Earlier {
                        r1: Some(old().fit_radius[c as usize]),
                        ball: keep_balls
                            .then(|| old().trial_balls.get(cell.depth, cell.key))
                            .flatten(),
                        keep_ball: keep_balls,
                    };
                    refit_octree_cell(&input, &cell, eps0, earlier)
                }
            })
        })
        .collect();
    let (fits, answers): (Vec<CellFit>, Vec<Option<BallAnswer>>) =
        fits.ok_or(Interrupted)?.into_iter().unzip();
    let from_earlier = answers
        .iter()
        .flatten()
        .filter(|a| a.from_earlier())
        .count();
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
    })
}
