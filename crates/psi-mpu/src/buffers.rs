//! Memory for an MPU build to fill instead of allocating: the largest arrays of an earlier MPU,
//! or fresh ones touched once.

use std::sync::OnceLock;

use glam::DVec3;
use psi_octree::{OctreeBuffers, OrientedPoint};

use crate::Mpu;
use crate::eval_nodes::EvalNode;
use crate::input_local::InputLocalSlot;

/// Memory for an MPU build to fill instead of allocating: the largest arrays of an earlier MPU
/// ([`Mpu::into_buffers`]) or fresh ones touched once ([`MpuBuffers::in_step_with`]). Memory the
/// process already maps costs nothing to write; fresh memory costs a page fault per 4 KiB.
#[derive(Debug, Default)]
pub struct MpuBuffers {
    pub(crate) points: Vec<OrientedPoint>,
    pub(crate) positions: Vec<DVec3>,
    pub(crate) octree: OctreeBuffers,
    pub(crate) nodes: Vec<EvalNode>,
    pub(crate) candidates: Vec<OnceLock<Box<[u32]>>>,
    pub(crate) input_local: Vec<InputLocalSlot>,
}

/// Buffers hold no content, only memory: a clone is empty (it allocates when used).
impl Clone for MpuBuffers {
    fn clone(&self) -> Self {
        Self::default()
    }
}

impl MpuBuffers {
    /// Buffers for the build after `mpu`'s, in step with it: its points and their local
    /// positions copied (a brush then brings up to date only the points it moves:
    /// [`crate::BuildOptions::synced`] with no earlier lag), the other arrays sized like its
    /// (about its cells) and their memory touched once. No footprint table: a brush carries
    /// `mpu`'s ([`Mpu::carry_footprint`]), and a table allocated here would only be freed then.
    pub fn in_step_with(mpu: &Mpu) -> Self {
        let cells = mpu.octree.cells().len() + 1024;
        let mut b = Self {
            points: mpu.points.clone(),
            positions: mpu.octree.positions().to_vec(),
            octree: OctreeBuffers::with_capacity(cells, mpu.points.len()),
            nodes: Vec::with_capacity(cells),
            candidates: Vec::with_capacity(cells),
            input_local: Vec::new(),
        };
        // Touched once, then emptied (capacity kept).
        b.nodes.extend(mpu.nodes.iter().copied());
        b.nodes.clear();
        b.candidates.resize_with(cells, OnceLock::new);
        b.candidates.clear();
        b
    }

    /// The buffer for the next build's points as the buffers' MPU left them (to be brought up
    /// to date by the caller: [`crate::BuildOptions::synced`]).
    pub fn take_synced_points(&mut self) -> Vec<OrientedPoint> {
        std::mem::take(&mut self.points)
    }

    /// The buffer for the next build's points (empty; its capacity kept).
    pub fn take_points(&mut self) -> Vec<OrientedPoint> {
        let mut p = std::mem::take(&mut self.points);
        p.clear();
        p
    }
}

impl Mpu {
    /// The MPU's largest arrays, for a later build to reuse ([`MpuBuffers`]).
    pub fn into_buffers(self) -> MpuBuffers {
        let (octree, positions) = self.octree.into_buffers();
        // The lazily filled tables come back only when this MPU held the last reference.
        let mut candidates = std::sync::Arc::try_unwrap(self.leaf_candidates).unwrap_or_default();
        candidates.clear();
        MpuBuffers {
            points: self.points,
            positions,
            octree,
            nodes: self.nodes,
            candidates,
            input_local: self.footprint.into_memory(),
        }
    }
}
