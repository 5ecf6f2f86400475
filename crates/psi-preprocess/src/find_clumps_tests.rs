//! Tests of [`super::find_clumps`]: a brute-force twin of the definition on small random
//! scenes, clumps planted on analytic shapes, clean samplings, the reach, odd inputs.

use super::*;
use psi_octree::OrientedPoint;
use psi_shapes::{AnalyticShape, builtin_model, gaussian_vector};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64Mcg;

/// The definition of [`find_clumps`] before the 1 % rule, by brute force (every pair of
/// points, every point's spacing; shares only `fit_plane` with the code under test): the
/// stray groups (ascending indices, by first index), the link distance and the number of small
/// groups. For N ≤ 4096.
fn brute_force(p: &[DVec3]) -> (Vec<Vec<u32>>, f64, usize) {
    let n = p.len();
    let lo = p.iter().fold(DVec3::INFINITY, |m, &x| m.min(x));
    let hi = p.iter().fold(DVec3::NEG_INFINITY, |m, &x| m.max(x));
    let mut spacings: Vec<f64> = (0..n)
        .map(|i| {
            let mut d: Vec<f64> = (0..n)
                .filter(|&j| j != i)
                .map(|j| p[i].distance(p[j]))
                .collect();
            let k = d.len().min(16).saturating_sub(1);
            let r = if d.is_empty() {
                0.0
            } else {
                *d.select_nth_unstable_by(k, f64::total_cmp).1
            };
            r * (std::f64::consts::PI / 16.0).sqrt()
        })
        .collect();
    spacings.sort_by(f64::total_cmp);
    let high = spacings[((n - 1) as f64 * 0.9) as usize];
    let typical = spacings[n / 2];
    let link = (0.02 * (hi - lo).length()).max(3.0 * high);
    let dense = if typical > 0.0 {
        std::f64::consts::PI * (link / 2.0 / typical).powi(2)
    } else {
        0.0
    };
    // Groups: flood fill over all pairs.
    let mut group = vec![usize::MAX; n];
    let mut groups: Vec<Vec<usize>> = Vec::new();
    for start in 0..n {
        if group[start] != usize::MAX {
            continue;
        }
        let mut members = vec![start];
        group[start] = groups.len();
        let mut k = 0;
        while k < members.len() {
            let i = members[k];
            k += 1;
            for j in 0..n {
                if group[j] == usize::MAX && p[i].distance(p[j]) <= link {
                    group[j] = groups.len();
                    members.push(j);
                }
            }
        }
        members.sort_unstable();
        groups.push(members);
    }
    let small = |g: &Vec<usize>| {
        let lo = g.iter().fold(DVec3::INFINITY, |m, &i| m.min(p[i]));
        let hi = g.iter().fold(DVec3::NEG_INFINITY, |m, &i| m.max(p[i]));
        g.len() <= 100 && (hi - lo).max_element() <= 2.0 * link
    };
    let is_small: Vec<bool> = groups.iter().map(small).collect();
    let stray = |g: &Vec<usize>| {
        let mut best: Option<(f64, usize, usize)> = None;
        for &q in g {
            for s in (0..n).filter(|&s| !is_small[group[s]] && p[q].distance(p[s]) <= 3.0 * link) {
                let d2 = (p[q] - p[s]).length_squared();
                if best.is_none_or(|b| (d2, q, s) < b) {
                    best = Some((d2, q, s));
                }
            }
        }
        let Some((_, q, s)) = best else { return true };
        let near: Vec<DVec3> = (0..n)
            .filter(|&k| p[s].distance(p[k]) <= link / 2.0)
            .map(|k| p[k])
            .collect();
        (near.len() as f64) >= 0.25 * dense
            && fit_plane(near).is_some_and(|f| (p[q] - p[s]).dot(f.normal).abs() > link / 2.0)
    };
    let found = groups
        .iter()
        .filter(|g| small(g) && stray(g))
        .map(|g| g.iter().map(|&i| i as u32).collect())
        .collect();
    (found, link, is_small.iter().filter(|&&s| s).count())
}

