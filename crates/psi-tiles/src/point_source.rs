//! Where a tiled build reads its points: the input in memory (bucketed by tile) or a tile
//! store on disk; both give the points near a cube in input index order.

use glam::DVec3;
use psi_mpu::MpuFrame;
use psi_octree::OrientedPoint;

use crate::tile_buckets::TileBuckets;
use crate::{TileError, TileStore};

/// A source of the input's points by place.
pub trait PointSource: Sync {
    /// The whole input's frame.
    fn frame(&self) -> MpuFrame;

    /// Points in the whole input.
    fn population(&self) -> usize;

    /// The points within ∞-distance `halo` of the cube with local centre `center` and
    /// half-edge `half` (world units) whose world position `keep` accepts, in increasing input
    /// index order.
    fn gather_box_where(
        &self,
        center: DVec3,
        half: f64,
        halo: f64,
        keep: &(dyn Fn(DVec3) -> bool + Sync),
    ) -> Result<Vec<OrientedPoint>, TileError>;

    /// Every point of [`PointSource::gather_box_where`]'s box.
    fn gather_box(
        &self,
        center: DVec3,
        half: f64,
        halo: f64,
    ) -> Result<Vec<OrientedPoint>, TileError> {
        self.gather_box_where(center, half, halo, &|_| true)
    }

    /// The points a relaxation's MPU holds for its data test, in increasing input index order:
    /// every input point when there are at most `at_most`, else about `at_most` of them, each
    /// kept with probability `at_most / N` by a hash of its position (so the same whatever the
    /// tiling; one pass over the input).
    fn relaxation_points(&self, at_most: usize) -> Result<Vec<OrientedPoint>, TileError> {
        let frame = self.frame();
        let n = self.population();
        if n <= at_most {
            return self.gather_box(frame.root_center, frame.root_half, 0.0);
        }
        let rate = at_most as f64 / n as f64;
        self.gather_box_where(frame.root_center, frame.root_half, 0.0, &|p| {
            position_hash(p) < rate
        })
    }

    /// How many parts a pass over every point reads one at a time ([`PointSource::part_where`]):
    /// a store's tile files, the buckets of points in memory.
    fn part_count(&self) -> usize;

    /// The points of part `part` (< [`PointSource::part_count`]) whose world position `keep`
    /// accepts, each with its input index, in no particular order. Every point lies in exactly
    /// one part.
    fn part_where(
        &self,
        part: usize,
        keep: &(dyn Fn(DVec3) -> bool + Sync),
    ) -> Result<Vec<(u64, OrientedPoint)>, TileError>;

    /// The distance (world units) from world position `center` to its `k`-th nearest input
    /// point, or `None` when this source does not tell (the default) or has fewer points.
    fn kth_distance(&self, _center: DVec3, _k: usize) -> Result<Option<f64>, TileError> {
        Ok(None)
    }

    /// The points within `radius` of world position `center`, in increasing input index order.
    fn gather_ball(&self, center: DVec3, radius: f64) -> Result<Vec<OrientedPoint>, TileError> {
        let frame = self.frame();
        let mut points = self.gather_box(center - frame.origin, 0.0, radius)?;
        points.retain(|p| (p.p - center).length() <= radius);
        Ok(points)
    }
}

/// A hash of world position `p` in [0, 1) (SplitMix64's finaliser over the coordinates' bits):
/// uniform in its top bits, as a fraction needs. (psi-mpu's coarse-point hash is read modulo 16
/// and is not meant to be.)
pub(crate) fn position_hash(p: DVec3) -> f64 {
    let mix = |mut x: u64| {
        x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        x ^ (x >> 31)
    };
    let h = mix(p.x.to_bits() ^ mix(p.y.to_bits() ^ mix(p.z.to_bits())));
    (h >> 11) as f64 / (1u64 << 53) as f64
}

/// The input in memory, bucketed by the cubes at a depth for gathering.
pub struct PointsInMemory<'a> {
    points: &'a [OrientedPoint],
    frame: MpuFrame,
    buckets: TileBuckets,
}

impl<'a> PointsInMemory<'a> {
    /// `points` (shape N, world units, inside `frame`'s root cube), bucketed at `depth`.
    pub fn new(points: &'a [OrientedPoint], frame: MpuFrame, depth: u8) -> Self {
        PointsInMemory {
            points,
            frame,
            buckets: TileBuckets::new(points, &frame, depth),
        }
    }

    /// Points in the bucket of tile `key`.
    pub(crate) fn count(&self, key: [u32; 3]) -> usize {
        self.buckets.count(key)
    }
}

impl PointSource for PointsInMemory<'_> {
    fn frame(&self) -> MpuFrame {
        self.frame
    }

    fn part_count(&self) -> usize {
        self.buckets.bucket_count()
    }

    fn part_where(
        &self,
        part: usize,
        keep: &(dyn Fn(DVec3) -> bool + Sync),
    ) -> Result<Vec<(u64, OrientedPoint)>, TileError> {
        Ok(self
            .buckets
            .bucket(part)
            .iter()
            .map(|&i| (u64::from(i), self.points[i as usize]))
            .filter(|(_, p)| keep(p.p))
            .collect())
    }

    fn population(&self) -> usize {
        self.points.len()
    }

    fn gather_box_where(
        &self,
        center: DVec3,
        half: f64,
        halo: f64,
        keep: &(dyn Fn(DVec3) -> bool + Sync),
    ) -> Result<Vec<OrientedPoint>, TileError> {
        let ids = self
            .buckets
            .gather(self.points, &self.frame, center, half, halo);
        Ok(ids
            .iter()
            .map(|&i| self.points[i as usize])
            .filter(|p| keep(p.p))
            .collect())
    }
}

impl PointSource for TileStore {
    fn frame(&self) -> MpuFrame {
        self.manifest().frame
    }

    fn population(&self) -> usize {
        self.manifest().population as usize
    }

    fn part_count(&self) -> usize {
        self.manifest().tiles.len()
    }

    fn part_where(
        &self,
        part: usize,
        keep: &(dyn Fn(DVec3) -> bool + Sync),
    ) -> Result<Vec<(u64, OrientedPoint)>, TileError> {
        self.tile_file_where(part, keep)
    }

    fn gather_box_where(
        &self,
        center: DVec3,
        half: f64,
        halo: f64,
        keep: &(dyn Fn(DVec3) -> bool + Sync),
    ) -> Result<Vec<OrientedPoint>, TileError> {
        TileStore::gather_box_where(self, center, half, halo, keep)
    }

    fn gather_ball(&self, center: DVec3, radius: f64) -> Result<Vec<OrientedPoint>, TileError> {
        TileStore::gather_ball(self, center, radius)
    }

    fn kth_distance(&self, center: DVec3, k: usize) -> Result<Option<f64>, TileError> {
        TileStore::kth_distance(self, center, k)
    }
}
