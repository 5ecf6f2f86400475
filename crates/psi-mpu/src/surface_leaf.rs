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
use psi_octree::{Cell, Octree};

use crate::MpuParams;
use crate::fit_cell::CellFit;
use crate::fit_store::FitStore;

/// Whether leaf `leaf` of `octree` (local frame) holds the surface: a point in its cube, or,
/// given its function (`fit`: the store and the leaf's id in it; noisy point clouds), a point
/// whose projection onto it (x − Q(x)∇Q(x)/|∇Q(x)|², local frame) lies in its cube (closed).
/// A point where the step is not finite (a vanishing gradient) stays where it is.
pub(crate) fn holds_surface(octree: &Octree, fit: Option<(&FitStore, u32)>, leaf: u32) -> bool {
    let positions = octree.positions();
    let points = octree
        .points_in(leaf)
        .iter()
        .map(|&i| positions[i as usize]);
    let cell = octree.cell(leaf);
    match fit {
        None => points_hold_surface(cell, None, points),
        Some((fits, id)) => {
            points_hold_surface(cell, Some(&|x| fits.value_and_gradient(id, x)), points)
        }
    }
}

/// [`holds_surface`] of leaf `cell` given the positions of its points (local frame) and, for a
/// noisy point cloud, its function's value and gradient `fit` (local frame): a tile's decisions
/// read the points they hold.
pub(crate) fn points_hold_surface(
    cell: &Cell,
    fit: Option<&dyn Fn(DVec3) -> (f64, DVec3)>,
    mut points: impl Iterator<Item = DVec3>,
) -> bool {
    let Some(fit) = fit else {
        return points.next().is_some();
    };
    points.any(|x| {
        let (q, g) = fit(x);
        (projected(x, q, g) - cell.center).abs().max_element() <= cell.half
    })
}

/// Whether `cell`, fitted with `f` (its error against `eps0`, world units), is a leaf that holds
/// the surface as the whole build finds it ([`points_hold_surface`] of `points`, its points in
/// the local frame; with its function when `params.error_rank` ranks the cells' errors); false
/// for a cell that splits.
pub(crate) fn leaf_holds_surface(
    params: &MpuParams,
    cell: &Cell,
    f: &CellFit,
    eps0: f64,
    points: impl Iterator<Item = DVec3>,
) -> bool {
    if f.splits(cell, eps0, params.max_depth) {
        return false;
    }
    let function = &f.fit.function;
    let value_and_gradient = |x| function.value_and_gradient(x);
    let fit: Option<&dyn Fn(DVec3) -> (f64, DVec3)> =
        params.error_rank.is_some().then_some(&value_and_gradient);
    points_hold_surface(cell, fit, points)
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
