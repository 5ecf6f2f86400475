//! The input points bucketed by the tile cube (at the tile depth) that holds them, and the
//! points within a box around a tile gathered from the buckets it overlaps.

use glam::DVec3;
use psi_mpu::MpuFrame;
use psi_octree::OrientedPoint;

use crate::tile_records::tile_key;

/// Per tile key (at one depth), the indices of the points whose tile it is, increasing.
pub(crate) struct TileBuckets {
    depth: u8,
    frame: MpuFrame,
    /// The tile edge, world units.
    edge: f64,
    /// Per bucket (x + n·(y + n·z), n = 2^depth): indices into the points.
    buckets: Vec<Vec<u32>>,
}

impl TileBuckets {
    /// Buckets `points` (shape N, world units, inside `frame`'s root cube) at `depth`, by the
    /// rule the tile store files them ([`tile_key`]).
    pub(crate) fn new(points: &[OrientedPoint], frame: &MpuFrame, depth: u8) -> Self {
        let n = 1usize << depth;
        let mut this = TileBuckets {
            depth,
            frame: *frame,
            edge: 2.0 * frame.root_half / n as f64,
            buckets: vec![Vec::new(); n * n * n],
        };
        for (i, p) in points.iter().enumerate() {
            let slot = this.slot(tile_key(frame, depth, p.p));
            this.buckets[slot].push(i as u32);
        }
        this
    }

    /// The tile key holding local position `x` (clamped to the root cube).
    fn key_of(&self, x: DVec3) -> [u32; 3] {
        tile_key(&self.frame, self.depth, x + self.frame.origin)
    }

    fn slot(&self, k: [u32; 3]) -> usize {
        let n = 1usize << self.depth;
        k[0] as usize + n * (k[1] as usize + n * k[2] as usize)
    }

    /// Points in the tile `key`'s bucket.
    pub(crate) fn count(&self, key: [u32; 3]) -> usize {
        self.buckets[self.slot(key)].len()
    }

    /// How many buckets (8^depth, empty ones included).
    pub(crate) fn bucket_count(&self) -> usize {
        self.buckets.len()
    }

    /// The indices (increasing) of bucket `i` (< [`TileBuckets::bucket_count`]).
    pub(crate) fn bucket(&self, i: usize) -> &[u32] {
        &self.buckets[i]
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
