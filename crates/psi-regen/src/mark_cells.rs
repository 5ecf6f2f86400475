//! Marking: the cells an edit can change are those whose fit radius (R1 ≥ the support radius)
//! holds a changed position; every other cell's fit and split decision is provably unchanged.

use glam::DVec3;
use psi_mpu::Mpu;
use psi_octree::PointIndex;
use rayon::prelude::*;

/// Per cell of `mpu`: whether a changed position (world units) lies within its fit radius.
pub fn mark_cells(mpu: &Mpu, changed: &[DVec3]) -> Vec<bool> {
    if changed.is_empty() {
        return vec![false; mpu.octree().cells().len()];
    }
    let origin = mpu.frame_origin();
    let local: Vec<DVec3> = changed.iter().map(|p| *p - origin).collect();
    let index = PointIndex::new(&local);
    // Cells farther from the changed points' bounding box than their fit radius cannot be
    // marked: a box-distance test rejects most cells without a kd query.
    let bounds = psi_octree::Aabb::from_points(local.iter().copied()).expect("non-empty");
    mpu.octree()
        .cells()
        .par_iter()
        .enumerate()
        .map(|(i, c)| {
            let r = mpu.fit_radius(i as u32) * (1.0 + 1e-9);
            let outside = (bounds.min - c.center)
                .max(c.center - bounds.max)
                .max(DVec3::ZERO);
            outside.length_squared() <= r * r
                && index
                    .nearest_one(c.center)
                    .is_some_and(|(_, d2)| d2 <= r * r)
        })
        .collect()
}

/// Brute-force twin of [`mark_cells`] (tests).
pub fn mark_cells_brute_force(mpu: &Mpu, changed: &[DVec3]) -> Vec<bool> {
    let origin = mpu.frame_origin();
    mpu.octree()
        .cells()
        .iter()
        .enumerate()
        .map(|(i, c)| {
            let r = mpu.fit_radius(i as u32) * (1.0 + 1e-9);
            changed
                .iter()
                .any(|p| (*p - origin - c.center).length_squared() <= r * r)
        })
        .collect()
}
