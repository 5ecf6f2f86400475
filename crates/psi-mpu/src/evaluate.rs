//! Evaluation of the blended implicit f = Σ w_i Q_i / Σ w_i and its analytic gradient (quotient
//! rule), with support-ball pruning on the octree, and the brute-force twin over all leaves.
//!
//! Far from the data, where no leaf support reaches, f must stay finite and positive (Ohtake
//! returns −1e5 outside the root box, which would flip signs under particles). psi adds a
//! background term of weight [`BACKGROUND_WEIGHT`] whose value is F(y) = |y| + h_root (always
//! positive): it changes f by at most ~1e-9 relative where leaves cover x and takes over
//! smoothly where they do not.

use glam::DVec3;

use crate::Mpu;
use crate::bspline_weight::{weight_and_gradient, weight_and_gradient_inv_r2};
use crate::eval_nodes::{EvalNode, NO_FIT};

/// f and ∇f at a position, and the leaf containing it ([`Mpu::value_and_gradient_from`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LeafEvaluation {
    /// f, world units (≈ signed distance near the surface; > 0 outside).
    pub f: f64,
    /// ∇f (dimensionless; |∇f| ≈ 1 near the surface).
    pub gradient: DVec3,
    /// The leaf containing the position, `None` outside the root cube.
    pub leaf: Option<u32>,
}

/// Weight of the positive background term (a partition of unity sums to O(1) near data).
pub const BACKGROUND_WEIGHT: f64 = 1e-9;

/// Running sums of the quotient rule.
#[derive(Default)]
struct Sums {
    w: f64,
    wq: f64,
    gw: DVec3,
    g_wq: DVec3,
}

/// Cells from this depth down take their candidate lists from their parents' ([`Mpu::candidates`]);
/// shallower cells, whose lists hold a large share of all leaves, traverse the tree.
const FILTER_FROM_DEPTH: u8 = 3;

/// Whether a node's support ball meets the cube of centre `center` and half-edge `half` (local
/// frame): the squared distance from the ball's centre to the cube against R², with a relative
/// margin for rounding (a superset is harmless, a miss is not). A cube inside that one gives a
/// larger distance, so a ball that meets it meets this one too.
fn ball_meets_cube(center: DVec3, half: f64) -> impl Fn(&EvalNode) -> bool {
    move |n: &EvalNode| {
        let gap = ((n.center - center).abs() - DVec3::splat(half)).max(DVec3::ZERO);
        gap.length_squared() <= n.r2 * (1.0 + 1e-9)
    }
}

impl Mpu {
    /// The leaves whose support ball meets the cube of cell `cell` (exactly the leaves that can
    /// cover some point of that cube, up to rounding on the ball's surface), in arena order;
    /// computed on first use and cached. Below depth [`FILTER_FROM_DEPTH`] a cell's list is its
    /// parent's, filtered: a ball that meets the cell's cube meets the parent's, which holds it,
    /// so siblings (a surface leaf's often hold particles too) and their descendants share one
    /// traversal instead of one from the root each. The result is the
    /// traversal's own up to rounding on a cube's face, which can only add or drop a ball
    /// farther than R from every point of the cube (never visited: `d2 <= r2`;
    /// `candidates_are_the_traversals`).
    fn candidates(&self, cell: u32) -> &[u32] {
        self.leaf_candidates[cell as usize].get_or_init(|| {
            let c = self.octree.cell(cell);
            if c.depth >= FILTER_FROM_DEPTH && c.parent != psi_octree::NO_CELL {
                let meets = ball_meets_cube(c.center, c.half);
                let out: Vec<u32> = self
                    .candidates(c.parent)
                    .iter()
                    .copied()
                    .filter(|&i| meets(&self.nodes[i as usize]))
                    .collect();
                return out.into_boxed_slice();
            }
            self.candidates_by_traversal(cell).into_boxed_slice()
        })
    }

    /// The leaves whose support ball meets the cube of cell `cell`, by a traversal from the root
    /// pruned at balls that miss it (a child's ball lies inside its parent's), in arena order.
    fn candidates_by_traversal(&self, cell: u32) -> Vec<u32> {
        let cell = self.octree.cell(cell);
        let nodes = &self.nodes;
        let meets = ball_meets_cube(cell.center, cell.half);
        let mut out = Vec::new();
        let mut stack = vec![0u32];
        while let Some(i) = stack.pop() {
            let n = &nodes[i as usize];
            if !meets(n) {
                continue;
            }
            if n.fit != NO_FIT {
                out.push(i);
            }
            if n.first_child != psi_octree::NO_CELL {
                stack.extend(n.first_child..n.first_child + 8);
            }
        }
        out.sort_unstable();
        out
    }

