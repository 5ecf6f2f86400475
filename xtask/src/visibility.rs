//! What a range sensor sees of a surface: the single-view ray cast shared by the scan
//! generators (`scans.rs`'s one view, `multiview.rs`'s merged views).

use parry3d_f64::query::{Ray, RayCast};
use parry3d_f64::shape::TriMesh;
use psi::{DVec3, OrientedPoint};
use rayon::prelude::*;

/// Whether a sensor at `sensor` (world units) sees the surface point `p` of `mesh`: `p`'s normal
/// faces the sensor and the ray from the sensor meets `mesh` first at `p` (within a relative
/// 1e-6 of the distance, so the point's own triangle does not hide it).
pub(crate) fn sees(mesh: &TriMesh, sensor: DVec3, p: &OrientedPoint) -> bool {
    let to = p.p - sensor;
    let d = to.length();
    if p.n.dot(-to) <= 0.0 || d == 0.0 {
        return false;
    }
    let ray = Ray::new(sensor, to / d);
    mesh.cast_local_ray(&ray, d, false)
        .is_none_or(|t| t >= d * (1.0 - 1e-6) - 1e-9)
}

/// The points (shape: N, on `mesh`'s surface, unit normals) a sensor at `sensor` sees ([`sees`]),
/// in their order (shape: M ≤ N).
pub(crate) fn visible(
    points: &[OrientedPoint],
    mesh: &TriMesh,
    sensor: DVec3,
) -> Vec<OrientedPoint> {
    points
        .par_iter()
        .filter(|p| sees(mesh, sensor, p))
        .copied()
        .collect()
}
