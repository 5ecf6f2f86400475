//! The points a region's seeds need: the union of its leaves' cubes, each grown by a margin of
//! its own edge, as a grid of fine cells (a superset: a fine cell counts when it meets a grown
//! cube). A region gathers only the points the cover holds, not every point of its cube's
//! neighbourhood.

use glam::DVec3;
use psi_mpu::{CellAddress, MpuFrame, Region};

/// Fine cells per axis at most (the grid takes at most 256³ bits, 2 MiB).
const MAX_CELLS: f64 = 256.0;

/// The union of leaf cubes grown by a margin, as a bit grid over their bounding box.
pub(crate) struct LeafCover {
    /// World position of the grid's low corner.
    lo: DVec3,
    /// A fine cell's edge, world units.
    edge: f64,
    /// Fine cells per axis.
    dims: [usize; 3],
    bits: Vec<u64>,
}

impl LeafCover {
    /// The cover of `leaves` (addresses in `frame`'s octree), each cube grown by `margin` × its
    /// edge on every side; `None` for no leaves.
    pub(crate) fn new(frame: &MpuFrame, leaves: &[CellAddress], margin: f64) -> Option<Self> {
        let boxes: Vec<(DVec3, DVec3, f64)> = leaves
            .iter()
            .map(|&(d, key)| {
                let (c, h) = Region::tile(d, key).cube(frame);
                let grown = h + margin * 2.0 * h;
                let world = c + frame.origin;
                (world - DVec3::splat(grown), world + DVec3::splat(grown), h)
            })
            .collect();
        let lo = boxes.iter().map(|b| b.0).reduce(DVec3::min)?;
        let hi = boxes.iter().map(|b| b.1).reduce(DVec3::max)?;
        let finest = boxes
            .iter()
            .map(|b| 2.0 * b.2)
            .fold(f64::INFINITY, f64::min);
        let edge = finest.max((hi - lo).max_element() / MAX_CELLS);
        let dims: [usize; 3] =
            std::array::from_fn(|a| (((hi[a] - lo[a]) / edge).ceil() as usize).max(1));
        let mut cover = LeafCover {
            lo,
            edge,
            dims,
            bits: vec![0; (dims[0] * dims[1] * dims[2]).div_ceil(64)],
        };
        for (a, b, _) in boxes {
            let (i0, i1) = (cover.cell_of(a), cover.cell_of(b));
            for z in i0[2]..=i1[2] {
                for y in i0[1]..=i1[1] {
                    for x in i0[0]..=i1[0] {
                        let i = cover.slot([x, y, z]);
                        cover.bits[i / 64] |= 1 << (i % 64);
                    }
                }
            }
        }
        Some(cover)
    }

    /// The fine cell holding world position `p`, clamped to the grid.
    fn cell_of(&self, p: DVec3) -> [usize; 3] {
        std::array::from_fn(|a| {
            let t = ((p[a] - self.lo[a]) / self.edge).floor().max(0.0) as usize;
            t.min(self.dims[a] - 1)
        })
    }

    fn slot(&self, c: [usize; 3]) -> usize {
        (c[2] * self.dims[1] + c[1]) * self.dims[0] + c[0]
    }

    /// Whether world position `p` lies in a marked fine cell (every point of a grown cube
    /// does; a point outside the grid does not).
    pub(crate) fn holds(&self, p: DVec3) -> bool {
        let t = (p - self.lo) / self.edge;
        if (0..3).any(|a| !(t[a] >= 0.0 && t[a] <= self.dims[a] as f64)) {
            return false;
        }
        let i = self.slot(self.cell_of(p));
        self.bits[i / 64] >> (i % 64) & 1 == 1
    }

    /// The cube around the grid (local centre in `frame`, half-edge; world units), for a
    /// gather.
    pub(crate) fn bounding_cube(&self, frame: &MpuFrame) -> (DVec3, f64) {
        let size = DVec3::new(
            self.dims[0] as f64,
            self.dims[1] as f64,
            self.dims[2] as f64,
        ) * self.edge;
        (
            self.lo + 0.5 * size - frame.origin,
            0.5 * size.max_element(),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_cover_holds_every_grown_cube_and_little_else() {
        let frame = MpuFrame {
            origin: DVec3::new(1.0, -2.0, 0.5),
            root_center: DVec3::ZERO,
            root_half: 1.0,
            diagonal: 3.0,
        };
        let leaves: Vec<CellAddress> = vec![(3, [1, 2, 3]), (5, [20, 7, 9]), (2, [3, 3, 0])];
        let margin = 2.0;
        let cover = LeafCover::new(&frame, &leaves, margin).expect("leaves");
        // Brute force: the ∞-distance from each grown cube.
        let outside = |p: DVec3| -> f64 {
            leaves
                .iter()
                .map(|&(d, key)| {
                    let (c, h) = Region::tile(d, key).cube(&frame);
                    ((p - frame.origin - c).abs() - DVec3::splat(h + margin * 2.0 * h))
                        .max_element()
                })
                .fold(f64::INFINITY, f64::min)
        };
        let mut state = 7u64;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let (center, half) = cover.bounding_cube(&frame);
        let (mut inside, mut extra) = (0, 0);
        for _ in 0..20000 {
            let p = frame.origin
                + center
                + DVec3::new(next(), next(), next()).map(|t| (2.0 * t - 1.0) * 1.2 * half);
            let d = outside(p);
            if d <= 0.0 {
                inside += 1;
                assert!(cover.holds(p), "{p} lies in a grown cube");
            } else if cover.holds(p) {
                extra += 1;
                // Only within a fine cell (the finest leaf's edge here) of a grown cube.
                assert!(d <= 2.0 / 32.0 + 1e-12, "{p} is {d} away");
            }
        }
        assert!(
            inside > 1000 && extra < inside,
            "{inside} inside, {extra} extra"
        );
    }
}