    /// Calls `visit(node, d2)` for every leaf whose support ball contains local `y`, in arena
    /// order: from the candidate list of `leaf` (the leaf containing `y`), or by traversal
    /// outside the root cube (`leaf` = `None`).
    #[inline]
    fn for_each_support_leaf(
        &self,
        y: DVec3,
        leaf: Option<u32>,
        mut visit: impl FnMut(&EvalNode, f64),
    ) {
        match leaf {
            Some(leaf) => {
                // Two passes per block of candidates: the support test written branch-free
                // (about a third of the candidates pass, too irregularly for the branch
                // predictor), then the visits in candidate order.
                const BLOCK: usize = 32;
                let mut hits = [(0u32, 0.0f64); BLOCK];
                for block in self.candidates(leaf).chunks(BLOCK) {
                    let mut count = 0;
                    for &i in block {
                        let node = &self.nodes[i as usize];
                        let d2 = (y - node.center).length_squared();
                        hits[count] = (i, d2);
                        count += usize::from(d2 <= node.r2);
                    }
                    for &(i, d2) in &hits[..count] {
                        visit(&self.nodes[i as usize], d2);
                    }
                }
            }
            None => self.for_each_support_node(y, |node, d2| {
                if node.fit != NO_FIT {
                    visit(node, d2)
                }
            }),
        }
    }

    /// Calls `visit(node, d2)` for every cell whose support ball contains local `y` (pruned at
    /// the parent, exact for α ≥ 0.5; the same set as `Octree::for_each_support_cell`).
    #[inline]
    fn for_each_support_node(&self, y: DVec3, mut visit: impl FnMut(&EvalNode, f64)) {
        let nodes = &self.nodes;
        let root = &nodes[0];
        let d2 = (y - root.center).length_squared();
        if d2.partial_cmp(&root.r2).is_none_or(|o| o.is_gt()) {
            return;
        }
        visit(root, d2);
        let mut stack = [0u32; 8 * (psi_octree::DEPTH_LIMIT as usize + 1)];
        let mut top = 0usize;
        if root.first_child != psi_octree::NO_CELL {
            stack[0] = root.first_child;
            top = 1;
        }
        while top > 0 {
            top -= 1;
            let first = stack[top] as usize;
            for node in &nodes[first..first + 8] {
                let d2 = (y - node.center).length_squared();
                if d2 <= node.r2 {
                    visit(node, d2);
                    if node.first_child != psi_octree::NO_CELL {
                        stack[top] = node.first_child;
                        top += 1;
                    }
                }
            }
        }
    }

    #[inline]
    fn accumulate_node(&self, y: DVec3, node: &EvalNode, d2: f64, s: &mut Sums) {
        if node.fit == NO_FIT {
            return;
        }
        let (w, gw) = weight_and_gradient_inv_r2(y, node.center, node.inv_r2, d2);
        if w <= 0.0 {
            return;
        }
        let (q, gq) = self.fits.value_and_gradient(node.fit, y);
        s.w += w;
        s.wq += w * q;
        s.gw += gw;
        s.g_wq += gw * q + w * gq;
    }

    #[inline]
    fn accumulate(&self, y: DVec3, cell: u32, d2: f64, s: &mut Sums) {
        let f = self.cell_fit[cell as usize];
        if f == NO_FIT {
            return;
        }
        let c = self.octree.cell(cell);
        let r = c.support_radius(self.params.alpha);
        let (w, gw) = weight_and_gradient(y, c.center, r, d2);
        if w <= 0.0 {
            return;
        }
        let (q, gq) = self.fits.value_and_gradient(f, y);
        s.w += w;
        s.wq += w * q;
        s.gw += gw;
        s.g_wq += gw * q + w * gq;
    }

