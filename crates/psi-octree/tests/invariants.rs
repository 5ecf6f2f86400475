//! Property tests of the octree's invariants against brute force (seeded, 256 cases each).

use glam::DVec3;
use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed};
use psi_octree::{Octree, OctreeParams, PointIndex};

fn config() -> Config {
    Config {
        cases: 256,
        rng_seed: RngSeed::Fixed(0x0c7_2ee),
        failure_persistence: None,
        ..Config::default()
    }
}

/// A point set: uniform points plus a tight cluster (so depth varies), at an arbitrary offset
/// and scale.
fn point_sets() -> impl Strategy<Value = Vec<DVec3>> {
    (
        prop::collection::vec((-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0), 2..300),
        prop::collection::vec((-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0), 0..100),
        -1e3f64..1e3,
        0.01f64..100.0,
    )
        .prop_map(|(a, b, offset, scale)| {
            let mut pts: Vec<DVec3> = a.into_iter().map(|(x, y, z)| DVec3::new(x, y, z)).collect();
            pts.extend(
                b.into_iter()
                    .map(|(x, y, z)| DVec3::new(0.3, 0.2, -0.1) + 0.01 * DVec3::new(x, y, z)),
            );
            pts.into_iter()
                .map(|p| DVec3::splat(offset) + scale * p)
                .collect()
        })
}

/// Builds with a split rule that leaves some empty cells too: split when a cell holds more
/// than `cap` points, or (at shallow depth) when a hash of its key says so.
fn build(points: &[DVec3], cap: usize, max_depth: u8, alpha: f64) -> Octree {
    let params = OctreeParams {
        box_scale: 1.2,
        alpha,
        max_depth,
    };
    Octree::build(points, &params, |v| {
        let k = v.cell.key;
        let hash = (k[0].wrapping_mul(73856093)
            ^ k[1].wrapping_mul(19349663)
            ^ k[2].wrapping_mul(83492791))
            % 7;
        v.points.len() > cap || (v.cell.depth < 2 && hash == 0)
    })
    .expect("valid input")
}

