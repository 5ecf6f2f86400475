//! Partitions a rebuild takes from an earlier octree ([`KnownPartitions`]): a cell the earlier
//! octree split over the same points is split the same way without looking at its points
//! again, and after a brush the earlier arrangement is patched where points moved.

use glam::DVec3;

use crate::id_map::IdMap;
use crate::{KnownPartitions, NO_CELL, Octree};

/// The depth-first octant order of cells `a` and `b` of `tree`, neither holding the other.
fn depth_first(tree: &Octree, a: u32, b: u32) -> std::cmp::Ordering {
    let (mut a, mut b) = (a, b);
    while tree.cell(a).depth > tree.cell(b).depth {
        a = tree.cell(a).parent;
    }
    while tree.cell(b).depth > tree.cell(a).depth {
        b = tree.cell(b).parent;
    }
    if a == b {
        return std::cmp::Ordering::Equal;
    }
    // Up to the children of the common ancestor: siblings, in octant (index) order.
    while tree.cell(a).parent != tree.cell(b).parent {
        a = tree.cell(a).parent;
        b = tree.cell(b).parent;
    }
    a.cmp(&b)
}

impl<'a> KnownPartitions<'a> {
    /// The child counts and the point order of the earlier octree's cell `o` (at the address
    /// of a cell of the new build holding `count` points), if it split the same points: each
    /// child's segment holds the child's points, in the order the earlier subtree left them
    /// (the build restores increasing order where the new subtree differs).
    pub(crate) fn partition_at(&self, o: u32, count: u32) -> Option<([u32; 8], &'a [u32])> {
        if o == NO_CELL || self.changed[o as usize] {
            return None;
        }
        let oc = self.old.cell(o);
        let children = self.old.children(o)?;
        if oc.end - oc.start != count {
            return None;
        }
        let mut counts = [0u32; 8];
        for (k, ch) in children.enumerate() {
            let c = self.old.cell(ch);
            counts[k] = c.end - c.start;
        }
        Some((counts, &self.old.order[oc.start as usize..oc.end as usize]))
    }

    /// Writes into `order` the earlier octree's arrangement of the points with the `moved`
    /// ones taken out of the leaves they were in and put, in index order, into the earlier
    /// leaves holding their new `positions` (shape: N, every point's current position, all in
    /// the root cube); returns how many points each earlier cell gained (negative: lost).
    /// Costs a copy of the arrangement and time in the points moved.
    pub(crate) fn patch_order(
        &self,
        moved: &[u32],
        positions: &[DVec3],
        order: &mut Vec<u32>,
    ) -> IdMap<i64> {
        let old = self.old;
        let mut gained: IdMap<i64> = IdMap::default();
        // Per earlier leaf that changes: the points leaving it and those joining it.
        let mut leaving: IdMap<Vec<u32>> = IdMap::default();
        let mut joining: IdMap<Vec<u32>> = IdMap::default();
        for &id in moved {
            let from = old.leaf_of_point(id);
            let to = old
                .leaf_containing(positions[id as usize])
                .expect("moved points stay in the root cube");
            if from == to {
                continue;
            }
            leaving.entry(from).or_default().push(id);
            joining.entry(to).or_default().push(id);
            for (leaf, step) in [(from, -1), (to, 1)] {
                let mut c = leaf;
                while c != NO_CELL {
                    *gained.entry(c).or_default() += step;
                    c = old.cell(c).parent;
                }
            }
        }
        let mut leaves: Vec<u32> = leaving.keys().chain(joining.keys()).copied().collect();
        // In the order the arrangement lists them: by start, and empty leaves at the same
        // start in depth-first octant order.
        leaves.sort_unstable_by(|&a, &b| {
            (old.cell(a).start.cmp(&old.cell(b).start)).then_with(|| depth_first(old, a, b))
        });
        leaves.dedup();
        order.clear();
        let mut cursor = 0usize;
        for l in leaves {
            let c = old.cell(l);
            let (start, end) = (c.start as usize, c.end as usize);
            order.extend_from_slice(&old.order[cursor..start]);
            let gone = leaving.get(&l).map_or(&[][..], |v| &v[..]);
            let mut bucket: Vec<u32> = old.order[start..end]
                .iter()
                .copied()
                .filter(|id| !gone.contains(id))
                .collect();
            bucket.extend(joining.get(&l).map_or(&[][..], |v| &v[..]));
            bucket.sort_unstable();
            order.extend_from_slice(&bucket);
            cursor = end;
        }
        order.extend_from_slice(&old.order[cursor..]);
        gained
    }

