//! Marking: the cells an edit can change are those whose fit radius (R1 ≥ the support radius)
//! holds a changed position; every other cell's fit and split decision is provably unchanged.

use glam::DVec3;
use psi_mpu::Mpu;

/// Per cell of `mpu`: whether a changed position (world units) lies within its fit radius.
pub fn mark_cells(mpu: &Mpu, changed: &[DVec3]) -> Vec<bool> {
    let mut marked = vec![false; mpu.octree().cells().len()];
    // (Only the cells near the changed positions are visited: `Mpu::cells_reaching`.)
    for (c, _) in mpu.cells_reaching(changed, 1.0, false) {
        marked[c as usize] = true;
    }
    marked
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
