//! Tests of the outlier step by parts: bitwise the whole step (repeats left out, then
//! `find_outliers`) on a noisy torus with stray points scattered and lifted, repeated positions
//! and normals across the surface, split into 8 and 27 parts whose halos grow as refused.

use super::*;
use crate::find_outliers;
use crate::grid_parts::grid_parts;
use crate::median::median_of_passes;
use crate::outlier_verdicts_by_parts::part_outliers;
use psi_shapes::AnalyticShape;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64Mcg;

/// What the whole step leaves out, the in-core way (repeats of a lower index out, then
/// `find_outliers` on the rest): per point whether it is kept or a repeat or an outlier (as
/// `Far`, the kinds counted apart), the counts of far and off-surface outliers, and the
/// statistic it reads, with each point's 16th-neighbour distance (brute force; NaN for a
/// repeat) and, for a point unsure after the first stage, the distance to its 16th nearest
/// core point (0 for the others).
type Whole = (
    Vec<StrayVerdict>,
    (usize, usize),
    OutlierStats,
    [Vec<f64>; 2],
);

fn whole(positions: &[DVec3], normals: Option<&[DVec3]>) -> Whole {
    let index = MortonIndex::new(positions);
    let mut keep = vec![true; positions.len()];
    for c in index.repeated_positions() {
        keep[c as usize] = false;
    }
    let kept: Vec<usize> = (0..positions.len()).filter(|&i| keep[i]).collect();
    let at: Vec<DVec3> = kept.iter().map(|&i| positions[i]).collect();
    let with: Option<Vec<DVec3>> = normals.map(|n| kept.iter().map(|&i| n[i]).collect());
    let found = find_outliers(&at, with.as_deref());
    let mut verdicts = vec![StrayVerdict::Repeated; positions.len()];
    for (k, &i) in kept.iter().enumerate() {
        verdicts[i] = if found.mask[k] {
            StrayVerdict::Far
        } else {
            StrayVerdict::Kept
        };
    }
    let mut reaches: Vec<f64> = at
        .iter()
        .enumerate()
        .map(|(i, &p)| {
            let mut d: Vec<f64> = at
                .iter()
                .enumerate()
                .filter(|&(j, _)| j != i)
                .map(|(_, &q)| (q - p).length())
                .collect();
            *d.select_nth_unstable_by(15, f64::total_cmp).1
        })
        .collect();
    let mut reach_of = vec![f64::NAN; positions.len()];
    for (&i, &r) in kept.iter().zip(&reaches) {
        reach_of[i] = r;
    }
    let mid = reaches.len() / 2;
    let stats = OutlierStats {
        typical: *reaches.select_nth_unstable_by(mid, f64::total_cmp).1,
        points: at.len() as u64,
    };
    // The first stage's standings, the whole's way, and the unsure points' core balls.
    let kept_index = MortonIndex::new(&at);
    let nearest = crate::find_outliers::nearest_of(&kept_index, &psi_octree::Monitor::silent());
    let nearest = nearest.expect("silent");
    let by_slot = kept_index.points();
    let normal_of = with.as_ref().map(|v| {
        let ids = kept_index.ids();
        move |s: usize| v[ids[s] as usize]
    });
    let normal_of = normal_of
        .as_ref()
        .map(|f| f as &crate::find_outliers::NormalOf<'_>);
    let status: Vec<Status> = (0..at.len())
        .map(|s| status_of(s, by_slot, &nearest, stats.typical, normal_of))
        .collect();
    let cores: Vec<DVec3> = (0..at.len())
        .filter(|&s| status[s] == Status::Core)
        .map(|s| by_slot[s])
        .collect();
    let mut core_reach = vec![0.0; positions.len()];
    for s in (0..at.len()).filter(|&s| status[s] == Status::Unsure) {
        let mut d: Vec<f64> = cores.iter().map(|&c| (c - by_slot[s]).length()).collect();
        let i = kept[kept_index.ids()[s] as usize];
        core_reach[i] = *d.select_nth_unstable_by(15, f64::total_cmp).1;
    }
    let reaches = [reach_of, core_reach];
    (verdicts, (found.far, found.off_surface), stats, reaches)
}

/// A test's work on one part: its points, input indices, which are its own, their normals,
/// the part; per own point, its index and what was found.
type PartTask<'a, T> = dyn Fn(
        &[DVec3],
        &[u32],
        &[bool],
        Option<&[DVec3]>,
        &crate::grid_parts::GridPart,
    ) -> Result<Vec<(u32, T)>, IncompletePart>
    + 'a;

