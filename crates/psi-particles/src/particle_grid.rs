//! Particles bucketed in a uniform grid of cubes, for the relaxation's ball queries: a query
//! of radius r visits the cubes its bounding box meets, without a branch per candidate. With
//! the edge near the typical query radius (3σ) a query reads a few dozen candidates from
//! contiguous memory, where a kd-tree descends from its root; the grid is rebuilt each
//! iteration by one counting sort.

use glam::DVec3;

/// A uniform grid over point positions (world units); items are indices into them.
#[derive(Clone)]
pub struct ParticleGrid {
    min: DVec3,
    inv_edge: f64,
    dims: [usize; 3],
    /// Per cube (x fastest, then y, then z): where its items start in `ids`; one more entry.
    starts: Vec<u32>,
    ids: Vec<u32>,
    /// The positions in `ids` order.
    positions: Vec<DVec3>,
}

/// The relaxation's grid cubes are this fraction of the mean query radius 3σ (chosen by a sweep:
/// notes, relaxation); any edge gives the same neighbours.
pub const GRID_EDGE_FACTOR: f64 = 0.7;

/// At most this many cubes per point: a sparse set gets larger cubes instead of a huge table.
const CUBES_PER_POINT: usize = 4;

impl ParticleGrid {
    /// Buckets `positions` (shape: N, world units) in cubes of edge about `edge` (larger when
    /// the box of the positions would need more than `CUBES_PER_POINT` cubes per point).
    /// Non-finite positions are left out.
    pub fn new(positions: &[DVec3], edge: f64) -> Self {
        let finite = positions.iter().filter(|p| p.is_finite());
        let (min, max) = finite.fold(
            (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |(lo, hi), p| (lo.min(*p), hi.max(*p)),
        );
        if !(min.is_finite() && max.is_finite()) {
            return Self {
                min: DVec3::ZERO,
                inv_edge: 0.0,
                dims: [1, 1, 1],
                starts: vec![0, 0],
                ids: Vec::new(),
                positions: Vec::new(),
            };
        }
        let extent = (max - min).max(DVec3::splat(f64::MIN_POSITIVE));
        let budget = (CUBES_PER_POINT * positions.len()).max(1) as f64;
        let mut edge = if edge > 0.0 && edge.is_finite() {
            edge
        } else {
            extent.max_element()
        };
        let count = |e: f64| (extent / e).floor() + DVec3::ONE;
        if count(edge).x * count(edge).y * count(edge).z > budget {
            edge = (extent.x * extent.y * extent.z / budget).cbrt().max(edge);
            while count(edge).x * count(edge).y * count(edge).z > budget {
                edge *= 1.25;
            }
        }
        let c = count(edge);
        let dims = [c.x as usize, c.y as usize, c.z as usize];
        let inv_edge = 1.0 / edge;
        // (`as usize` truncates and saturates, so a clamped coordinate needs no `floor`, a libm
        // call on baseline x86-64: docs/notes/2026-12-02-dragon-stroke-profile.md.)
        let cube = |p: DVec3| {
            let k = (p - min) * inv_edge;
            let clamp = |v: f64, n: usize| (v.max(0.0) as usize).min(n - 1);
            clamp(k.x, dims[0]) + dims[0] * (clamp(k.y, dims[1]) + dims[1] * clamp(k.z, dims[2]))
        };
        let cubes = dims[0] * dims[1] * dims[2];
        let mut starts = vec![0u32; cubes + 1];
        let keys: Vec<usize> = positions
            .iter()
            .map(|p| if p.is_finite() { cube(*p) } else { usize::MAX })
            .collect();
        for &k in keys.iter().filter(|&&k| k != usize::MAX) {
            starts[k + 1] += 1;
        }
        // Counts to starts by a running total (`starts[i + 1] += starts[i]` makes every step
        // wait on the store before it).
        let mut total = 0;
        for s in starts.iter_mut() {
            total += *s;
            *s = total;
        }
        let n = starts[cubes] as usize;
        let mut cursor = starts.clone();
        let mut ids = vec![0u32; n];
        let mut sorted = vec![DVec3::ZERO; n];
        for (i, &k) in keys.iter().enumerate() {
            if k == usize::MAX {
                continue;
            }
            let slot = cursor[k] as usize;
            cursor[k] += 1;
            ids[slot] = i as u32;
            sorted[slot] = positions[i];
        }
        Self {
            min,
            inv_edge,
            dims,
            starts,
            ids,
            positions: sorted,
        }
    }

    /// Appends to `out` every indexed point within `radius` of `x` (|p − x| ≤ radius, plain
    /// radius), in the grid's order (cube by cube): the same order for the same positions.
    /// Branch-free over the candidates: each is written, and kept by advancing the length when
    /// it lies within the radius (about a quarter of a relaxation query's candidates do; a
    /// branch per candidate mispredicted often enough to be most of a query's cost).
    pub fn append_within(&self, x: DVec3, radius: f64, out: &mut Vec<u32>) {
        if self.ids.is_empty() || radius.is_nan() || radius < 0.0 || !x.is_finite() {
            return;
        }
        // The cubes from ⌊lo⌋ to ⌊hi⌋ per axis, clipped to the grid, without `floor`:
        // ⌊hi⌋ < 0 ⇔ hi < 0, ⌊lo⌋ > n − 1 ⇔ lo ≥ n, and on non-negative values truncation
        // is the floor.
        let lo = (x - radius - self.min) * self.inv_edge;
        let hi = (x + radius - self.min) * self.inv_edge;
        let range = |a: f64, b: f64, n: usize| {
            if b < 0.0 || a >= n as f64 {
                None
            } else {
                Some((a.max(0.0) as usize, (b as usize).min(n - 1)))
            }
        };
        let (Some((x0, x1)), Some((y0, y1)), Some((z0, z1))) = (
            range(lo.x, hi.x, self.dims[0]),
            range(lo.y, hi.y, self.dims[1]),
            range(lo.z, hi.z, self.dims[2]),
        ) else {
            return;
        };
        let r2 = radius * radius;
        let mut len = out.len();
        for z in z0..=z1 {
            for y in y0..=y1 {
                let row = self.dims[0] * (y + self.dims[1] * z);
                // The cubes x0..=x1 of a row are contiguous in `ids`.
                let (a, b) = (
                    self.starts[row + x0] as usize,
                    self.starts[row + x1 + 1] as usize,
                );
                if out.len() < len + (b - a) {
                    out.resize(len + (b - a), 0);
                }
                let slots = &mut out[len..len + (b - a)];
                let mut kept = 0;
                for (p, &id) in self.positions[a..b].iter().zip(&self.ids[a..b]) {
                    slots[kept] = id;
                    kept += usize::from((*p - x).length_squared() <= r2);
                }
                len += kept;
            }
        }
        out.truncate(len);
    }

    /// Whether an indexed point lies within `radius` of `x` (|p − x| ≤ radius): whether
    /// [`ParticleGrid::append_within`] would append any.
    pub fn any_within(&self, x: DVec3, radius: f64) -> bool {
        if self.ids.is_empty() || radius.is_nan() || radius < 0.0 || !x.is_finite() {
            return false;
        }
        let lo = (x - radius - self.min) * self.inv_edge;
        let hi = (x + radius - self.min) * self.inv_edge;
        let range = |a: f64, b: f64, n: usize| {
            (b >= 0.0 && a < n as f64).then(|| (a.max(0.0) as usize, (b as usize).min(n - 1)))
        };
        let (Some((x0, x1)), Some((y0, y1)), Some((z0, z1))) = (
            range(lo.x, hi.x, self.dims[0]),
            range(lo.y, hi.y, self.dims[1]),
            range(lo.z, hi.z, self.dims[2]),
        ) else {
            return false;
        };
        let r2 = radius * radius;
        (z0..=z1).any(|z| {
            (y0..=y1).any(|y| {
                let row = self.dims[0] * (y + self.dims[1] * z);
                let (a, b) = (
                    self.starts[row + x0] as usize,
                    self.starts[row + x1 + 1] as usize,
                );
                self.positions[a..b]
                    .iter()
                    .any(|p| (*p - x).length_squared() <= r2)
            })
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64Mcg;

    #[test]
    fn ball_queries_equal_brute_force() {
        let mut rng = Pcg64Mcg::seed_from_u64(7);
        let mut pts: Vec<DVec3> = (0..3000)
            .map(|_| {
                // A thin shell, as particles on a surface, plus a far cluster.
                let d = DVec3::new(
                    rng.random::<f64>() - 0.5,
                    rng.random::<f64>() - 0.5,
                    rng.random::<f64>() - 0.5,
                )
                .normalize();
                d * (1.0 + 0.01 * rng.random::<f64>())
            })
            .collect();
        pts.extend((0..50).map(|i| DVec3::new(40.0 + 0.01 * i as f64, 0.0, 0.0)));
        pts.push(DVec3::new(f64::NAN, 0.0, 0.0));
        for edge in [0.05, 0.2, 1e-6, 0.0] {
            let grid = ParticleGrid::new(&pts, edge);
            // Near the points, then balls reaching over the grid's faces from outside it, or
            // missing it on either side.
            let outside = [
                (DVec3::new(-1.3, 0.0, 0.0), 0.4),
                (DVec3::new(0.0, -1.05, 0.2), 0.1),
                (DVec3::new(-3.0, 0.0, 0.0), 1.0),
                (DVec3::new(40.6, 0.0, 0.0), 0.15),
                (DVec3::new(41.0, 0.0, 0.0), 0.5),
                (DVec3::new(0.3, 0.2, 1.2), 0.25),
                (DVec3::new(0.0, 0.0, 9.0), 3.0),
            ];
            for q in 0..200 + outside.len() {
                let (x, r) = match q.checked_sub(200) {
                    None => (
                        pts[(q * 17) % 3050] + DVec3::splat(0.01 * (q % 5) as f64),
                        0.02 + 0.1 * (q % 7) as f64,
                    ),
                    Some(k) => outside[k],
                };
                let mut got = vec![u32::MAX];
                grid.append_within(x, r, &mut got);
                assert_eq!(
                    grid.any_within(x, r),
                    got.len() > 1,
                    "edge {edge}, query {q}"
                );
                assert_eq!(got.remove(0), u32::MAX, "appends after what was there");
                got.sort_unstable();
                let want: Vec<u32> = (0..pts.len() as u32)
                    .filter(|&j| (pts[j as usize] - x).length_squared() <= r * r)
                    .collect();
                assert_eq!(got, want, "edge {edge}, query {q}");
            }
        }
    }
}
