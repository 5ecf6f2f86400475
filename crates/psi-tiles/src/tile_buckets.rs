//! The input points bucketed by the tile cube (at the tile depth) that holds them, and the
//! points within a box around a tile gathered from the buckets it overlaps.

use glam::DVec3;
use psi_mpu::MpuFrame;
use psi_octree::OrientedPoint;

/// Per tile key (at one depth), the indices of the points whose tile it is, increasing.
pub(crate) struct TileBuckets {
    depth: u8,
    /// The root cube's low corner (local frame) and the tile edge (world units).
    low: DVec3,
    edge: f64,
    /// Per bucket (x + n·(y + n·z), n = 2^depth): indices into the points.
    buckets: Vec<Vec<u32>>,
}

impl TileBuckets {
    /// Buckets `points` (shape N, world units, inside `frame`'s root cube) at `depth`.
    pub(crate) fn new(points: &[OrientedPoint], frame: &MpuFrame, depth: u8) -> Self {
        let n = 1usize << depth;
        let low = frame.root_center - DVec3::splat(frame.root_half);
        let edge = 2.0 * frame.root_half / n as f64;
        let mut buckets = vec![Vec::new(); n * n * n];
        let this = TileBuckets {
            depth,
            low,
            edge,
            buckets: Vec::new(),
        };
        for (i, p) in points.iter().enumerate() {
            let k = this.key_of(p.p - frame.origin);
            buckets[this.slot(k)].push(i as u32);
        }
        TileBuckets { buckets, ..this }
    }

    /// Tiles per axis.
    fn side(&self) -> u32 {
        1 << self.depth
    }

    /// The tile key holding local position `x` (clamped to the root cube; the bucket is only a
    /// coarse filter, so which of two tiles a point on a face lands in does not matter).
    fn key_of(&self, x: DVec3) -> [u32; 3] {
        let k = ((x - self.low) / self.edge).floor();
        let clamp = |v: f64| (v.max(0.0) as u32).min(self.side() - 1);
        [clamp(k.x), clamp(k.y), clamp(k.z)]
    }

    fn slot(&self, k: [u32; 3]) -> usize {
        let n = self.side() as usize;
        k[0] as usize + n * (k[1] as usize + n * k[2] as usize)
    }

    /// Points in the tile `key`'s bucket.
    pub(crate) fn count(&self, key: [u32; 3]) -> usize {
        self.buckets[self.slot(key)].len()
    }

    /// Indices (increasing) of the points within ∞-distance `halo` of the cube with local
    /// centre `center` and half-edge `half`.
    pub(crate) fn gather(
        &self,
        points: &[OrientedPoint],
        frame: &MpuFrame,
        center: DVec3,
        half: f64,
        halo: f64,
    ) -> Vec<u32> {
        let reach = half + halo;
        // Buckets overlapping the box, one bucket of slack for rounding at their faces.
        let lo = self.key_of(center - DVec3::splat(reach + self.edge));
        let hi = self.key_of(center + DVec3::splat(reach + self.edge));
        let mut out = Vec::new();
        for z in lo[2]..=hi[2] {
            for y in lo[1]..=hi[1] {
                for x in lo[0]..=hi[0] {
                    out.extend(
                        self.buckets[self.slot([x, y, z])]
                            .iter()
                            .copied()
                            .filter(|&i| {
                                let d = (points[i as usize].p - frame.origin - center).abs();
                                d.max_element() <= reach
                            }),
                    );
                }
            }
        }
        out.sort_unstable();
        out
    }
}