/// `f` on each of the g³ parts of `positions` (with `normals`), each part's halo grown from
/// `halo` while it refuses: what it found, how many parts grew, each part's last halo.
fn each_part<T>(
    positions: &[DVec3],
    normals: Option<&[DVec3]>,
    (g, halo): (usize, f64),
    f: &PartTask<'_, T>,
) -> (Vec<(u32, T)>, usize, Vec<f64>) {
    let mut grown = 0;
    let mut out = Vec::new();
    let mut halos = Vec::new();
    for c in 0..g * g * g {
        let mut h = halo;
        for tries in 0.. {
            // (The halo grows geometrically: a part refused this often refuses for ever.)
            assert!(tries < 40, "part {c} refused {tries} times");
            let part = grid_parts(positions, g, h).swap_remove(c);
            let held: Vec<DVec3> = part.ids.iter().map(|&i| positions[i as usize]).collect();
            let with: Option<Vec<DVec3>> =
                normals.map(|n| part.ids.iter().map(|&i| n[i as usize]).collect());
            match f(&held, &part.ids, &part.own, with.as_deref(), &part) {
                Ok(found) => {
                    out.extend(found);
                    halos.push(h);
                    break;
                }
                Err(e) => {
                    assert!(e.reach > 0.0);
                    grown += usize::from(h == halo);
                    h = if e.reach.is_finite() {
                        (1.01 * e.reach).max(1.5 * h)
                    } else {
                        2.0 * h
                    };
                }
            }
        }
    }
    (out, grown, halos)
}

