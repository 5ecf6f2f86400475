//! A cell's fitting radius R1 (Ohtake's enlarged support radius, alg. §1.1) and the ball of
//! that radius: from one ball query a little wider than R when it holds enough points, else
//! from the kd-tree's k-nearest distance.

use glam::DVec3;
use psi_octree::{BallAnswer, PointIndex};

use crate::MpuParams;

/// The trial ball's radius, R + m·λR with m = ⌈TRIAL / λ⌉: wide enough to settle most cells'
/// R1 from one query, narrow enough that its points cost little more than the ball of R.
const TRIAL: f64 = 0.4;

/// R1 from the `need`-th nearest distance `d` (world units): the smallest R + m·λR (m ≥ 0)
/// not below `d`, the result of Ohtake's loop that grows R by λR until the ball holds more
/// than N_min points.
pub(crate) fn radius_reaching(d: f64, r: f64, lambda: f64) -> f64 {
    if d <= r {
        return r;
    }
    let step = lambda * r;
    let m = ((d - r) / step).ceil();
    let mut r1 = r + m * step;
    // Guard against rounding leaving the needed point just outside.
    while r1 < d {
        r1 += step;
    }
    r1
}

/// The enlarged fitting radius: R1 = R + m·λR for the smallest m ≥ 0 with more than N_min
/// points in B(c, R1) (all points when there are fewer: `need` = min(N_min + 1, N)), computed
/// from the `need`-th nearest distance instead of Ohtake's loop, with the same result.
fn fit_radius(index: &PointIndex, params: &MpuParams, need: usize, center: DVec3, r: f64) -> f64 {
    let nearest = index.nearest(center, need);
    let Some(&(_, d2)) = nearest.last() else {
        return r;
    };
    radius_reaching(d2.sqrt(), r, params.lambda)
}

/// What a refit after an edit knows of the cell's earlier fit; it changes no result, only
/// the work.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Earlier<'a> {
    /// The earlier R1 (world units).
    pub(crate) r1: Option<f64>,
    /// The answer of the earlier fit's ball query ([`psi_octree::PointIndex::ball_answer`]).
    pub(crate) ball: Option<&'a BallAnswer>,
    /// Whether to return this fit's ball answer (for the next refit).
    pub(crate) keep_ball: bool,
}

