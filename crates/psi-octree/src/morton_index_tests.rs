//! Tests of `morton_index`: every query and sweep against brute force.

use super::*;
use proptest::prelude::*;

use crate::{Interrupted, Monitor, StopFlag};

/// The k nearest of `x` among `points` other than index `skip`, by brute force, as
/// (original index, squared distance) in (distance, index) order.
fn brute(points: &[DVec3], x: DVec3, k: usize, skip: Option<usize>) -> Vec<(u32, f64)> {
    let mut all: Vec<(f64, u32)> = points
        .iter()
        .enumerate()
        .filter(|(i, p)| Some(*i) != skip && p.is_finite())
        .map(|(i, p)| ((*p - x).length_squared(), i as u32))
        .collect();
    all.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    all.truncate(k);
    all.into_iter().map(|(d, i)| (i, d)).collect()
}

/// A cloud with what makes nearest neighbours hard: a dense sheet, a sparse patch, exact
/// grid ties, coincident twins and far strays.
fn cloud(seed: u64, n: usize) -> Vec<DVec3> {
    use rand::{RngExt, SeedableRng};
    let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(seed);
    let mut rnd = move || rng.random::<f64>();
    let mut p = Vec::new();
    for i in 0..n {
        let v = match i % 10 {
            0..=5 => DVec3::new(rnd(), rnd(), 0.01 * rnd()),
            6 => DVec3::new(2.0 + 0.5 * rnd(), rnd(), 3.0 * rnd()),
            7 => DVec3::new((i % 7) as f64 * 0.1, (i / 7 % 5) as f64 * 0.1, 0.5),
            8 => p.last().copied().unwrap_or(DVec3::ZERO),
            _ => DVec3::new(10.0 * rnd() - 5.0, 10.0 * rnd(), -3.0 * rnd()),
        };
        p.push(v);
    }
    p
}

fn check_all(points: &[DVec3], k: usize) {
    let index = MortonIndex::new(points);
    let ids = index.ids().to_vec();
    let got = index.map_nearest(k, |s, near| {
        (
            s,
            near.iter()
                .map(|&(t, d)| (ids[t as usize], d))
                .collect::<Vec<_>>(),
        )
    });
    assert_eq!(got.len(), index.len());
    for (s, near) in got {
        let i = ids[s] as usize;
        let alone: Vec<(u32, f64)> = index
            .nearest_other(s, k)
            .into_iter()
            .map(|(t, d)| (ids[t as usize], d))
            .collect();
        assert_eq!(alone, near, "point {i} alone, k {k}");
        assert_eq!(
            near,
            brute(points, points[i], k, Some(i)),
            "point {i}, k {k}"
        );
    }
    // The sweep of some slots alone (every third, and those of a box): their answers.
    let all = index.map_nearest(k, |_, near| near.to_vec());
    let boxed = |s: usize| index.points()[s].x < 0.3;
    for want in [
        &(|s: usize| s % 3 == 1) as &(dyn Fn(usize) -> bool + Sync),
        &boxed,
    ] {
        let some = index.map_nearest_of(k, want, |s, near| (s, near.to_vec()));
        let expected: Vec<(usize, Vec<(u32, f64)>)> = (0..index.len())
            .filter(|&s| want(s))
            .map(|s| (s, all[s].clone()))
            .collect();
        assert_eq!(some, expected, "k {k}");
    }
}

#[test]
fn every_points_neighbours_equal_brute_force() {
    for (seed, n) in [(1, 2000), (2, 700), (3, 64), (4, 5)] {
        for k in [1, 8, 16, 48] {
            check_all(&cloud(seed, n), k);
        }
    }
}

#[test]
fn degenerate_clouds() {
    check_all(&[], 4);
    check_all(&[DVec3::ONE; 50], 8);
    let line: Vec<DVec3> = (0..300).map(|i| DVec3::new(i as f64, 0.0, 0.0)).collect();
    check_all(&line, 10);
    let mut holes = cloud(5, 400);
    holes[3] = DVec3::NAN;
    holes[17] = DVec3::new(f64::INFINITY, 0.0, 0.0);
    check_all(&holes, 12);
    let index = MortonIndex::new(&holes);
    assert_eq!(index.len(), 398);
    assert!(index.nearest(DVec3::NAN, 3).is_empty());
    // k of zero or beyond the points.
    assert_eq!(index.map_nearest(0, |_, near| near.len()), vec![0; 398]);
    assert_eq!(index.nearest(DVec3::ZERO, usize::MAX).len(), 398);
    check_all(&holes[..20], 1000);
    // Far from the origin: 1 m of points 6.4e6 m away (earth-centred coordinates).
    let far: Vec<DVec3> = cloud(6, 500)
        .iter()
        .map(|p| *p * 0.1 + DVec3::new(6.4e6, -1.2e6, 3.3e5))
        .collect();
    check_all(&far, 9);
}

