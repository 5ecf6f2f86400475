//! Inputs shared by the integration tests.

use glam::DVec3;
use psi_octree::OrientedPoint;
use rand::RngExt;
use rand_pcg::Pcg64Mcg;

/// An open square patch in the z = 0 plane: a `side` × `side` grid of step `h` (world units),
/// each point moved by up to 0.15 h along x and y (two draws of `rng` a point), normals +z,
/// row by row.
/// Shape: `side`² points.
pub(crate) fn jittered_patch(side: usize, h: f64, rng: &mut Pcg64Mcg) -> Vec<OrientedPoint> {
    (0..side * side)
        .map(|k| {
            let (i, j) = ((k % side) as f64, (k / side) as f64);
            let jitter = DVec3::new(rng.random::<f64>() - 0.5, rng.random::<f64>() - 0.5, 0.0);
            OrientedPoint {
                p: DVec3::new(i * h, j * h, 0.0) + 0.3 * h * jitter,
                n: DVec3::Z,
            }
        })
        .collect()
}