/// R1 of the cell at `center` with nominal radius `r` (world units), and the indices of the
/// points within R1 when one trial query found them. The trial ball has a radius R1 can take,
/// R + m·λR: the smallest reaching `earlier.r1` (a cell refitted after an edit passes its
/// earlier R1, which most edits leave as it was; or `earlier.ball`'s own radius when that is
/// at most two steps wider), else m = ⌈[`TRIAL`]/λ⌉. It holds every
/// point within its radius with the kd-tree's own squared distances, the ones a k-nearest
/// query computes; when it holds `need` points its `need`-th smallest distance is the
/// `need`-th nearest distance, R1 is what [`fit_radius`] finds, and R1 is at most the trial
/// radius, so the ball of R1 is the trial points with d² ≤ R1² (the test the kd-tree applies;
/// in some order, which no decision reads). Otherwise R1 comes from a k-nearest query and the
/// ball is `None`.
///
/// The trial ball is read from `earlier.ball` when that applies (an answer of an earlier
/// version of `index` at this centre: [`PointIndex::ball_answer`]); with `earlier.keep_ball`,
/// the trial ball's answer is returned too (sorted by id, so that the ball comes sorted, as a
/// fit reads its points, and so does the next refit's answer read from it).
pub(crate) fn settle_radius_from(
    index: &PointIndex,
    params: &MpuParams,
    need: usize,
    center: DVec3,
    r: f64,
    earlier: Earlier<'_>,
) -> (f64, Option<Vec<u32>>, Option<BallAnswer>) {
    let Earlier {
        r1: hint,
        ball: earlier,
        keep_ball: keep,
    } = earlier;
    let mut trial = match hint {
        Some(h) if h.is_finite() => radius_reaching(h, r, params.lambda),
        _ => r + (TRIAL / params.lambda).ceil().max(1.0) * (params.lambda * r),
    };
    // An earlier answer up to two steps wider is read at its own radius: the pairs beyond the
    // trial cost little more (they are all visited), and where R1 went back and forth it
    // settles R1 without a k-nearest query. (Bounded, so that kept answers do not widen
    // stroke after stroke; a trial R1 could not take is caught below.)
    if let Some(e) = earlier
        && e.radius() > trial
        && e.radius() <= trial + 2.0 * params.lambda * r
    {
        trial = e.radius();
    }
    let mut near = Vec::with_capacity(8 * need);
    let answer = if keep || earlier.is_some() {
        let mut answer = index.ball_answer(center, trial, earlier, std::mem::take(&mut near));
        if keep {
            answer.sort_by_id();
        }
        Some(answer)
    } else {
        index.within_distances(center, trial, &mut near);
        None
    };
    let count = answer.as_ref().map_or(near.len(), |a| a.near().len());
    if need == 0 || count < need {
        return (fit_radius(index, params, need, center, r), None, answer);
    }
    // The need-th smallest squared distance: in place when the pairs are this fit's alone (a
    // reorder no decision reads), from a copy when they are the answer kept.
    let kth = match &answer {
        Some(a) => {
            let mut d2: Vec<f64> = a.near().iter().map(|n| n.1).collect();
            *d2.select_nth_unstable_by(need - 1, f64::total_cmp).1
        }
        None => {
            near.select_nth_unstable_by(need - 1, |a, b| a.1.total_cmp(&b.1))
                .1
                .1
        }
    };
    let r1 = radius_reaching(kth.sqrt(), r, params.lambda);
    let near = answer.as_ref().map_or(&near[..], |a| a.near());
    if r1 > trial {
        // (Rounding at the trial sphere: the k-nearest query decides.)
        return (fit_radius(index, params, need, center, r), None, answer);
    }
    let r1_2 = r1 * r1;
    let ball = near.iter().filter(|n| n.1 <= r1_2).map(|n| n.0).collect();
    (r1, Some(ball), answer)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64Mcg;

    /// Brute force: Ohtake's loop (R grown by λR until more than N_min points lie within it,
    /// or all of them) and the ball of the result.
    fn ohtake(points: &[DVec3], params: &MpuParams, center: DVec3, r: f64) -> (f64, Vec<u32>) {
        let need = (params.n_min + 1).min(points.len());
        let count = |r1: f64| {
            points
                .iter()
                .filter(|p| (**p - center).length_squared() <= r1 * r1)
                .count()
        };
        let mut m = 0.0;
        let mut r1 = r;
        while count(r1) < need {
            m += 1.0;
            r1 = r + m * params.lambda * r;
        }
        let ball = (0..points.len() as u32)
            .filter(|&i| (points[i as usize] - center).length_squared() <= r1 * r1)
            .collect();
        (r1, ball)
    }

    #[test]
    fn the_radius_and_ball_are_ohtakes_whether_the_trial_settles_them_or_not() {
        let mut rng = Pcg64Mcg::seed_from_u64(11);
        let mut rnd = move || rng.random::<f64>();
        // A clustered cloud: dense lumps and a sparse background, so cells of every radius
        // see from none to hundreds of points within R.
        let mut points = Vec::new();
        for _ in 0..20 {
            let c = DVec3::new(rnd(), rnd(), rnd());
            for _ in 0..150 {
                points.push(c + 0.03 * DVec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5));
            }
        }
        for _ in 0..600 {
            points.push(DVec3::new(rnd(), rnd(), rnd()));
        }
        let index = PointIndex::new(&points);
        let params = MpuParams::paper();
        let need = params.n_min + 1;
        let (mut settled, mut fell_back, mut settled_wider) = (0, 0, 0);
        for k in 0..600 {
            let center = DVec3::new(rnd(), rnd(), rnd());
            let r = 0.005 * (1.0 + (k % 30) as f64);
            let (want_r1, want_ball) = ohtake(&points, &params, center, r);
            // No hint, or an earlier R1 (as after an edit): right, too small or too large.
            let hint = match k % 5 {
                0 | 1 => None,
                2 => Some(want_r1),
                3 => Some(r.max(want_r1 - 2.0 * params.lambda * r)),
                _ => Some(want_r1 + 3.0 * params.lambda * r),
            };
            let earlier = |ball, keep_ball| Earlier {
                r1: hint,
                ball,
                keep_ball,
            };
            let settle = |e: Earlier<'_>| settle_radius_from(&index, &params, need, center, r, e);
            let (r1, ball, answer) = settle(earlier(None, k % 2 == 0));
            let (plain_r1, plain_ball, _) = settle(earlier(None, false));
            assert_eq!(r1.to_bits(), plain_r1.to_bits());
            // Read again from its own answer: the same radius and ball.
            let (again_r1, again_ball, _) = settle(earlier(answer.as_ref(), true));
            assert_eq!(r1.to_bits(), again_r1.to_bits());
            let sorted = |b: Option<Vec<u32>>| {
                b.map(|mut b| {
                    b.sort_unstable();
                    b
                })
            };
            assert_eq!(sorted(ball.clone()), sorted(again_ball));
            assert_eq!(sorted(ball.clone()), sorted(plain_ball));
            // An answer kept at a trial up to two steps wider than this one (as when R1 went
            // back and forth between strokes) is read at its own radius: the same R1, and the
            // ball where it settles it.
            let step = params.lambda * r;
            let trial = hint.map_or(r + 4.0 * step, |h| radius_reaching(h, r, params.lambda));
            let wider = Earlier {
                r1: Some(trial + step * (1 + k % 2) as f64),
                ball: None,
                keep_ball: true,
            };
            let (_, _, wide_answer) = settle(wider);
            let (wide_r1, wide_ball, _) = settle(earlier(wide_answer.as_ref(), true));
            assert_eq!(wide_r1.to_bits(), r1.to_bits());
            if let Some(b) = sorted(wide_ball) {
                assert_eq!(b, sorted(Some(want_ball.clone())).unwrap());
                settled_wider += usize::from(ball.is_none());
            }
            psi_shapes::assert_near!(r1, want_r1, 1e-12);
            assert_eq!(
                r1.to_bits(),
                fit_radius(&index, &params, need, center, r).to_bits()
            );
            match ball {
                Some(mut ball) => {
                    ball.sort_unstable();
                    assert_eq!(ball, want_ball, "cell {k}");
                    let mut kd = Vec::new();
                    index.within(center, r1, &mut kd);
                    kd.sort_unstable();
                    assert_eq!(ball, kd);
                    settled += 1;
                }
                None => fell_back += 1,
            }
        }
        assert!(
            settled > 100 && fell_back > 20 && settled_wider > 10,
            "{settled} settled, {fell_back} fell back, {settled_wider} settled by a wider answer"
        );
    }
}