/// A point uniform in the ball of radius `r` about the origin.
fn in_ball(rng: &mut Pcg64Mcg, r: f64) -> DVec3 {
    r * rng.random::<f64>().cbrt() * gaussian_vector(rng).normalize()
}

/// Three random square patches of a wavy surface 0.25 wide in the unit cube, 700 to 1000
/// points each: dense against 2 % D, unlike a closed shape's few thousand points.
fn patches(rng: &mut Pcg64Mcg) -> Vec<OrientedPoint> {
    let mut out = Vec::new();
    for _ in 0..3 {
        let centre = DVec3::new(rng.random(), rng.random(), rng.random());
        let n = gaussian_vector(rng).normalize();
        let u = n.any_orthonormal_vector();
        let v = n.cross(u);
        for _ in 0..rng.random_range(700..1000) {
            let (a, b): (f64, f64) = (rng.random(), rng.random());
            let p = centre + 0.25 * ((a - 0.5) * u + (b - 0.5) * v) + 0.01 * (20.0 * a).sin() * n;
            out.push(OrientedPoint { p, n });
        }
    }
    out
}

/// A random scene: a sampled shape (sparse against 2 % D, or dense patches; in one scene of
/// four, thinned to an eighth in a ball) and groups of 1 to 150 points of random widths, up to 30 % D off the
/// surface along its normal or any way, or up to 10 % D along it.
fn scene(seed: u64) -> Vec<DVec3> {
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    let shape = match seed % 3 {
        0 => AnalyticShape::Sphere { radius: 1.0 },
        1 => AnalyticShape::Torus {
            major: 1.0,
            minor: 0.35,
        },
        _ => AnalyticShape::Box {
            half: DVec3::new(1.0, 0.6, 0.3),
        },
    };
    let mut surface = match seed % 5 {
        4 => patches(&mut rng),
        _ => shape.sample(rng.random_range(150..3000), seed),
    };
    let d = 2.0 * shape_reach(&surface.iter().map(|p| p.p).collect::<Vec<_>>());
    if seed % 4 == 3 {
        let centre = surface[0].p;
        let mut k = 0;
        surface.retain(|p| {
            k += 1;
            p.p.distance(centre) > 0.25 * d || k % 8 == 0
        });
    }
    let mut points: Vec<DVec3> = surface.iter().map(|p| p.p).collect();
    for _ in 0..rng.random_range(0..10) {
        let size = [1, 2, 4, 12, 40, 99, 100, 101, 150][rng.random_range(0..9)];
        let base = surface[rng.random_range(0..surface.len())];
        let any = gaussian_vector(&mut rng).normalize();
        let (way, reach) = match rng.random_range(0..3) {
            0 => (base.n, 0.3),
            1 => (any, 0.3),
            _ => ((any - any.dot(base.n) * base.n).normalize_or_zero(), 0.1),
        };
        let centre = base.p + rng.random_range(0.0..reach) * d * way;
        let width = [0.0, 0.002, 0.01, 0.03][rng.random_range(0..4)] * d;
        points.extend((0..size).map(|_| centre + in_ball(&mut rng, width)));
    }
    points
}

/// Half the diagonal of the bounding box of `points`.
fn shape_reach(points: &[DVec3]) -> f64 {
    Aabb::from_points(points.iter().copied()).map_or(0.0, |b| b.diagonal() / 2.0)
}

/// The grid-and-index method equals the brute-force definition on random scenes, and the
/// scenes reach every verdict: clumps found, and small groups kept beside a surface.
#[test]
fn clumps_equal_the_brute_force_definition() {
    let (mut found, mut kept) = (0, 0);
    for seed in 0..60 {
        let points = scene(seed);
        let (groups, link) = stray_groups(&points, &MortonIndex::new(&points), &Monitor::silent());
        let (twin, twin_link, small) = brute_force(&points);
        assert!(
            (link - twin_link).abs() <= 1e-12 * link,
            "seed {seed}: {link} {twin_link}"
        );
        assert_eq!(groups, twin, "seed {seed}");
        // Each clump lies farther than h ≥ 2 % D from every other point.
        let gap = 0.02 * 2.0 * shape_reach(&points);
        for g in &groups {
            let apart = |j: usize| {
                g.iter()
                    .all(|&i| points[i as usize].distance(points[j]) > link)
            };
            let outside = (0..points.len()).filter(|&j| g.binary_search(&(j as u32)).is_err());
            assert!(link >= gap && outside.clone().all(apart), "seed {seed}");
        }
        found += groups.len();
        kept += small - groups.len();
    }
    assert!(found >= 40 && kept >= 5, "found {found}, kept {kept}");
}

