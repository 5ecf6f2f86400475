//! The points a region's fits read: validated, with unit normals, in the local frame, with
//! their kd-tree and coarse index; and the octree's own rule for which cell holds a point.

use glam::DVec3;
use psi_octree::{OrientedPoint, PointIndex};

use crate::coarse_index::CoarseIndex;
use crate::fit_cell::FitInput;
use crate::{MpuError, MpuFrame, MpuParams};

/// Points ready for fitting: unit normals, local positions, their kd-tree and coarse index.
pub(crate) struct IndexedPoints {
    data: crate::build::Prepared,
    index: PointIndex,
    coarse: CoarseIndex,
}

impl IndexedPoints {
    /// `points` (world units, any normal length) in `frame`.
    pub(crate) fn new(points: &[OrientedPoint], frame: &MpuFrame) -> Result<Self, MpuError> {
        let data = prepare_any(points, frame)?;
        let index = PointIndex::new(&data.positions);
        let coarse = CoarseIndex::new(&data.positions);
        Ok(IndexedPoints {
            data,
            index,
            coarse,
        })
    }

    /// Their local-frame positions (shape M).
    pub(crate) fn positions(&self) -> &[DVec3] {
        &self.data.positions
    }

    /// The fits' input over these points, the whole input having `population` points.
    pub(crate) fn input<'a>(&'a self, params: &'a MpuParams, population: usize) -> FitInput<'a> {
        FitInput {
            positions: &self.data.positions,
            points: &self.data.points,
            index: Some(&self.index),
            coarse: &self.coarse,
            params,
            population,
        }
    }
}

/// Checks the parameters and that the whole input has more than N_min points; returns
/// N_min + 1.
pub(crate) fn check_population(params: &MpuParams, population: usize) -> Result<usize, MpuError> {
    params.validate()?;
    let need = params.n_min + 1;
    if population < need {
        return Err(MpuError::TooFewPoints {
            got: population,
            need,
        });
    }
    Ok(need)
}

/// The key at `depth` of the cell holding local position `x` by the octree's own rule (the
/// octant comparisons from the root with its halving arithmetic), so a point on a face lands
/// where the octree puts it.
pub(crate) fn key_of_point(frame: &MpuFrame, x: DVec3, depth: u8) -> [u32; 3] {
    let (mut center, mut half) = (frame.root_center, frame.root_half);
    let mut key = [0u32; 3];
    for _ in 0..depth {
        let h = 0.5 * half;
        let bits = [x.x >= center.x, x.y >= center.y, x.z >= center.z];
        let sign = |b: bool| if b { 1.0 } else { -1.0 };
        center += h * DVec3::new(sign(bits[0]), sign(bits[1]), sign(bits[2]));
        for a in 0..3 {
            key[a] = 2 * key[a] + u32::from(bits[a]);
        }
        half = h;
    }
    key
}

/// Validated points with unit normals and their local-frame positions (any number of them: a
/// region's share of the input may be below N_min).
pub(crate) fn prepare_any(
    points: &[OrientedPoint],
    frame: &MpuFrame,
) -> Result<crate::build::Prepared, MpuError> {
    for (index, p) in points.iter().enumerate() {
        let len = p.n.length();
        if !p.p.is_finite() || !len.is_finite() || len <= 0.0 {
            return Err(MpuError::BadPoint { index });
        }
    }
    let points: Vec<OrientedPoint> = points
        .iter()
        .map(|p| OrientedPoint {
            p: p.p,
            n: p.n / p.n.length(),
        })
        .collect();
    let positions = points.iter().map(|p| p.p - frame.origin).collect();
    Ok(crate::build::Prepared { positions, points })
}
