//! What an input point's 9 nearest points say about the data around it ([`InputLocal`]: its
//! spacing, its neighbours, whether they surround it), and the table that keeps one per input
//! point, computed on first use ([`LocalTable`]): dense (a once-cell per point, a cache line
//! each) up to [`FOOTPRINT_SPARSE_ABOVE`] points, sparse above (only the entries computed, in
//! a sharded hash map: a relaxation reads the points near its particles, a small share of a
//! dense scan's; counted in docs/notes/2026-11-29-shared-index.md). An entry is a pure
//! function of the input, so which thread computes it first changes nothing.

use std::collections::HashMap;
use std::hash::BuildHasherDefault;
use std::sync::{OnceLock, PoisonError, RwLock};

use glam::DVec3;
use psi_octree::{IdHasher, OrientedPoint, PointIndex};

use crate::point_footprint::vector_of;

/// Inputs of more points than this keep their data footprint's table sparse (a dense one is
/// 64 bytes a point, written when the MPU is made).
pub const FOOTPRINT_SPARSE_ABOVE: usize = 1 << 21;

/// Shards of a sparse table (by point index), so that threads filling it seldom wait.
const SHARDS: usize = 64;

/// The input as the footprint reads it.
#[derive(Clone, Copy)]
pub(crate) struct InputData<'a> {
    /// Positions, local frame (shape: N).
    pub(crate) positions: &'a [DVec3],
    /// The points, for their unit normals (shape: N).
    pub(crate) points: &'a [OrientedPoint],
    /// A kd-tree over `positions`.
    pub(crate) index: &'a PointIndex,
}

/// What an input point's 9 nearest points (itself and 8 neighbours) say about the data around
/// it: a pure function of the input. 56 bytes, so that with its once-flag an entry of the table
/// fills one cache line ([`InputLocalSlot`]): the footprint test reads one line a point
/// instead of two.
#[derive(Clone, Copy, Debug)]
pub(crate) struct InputLocal {
    /// Centroid of the point's 8 nearest input points (itself included) minus the point, local
    /// frame (f32: a fraction of a spacing, to about 1e-7 of it).
    pub(crate) centroid_offset: [f32; 3],
    /// The distance to the 9th nearest (to the last, when there are fewer), world units.
    pub(crate) last: f64,
    /// The point's nearest input points other than itself (its 9 nearest but itself; the
    /// first 8 of them in a cluster of 9 or more coincident points that leaves it out), the
    /// first `near_len` valid.
    pub(crate) near: [u32; 8],
    pub(crate) near_len: u8,
    /// Whether the point's 9 nearest are 9 (the input has more points than that).
    pub(crate) full: bool,
    /// `DataFootprint::is_interior`.
    pub(crate) interior: bool,
}

impl InputLocal {
    /// The entry of input point `q` from its 9 nearest points `around` (itself and 8
    /// neighbours, as `(index, squared distance)`, nearest first; the centroid is of the
    /// first 8).
    pub(crate) fn from_nearest(data: InputData<'_>, q: u32, around: &[(u32, f64)]) -> InputLocal {
        let positions = data.positions;
        let y = positions[q as usize];
        let last = around.last().map_or(0.0, |n| n.1.sqrt());
        let spacing = spacing_of(last);
        let first = &around[..around.len().min(8)];
        let centroid = first
            .iter()
            .map(|&(i, _)| positions[i as usize])
            .sum::<DVec3>()
            / first.len().max(1) as f64;
        let n = data.points[q as usize].n;
        let offset = centroid - y;
        let interior = tangential_length(offset, n) <= 0.5 * spacing;
        let mut near = [0u32; 8];
        let mut near_len = 0;
        for &(i, _) in around {
            if i != q && near_len < near.len() {
                near[near_len] = i;
                near_len += 1;
            }
        }
        InputLocal {
            centroid_offset: [offset.x as f32, offset.y as f32, offset.z as f32],
            last,
            near,
            near_len: near_len as u8,
            full: around.len() >= 9,
            interior,
        }
    }

    /// d₈·√(π/8), world units (`DataFootprint::spacing`).
    #[inline]
    pub(crate) fn spacing(&self) -> f64 {
        spacing_of(self.last)
    }

    /// The centroid of the point's 8 nearest minus the point, local frame, world units.
    #[inline]
    pub(crate) fn centroid_offset(&self) -> DVec3 {
        vector_of(self.centroid_offset)
    }

    /// Every input point but the point and `near` is at least this far from the point, world
    /// units (the 9th nearest's distance; ∞ when there are no more points).
    #[inline]
    pub(crate) fn beyond(&self) -> f64 {
        if self.full { self.last } else { f64::INFINITY }
    }
}

/// The length of `v`'s component in the plane normal to unit `n` (the units of `v`).
#[inline]
pub(crate) fn tangential_length(v: DVec3, n: DVec3) -> f64 {
    (v - n * v.dot(n)).length()
}