/// A cell's slots found by galloping from any slot are the binary search's, for occupied and
/// empty cells at every level, and the lower bound near any position is the first key not
/// below the one sought.
#[test]
fn galloping_finds_what_bisection_finds() {
    use rand::{RngExt, SeedableRng};
    let index = MortonIndex::new(&cloud(9, 3000));
    let n = index.len();
    let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(3);
    for level in [0, 1, 3, 6, 9, 12] {
        let side = 1u64 << level;
        for _ in 0..400 {
            let c = [0; 3].map(|_: u64| rng.random_range(0..side));
            let near = rng.random_range(0..=n);
            assert_eq!(
                index.cell_range_near(c, level, near),
                index.cell_range(c, level, (0, n)),
                "level {level}, cell {c:?}, from {near}"
            );
        }
        // The occupied cells themselves, from their neighbours in slot order.
        for s in (0..n).step_by(37) {
            let c = index.cell_of(index.points()[s], level);
            let near = s.saturating_sub(rng.random_range(0..50));
            assert_eq!(
                index.cell_range_near(c, level, near),
                index.cell_range(c, level, (0, n))
            );
        }
    }
    let keys = [1u64, 3, 3, 3, 7, 9];
    for key in 0..11 {
        let want = keys.partition_point(|&k| k < key);
        for near in 0..=keys.len() + 2 {
            assert_eq!(
                lower_bound_near(&keys, key, near),
                want,
                "key {key} from {near}"
            );
        }
    }
    assert_eq!(lower_bound_near(&[], 5, 0), 0);
}

/// A ball holds the points on its sphere (|p − x| = radius exactly, on an integer grid), as the
/// kd-tree's does: the centre and its 6 face neighbours at radius 1; at radius 2 also the 12 edge
/// and 8 corner neighbours and the 6 two steps away.
#[test]
fn a_ball_holds_the_points_on_its_sphere() {
    let grid: Vec<DVec3> = (0..1000)
        .map(|i| DVec3::new((i % 10) as f64, (i / 10 % 10) as f64, (i / 100) as f64))
        .collect();
    let index = MortonIndex::new(&grid);
    let tree = crate::PointIndex::new(&grid);
    let x = DVec3::new(4.0, 5.0, 6.0);
    for (radius, count) in [(1.0, 7), (1.5, 19), (2.0, 33), (0.5, 1)] {
        let (mut ours, mut theirs) = (Vec::new(), Vec::new());
        index.within(x, radius, &mut ours);
        tree.within(x, radius, &mut theirs);
        ours.sort_unstable();
        theirs.sort_unstable();
        assert_eq!(ours.len(), count, "radius {radius}");
        assert_eq!(ours, theirs, "radius {radius}");
    }
    let mut none = Vec::new();
    index.within(DVec3::NAN, 1.0, &mut none);
    assert!(none.is_empty());
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]
    /// Queries anywhere, inside the cloud's box or far outside it, equal brute force.
    #[test]
    fn queries_equal_brute_force(seed in 0u64..1000, n in 1usize..1500, k in 1usize..40,
                                 qx in -20.0f64..20.0, qy in -20.0f64..20.0, qz in -20.0f64..20.0) {
        let points = cloud(seed, n);
        let index = MortonIndex::new(&points);
        let x = DVec3::new(qx, qy, qz) * if seed % 2 == 0 { 0.1 } else { 1.0 };
        let got: Vec<(u32, f64)> = index
            .nearest(x, k)
            .into_iter()
            .map(|(s, d)| (index.ids()[s as usize], d))
            .collect();
        prop_assert_eq!(got, brute(&points, x, k, None));
    }

    /// Ball queries anywhere equal brute force and `PointIndex`'s: the same points with the
    /// same squared distances (ties on the sphere included: the cloud has grid points).
    #[test]
    fn balls_equal_brute_force_and_the_kd_tree(seed in 0u64..1000, n in 1usize..1500,
                                               radius in 0.0f64..3.0, at in 0usize..1500,
                                               qx in -8.0f64..8.0, qy in -8.0f64..8.0) {
        let points = cloud(seed, n);
        let index = MortonIndex::new(&points);
        let tree = crate::PointIndex::new(&points);
        // Half the queries at a point of the cloud (grid ties at exact distances).
        let x = if at % 2 == 0 { points[at % n] } else { DVec3::new(qx, qy, 0.0) };
        let mut got = Vec::new();
        index.within_distances(x, radius, &mut got);
        got.sort_by_key(|g| g.0);
        let want: Vec<(u32, f64)> = (0..n as u32)
            .map(|i| (i, (points[i as usize] - x).length_squared()))
            .filter(|g| g.1 <= radius * radius)
            .collect();
        prop_assert_eq!(&got, &want);
        let mut kd = Vec::new();
        tree.within_distances(x, radius, &mut kd);
        kd.sort_by_key(|g| g.0);
        prop_assert_eq!(&got, &kd);
        let mut ids = Vec::new();
        index.within(x, radius, &mut ids);
        prop_assert_eq!(ids.len(), got.len());
    }

    /// Every point's k nearest others from the sweep equal brute force, whichever path each
    /// point takes (the block within its predecessor's bound or the block's reach, the outer
    /// ring, the search from a coarser level).
    #[test]
    fn sweeps_equal_brute_force(seed in 0u64..1000, n in 1usize..1200, k in 1usize..64) {
        check_all(&cloud(seed, n), k);
    }
}

