//! Cell location by address: the cell at a given depth and integer key, if the tree has it.

use crate::Octree;

impl Octree {
    /// The cell at `depth` whose integer coordinates are `key` (see [`crate::Cell::key`]),
    /// found by descending from the root along the key's bits (O(depth), no hashing). `None`
    /// when the tree stops above that depth there, or the key lies outside the root.
    pub fn cell_at(&self, depth: u8, key: [u32; 3]) -> Option<u32> {
        if u32::from(depth) >= 32 || key.iter().any(|&k| k >> depth != 0) {
            return None;
        }
        let mut i = 0u32;
        for level in (0..depth).rev() {
            let c = &self.cells()[i as usize];
            if c.is_leaf() {
                return None;
            }
            let bit = |axis: usize| (key[axis] >> level) & 1;
            i = c.first_child + (bit(0) | (bit(1) << 1) | (bit(2) << 2));
        }
        Some(i)
    }
}

#[cfg(test)]
mod tests {
    use glam::DVec3;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64Mcg;

    use crate::{Octree, OctreeParams};

    #[test]
    fn every_cell_is_found_at_its_address_and_nothing_else() {
        let mut rng = Pcg64Mcg::seed_from_u64(3);
        let points: Vec<DVec3> = (0..3000)
            .map(|_| DVec3::new(rng.random(), rng.random::<f64>().powi(3), rng.random()))
            .collect();
        let tree = Octree::build(&points, &OctreeParams::mpu(), |v| {
            v.points.len() > 20 && v.cell.depth < 7
        })
        .unwrap();
        // Brute force: the address → index map of all cells.
        let all: std::collections::HashMap<(u8, [u32; 3]), u32> = tree
            .cells()
            .iter()
            .enumerate()
            .map(|(i, c)| ((c.depth, c.key), i as u32))
            .collect();
        for (&(depth, key), &i) in &all {
            assert_eq!(tree.cell_at(depth, key), Some(i));
        }
        for _ in 0..5000 {
            let depth = rng.random_range(0..9u8);
            let key = [0; 3].map(|_| rng.random_range(0..(1u32 << depth) + 1));
            assert_eq!(tree.cell_at(depth, key), all.get(&(depth, key)).copied());
        }
    }
}
