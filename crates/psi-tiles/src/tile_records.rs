//! Where a point goes in a tile store and how it is stored there: the key of the tile (or
//! sub-cell) cube holding a position, and the record layout (little endian, 56 bytes: input
//! index u64, position 3 × f64 in world units, normal 3 × f64).

use glam::DVec3;
use psi_mpu::MpuFrame;

/// Bytes of one point record.
pub(crate) const RECORD: usize = 56;

/// The key at `depth` of the tile cube holding world position `p` (clamped to the root cube;
/// gathering filters by distance, so which of two tiles a point on a face lands in does not
/// matter).
pub(crate) fn tile_key(frame: &MpuFrame, depth: u8, p: DVec3) -> [u32; 3] {
    let side = 1u32 << depth;
    let low = frame.root_center - DVec3::splat(frame.root_half);
    let edge = 2.0 * frame.root_half / f64::from(side);
    let k = ((p - frame.origin - low) / edge).floor();
    let clamp = |v: f64| (v.max(0.0) as u32).min(side - 1);
    [clamp(k.x), clamp(k.y), clamp(k.z)]
}

/// The world position of a record (bytes 8..32).
pub(crate) fn record_position(r: &[u8]) -> DVec3 {
    let f = |k: usize| f64::from_le_bytes(r[8 + 8 * k..16 + 8 * k].try_into().expect("8 bytes"));
    DVec3::new(f(0), f(1), f(2))
}