/// The parts' verdicts per point, each part's halo grown from `halo` as the part asks; how
/// many parts grew, and how many grew further to judge their unsure points than to give
/// their points' standings. Each own point's standing reads, as the whole's does, the
/// 16th-neighbour distances `reach_of[0]` (shape: N) of its 16 nearest, and a part holds the
/// ball of its 16 nearest core points, `reach_of[1]`, around each unsure own point (checked).
fn by_parts(
    positions: &[DVec3],
    normals: Option<&[DVec3]>,
    reach_of: &[Vec<f64>; 2],
    parts: (usize, f64),
) -> (Vec<StrayVerdict>, OutlierStats, [usize; 2]) {
    // The first pass: every own point's standing reads its neighbours' reaches, the whole's.
    let (standings, _, first_halos) =
        each_part(positions, normals, parts, &|held, ids, own, with, part| {
            let complete = |x: DVec3, r: f64| part.holds_ball(x, r);
            let found = part_standings(held, ids, own, with, &complete)?;
            let hood = Neighbourhoods::of(held, own, &complete);
            for s in (0..hood.index.len()).filter(|&s| own[hood.part_of[s]]) {
                for &q in &hood.nearest[s].0 {
                    let id = ids[hood.part_of[q as usize]] as usize;
                    assert_eq!(hood.nearest[q as usize].1, reach_of[0][id], "point {id}");
                }
            }
            let mine = ids.iter().zip(own).filter(|p| *p.1).map(|p| *p.0);
            Ok(mine.zip(found).collect())
        });
    let mut standing_of = vec![None; positions.len()];
    for &(i, st) in &standings {
        assert!(
            standing_of[i as usize].replace(st).is_none(),
            "point {i} twice"
        );
    }
    let reaches: Vec<f64> = standings
        .iter()
        .filter_map(|(_, st)| st.searched_reach())
        .collect();
    let typical = median_of_passes(|visit: &mut dyn FnMut(f64)| {
        reaches.iter().for_each(|&r| visit(r));
        Ok::<(), ()>(())
    })
    .unwrap()
    .unwrap();
    let stats = OutlierStats {
        typical,
        points: reaches.len() as u64,
    };
    let (found, grown, halos) =
        each_part(positions, normals, parts, &|held, ids, own, with, part| {
            let complete = |x: DVec3, r: f64| part.holds_ball(x, r);
            let mine: Vec<u32> = ids.iter().zip(own).filter(|p| *p.1).map(|p| *p.0).collect();
            let st: Vec<OwnStanding> = mine
                .iter()
                .map(|&i| standing_of[i as usize].expect("a standing"))
                .collect();
            let v = part_outliers(held, ids, own, with, &complete, (stats, &st))?;
            for &i in &mine {
                let x = positions[i as usize];
                assert!(
                    part.holds_ball(x, reach_of[1][i as usize]),
                    "point {i}: core ball"
                );
            }
            Ok(mine.into_iter().zip(v).collect())
        });
    let mut verdicts = vec![None; positions.len()];
    for (i, v) in found {
        assert!(verdicts[i as usize].replace(v).is_none(), "point {i} twice");
    }
    let verdicts = verdicts.into_iter().map(|v| v.expect("every point judged"));
    let further = halos
        .iter()
        .zip(&first_halos)
        .filter(|(a, b)| a > b)
        .count();
    (verdicts.collect(), stats, [grown, further])
}

/// A noisy torus with 200 points scattered through its box, 60 lifted 3 to 10 spacings off,
/// 40 points repeated (one of them 20 times), a wire of 40 points across its hole and, with
/// normals, 30 points a little off with
/// normals across: each point's verdict by parts is the whole step's.
#[test]
fn parts_leave_out_what_the_whole_step_leaves_out() {
    let torus = AnalyticShape::Torus {
        major: 1.0,
        minor: 0.35,
    };
    let surface = torus.sample(12_000, 5);
    let spacing = (torus.area() / 12_000.0).sqrt();
    let mut rng = Pcg64Mcg::seed_from_u64(3);
    let mut positions: Vec<DVec3> = surface
        .iter()
        .map(|p| p.p + 0.05 * spacing * psi_shapes::gaussian(&mut rng) * p.n)
        .collect();
    let mut normals: Vec<DVec3> = surface.iter().map(|p| p.n).collect();
    for _ in 0..200 {
        let p = DVec3::new(
            rng.random_range(-1.4..1.4),
            rng.random_range(-1.4..1.4),
            rng.random_range(-0.4..0.4),
        );
        positions.push(p);
        normals.push(DVec3::Z);
    }
    for k in 0..60 {
        let p = surface[k * 191];
        positions.push(p.p + rng.random_range(3.0..10.0) * spacing * p.n);
        normals.push(p.n);
    }
    for k in 0..40 {
        positions.push(positions[k * 251]);
        normals.push(normals[k * 251]);
    }
    for _ in 0..19 {
        positions.push(positions[777]);
        normals.push(normals[777]);
    }
    // A straight wire of 40 points through the torus's hole, 0.06 apart (its points' 16
    // nearest are its own, along a line: no surface, none of them core), by the faces of the
    // parts; each is judged against the inner ring, farther than its neighbours reach.
    for k in 0..40 {
        positions.push(DVec3::new(0.02, 0.01, -1.17 + 0.06 * k as f64));
        normals.push(DVec3::X);
    }
    for k in 0..30 {
        let i = 100 + k * 353;
        positions[i] += 0.8 * spacing * normals[i];
        normals[i] = normals[i].any_orthonormal_vector();
    }
    // The surface and the wire alone first: its halos grow no farther than its points'
    // neighbours reach, so a neighbour's own neighbours, and the wire's nearest core points,
    // can lie beyond them.
    let clean = surface.len();
    let mut wired = positions[..clean].to_vec();
    wired.extend_from_slice(&positions[positions.len() - 40..]);
    let (truth, _, _, reach_of) = whole(&wired, None);
    assert!(truth[..clean].iter().all(|v| *v == StrayVerdict::Kept));
    assert!(truth[clean..].iter().all(|v| *v == StrayVerdict::Far));
    let (found, _, grown) = by_parts(&wired, None, &reach_of, (2, 0.02));
    assert_eq!(found, truth);
    assert!(grown[0] > 0 && grown[1] > 0);
    for with in [None, Some(normals.as_slice())] {
        let (truth, (far, off), stats, reach_of) = whole(&positions, with);
        let left_out = truth.iter().filter(|v| **v != StrayVerdict::Kept).count();
        let repeats = truth
            .iter()
            .filter(|v| **v == StrayVerdict::Repeated)
            .count();
        assert_eq!(repeats, 59);
        assert!(left_out > repeats + 200, "{left_out} left out");
        for g in [2, 3] {
            let (found, parts_stats, grown) = by_parts(&positions, with, &reach_of, (g, 0.02));
            assert_eq!(parts_stats.points, stats.points);
            assert_eq!(parts_stats.typical.to_bits(), stats.typical.to_bits());
            let kinds = |v: StrayVerdict| match v {
                StrayVerdict::OffSurface => StrayVerdict::Far,
                v => v,
            };
            for (i, (a, b)) in found.iter().zip(&truth).enumerate() {
                assert_eq!(kinds(*a), *b, "point {i} ({:?} parts)", g * g * g);
            }
            assert!(grown[0] > 0, "no halo grew");
            assert!(grown[1] > 0, "no halo grew to judge");
            let count = |k| found.iter().filter(|v| **v == k).count();
            assert_eq!(count(StrayVerdict::Far), far);
            assert_eq!(count(StrayVerdict::OffSurface), off);
            assert!(off > 0 && far > 0);
        }
    }
}