fn bounds_of(tree: &Octree) -> (DVec3, f64) {
    (tree.root().center, tree.root().half)
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn every_point_in_exactly_one_leaf(points in point_sets(), cap in 1usize..20, max_depth in 0u8..9) {
        let tree = build(&points, cap, max_depth, 0.75);
        let mut count = vec![0u32; points.len()];
        for leaf in tree.leaves() {
            for &p in tree.points_in(leaf) {
                count[p as usize] += 1;
                prop_assert!(tree.cell(leaf).contains(points[p as usize]));
                prop_assert_eq!(tree.leaf_of_point(p), leaf);
            }
        }
        prop_assert!(count.iter().all(|&c| c == 1));
    }

    #[test]
    fn children_partition_their_parent(points in point_sets(), cap in 1usize..20, max_depth in 0u8..9) {
        let tree = build(&points, cap, max_depth, 0.75);
        for (i, c) in tree.cells().iter().enumerate() {
            let Some(children) = tree.children(i as u32) else { continue };
            let mut union: Vec<u32> = Vec::new();
            let mut volume = 0.0;
            for ch in children {
                let cc = tree.cell(ch);
                prop_assert_eq!(cc.depth, c.depth + 1);
                prop_assert_eq!(cc.parent, i as u32);
                psi_shapes::assert_near!(cc.half, 0.5 * c.half, 0.0);
                // The child cube lies in the parent cube, touching its centre.
                let off = (cc.center - c.center).abs();
                prop_assert!((off - DVec3::splat(cc.half)).abs().max_element() <= 1e-12 * c.half.max(1.0));
                volume += (2.0 * cc.half).powi(3);
                union.extend_from_slice(tree.points_in(ch));
            }
            psi_shapes::assert_near!(volume, (2.0 * c.half).powi(3), 1e-9 * (2.0 * c.half).powi(3));
            let mut parent: Vec<u32> = tree.points_in(i as u32).to_vec();
            union.sort_unstable();
            parent.sort_unstable();
            prop_assert_eq!(union, parent);
        }
    }

    #[test]
    fn no_depth_exceeds_the_maximum(points in point_sets(), max_depth in 0u8..10) {
        // cap 0 asks to split everything holding a point: only the maximum stops it.
        let tree = build(&points, 0, max_depth, 0.75);
        prop_assert!(tree.cells().iter().all(|c| c.depth <= max_depth));
        prop_assert_eq!(tree.max_depth_reached(), max_depth);
    }

    #[test]
    fn leaf_lookup_equals_brute_force(points in point_sets(), cap in 1usize..20, q in prop::collection::vec((-0.99f64..0.99, -0.99f64..0.99, -0.99f64..0.99), 20)) {
        let tree = build(&points, cap, 8, 0.75);
        let (c, h) = bounds_of(&tree);
        for (x, y, z) in q {
            let x = c + h * DVec3::new(x, y, z);
            let found = tree.leaf_containing(x).expect("inside the root");
            let brute: Vec<u32> = tree.leaves().filter(|&l| tree.cell(l).contains(x)).collect();
            prop_assert!(brute.contains(&found), "{found} not in {brute:?}");
        }
        let outside = c + DVec3::splat(1.01 * h);
        prop_assert_eq!(tree.leaf_containing(outside), None);
    }

    #[test]
    fn support_query_equals_brute_force(points in point_sets(), cap in 1usize..20, alpha in 0.5f64..1.5, q in prop::collection::vec((-0.8f64..0.8, -0.8f64..0.8, -0.8f64..0.8), 20)) {
        let tree = build(&points, cap, 8, alpha);
        let (c, h) = bounds_of(&tree);
        for (x, y, z) in q {
            let x = c + 2.0 * h * DVec3::new(x, y, z);
            let mut fast = tree.support_cells(x);
            let mut brute = Vec::new();
            tree.for_each_support_cell_exhaustive(x, |i, _| brute.push(i));
            fast.sort_unstable();
            prop_assert_eq!(fast, brute);
        }
    }

    #[test]
    fn radius_queries_equal_brute_force(points in point_sets(), cap in 1usize..20, r in 0.001f64..0.5, q in prop::collection::vec(0usize..10_000, 10)) {
        let tree = build(&points, cap, 8, 0.75);
        let index = PointIndex::new(&points);
        let radius = r * 2.0 * tree.root().half;
        for k in q {
            let x = points[k % points.len()] + DVec3::splat(0.1 * radius);
            let mut brute: Vec<u32> = (0..points.len() as u32)
                .filter(|&i| (points[i as usize] - x).length_squared() <= radius * radius)
                .collect();
            let mut by_tree = Vec::new();
            tree.points_within(x, radius, &mut by_tree);
            let mut by_kd = Vec::new();
            index.within(x, radius, &mut by_kd);
            brute.sort_unstable();
            by_tree.sort_unstable();
            by_kd.sort_unstable();
            prop_assert_eq!(&by_tree, &brute);
            prop_assert_eq!(&by_kd, &brute);
        }
    }

    #[test]
    fn child_support_lies_inside_parent_support(points in point_sets(), cap in 1usize..20, alpha in 0.5f64..2.0) {
        let tree = build(&points, cap, 8, alpha);
        for c in tree.cells().iter().skip(1) {
            let p = tree.cell(c.parent);
            let reach = (c.center - p.center).length() + c.support_radius(alpha);
            prop_assert!(reach <= p.support_radius(alpha) * (1.0 + 1e-12));
        }
    }
}

#[test]
fn pruning_would_be_inexact_below_one_half() {
    // The nesting argument fails for α < 0.5: a child's ball then pokes out of its parent's.
    let points = [DVec3::ZERO, DVec3::ONE];
    let tree = build(&points, 0, 1, 0.4);
    let child = tree.cell(1);
    let parent = tree.root();
    assert!(
        (child.center - parent.center).length() + child.support_radius(0.4)
            > parent.support_radius(0.4)
    );
}

#[test]
fn nearest_matches_brute_force() {
    let pts = psi_shapes::AnalyticShape::Sphere { radius: 1.0 }.sample(500, 3);
    let pos: Vec<DVec3> = pts.iter().map(|p| p.p).collect();
    let index = PointIndex::new(&pos);
    let q = DVec3::new(0.3, -0.2, 0.9);
    let got = index.nearest(q, 5);
    let mut brute: Vec<(u32, f64)> = pos
        .iter()
        .enumerate()
        .map(|(i, p)| (i as u32, (*p - q).length_squared()))
        .collect();
    brute.sort_by(|a, b| a.1.total_cmp(&b.1));
    for (g, b) in got.iter().zip(&brute) {
        psi_shapes::assert_near!(g.1, b.1, psi_shapes::tolerance::EXACT);
    }
    assert_eq!(got.len(), 5);
}