#[test]
fn a_subset_answers_for_its_points_alone() {
    let points = cloud(7, 1500);
    let index = MortonIndex::new(&points);
    let sub = index.subset(|s| index.ids()[s].is_multiple_of(3));
    let kept: Vec<DVec3> = points
        .iter()
        .enumerate()
        .map(|(i, p)| if i % 3 == 0 { *p } else { DVec3::NAN })
        .collect();
    for q in [
        DVec3::ZERO,
        DVec3::new(0.5, 0.5, 0.0),
        DVec3::new(3.0, 9.0, -2.0),
    ] {
        let got: Vec<(u32, f64)> = sub
            .nearest(q, 10)
            .into_iter()
            .map(|(s, d)| (sub.ids()[s as usize], d))
            .collect();
        assert_eq!(got, brute(&kept, q, 10, None));
    }
}

/// A retained index answers as a fresh index of the retained points (renumbered as `retain`
/// numbers them), sweeps and single queries alike, though its frame is the whole set's: the
/// dropped points set the cube (a far point among them), and a non-finite point is skipped.
/// `rank_of` against brute force: the number of keys below the query's, for the indexed
/// points (twins and grid ties among them), points between them, a far one and a non-finite one.
#[test]
fn a_rank_counts_the_keys_below() {
    let points = cloud(11, 3_000);
    let index = MortonIndex::new(&points);
    let mut queries: Vec<DVec3> = index.points().to_vec();
    queries.extend(
        points
            .windows(2)
            .map(|w| 0.5 * (w[0] + w[1]))
            .filter(|q| q.is_finite()),
    );
    queries.extend([DVec3::splat(1e9), DVec3::splat(-1e9)]);
    for x in queries {
        let key = key_in(x, index.lo, index.scale);
        let below = index.keys.iter().filter(|&&k| k < key).count();
        assert_eq!(index.rank_of(x), below, "{x}");
    }
    assert_eq!(index.rank_of(DVec3::new(f64::NAN, 0.0, 0.0)), 0);
    // Along the order, each point ranks at its first slot among its key's.
    for s in 0..index.len() {
        let r = index.rank_of(index.points()[s]);
        assert!(r <= s && index.keys[r] == index.keys[s], "slot {s}: {r}");
    }
}

