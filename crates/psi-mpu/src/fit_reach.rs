//! The cells an edit reaches: those whose reach (a factor times the fit radius R1, plus a
//! multiple of the half-edge) holds a changed position, found by descending the octree from
//! the root instead of testing every cell. A subtree is left when the changed positions'
//! bounding box lies farther from its cube than the largest reach at its depth or below (from
//! `Mpu::reach_by_depth` and the depth's half-edge), which no cell inside can then reach; the
//! cells left are tested against the nearest changed position in parallel. The cost follows
//! the cells near the edit, not the model.

use glam::DVec3;
use psi_octree::{Aabb, PointIndex};
use rayon::prelude::*;

use crate::Mpu;

/// The relative margin on every radius: a position on the sphere counts as inside whatever the
/// rounding of the distance.
const MARGIN: f64 = 1e-9;

/// How far a cell reaches from its centre (world units): `factor`·R1 + `halves`·half-edge,
/// both ≥ 0.
#[derive(Clone, Copy, Debug)]
pub(crate) struct CellReach {
    pub(crate) factor: f64,
    pub(crate) halves: f64,
}

/// Squared distance between an axis-aligned box and a cube (centre `c`, half-edge `h`).
fn box_cube_distance2(b: &Aabb, c: DVec3, h: f64) -> f64 {
    let lo = c - DVec3::splat(h);
    let hi = c + DVec3::splat(h);
    let gap = (b.min - hi).max(lo - b.max).max(DVec3::ZERO);
    gap.length_squared()
}

impl Mpu {
    /// The cells (only leaves when `leaves_only`) whose centre lies within `factor`·R1 of a
    /// position of `changed` (shape: K, world units; R1 the cell's [`Mpu::fit_radius`], with
    /// a relative margin of 1e-9), each with the distance from its centre to the nearest
    /// changed position (world units), in increasing cell order. `factor` ≥ 0.
    pub fn cells_reaching(
        &self,
        changed: &[DVec3],
        factor: f64,
        leaves_only: bool,
    ) -> Vec<(u32, f64)> {
        let origin = self.frame.origin;
        let local: Vec<DVec3> = changed.iter().map(|p| *p - origin).collect();
        let reach = CellReach {
            factor,
            halves: 0.0,
        };
        let Some(bounds) = Aabb::from_points(local.iter().copied()) else {
            return Vec::new();
        };
        // (The changed positions' kd-tree is built while the octree is descended.)
        let (near, index) = rayon::join(
            || self.cells_near(&bounds, reach, leaves_only),
            || PointIndex::new(&local),
        );
        self.cells_within_reach(near, &bounds, &index, reach)
    }

    /// [`Mpu::cells_reaching`] of the changed positions `local` (shape: K, local frame),
    /// `index` their kd-tree, each cell's reach `reach`.
    pub(crate) fn cells_reaching_local(
        &self,
        local: &[DVec3],
        index: &PointIndex,
        reach: CellReach,
        leaves_only: bool,
    ) -> Vec<(u32, f64)> {
        let Some(bounds) = Aabb::from_points(local.iter().copied()) else {
            return Vec::new();
        };
        let near = self.cells_near(&bounds, reach, leaves_only);
        self.cells_within_reach(near, &bounds, index, reach)
    }

    /// The cells (only leaves when `leaves_only`) that may reach a position in `bounds` (local
    /// frame), in increasing order: a depth-first descent that leaves the subtrees out of
    /// reach (a cell's descendants are no larger than it).
    fn cells_near(&self, bounds: &Aabb, reach: CellReach, leaves_only: bool) -> Vec<u32> {
        let CellReach { factor, halves } = reach;
        let tree = &self.octree;
        let scale = factor * (1.0 + MARGIN);
        let mut near: Vec<u32> = Vec::new();
        let mut stack = vec![0u32];
        while let Some(c) = stack.pop() {
            let cell = tree.cell(c);
            let reach = scale * self.reach_by_depth[usize::from(cell.depth)]
                + (1.0 + MARGIN) * halves * cell.half;
            if box_cube_distance2(bounds, cell.center, cell.half) > reach * reach {
                continue;
            }
            if !leaves_only || cell.is_leaf() {
                near.push(c);
            }
            if let Some(children) = tree.children(c) {
                stack.extend(children);
            }
        }
        near.sort_unstable();
        near
    }

