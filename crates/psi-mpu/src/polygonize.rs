//! Polygonization of the zero set: surface nets on a sparse grid restricted to a band around
//! the input points, each vertex projected onto f = 0 by damped Newton steps so the mesh lies on
//! the MPU surface to rounding, and vertices (hence their triangles) farther than a few input
//! spacings from the data dropped, so no sheets appear away from the data.

use std::collections::HashMap;
use std::hash::BuildHasherDefault;

use glam::DVec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use psi_octree::{IdHasher, Interrupted, Monitor};

use crate::Mpu;

/// Parameters of [`polygonize`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PolygonizeParams {
    /// Grid cells across the root cube's edge (at most 2^20).
    pub resolution: u32,
    /// Newton steps projecting each vertex onto f = 0 (0 keeps the averaged edge crossings).
    pub newton_steps: u32,
    /// Triangles with a vertex farther than this many local input spacings from every input
    /// point are dropped: the MPU's zero set away from data (bridges between close parts, caps
    /// over holes) is not part of the sampled surface. `f64::INFINITY` keeps everything.
    pub max_data_distance: f64,
}

impl PolygonizeParams {
    /// 256 cells across the root cube, 4 Newton steps, surface kept within 1.5 input spacings of
    /// the data.
    pub fn standard() -> Self {
        Self {
            resolution: 256,
            newton_steps: 4,
            max_data_distance: 1.5,
        }
    }
}

/// A triangle mesh: vertices (world units, shape V) and counter-clockwise faces seen from
/// outside (shape F × 3 indices into `vertices`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriangleSoup {
    /// Vertex positions, world units.
    pub vertices: Vec<DVec3>,
    /// Triangles as vertex indices, outward by the right-hand rule.
    pub faces: Vec<[u32; 3]>,
}

const BITS: u32 = 21;
const MASK: u64 = (1 << BITS) - 1;

#[inline]
fn key(i: i64, j: i64, k: i64) -> u64 {
    (i as u64) | ((j as u64) << BITS) | ((k as u64) << (2 * BITS))
}

#[inline]
fn unkey(key: u64) -> [i64; 3] {
    [
        (key & MASK) as i64,
        ((key >> BITS) & MASK) as i64,
        ((key >> (2 * BITS)) & MASK) as i64,
    ]
}

/// Extracts the zero set of `mpu` near its input points as a triangle mesh.
///
/// The band: grid cells within ⌈1.5 × (median nearest-neighbour spacing of the input) / h⌉ + 1
/// cells of an input point, h the grid step. Output is deterministic.
pub fn polygonize(mpu: &Mpu, params: &PolygonizeParams) -> TriangleSoup {
    polygonize_with(mpu, params, &Monitor::silent()).expect("a silent monitor never stops")
}