    /// The earlier octree's cell at the address of child `k` of the cell at `o`'s address
    /// ([`NO_CELL`] when it has none).
    pub(crate) fn child_of(&self, o: u32, k: u32) -> u32 {
        if o == NO_CELL {
            return NO_CELL;
        }
        self.old.children(o).map_or(NO_CELL, |c| c.start + k)
    }
}

#[cfg(test)]
mod tests {
    use glam::DVec3;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64Mcg;

    use crate::{KnownPartitions, Octree, OctreeBuild, OctreeParams, root_cube};

    /// A rebuild after some points moved, from the earlier arrangement patched, equals a build
    /// from scratch (the brute-force twin): the same cells and the same points in every cell,
    /// in the same order, over rounds of moves that cross cell faces and empty some leaves;
    /// built in parallel or serially over borrowed points alike.
    #[test]
    fn a_patched_rebuild_equals_a_build_from_scratch() {
        let mut rng = Pcg64Mcg::seed_from_u64(5);
        let mut points: Vec<DVec3> = (0..4000)
            .map(|_| DVec3::new(rng.random(), rng.random::<f64>().powi(2), rng.random()))
            .collect();
        let params = OctreeParams::mpu();
        let bounds = crate::Aabb::from_points(points.iter().copied()).unwrap();
        let root = root_cube(&bounds, 1.5).unwrap();
        let split = |v: crate::CellView<'_>| (v.points.len() > 12 && v.cell.depth < 8, ());
        let fresh = |points: &[DVec3]| {
            let options = OctreeBuild {
                root: Some(root),
                ..Default::default()
            };
            Octree::build_with(points.to_vec(), &params, options, split)
                .unwrap()
                .0
        };
        let mut tree = fresh(&points);
        let beside = std::sync::atomic::AtomicBool::new(true);
        for round in 0..12 {
            let c = DVec3::new(rng.random(), rng.random(), rng.random());
            let r = 0.05 + 0.1 * rng.random::<f64>();
            let moved: Vec<u32> = (0..points.len() as u32)
                .filter(|&i| (points[i as usize] - c).length() < r)
                .collect();
            let mut changed = vec![false; tree.cells().len()];
            for &i in &moved {
                let old = points[i as usize];
                let shift = 0.06 * DVec3::new(rng.random(), rng.random(), rng.random()) - 0.03;
                let new = (old + shift).clamp(bounds.min, bounds.max);
                points[i as usize] = new;
                for x in [old, new] {
                    let mut cell = tree.leaf_containing(x).unwrap();
                    loop {
                        changed[cell as usize] = true;
                        match tree.cell(cell).parent {
                            crate::NO_CELL => break,
                            p => cell = p,
                        }
                    }
                }
            }
            let options = OctreeBuild {
                root: Some(root),
                known: Some(KnownPartitions {
                    old: &tree,
                    changed: &changed,
                    moved: Some(&moved),
                }),
                // Every other round on the calling thread alone, over borrowed points.
                beside: (round % 2 == 1).then_some(&beside),
                ..Default::default()
            };
            let patched = if round % 2 == 1 {
                let (unplaced, _) = Octree::build_over(&points, &params, options, split).unwrap();
                unplaced.with_positions(points.clone())
            } else {
                Octree::build_with(points.clone(), &params, options, split)
                    .unwrap()
                    .0
            };
            let scratch = fresh(&points);
            assert_eq!(
                patched.cells().len(),
                scratch.cells().len(),
                "round {round}"
            );
            for (i, c) in patched.cells().iter().enumerate() {
                let j = scratch.cell_at(c.depth, c.key).expect("same cells");
                assert_eq!(
                    patched.points_in(i as u32),
                    scratch.points_in(j),
                    "round {round}, cell {:?} {:?}",
                    c.depth,
                    c.key
                );
            }
            // Every point is listed by the leaf its position descends to.
            for p in 0..points.len() as u32 {
                let leaf = patched.leaf_of_point(p);
                assert!(patched.cell(leaf).is_leaf() && patched.points_in(leaf).contains(&p));
            }
            tree = patched;
        }
    }
}