/// A plane sampled on an exact unit grid with points lifted 0.8 above some nodes, their
/// normals across it (unsure points, judged against the grid): the distances to the grid tie
/// exactly, so the 16th nearest core point of a lifted point ties with points beyond a part's
/// face. By parts, every verdict is the whole step's (and the parts end: a tied point of the
/// halo is decided with the rest).
#[test]
fn exact_ties_on_a_grid_are_judged_as_the_whole_step_judges_them() {
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    // (A second plane far below, so that the parts split the grid across x and y alone.)
    for z in [0.0, -40.0] {
        for i in 0..40 {
            for j in 0..40 {
                positions.push(DVec3::new(f64::from(i), f64::from(j), z));
                normals.push(DVec3::Z);
            }
        }
    }
    // Two nodes from a face of the parts (19.5; 13 and 26): the 16th nearest core point ties
    // with a node across it.
    for (i, j) in [(18, 9), (18, 20), (18, 29), (11, 20), (24, 12), (21, 30)] {
        positions.push(DVec3::new(f64::from(i), f64::from(j), 0.8));
        normals.push(DVec3::X);
    }
    let (truth, (_, off), _, reach_of) = whole(&positions, Some(&normals));
    assert!(off > 0, "no lifted point left out");
    for g in [2, 3] {
        let (found, _, _) = by_parts(&positions, Some(&normals), &reach_of, (g, 0.6));
        let kinds = |v: StrayVerdict| match v {
            StrayVerdict::OffSurface => StrayVerdict::Far,
            v => v,
        };
        let found: Vec<StrayVerdict> = found.into_iter().map(kinds).collect();
        assert_eq!(found, truth, "{} parts", g * g * g);
    }
}