/// [`polygonize`], reporting its phases to `monitor` (stage `"mesh"`, four steps: band cells,
/// corner values, vertices, faces) and returning [`Interrupted`] soon after its stop flag is
/// set. A run that completes equals [`polygonize`]'s.
pub fn polygonize_with(
    mpu: &Mpu,
    params: &PolygonizeParams,
    monitor: &Monitor<'_>,
) -> Result<TriangleSoup, Interrupted> {
    const STEPS: u64 = 4;
    monitor.report("mesh", 0, STEPS);
    let res = i64::from(params.resolution.clamp(2, 1 << 20));
    let root = *mpu.octree().root();
    let h = 2.0 * root.half / res as f64;
    let min = root.center - DVec3::splat(root.half);
    let local: &[DVec3] = mpu.octree().positions();

    // Band width in cells from the sample spacing.
    let spacing = median_spacing(local);
    let band = ((1.5 * spacing / h).ceil() as i64 + 1).clamp(1, 6);

    // The band: the points' cells grown by `band` cells along each axis in turn (a cube
    // neighbourhood is the product of three intervals), clipped to the grid.
    let mut cells: Vec<u64> = local
        .par_iter()
        .map(|p| {
            let c = ((*p - min) / h).floor();
            key(c.x as i64, c.y as i64, c.z as i64)
        })
        .collect();
    cells.par_sort_unstable();
    cells.dedup();
    monitor.check()?;
    let cells = grown_cubes(&cells, -band..=band, res, monitor)?;
    monitor.report("mesh", 1, STEPS);

    // Every cell's eight corners: the cells grown by one along each axis upwards.
    let corners = grown_cubes(&cells, 0..=1, res + 1, monitor)?;
    let origin = mpu.frame_origin();
    let corner_pos = |c: u64| {
        let [i, j, k] = unkey(c);
        min + h * DVec3::new(i as f64, j as f64, k as f64)
    };
    let values: Vec<f64> = corners
        .par_iter()
        .map(|&c| {
            if monitor.stopped() {
                return 0.0;
            }
            mpu.value(corner_pos(c) + origin)
        })
        .collect();
    monitor.check()?;
    let value_of: KeyMap<f64> = corners
        .iter()
        .copied()
        .zip(values.iter().copied())
        .collect();
    monitor.check()?;
    monitor.report("mesh", 2, STEPS);

    // One vertex per cell with a sign change: the mean edge crossing, projected onto f = 0.
    const EDGES: [(usize, usize); 12] = [
        (0, 1),
        (2, 3),
        (4, 5),
        (6, 7),
        (0, 2),
        (1, 3),
        (4, 6),
        (5, 7),
        (0, 4),
        (1, 5),
        (2, 6),
        (3, 7),
    ];
    let verts: Vec<Option<DVec3>> = cells
        .par_iter()
        .map(|&c| {
            if monitor.stopped() {
                return None;
            }
            let [i, j, k] = unkey(c);
            let mut v = [0.0; 8];
            let mut p = [DVec3::ZERO; 8];
            for o in 0..8 {
                let ck = key(
                    i + (o & 1) as i64,
                    j + ((o >> 1) & 1) as i64,
                    k + ((o >> 2) & 1) as i64,
                );
                v[o] = value_of[&ck];
                p[o] = corner_pos(ck);
            }
            let (mut sum, mut n) = (DVec3::ZERO, 0);
            for (a, b) in EDGES {
                if (v[a] < 0.0) != (v[b] < 0.0) {
                    let t = v[a] / (v[a] - v[b]);
                    sum += p[a] + t * (p[b] - p[a]);
                    n += 1;
                }
            }
            if n == 0 {
                return None;
            }
            let mut x = sum / n as f64 + origin;
            for _ in 0..params.newton_steps {
                let (f, g) = mpu.value_and_gradient(x);
                let g2 = g.length_squared();
                if g2 < 1e-12 || f.abs() < 1e-15 {
                    break;
                }
                let mut step = (f / g2) * g;
                if step.length() > h {
                    step *= h / step.length();
                }
                x -= step;
            }
            // (A finite vertex is within an infinite distance: not measured then.)
            let kept = (params.max_data_distance == f64::INFINITY && x.is_finite())
                || mpu.distance_in_spacings(x) <= params.max_data_distance;
            kept.then_some(x)
        })
        .collect();
    monitor.check()?;
    monitor.report("mesh", 3, STEPS);
    let mut soup = TriangleSoup::default();
    let mut vertex_of: KeyMap<u32> =
        KeyMap::with_capacity_and_hasher(cells.len(), Default::default());
    for (c, v) in cells.iter().zip(&verts) {
        if let Some(x) = v {
            vertex_of.insert(*c, soup.vertices.len() as u32);
            soup.vertices.push(*x);
        }
    }
    // One quad per sign-changing grid edge whose four surrounding cells all have a vertex.
    for (&ck, &f0) in corners.iter().zip(&values) {
        let [i, j, k] = unkey(ck);
        for axis in 0..3 {
            let mut e = [i, j, k];
            e[axis] += 1;
            let Some(&f1) = value_of.get(&key(e[0], e[1], e[2])) else {
                continue;
            };
            if (f0 < 0.0) == (f1 < 0.0) {
                continue;
            }
            // The two other axes in cyclic order, so (u, v, axis) is right-handed.
            let (u, w) = ((axis + 1) % 3, (axis + 2) % 3);
            let ring = [(-1, -1), (0, -1), (0, 0), (-1, 0)];
            let mut quad = [0u32; 4];
            let mut ok = true;
            for (q, (du, dw)) in ring.iter().enumerate() {
                let mut c = [i, j, k];
                c[u] += du;
                c[w] += dw;
                if c.iter().any(|&x| x < 0) {
                    ok = false;
                    break;
                }
                match vertex_of.get(&key(c[0], c[1], c[2])) {
                    Some(&vi) => quad[q] = vi,
                    None => {
                        ok = false;
                        break;
                    }
                }
            }
            if !ok {
                continue;
            }
            // f increasing along +axis means the outward normal is +axis: keep the ring order.
            if f0 > f1 {
                quad.reverse();
            }
            soup.faces.push([quad[0], quad[1], quad[2]]);
            soup.faces.push([quad[0], quad[2], quad[3]]);
        }
    }
    drop_unreferenced_vertices(&mut soup);
    monitor.report("mesh", STEPS, STEPS);
    Ok(soup)
}

/// The keys `cells` (ascending, distinct) moved by every offset in `offsets` along all three
/// axes (a cube of offsets), those within `0..limit` on each axis kept: ascending, without
/// repeats. Worked out in slabs of [`SLAB`] planes of the third coordinate, each from the
/// cells whose cubes reach it, so that a stop request is seen between slabs.
fn grown_cubes(
    cells: &[u64],
    offsets: std::ops::RangeInclusive<i64>,
    limit: i64,
    monitor: &Monitor<'_>,
) -> Result<Vec<u64>, Interrupted> {
    let plane = |c: u64| unkey(c)[2];
    let (lo, hi) = (*offsets.start(), *offsets.end());
    let (Some(&first), Some(&last)) = (cells.first(), cells.last()) else {
        return Ok(Vec::new());
    };
    let from = (plane(first) + lo).max(0);
    let to = (plane(last) + hi).min(limit - 1);
    let starts: Vec<i64> = (from..=to).step_by(SLAB as usize).collect();
    let slabs: Vec<Vec<u64>> = starts
        .par_iter()
        .map(|&k0| {
            if monitor.stopped() {
                return Vec::new();
            }
            let k1 = k0 + SLAB;
            // The cells whose planes reach [k0, k1): k + d in it for an offset d.
            let a = cells.partition_point(|&c| plane(c) < k0 - hi);
            let b = cells.partition_point(|&c| plane(c) < k1 - lo);
            let mut out = cells[a..b].to_vec();
            for axis in 0..3 {
                out = grown(&out, axis, offsets.clone(), limit);
            }
            out.retain(|&c| (k0..k1).contains(&plane(c)));
            out
        })
        .collect();
    monitor.check()?;
    Ok(slabs.concat())
}