/// Clumps of 1, 20 and 100 points planted 3 to 10 % D off a sphere and a torus, along the
/// normal, all go and no surface point does; a clump of 150 points stays (beyond the bound), one
/// 1 % D off may stay.
#[test]
fn planted_clumps_go_and_the_surface_stays() {
    for shape in [
        AnalyticShape::Sphere { radius: 1.0 },
        AnalyticShape::Torus {
            major: 1.0,
            minor: 0.35,
        },
    ] {
        let surface = shape.sample(30_000, 7);
        let mut points: Vec<DVec3> = surface.iter().map(|p| p.p).collect();
        let d = 2.0 * shape_reach(&points);
        let mut rng = Pcg64Mcg::seed_from_u64(3);
        // (points, offset / D, whether they must go)
        let plan = [
            (1, 0.03, Some(true)),
            (20, 0.06, Some(true)),
            (100, 0.10, Some(true)),
            (100, 0.03, Some(true)),
            (20, 0.04, Some(true)),
            (150, 0.05, Some(false)),
            (20, 0.01, None),
        ];
        let mut planted = Vec::new();
        for (k, &(size, offset, verdict)) in plan.iter().enumerate() {
            let base = surface[k * 4001];
            let centre = base.p + offset * d * base.n;
            planted.push((points.len()..points.len() + size, verdict));
            points.extend((0..size).map(|_| centre + in_ball(&mut rng, 0.003 * d)));
        }
        let found = find_clumps(&points);
        assert!(
            !found.mask[..surface.len()].contains(&true),
            "{shape:?}: surface points"
        );
        for (range, verdict) in planted {
            if let Some(go) = verdict {
                assert!(
                    found.mask[range.clone()].iter().all(|&m| m == go),
                    "{shape:?} {range:?}"
                );
            }
        }
        assert_eq!(found.withheld, 0);
        assert!(found.groups >= 5, "{shape:?}: {}", found.groups);
    }
}

/// Clean samplings of the analytic shapes, sparse to dense, and the built-in model have no
/// small group at all (not even one the 1 % rule would keep).
#[test]
fn clean_samplings_have_no_clumps() {
    let shapes = [
        (
            AnalyticShape::Sphere { radius: 1.0 },
            &[300, 2_000, 20_000][..],
        ),
        (
            AnalyticShape::Ellipsoid {
                radii: DVec3::new(1.0, 0.5, 0.25),
            },
            &[2_000, 20_000],
        ),
        (
            AnalyticShape::Torus {
                major: 1.0,
                minor: 0.35,
            },
            &[2_000, 30_000],
        ),
        (
            AnalyticShape::Torus {
                major: 1.0,
                minor: 0.12,
            },
            &[1_000, 10_000],
        ),
        (
            AnalyticShape::Box {
                half: DVec3::splat(0.5),
            },
            &[2_000, 20_000],
        ),
        (
            AnalyticShape::Box {
                half: DVec3::new(0.5, 0.5, 0.02),
            },
            &[2_000, 20_000],
        ),
    ];
    for (shape, counts) in shapes {
        for &n in counts {
            let points: Vec<DVec3> = shape.sample(n, n as u64).iter().map(|p| p.p).collect();
            assert_eq!(
                small_groups_of(&points),
                Vec::<Vec<u32>>::new(),
                "{shape:?}, {n}"
            );
        }
    }
    let model: Vec<DVec3> = builtin_model().iter().map(|p| p.p).collect();
    assert!(small_groups_of(&model).is_empty());
}

/// Every small group of `points`, whatever the verdict on it, at their own scale.
fn small_groups_of(points: &[DVec3]) -> Vec<Vec<u32>> {
    let index = MortonIndex::new(points);
    let bounds = Aabb::from_points(points.iter().copied()).expect("points");
    let scale = Scale::of(points, &index, bounds.diagonal());
    small_groups(points, &index, bounds.min, scale.link)
}

