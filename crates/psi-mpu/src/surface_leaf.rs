//! Which leaves hold the surface: particles are seeded in these. The paper (§4, "Creating the
//! Initial Distribution") marks the cells that hold a control point, points that "already lay
//! on the surface". For a noisy point cloud
//! ([`crate::MpuParams::error_rank`]) the points scatter about the surface, and the denser
//! the sampling the more of the cubes the surface only grazes receive a stray point: the count
//! grew with density (measured in the note below). There a leaf holds the
//! surface when one of its points, moved onto the leaf's own fit by one Newton step along the
//! gradient, lies in its cube (docs/notes/2026-11-29-surface-leaves.md). Both rules read only
//! the leaf's points and its fit, which a local regeneration refits and a tile builds exactly.

use glam::DVec3;
use psi_octree::Octree;

use crate::fit_store::FitStore;

/// Whether leaf `leaf` of `octree` (local frame) holds the surface: a point in its cube, or,
/// given its function (`fit`: the store and the leaf's id in it; noisy point clouds), a point
/// whose projection onto it (x − Q(x)∇Q(x)/|∇Q(x)|², local frame) lies in its cube (closed).
/// A point where the step is not finite (a vanishing gradient) stays where it is.
pub(crate) fn holds_surface(octree: &Octree, fit: Option<(&FitStore, u32)>, leaf: u32) -> bool {
    let points = octree.points_in(leaf);
    let Some((fits, id)) = fit else {
        return !points.is_empty();
    };
    let cell = octree.cell(leaf);
    let positions = octree.positions();
    points.iter().any(|&i| {
        let x = positions[i as usize];
        let (q, g) = fits.value_and_gradient(id, x);
        (projected(x, q, g) - cell.center).abs().max_element() <= cell.half
    })
}

/// One Newton step from `x` onto the zero set of a function with value `q` and gradient `g`
/// there; `x` itself when the step is not finite (a vanishing gradient).
fn projected(x: DVec3, q: f64, g: DVec3) -> DVec3 {
    let y = x - (q / g.length_squared()) * g;
    if y.is_finite() { y } else { x }
}

#[cfg(test)]
mod tests {
    use super::*;

    use psi_shapes::assert_near;

    #[test]
    fn a_step_lands_on_a_plane_and_a_flat_gradient_stays() {
        // Q(x) = 2(x.z − 0.3): one step lands on z = 0.3, moving along z only.
        let y = projected(DVec3::new(0.1, 0.2, 0.9), 1.2, DVec3::new(0.0, 0.0, 2.0));
        assert_eq!((y.x, y.y), (0.1, 0.2));
        assert_near!(y.z, 0.3, 1e-15);
        let x = DVec3::new(1.0, 2.0, 3.0);
        assert_eq!(projected(x, 0.5, DVec3::ZERO), x);
        assert_eq!(projected(x, 0.0, DVec3::ZERO), x);
    }
}