/// Planes of the third coordinate per slab of [`grown_cubes`].
const SLAB: i64 = 16;

/// The keys `cells` (ascending) with each one's coordinate `axis` moved by every offset in
/// `offsets`, those within `0..limit` kept: ascending, without repeats.
fn grown(
    cells: &[u64],
    axis: usize,
    offsets: std::ops::RangeInclusive<i64>,
    limit: i64,
) -> Vec<u64> {
    let mut out: Vec<u64> = cells
        .par_iter()
        .flat_map_iter(|&c| {
            let at = unkey(c);
            offsets.clone().filter_map(move |d| {
                let mut moved = at;
                moved[axis] += d;
                (0..limit)
                    .contains(&moved[axis])
                    .then(|| key(moved[0], moved[1], moved[2]))
            })
        })
        .collect();
    out.par_sort_unstable();
    out.dedup();
    out
}

/// A map from grid keys (hashed multiplicatively: the keys are our own, not adversarial).
type KeyMap<V> = HashMap<u64, V, BuildHasherDefault<IdHasher>>;

/// Removes the vertices no face uses (those of quads dropped far from the data) and renumbers
/// the faces, keeping the vertices' order.
fn drop_unreferenced_vertices(soup: &mut TriangleSoup) {
    let mut new_index = vec![u32::MAX; soup.vertices.len()];
    for f in &soup.faces {
        for &v in f {
            new_index[v as usize] = 0;
        }
    }
    let mut next = 0u32;
    let mut kept = Vec::with_capacity(soup.vertices.len());
    for (v, slot) in new_index.iter_mut().enumerate() {
        if *slot == 0 {
            *slot = next;
            next += 1;
            kept.push(soup.vertices[v]);
        }
    }
    for f in &mut soup.faces {
        *f = f.map(|v| new_index[v as usize]);
    }
    soup.vertices = kept;
}

/// Median nearest-neighbour distance over up to 2000 evenly strided points.
fn median_spacing(points: &[DVec3]) -> f64 {
    let index = psi_octree::PointIndex::new(points);
    let stride = (points.len() / 2000).max(1);
    let mut d: Vec<f64> = points
        .iter()
        .step_by(stride)
        .filter_map(|p| index.nearest(*p, 2).get(1).map(|n| n.1.sqrt()))
        .collect();
    if d.is_empty() {
        return 0.0;
    }
    let mid = d.len() / 2;
    *d.select_nth_unstable_by(mid, f64::total_cmp).1
}

#[cfg(test)]
mod tests {
    use psi_octree::Monitor;

    use super::{grown, grown_cubes, key};

    /// Brute-force twin of the band: growing the cells along each axis in turn gives every
    /// cell of the cube neighbourhoods within the grid, near its faces too.
    #[test]
    fn growing_axis_by_axis_gives_the_cube_neighbourhoods() {
        // Planes across several slabs of `grown_cubes`, and seeds on and past the grid's faces.
        let res = 40i64;
        let seeds = [
            [0, 0, 0],
            [5, 5, 5],
            [11, 3, 40],
            [7, 11, 0],
            [6, 5, 15],
            [6, 5, 16],
            [39, 20, 31],
            [2, 2, 33],
        ];
        for band in 1..=3i64 {
            let mut cells: Vec<u64> = seeds.iter().map(|c| key(c[0], c[1], c[2])).collect();
            cells.sort_unstable();
            for axis in 0..3 {
                cells = grown(&cells, axis, -band..=band, res);
            }
            let mut want = Vec::new();
            for c in seeds {
                for di in -band..=band {
                    for dj in -band..=band {
                        for dk in -band..=band {
                            let (i, j, k) = (c[0] + di, c[1] + dj, c[2] + dk);
                            if [i, j, k].iter().all(|x| (0..res).contains(x)) {
                                want.push(key(i, j, k));
                            }
                        }
                    }
                }
            }
            want.sort_unstable();
            want.dedup();
            assert_eq!(cells, want, "band {band}");
            let mut seeds: Vec<u64> = seeds.iter().map(|c| key(c[0], c[1], c[2])).collect();
            seeds.sort_unstable();
            let by_slabs = grown_cubes(&seeds, -band..=band, res, &Monitor::silent()).unwrap();
            assert_eq!(by_slabs, want, "band {band}, by slabs");
        }
    }
}