/// Tiles that see their points and every point within 11h of them (the reach) judge their
/// points as the whole input does.
#[test]
fn tiles_with_a_halo_of_the_reach_decide_as_the_whole() {
    let mut total = 0;
    for seed in (4..60).step_by(5) {
        let points = scene(seed);
        let index = MortonIndex::new(&points);
        let bounds = Aabb::from_points(points.iter().copied()).expect("points");
        let scale = Scale::of(&points, &index, bounds.diagonal());
        let mut whole = vec![false; points.len()];
        for &i in clumps_at(&points, &index, &scale, &Monitor::silent())
            .iter()
            .flatten()
        {
            whole[i as usize] = true;
        }
        let side = bounds.extent() / 4.0;
        let mut found = 0;
        for t in 0..64 {
            let lo =
                bounds.min + side * DVec3::new((t % 4) as f64, (t / 4 % 4) as f64, (t / 16) as f64);
            let tile = Aabb {
                min: lo,
                max: lo + side,
            };
            let inside = |p: DVec3| p.cmpge(tile.min).all() && p.cmplt(tile.max).all();
            let near = |p: DVec3| (p - p.clamp(tile.min, tile.max)).length() <= 10.93 * scale.link;
            let sub: Vec<u32> = (0..points.len() as u32)
                .filter(|&i| near(points[i as usize]))
                .collect();
            let sub_points: Vec<DVec3> = sub.iter().map(|&i| points[i as usize]).collect();
            let sub_index = MortonIndex::new(&sub_points);
            let mut judged = vec![false; sub.len()];
            for &k in clumps_at(&sub_points, &sub_index, &scale, &Monitor::silent())
                .iter()
                .flatten()
            {
                judged[k as usize] = true;
            }
            for (k, &i) in sub.iter().enumerate() {
                if inside(points[i as usize]) {
                    assert_eq!(
                        judged[k], whole[i as usize],
                        "seed {seed}, tile {t}, point {i}"
                    );
                    found += usize::from(judged[k]);
                }
            }
        }
        // Points on the far faces of the bounds belong to no tile.
        let all = whole.iter().filter(|&&m| m).count();
        assert!(found + 2 >= all, "seed {seed}: {found} of {all}");
        total += found;
    }
    assert!(total >= 20, "{total}");
}

/// Empty, single, coincident, collinear and tiny inputs: no panic, and no clump where a clump
/// would be more than 1 % of the points.
#[test]
fn odd_inputs_give_sensible_answers() {
    assert_eq!(find_clumps(&[]), Clumps::default());
    assert_eq!(find_clumps(&[DVec3::ONE]).mask, vec![false]);
    let same = find_clumps(&[DVec3::ONE; 10]);
    assert_eq!((same.mask, same.link), (vec![false; 10], 0.0));
    let two = find_clumps(&[DVec3::ZERO, DVec3::ONE]);
    assert_eq!((two.mask, two.points), (vec![false; 2], 0));
    let line: Vec<DVec3> = (0..50).map(|i| DVec3::X * i as f64).collect();
    assert_eq!(find_clumps(&line).points, 0);
    // A plane of 10 000 points and groups of 5 points far above it: 20 groups (100 points, 1 %)
    // go, 30 groups (150 points) are too many.
    let plane: Vec<DVec3> = (0..10_000)
        .map(|i| DVec3::new((i % 100) as f64, (i / 100) as f64, 0.0))
        .collect();
    for (groups, expected) in [(20, 100), (30, 0)] {
        let mut points = plane.clone();
        for g in 0..groups {
            let at = DVec3::new((g % 6 * 16) as f64, (g / 6 * 16) as f64, 30.0);
            points.extend((0..5).map(|k| at + DVec3::new(0.5 * k as f64, 0.0, 0.0)));
        }
        let found = find_clumps(&points);
        assert_eq!(
            (found.points, found.groups == groups),
            (expected, expected > 0)
        );
        assert_eq!(found.withheld, 5 * groups - expected);
        assert!(!found.mask[..10_000].contains(&true));
    }
}

