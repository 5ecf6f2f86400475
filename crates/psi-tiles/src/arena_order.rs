//! Where each leaf of a tiled MPU stands in the arena of the octree its decisions describe
//! (`psi_octree::Octree`'s order: level by level, the eight children of each split cell
//! appended in octant order), without building that octree: a region's seeding builds only
//! its part of it ([`psi_mpu::BuildOptions::known_within`]) and names its leaves by their
//! place in the whole.

use std::collections::HashMap;

use psi_mpu::{CellAddress, CellTable};

/// The arena index of each leaf that `keep` accepts of the octree `cells` describe with
/// maximum depth `max_depth` (a cell splits when its decision says so and it lies above that
/// depth, as the octree's build decides), by address. A breadth-first walk from the root, the
/// children in octant order (bit 0: x, bit 1: y, bit 2: z), as `psi_octree::Octree` appends
/// them. A cell the table lacks is taken as a leaf (a build from the table would refuse it).
pub(crate) fn arena_indices(
    cells: &CellTable,
    max_depth: u8,
    keep: &dyn Fn(CellAddress) -> bool,
) -> HashMap<CellAddress, u32> {
    let mut index = HashMap::new();
    let mut level: Vec<CellAddress> = vec![(0, [0; 3])];
    let mut next_index = 0u32;
    while !level.is_empty() {
        let mut next = Vec::new();
        for (depth, key) in level {
            let at = next_index;
            next_index += 1;
            let splits = depth < max_depth && cells.get(depth, key).is_some_and(|d| d.split());
            if splits {
                next.extend((0..8u32).map(|o| {
                    let child = |axis: u32| 2 * key[axis as usize] + ((o >> axis) & 1);
                    (depth + 1, [child(0), child(1), child(2)])
                }));
            } else if keep((depth, key)) {
                index.insert((depth, key), at);
            }
        }
        level = next;
    }
    index
}

#[cfg(test)]
mod tests {
    use super::*;

    use psi_mpu::{BuildOptions, Mpu, MpuParams};
    use psi_shapes::AnalyticShape;

    use crate::{TileParams, decide_tiled};

    #[test]
    fn the_walk_names_every_leaf_as_the_built_octree_places_it() {
        // Oracle: the octree the decisions build, every leaf's address at its arena index.
        let points = AnalyticShape::Torus {
            major: 1.0,
            minor: 0.4,
        }
        .sample(4000, 11);
        let params = MpuParams::paper();
        let d = decide_tiled(
            &points,
            &params,
            &TileParams::at_depth(2),
            &psi_octree::Monitor::silent(),
        )
        .unwrap();
        let options = BuildOptions {
            frame: Some(d.frame),
            known_cells: Some(&d.cells),
            ..Default::default()
        };
        let mpu = Mpu::build_with(&points[..], &params, options).unwrap();
        let index = arena_indices(&d.cells, params.max_depth, &|_| true);
        let cells = mpu.octree().cells();
        assert!(cells.len() > 500, "{} cells", cells.len());
        let leaves: Vec<u32> = mpu.leaves().collect();
        assert_eq!(index.len(), leaves.len());
        for &l in &leaves {
            let c = mpu.octree().cell(l);
            assert_eq!(index[&(c.depth, c.key)], l, "leaf {l}");
        }
        // Kept by address: those of one octant alone.
        let one = arena_indices(&d.cells, params.max_depth, &|(d, k)| {
            d > 0 && k[0] >> (d - 1) == 1
        });
        assert!(!one.is_empty() && one.len() < index.len());
        assert!(
            one.iter()
                .all(|(a, i)| index[a] == *i && a.1[0] >> (a.0 - 1) == 1)
        );
    }
}
