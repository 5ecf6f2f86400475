//! The evaluation's compact copy of the octree: per cell its centre, support radius and the id
//! of its leaf function, in arena order, so that a sibling group is six cache lines.

use glam::DVec3;

/// Marks an inner cell in the cell-to-function table and in [`EvalNode::fit`].
pub(crate) const NO_FIT: u32 = u32::MAX;

/// A cell as the evaluation traverses it: 48 bytes, siblings contiguous (the octree's `Cell`
/// carries more).
#[derive(Clone, Copy, Debug)]
pub(crate) struct EvalNode {
    /// Cube centre, local frame.
    pub(crate) center: DVec3,
    /// Squared support radius R².
    pub(crate) r2: f64,
    /// 1 / R², for the weight (a division saved per evaluated leaf).
    pub(crate) inv_r2: f64,
    pub(crate) first_child: u32,
    /// The leaf's function id in the store, [`NO_FIT`] for an inner cell.
    pub(crate) fit: u32,
}

/// The evaluation nodes of `octree` with support radii α × the cell diagonal and the leaf-fit
/// table `cell_fit` (shape: one per cell, arena order), written into `nodes` (emptied first).
pub(crate) fn eval_nodes_into(
    octree: &psi_octree::Octree,
    cell_fit: &[u32],
    alpha: f64,
    nodes: &mut Vec<EvalNode>,
) {
    nodes.clear();
    nodes.extend(octree.cells().iter().zip(cell_fit).map(|(c, &fit)| {
        let r = c.support_radius(alpha);
        EvalNode {
            center: c.center,
            r2: r * r,
            inv_r2: 1.0 / (r * r),
            first_child: c.first_child,
            fit,
        }
    }));
}