#[test]
fn a_retained_index_answers_as_a_fresh_one() {
    let mut points = cloud(11, 3000);
    points[17] = DVec3::new(1e3, -1e3, 5e2);
    points[40] = DVec3::new(f64::NAN, 0.0, 0.0);
    let keep: Vec<bool> = (0..points.len()).map(|i| i % 4 != 1 && i != 17).collect();
    let mut left = keep.iter();
    let mut kept = points.clone();
    kept.retain(|_| *left.next().unwrap());
    let retained = MortonIndex::new(&points).retained(&keep);
    let fresh = MortonIndex::new(&kept);
    assert_eq!(retained.len(), fresh.len());
    let by_id = |index: &MortonIndex, k| {
        let mut all: Vec<(u32, Vec<(u32, u64)>)> = index
            .ids()
            .iter()
            .zip(index.map_nearest(k, |_, near| {
                near.iter()
                    .map(|&(s, d2)| (index.ids()[s as usize], d2.to_bits()))
                    .collect::<Vec<_>>()
            }))
            .map(|(&id, near)| (id, near))
            .collect();
        all.sort_by_key(|e| e.0);
        all
    };
    for k in [1, 7, 30] {
        assert_eq!(by_id(&retained, k), by_id(&fresh, k));
    }
    for q in [DVec3::ZERO, DVec3::new(0.3, -0.2, 0.1), DVec3::splat(4.0)] {
        let ids = |index: &MortonIndex| -> Vec<(u32, f64)> {
            index
                .nearest(q, 12)
                .into_iter()
                .map(|(s, d)| (index.ids()[s as usize], d))
                .collect()
        };
        assert_eq!(ids(&retained), ids(&fresh));
        assert_eq!(ids(&fresh), brute(&kept, q, 12, None));
    }
}

#[test]
fn the_monitored_sweep_equals_the_plain_one_and_stops_between_cells() {
    let points = cloud(7, 20_000);
    let index = MortonIndex::new(&points);
    let plain = index.map_nearest(8, |_, near| near.to_vec());
    let flag = StopFlag::new();
    let monitor = Monitor::new(None, Some(&flag));
    assert_eq!(
        index.map_nearest_with(8, &monitor, |_, near| near.to_vec()),
        Ok(plain)
    );
    // Stopped after the 100th point: the cells that start later search nothing.
    let calls = std::sync::atomic::AtomicUsize::new(0);
    let stopped = index.map_nearest_with(8, &monitor, |_, _| {
        if calls.fetch_add(1, std::sync::atomic::Ordering::Relaxed) == 100 {
            flag.stop();
        }
    });
    assert_eq!(stopped, Err(Interrupted));
    let calls = calls.into_inner();
    assert!(
        calls < 5_000,
        "{calls} of {} points searched after the stop",
        index.len()
    );
}

/// Brute force: the indices of the finite points whose position equals (`==` per
/// coordinate) that of a finite point with a smaller index.
fn repeated_brute(points: &[DVec3]) -> Vec<u32> {
    let same = |a: DVec3, b: DVec3| a.x == b.x && a.y == b.y && a.z == b.z;
    (0..points.len())
        .filter(|&i| {
            points[i].is_finite()
                && (0..i).any(|j| points[j].is_finite() && same(points[i], points[j]))
        })
        .map(|i| i as u32)
        .collect()
}

#[test]
fn repeated_positions_equal_brute_force() {
    let mut points = cloud(5, 600);
    // (The cloud has coincident twins and grid ties of its own.) Copies before and after their
    // original, −0 for +0, one position 100 times (a run sorted before it is compared), a
    // point sharing a Morton cell without being equal, and points that are not finite.
    let copies: Vec<DVec3> = (0..60).map(|k| points[(k * 7) % 600]).collect();
    points.extend(copies);
    points.insert(3, points[400]);
    points.push(DVec3::new(0.0, 0.25, 0.5));
    points.push(DVec3::new(-0.0, 0.25, 0.5));
    points.extend(std::iter::repeat_n(points[10], 100));
    points.push(points[20] + DVec3::splat(1e-15));
    points.push(DVec3::new(f64::NAN, 0.0, 0.0));
    points.push(DVec3::new(f64::NAN, 0.0, 0.0));
    let want = repeated_brute(&points);
    assert!(want.len() > 150, "{}", want.len());
    assert_eq!(MortonIndex::new(&points).repeated_positions(), want);
    // One position only, many times; and no repeats.
    let one = vec![DVec3::new(1.0, -2.0, 3.0); 1000];
    assert_eq!(
        MortonIndex::new(&one).repeated_positions(),
        (1..1000).collect::<Vec<u32>>()
    );
    let distinct: Vec<DVec3> = (0..500)
        .map(|i| DVec3::new(i as f64, (i * i % 97) as f64, 0.5))
        .collect();
    assert!(MortonIndex::new(&distinct).repeated_positions().is_empty());
}
