//! The accepted darts of one dart-throwing pass, bucketed by grid cube for the "is any dart
//! within r" test: cubes of a given edge, hashed into a power-of-two table of chained lists
//! (arrays, no allocation per cube). Points of other cubes that share a bucket are only
//! tested too: the distance test decides, so the answers are those of exact cubes.

use glam::DVec3;

/// No entry (end of a chain, empty bucket).
const NONE: u32 = u32::MAX;

/// Darts (ids and positions, world units) in hashed grid cubes of edge `edge`.
pub(crate) struct DartGrid {
    edge: f64,
    mask: u64,
    head: Vec<u32>,
    next: Vec<u32>,
    darts: Vec<(u32, DVec3)>,
}

/// The integer cube of `p` for cubes of edge `edge` (as `floor(p / edge)`, saturating).
fn cube_of(p: DVec3, edge: f64) -> [i64; 3] {
    [
        (p.x / edge).floor() as i64,
        (p.y / edge).floor() as i64,
        (p.z / edge).floor() as i64,
    ]
}

impl DartGrid {
    /// An empty grid of cubes of edge `edge` (world units, > 0) with room for about `capacity`
    /// darts before its table grows.
    pub(crate) fn new(edge: f64, capacity: usize) -> Self {
        let buckets = (2 * capacity.max(1)).next_power_of_two();
        Self {
            edge,
            mask: buckets as u64 - 1,
            head: vec![NONE; buckets],
            next: Vec::with_capacity(capacity),
            darts: Vec::with_capacity(capacity),
        }
    }

    fn bucket(&self, c: [i64; 3]) -> usize {
        // Large odd multipliers mix the three coordinates (Teschner et al., "Optimized Spatial
        // Hashing for Collision Detection of Deformable Objects", 2003, use three primes the
        // same way).
        let h = (c[0] as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15)
            ^ (c[1] as u64).wrapping_mul(0xc2b2_ae3d_27d4_eb4f)
            ^ (c[2] as u64).wrapping_mul(0x1656_67b1_9e37_79f9);
        ((h ^ (h >> 29)) & self.mask) as usize
    }

    /// Adds dart `id` at `p`. The table doubles when it holds as many darts as half its
    /// buckets (the darts rechained in insertion order: every query finds the same darts).
    pub(crate) fn insert(&mut self, id: u32, p: DVec3) {
        if 2 * (self.darts.len() + 1) > self.head.len() {
            self.grow();
        }
        self.next.push(NONE);
        self.chain(self.darts.len() as u32, p);
        self.darts.push((id, p));
    }

    /// Links entry `k` (its `next` slot allocated) at `p` into its bucket's chain.
    fn chain(&mut self, k: u32, p: DVec3) {
        let b = self.bucket(cube_of(p, self.edge));
        self.next[k as usize] = self.head[b];
        self.head[b] = k;
    }

    /// Twice the buckets, every dart chained again.
    fn grow(&mut self) {
        let buckets = 2 * self.head.len();
        self.mask = buckets as u64 - 1;
        self.head = vec![NONE; buckets];
        for k in 0..self.darts.len() {
            self.chain(k as u32, self.darts[k].1);
        }
    }

    /// Whether `near(id, position)` holds for a dart in the 27 cubes around `p`'s (every dart
    /// within one edge of `p` among them).
    pub(crate) fn any_around(&self, p: DVec3, mut near: impl FnMut(u32, DVec3) -> bool) -> bool {
        let [x, y, z] = cube_of(p, self.edge);
        for dx in -1..=1i64 {
            for dy in -1..=1i64 {
                for dz in -1..=1i64 {
                    let c = [x.wrapping_add(dx), y.wrapping_add(dy), z.wrapping_add(dz)];
                    let mut k = self.head[self.bucket(c)];
                    while k != NONE {
                        let (id, q) = self.darts[k as usize];
                        if near(id, q) {
                            return true;
                        }
                        k = self.next[k as usize];
                    }
                }
            }
        }
        false
    }
}

#[cfg(test)]
mod tests {
    use glam::DVec3;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64Mcg;

    use super::DartGrid;

    /// Brute force: for random darts and edges (a table started at 8 buckets and doubled as
    /// the darts came, each dart chained again; buckets shared by other cubes), a query finds a
    /// dart within r ≤ edge exactly when one exists.
    #[test]
    fn finds_a_dart_within_an_edge_exactly_when_one_exists() {
        let mut rng = Pcg64Mcg::seed_from_u64(3);
        for edge in [0.01, 0.05, 0.2] {
            let darts: Vec<DVec3> = (0..300)
                .map(|_| DVec3::new(rng.random(), rng.random(), rng.random()) - 0.5)
                .collect();
            let mut grid = DartGrid::new(edge, 4);
            for (i, &p) in darts.iter().enumerate() {
                grid.insert(i as u32, p);
            }
            assert_eq!(
                grid.head.len(),
                1024,
                "grown from 8 buckets to hold 300 darts"
            );
            let (mut hits, mut misses) = (0, 0);
            for _ in 0..2000 {
                // Half the queries near a dart (within an edge), half anywhere.
                let p = if rng.random::<bool>() {
                    let d = darts[rng.random_range(0..darts.len())];
                    d + edge * (DVec3::new(rng.random(), rng.random(), rng.random()) - 0.5)
                } else {
                    DVec3::new(rng.random(), rng.random(), rng.random()) - 0.5
                };
                let r = edge * rng.random::<f64>();
                let near = |_, q: DVec3| (q - p).length_squared() < r * r;
                let want = darts.iter().any(|&q| near(0, q));
                assert_eq!(grid.any_around(p, near), want, "edge {edge}");
                if want {
                    hits += 1;
                } else {
                    misses += 1;
                }
            }
            assert!(hits > 20 && misses > 20, "{hits} hits, {misses} misses");
        }
    }
}
