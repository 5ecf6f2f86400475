//! Tests of the orientation by parts: bitwise `orient_normals` on shapes whose graphs have ties,
//! orthogonal pairs, several trees and a second sheet, split into 8 and 27 parts.

use super::*;
use crate::grid_parts::grid_parts;
use crate::orient_normals;
use psi_shapes::AnalyticShape;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64Mcg;

/// `points` split by a `g` × `g` × `g` grid over their bounding box, each cell's part with
/// every point within ∞-distance `halo` of the cell: the parts' edges.
fn parts_of(
    points: &[OrientedPoint],
    g: usize,
    halo: f64,
) -> Result<Vec<PartEdges>, IncompletePart> {
    let positions: Vec<DVec3> = points.iter().map(|p| p.p).collect();
    grid_parts(&positions, g, halo)
        .iter()
        .map(|part| {
            let held: Vec<OrientedPoint> = part.ids.iter().map(|&i| points[i as usize]).collect();
            part_orientation_edges(&held, &part.ids, &part.own, &|x, r| part.holds_ball(x, r))
        })
        .collect()
}

/// `truth` with every normal's side drawn at random (seeded).
fn scrambled(truth: &[OrientedPoint], seed: u64) -> Vec<OrientedPoint> {
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    truth
        .iter()
        .map(|p| OrientedPoint {
            p: p.p,
            n: if rng.random::<bool>() { -p.n } else { p.n },
        })
        .collect()
}

/// Shapes whose orientation graphs have what the parts must reproduce: ties of weight (a box's
/// faces: n·n = 1 exactly between many pairs), edges with n·n = 0 exactly (across a box's
/// edges), several trees (two spheres apart), a second sheet nearby (a thin slab).
fn cases() -> Vec<(&'static str, Vec<OrientedPoint>)> {
    let sphere = AnalyticShape::Sphere { radius: 1.0 };
    let mut two = sphere.sample(1500, 5);
    two.extend(sphere.sample(1500, 6).into_iter().map(|p| OrientedPoint {
        p: p.p * 0.5 + DVec3::new(4.0, 0.3, 0.0),
        n: p.n,
    }));
    vec![
        ("sphere", sphere.sample(3000, 1)),
        (
            "torus",
            AnalyticShape::Torus {
                major: 1.0,
                minor: 0.35,
            }
            .sample(4000, 2),
        ),
        (
            "box",
            AnalyticShape::Box {
                half: DVec3::new(0.5, 0.4, 0.3),
            }
            .sample(3000, 3),
        ),
        (
            "slab",
            AnalyticShape::Box {
                half: DVec3::new(0.6, 0.6, 0.03),
            }
            .sample(4000, 4),
        ),
        ("two spheres", two),
    ]
}

#[test]
fn parts_orient_bitwise_as_the_whole() {
    for (name, truth) in cases() {
        for (g, seed) in [(2, 11), (3, 12)] {
            let start = scrambled(&truth, seed);
            let mut whole = start.clone();
            let whole_flips = orient_normals(&mut whole);
            let parts = parts_of(&start, g, 0.3).unwrap_or_else(|e| panic!("{name}: {e}"));
            // The parts must matter: edges cross their faces, and their forests hold edges.
            let across: usize = parts.iter().map(|p| p.across.len()).sum();
            assert!(
                parts.len() >= 8 && across > 0,
                "{name}: {across} edges across"
            );
            let mut by_parts = start.clone();
            let flips = orient_by_parts(&mut by_parts, &parts);
            assert_eq!(flips, whole_flips, "{name}, {g}³ parts");
            assert!(by_parts == whole, "{name}, {g}³ parts: normals differ");
            // Without the edges across the parts, the sides come out otherwise: the test sees
            // the join. (Not for the two spheres: each part's piece of them happens to be
            // seeded outward on its own.)
            if name == "two spheres" {
                continue;
            }
            let cut: Vec<PartEdges> = parts
                .iter()
                .map(|p| PartEdges {
                    across: Vec::new(),
                    ..p.clone()
                })
                .collect();
            let mut apart = start.clone();
            orient_by_parts(&mut apart, &cut);
            assert!(apart != whole, "{name}: the parts alone orient alike");
        }
    }
}

#[test]
fn a_box_has_orthogonal_pairs_in_its_forest() {
    // The cut rule is exercised: some kept edges have n·n = 0 exactly.
    let truth = AnalyticShape::Box {
        half: DVec3::new(0.5, 0.4, 0.3),
    }
    .sample(3000, 3);
    let parts = parts_of(&scrambled(&truth, 1), 2, 0.3).unwrap();
    let zero = parts
        .iter()
        .flat_map(|p| p.forest.iter().chain(&p.across))
        .filter(|e| e.dot == 0.0)
        .count();
    assert!(zero > 0);
}

#[test]
fn a_halo_too_thin_is_refused_with_the_reach_that_certifies_the_part() {
    // Each refusal names the farthest reach among a part's points: a halo grown to it
    // certifies that part, so the halo grows at most once per part.
    let truth = AnalyticShape::Torus {
        major: 1.0,
        minor: 0.35,
    }
    .sample(4000, 2);
    let start = scrambled(&truth, 5);
    let mut halo = 0.01;
    let mut grown = 0;
    let parts = loop {
        match parts_of(&start, 2, halo) {
            Ok(parts) => break parts,
            Err(e) => {
                assert!(e.reach > halo && e.reach < 1.0, "{e}");
                halo = e.reach;
                grown += 1;
                assert!(grown <= 8, "grown {grown} times");
            }
        }
    };
    assert!(grown > 0);
    let mut whole = start.clone();
    orient_normals(&mut whole);
    let mut by_parts = start;
    orient_by_parts(&mut by_parts, &parts);
    assert!(by_parts == whole);
}

#[test]
fn sided_sets_keep_parities_against_brute_force() {
    // Random joins on 40 points against sides propagated over the joined edges.
    let mut rng = Pcg64Mcg::seed_from_u64(3);
    let n = 40;
    let mut sets = SidedSets::new(n);
    let mut edges: Vec<(u32, u32, bool)> = Vec::new();
    for _ in 0..60 {
        let (a, b) = (rng.random_range(0..n as u32), rng.random_range(0..n as u32));
        let opposed = rng.random::<bool>();
        if sets.root(a).0 != sets.root(b).0 {
            edges.push((a, b, opposed));
        }
        sets.join(a, b, opposed);
    }
    for &(a, b, opposed) in &edges {
        let ((ra, fa), (rb, fb)) = (sets.root(a), sets.root(b));
        assert_eq!(ra, rb);
        assert_eq!(fa ^ fb, opposed, "edge {a}-{b}");
    }
}

#[test]
#[should_panic(expected = "out of Kruskal's order")]
fn the_join_refuses_edges_out_of_order() {
    let edge = |lo, hi, dot| OrientEdge {
        lo,
        hi,
        dot,
        same: true,
    };
    let mut join = OrientationJoin::new(4);
    join.offer(edge(0, 1, 0.9));
    join.offer(edge(1, 2, 0.99));
}