    /// The cells of `near` whose reach holds a position of `index` (the changed positions,
    /// local frame, within `bounds`), with the distance from the centre to the nearest one, in
    /// the order of `near`.
    fn cells_within_reach(
        &self,
        near: Vec<u32>,
        bounds: &Aabb,
        index: &PointIndex,
        reach: CellReach,
    ) -> Vec<(u32, f64)> {
        let CellReach { factor, halves } = reach;
        let tree = &self.octree;
        let scale = factor * (1.0 + MARGIN);
        near.par_iter()
            .filter_map(|&c| {
                let cell = tree.cell(c);
                let r = scale * self.fit_radius[c as usize] + (1.0 + MARGIN) * halves * cell.half;
                let outside = (bounds.min - cell.center)
                    .max(cell.center - bounds.max)
                    .max(DVec3::ZERO);
                if outside.length_squared() > r * r {
                    return None;
                }
                let (_, d2) = index.nearest_one(cell.center)?;
                (d2 <= r * r).then(|| (c, d2.sqrt()))
            })
            .collect()
    }
}

/// The largest fit radius of the cells at each depth or below (shape: one per depth of the
/// octree, world units): `per_depth` holds each depth's own largest.
pub(crate) fn reach_by_depth(mut per_depth: Vec<f64>) -> Vec<f64> {
    for d in (0..per_depth.len().saturating_sub(1)).rev() {
        per_depth[d] = per_depth[d].max(per_depth[d + 1]);
    }
    per_depth
}

#[cfg(test)]
mod tests {
    use glam::DVec3;
    use psi_shapes::AnalyticShape;

    use super::CellReach;
    use crate::{Mpu, MpuParams};

    /// Brute force over every cell: the same cells and distances as the descent, for brushes
    /// of several sizes and places, factors 1 and 3 and the footprint carry's reach, all cells
    /// and leaves only.
    #[test]
    fn the_descent_finds_the_cells_every_cell_tested_finds() {
        let points = AnalyticShape::Torus {
            major: 1.0,
            minor: 0.4,
        }
        .sample(6000, 5);
        let mpu = Mpu::build(&points, &MpuParams::paper()).unwrap();
        let origin = mpu.frame_origin();
        let mut found_any = 0;
        for (k, (centre, radius)) in [
            (DVec3::new(1.4, 0.0, 0.0), 0.05),
            (DVec3::new(0.0, -0.6, 0.3), 0.2),
            (DVec3::new(-1.0, 0.9, -0.1), 0.01),
            (DVec3::new(0.0, 0.0, 3.0), 0.1),
        ]
        .into_iter()
        .enumerate()
        {
            let changed: Vec<DVec3> = points
                .iter()
                .map(|p| p.p)
                .filter(|p| (*p - centre).length() < radius)
                .chain([centre + DVec3::new(0.0, 0.0, radius)])
                .collect();
            let local: Vec<DVec3> = changed.iter().map(|p| *p - origin).collect();
            let index = psi_octree::PointIndex::new(&local);
            for (factor, halves) in [(1.0, 0.0), (3.0, 0.0), (1.0, 2.0 * 3f64.sqrt())] {
                for leaves_only in [false, true] {
                    let got = if halves == 0.0 {
                        mpu.cells_reaching(&changed, factor, leaves_only)
                    } else {
                        let reach = CellReach { factor, halves };
                        mpu.cells_reaching_local(&local, &index, reach, leaves_only)
                    };
                    let want: Vec<(u32, f64)> = mpu
                        .octree()
                        .cells()
                        .iter()
                        .enumerate()
                        .filter(|(_, c)| !leaves_only || c.is_leaf())
                        .filter_map(|(i, c)| {
                            let r = (factor * mpu.fit_radius(i as u32) + halves * c.half)
                                * (1.0 + 1e-9);
                            let d = changed
                                .iter()
                                .map(|p| (*p - origin - c.center).length_squared())
                                .fold(f64::INFINITY, f64::min);
                            (d <= r * r).then(|| (i as u32, d.sqrt()))
                        })
                        .collect();
                    let ids = |v: &[(u32, f64)]| v.iter().map(|x| x.0).collect::<Vec<_>>();
                    assert_eq!(ids(&got), ids(&want), "brush {k}, factor {factor}");
                    for (g, w) in got.iter().zip(&want) {
                        psi_shapes::assert_near!(g.1, w.1, 1e-12);
                    }
                    found_any += got.len();
                }
            }
        }
        assert!(found_any > 100, "{found_any}");
    }
}