/// The result is the same for any thread count, and a stopped monitor stops the search.
#[test]
fn clumps_do_not_depend_on_the_thread_count() {
    let points = scene(24);
    let run = |threads| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("pool");
        pool.install(|| find_clumps(&points))
    };
    let one = run(1);
    assert!(one.withheld > 0);
    assert_eq!(one, run(3));
    let stop = psi_octree::StopFlag::new();
    stop.stop();
    let stopped = find_clumps_with(&points, &Monitor::new(None, Some(&stop)));
    assert_eq!(stopped.points, 0);
}

/// The search by parts ([`crate::clumps_by_parts`]): spacings each from the points in a cube
/// around its sample (brute force, the cube doubled until the spacing is certain), cubes
/// counted part by part in a shuffled order, the candidates' balls gathered by brute force,
/// gives [`find_clumps`]'s clumps bit for bit (and its 1 % rule) on random scenes.
#[test]
fn the_search_by_parts_is_the_whole_search() {
    use crate::clumps_by_parts::{
        ClumpCubes, ClumpScale, clump_spacing_in_cube, clumps_of_candidates,
    };
    let mut found_some = 0;
    let mut widened = 0;
    for seed in 0..24 {
        let points = scene(seed);
        let whole = find_clumps(&points);
        let n = points.len() as u64;
        let Some(bounds) = Aabb::from_points(points.iter().copied()) else {
            continue;
        };
        let stride = ClumpScale::spacing_stride(n) as usize;
        let spacings: Vec<f64> = (0..points.len())
            .step_by(stride)
            .map(|i| {
                let x = points[i];
                let mut reach = 1e-3 * bounds.diagonal();
                loop {
                    let cube: Vec<DVec3> = (points.iter())
                        .filter(|p| (**p - x).abs().max_element() <= reach)
                        .copied()
                        .collect();
                    let all = reach >= bounds.diagonal();
                    if let Some(s) = clump_spacing_in_cube(x, &cube, reach, all) {
                        break s;
                    }
                    reach *= 2.0;
                    widened += 1;
                }
            })
            .collect();
        let scale = ClumpScale::of_spacings(spacings, bounds.diagonal());
        assert_eq!(scale.link(), whole.link, "seed {seed}");
        let mut cubes: Vec<ClumpCubes> = (0..5)
            .map(|_| ClumpCubes::new(bounds.min, &scale))
            .collect();
        for (i, &p) in points.iter().enumerate().rev() {
            cubes[i * 7 % 5].add(p);
        }
        let cubes = cubes.into_iter().reduce(ClumpCubes::merge).unwrap();
        let candidates = cubes.candidates(&scale);
        let chosen: Vec<(u64, DVec3)> = points
            .iter()
            .enumerate()
            .filter(|(_, p)| candidates.holds(&cubes, **p))
            .map(|(i, &p)| (i as u64, p))
            .rev()
            .collect();
        let mut gathers = 0;
        let mut gather = |lo: DVec3, hi: DVec3| -> Result<Vec<(u64, DVec3)>, ()> {
            gathers += 1;
            Ok(points
                .iter()
                .enumerate()
                .filter(|(_, p)| p.cmpge(lo).all() && p.cmple(hi).all())
                .map(|(i, &p)| (i as u64, p))
                .rev()
                .collect())
        };
        let (groups, withheld) =
            clumps_of_candidates(n, &cubes, &scale, chosen, &mut gather).unwrap();
        let mut mask = vec![false; points.len()];
        for &i in groups.iter().flatten() {
            mask[i as usize] = true;
        }
        assert_eq!(mask, whole.mask, "seed {seed}");
        assert_eq!(withheld as usize, whole.withheld, "seed {seed}");
        assert_eq!(groups.len(), whole.groups, "seed {seed}");
        found_some += usize::from(whole.points > 0 || whole.withheld > 0);
        assert!(candidates.is_empty() == (gathers == 0));
    }
    assert!(found_some >= 8, "{found_some}");
    assert!(widened > 0, "every first cube held its sample's neighbours");
}