    #[inline]
    fn finish(&self, y: DVec3, mut s: Sums) -> (f64, DVec3) {
        let len = y.length();
        let background = len + self.octree.root().half;
        let grad_bg = if len > 0.0 { y / len } else { DVec3::ZERO };
        s.w += BACKGROUND_WEIGHT;
        s.wq += BACKGROUND_WEIGHT * background;
        s.g_wq += BACKGROUND_WEIGHT * grad_bg;
        let f = s.wq / s.w;
        let g = (s.g_wq * s.w - s.gw * s.wq) / (s.w * s.w);
        (f, g)
    }

    /// f(x) and ∇f(x) at world position `x` (world units; ∇f is dimensionless, |∇f| ≈ 1 near the
    /// surface). Visits only the cells whose support ball contains x.
    #[inline]
    pub fn value_and_gradient(&self, x: DVec3) -> (f64, DVec3) {
        let e = self.value_and_gradient_from(x, None);
        (e.f, e.gradient)
    }

    /// [`Mpu::value_and_gradient`] at world `x` with a guess of the leaf containing it (a
    /// particle's leaf before its last move, see [`Mpu::leaf_containing_from`]); also returns
    /// the leaf containing `x`. f and ∇f are bitwise equal to `value_and_gradient`'s: the guess
    /// only saves the descent from the root.
    #[inline]
    pub fn value_and_gradient_from(&self, x: DVec3, hint: Option<u32>) -> LeafEvaluation {
        let y = x - self.frame.origin;
        let mut s = Sums::default();
        let leaf = self.leaf_containing_from(x, hint);
        self.for_each_support_leaf(y, leaf, |node, d2| {
            self.accumulate_node(y, node, d2, &mut s)
        });
        let (f, gradient) = self.finish(y, s);
        LeafEvaluation { f, gradient, leaf }
    }

    /// f(x), world units (≈ signed distance near the surface; > 0 outside).
    #[inline]
    pub fn value(&self, x: DVec3) -> f64 {
        let y = x - self.frame.origin;
        let (mut w_sum, mut wq) = (0.0, 0.0);
        self.for_each_support_leaf(y, self.octree.leaf_containing(y), |node, d2| {
            let (w, _) = weight_and_gradient_inv_r2(y, node.center, node.inv_r2, d2);
            if w > 0.0 {
                w_sum += w;
                wq += w * self.fits.value(node.fit, y);
            }
        });
        let background = y.length() + self.octree.root().half;
        (wq + BACKGROUND_WEIGHT * background) / (w_sum + BACKGROUND_WEIGHT)
    }

    /// ∇f(x) at world position `x`.
    pub fn gradient(&self, x: DVec3) -> DVec3 {
        self.value_and_gradient(x).1
    }

    /// The brute-force twin of [`Mpu::value_and_gradient`]: sums over every leaf, no pruning.
    /// For tests and benchmarks only.
    pub fn value_and_gradient_brute_force(&self, x: DVec3) -> (f64, DVec3) {
        let y = x - self.frame.origin;
        let mut s = Sums::default();
        for (i, c) in self.octree.cells().iter().enumerate() {
            if c.is_leaf() {
                self.accumulate(y, i as u32, (y - c.center).length_squared(), &mut s);
            }
        }
        self.finish(y, s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::MpuParams;
    use psi_shapes::AnalyticShape;

    /// Every leaf's candidate list, filtered from its ancestors', equals the traversal's for
    /// that leaf (the brute-force twin): the same leaves in the same order. Leaves are asked in
    /// reverse arena order so that some parents are filled by a later sibling.
    #[test]
    fn candidates_are_the_traversals() {
        let points = AnalyticShape::Torus {
            major: 1.0,
            minor: 0.3,
        }
        .sample(3000, 11);
        let mpu = Mpu::build(&points, &MpuParams::paper()).expect("torus builds");
        let leaves: Vec<u32> = mpu.leaves().collect();
        assert!(leaves.len() > 100, "{} leaves", leaves.len());
        let deepest = leaves.iter().map(|&l| mpu.octree().cell(l).depth).max();
        assert!(deepest > Some(FILTER_FROM_DEPTH), "depth {deepest:?}");
        for &leaf in leaves.iter().rev() {
            let direct = mpu.candidates_by_traversal(leaf);
            assert!(!direct.is_empty(), "leaf {leaf} has no candidate");
            assert_eq!(mpu.candidates(leaf), &direct[..], "leaf {leaf}");
        }
    }
}