/// The input spacing d₈·√(π/8) for a distance d₈ to the 8th neighbour (world units): the
/// radius of the disc that holds one point on average when 8 points fill the disc of radius d₈.
#[inline]
pub(crate) fn spacing_of(d8: f64) -> f64 {
    d8 * (std::f64::consts::PI / 8.0).sqrt()
}

/// A table entry: an [`InputLocal`] filled on first use, aligned to a cache line.
#[derive(Debug, Default)]
#[repr(align(64))]
pub(crate) struct InputLocalSlot(OnceLock<InputLocal>);

impl InputLocalSlot {
    /// The distance to the point's 9th nearest input point (world units) when filled.
    pub(crate) fn reach(&self) -> Option<f64> {
        self.0.get().map(InputLocal::beyond)
    }

    /// Empties the entry (filled again on next use).
    pub(crate) fn clear(&mut self) {
        self.0.take();
    }
}

/// One [`InputLocal`] per input point, computed on first use (see the file's overview).
#[derive(Debug)]
pub(crate) enum LocalTable {
    /// A slot per point (shape: N).
    Dense(Vec<InputLocalSlot>),
    /// The entries computed so far, by point index, for `len` points.
    Sparse {
        len: usize,
        shards: Vec<RwLock<HashMap<u32, InputLocal, BuildHasherDefault<IdHasher>>>>,
    },
}

impl Default for LocalTable {
    fn default() -> Self {
        LocalTable::Dense(Vec::new())
    }
}

impl LocalTable {
    /// An empty table for `n` input points: dense in `memory`'s allocation (emptied first) up to
    /// [`FOOTPRINT_SPARSE_ABOVE`] points, sparse above.
    pub(crate) fn new_in(mut memory: Vec<InputLocalSlot>, n: usize) -> Self {
        if n > FOOTPRINT_SPARSE_ABOVE {
            return LocalTable::sparse(n);
        }
        memory.clear();
        memory.resize_with(n, InputLocalSlot::default);
        LocalTable::Dense(memory)
    }

    /// An empty dense table for `n` input points, whatever their number (for a caller that
    /// fills every entry: a sparse table would hold them in more memory).
    pub(crate) fn dense_for(n: usize) -> Self {
        LocalTable::Dense(
            std::iter::repeat_with(InputLocalSlot::default)
                .take(n)
                .collect(),
        )
    }

    /// An empty sparse table for `n` input points (what [`LocalTable::new_in`] makes above
    /// [`FOOTPRINT_SPARSE_ABOVE`] points).
    pub(crate) fn sparse(n: usize) -> Self {
        LocalTable::Sparse {
            len: n,
            shards: (0..SHARDS).map(|_| RwLock::default()).collect(),
        }
    }

    /// The number of entries computed so far.
    #[cfg(test)]
    pub(crate) fn filled(&self) -> usize {
        match self {
            LocalTable::Dense(slots) => slots.iter().filter(|s| s.0.get().is_some()).count(),
            LocalTable::Sparse { shards, .. } => shards
                .iter()
                .map(|s| s.read().unwrap_or_else(PoisonError::into_inner).len())
                .sum(),
        }
    }

    /// The number of points the table is for.
    pub(crate) fn len(&self) -> usize {
        match self {
            LocalTable::Dense(slots) => slots.len(),
            LocalTable::Sparse { len, .. } => *len,
        }
    }

    /// The entry of point `q` (below [`LocalTable::len`]), made by `make` on first use.
    pub(crate) fn get_or_init(&self, q: u32, make: impl FnOnce() -> InputLocal) -> InputLocal {
        match self {
            LocalTable::Dense(slots) => *slots[q as usize].0.get_or_init(make),
            LocalTable::Sparse { shards, .. } => {
                let shard = &shards[q as usize % SHARDS];
                let known = shard
                    .read()
                    .unwrap_or_else(PoisonError::into_inner)
                    .get(&q)
                    .copied();
                known.unwrap_or_else(|| {
                    // Made outside the lock; a thread that made it meanwhile made the same.
                    let made = make();
                    *shard
                        .write()
                        .unwrap_or_else(PoisonError::into_inner)
                        .entry(q)
                        .or_insert(made)
                })
            }
        }
    }

    /// The slots of a dense table.
    pub(crate) fn dense(&self) -> Option<&[InputLocalSlot]> {
        match self {
            LocalTable::Dense(slots) => Some(slots),
            LocalTable::Sparse { .. } => None,
        }
    }

    /// A dense table's slots, when it has `n`; the table is left empty.
    pub(crate) fn take_dense(&mut self, n: usize) -> Option<Vec<InputLocalSlot>> {
        match self {
            LocalTable::Dense(slots) if slots.len() == n => Some(std::mem::take(slots)),
            _ => None,
        }
    }

    /// A dense table's memory, for a later table (none from a sparse one).
    pub(crate) fn into_memory(self) -> Vec<InputLocalSlot> {
        match self {
            LocalTable::Dense(slots) => slots,
            LocalTable::Sparse { .. } => Vec::new(),
        }
    }
}
