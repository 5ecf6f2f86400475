//! A tile's own points and the points within a halo around it, with their input indices:
//! what a step that reads each point's nearest neighbours takes per tile (the normals and
//! their orientation by parts, `psi_preprocess::part_normals`), and whether a ball lies in
//! what it holds.

use glam::DVec3;
use psi_octree::OrientedPoint;

use crate::TileError;
use crate::tile_records::tile_key;
use crate::tile_store::TileStore;

/// The points of a tile and of its halo, in increasing input index order.
#[derive(Clone, Debug)]
pub struct TileWithHalo {
    /// Input indices (shape: M, ascending).
    pub ids: Vec<u64>,
    /// The points (shape: M, world units).
    pub points: Vec<OrientedPoint>,
    /// Which are the tile's own (shape: M): every point is one tile's own.
    pub own: Vec<bool>,
    /// The held cube: the frame's origin and the cube's centre in the local frame, its
    /// half-edge (the tile's plus the halo), and a slack for rounding (world units).
    origin: DVec3,
    center: DVec3,
    reach: f64,
    slack: f64,
    /// The held cube covers the root cube: every point of the store is held.
    all: bool,
}

impl TileWithHalo {
    /// The tile's own points with their input indices, in increasing index order.
    pub fn own_points(&self) -> impl Iterator<Item = (u64, &OrientedPoint)> {
        self.ids
            .iter()
            .zip(&self.points)
            .zip(&self.own)
            .filter(|(_, own)| **own)
            .map(|((&i, p), _)| (i, p))
    }

    /// Whether every input point within `r` of world position `x` is held (the ball lies in
    /// the held cube, with a slack for rounding, or the cube holds every point).
    pub fn holds_ball(&self, x: DVec3, r: f64) -> bool {
        // As the gather measures a point against the cube (local frame), with a slack for the
        // rounding of both (large coordinates far from the origin included).
        self.all
            || (x - self.origin - self.center).abs().max_element() + r + self.slack <= self.reach
    }
}

impl TileStore {
    /// The keys of the store's tiles (files), ascending.
    pub fn tile_keys(&self) -> Vec<[u32; 3]> {
        self.manifest().tiles.iter().map(|t| t.key).collect()
    }

    /// Tile `key`'s points and every point within ∞-distance `halo` (world units) of its cube.
    pub fn tile_with_halo(&self, key: [u32; 3], halo: f64) -> Result<TileWithHalo, TileError> {
        let manifest = self.manifest();
        let (frame, depth) = (manifest.frame, manifest.depth);
        let half = frame.root_half / f64::from(1u32 << depth);
        let low = frame.root_center - DVec3::splat(frame.root_half);
        let k = DVec3::new(f64::from(key[0]), f64::from(key[1]), f64::from(key[2]));
        let center = low + (2.0 * k + 1.0) * half;
        let found = self.gather_box_indexed(center, half, halo, &|_| true)?;
        let own = found
            .iter()
            .map(|(_, p)| tile_key(&frame, depth, p.p) == key)
            .collect();
        let (ids, points) = found.into_iter().unzip();
        let reach = half + halo;
        let scale = frame.origin.abs().max_element() + center.abs().max_element() + reach;
        Ok(TileWithHalo {
            ids,
            points,
            own,
            origin: frame.origin,
            center,
            reach,
            slack: 1e-12 * reach + 16.0 * f64::EPSILON * scale,
            all: halo >= 2.0 * frame.root_half,
        })
    }
}
