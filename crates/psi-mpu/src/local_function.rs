//! The local approximation of one MPU leaf: a smooth quadric or a sharp piecewise combination.

use glam::DVec3;
use serde::{Deserialize, Serialize};

use crate::Quadric;

/// Which kind of local fit a leaf holds (for the build report).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum FitKind {
    /// General 3D quadric with auxiliary points.
    GeneralQuadric,
    /// Bivariate quadratic height field over the tangent plane.
    Bivariate,
    /// Two bivariate pieces combined by max (convex) or min (concave).
    Edge,
    /// Three pieces combined by max/min according to pairwise convexity.
    Corner,
    /// A plane through the weighted centroid (the last fallback).
    Plane,
}

/// A leaf's local function Q. Its coordinates are the MPU's local frame: world position minus
/// [`crate::Mpu::frame_origin`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum LocalFunction {
    /// One quadric (general, bivariate or plane).
    Smooth(Quadric),
    /// Edge: max(Q0, Q1) when convex, min when concave.
    Edge {
        /// The two pieces.
        pieces: std::sync::Arc<[Quadric; 2]>,
        /// Convex edge (max) or concave (min).
        convex: bool,
    },
    /// Corner: `op_outer(op_pair(Q[order[0]], Q[order[1]]), Q[order[2]])`.
    Corner {
        /// The three pieces.
        pieces: std::sync::Arc<[Quadric; 3]>,
        /// Evaluation order: the first two are combined first.
        order: [u8; 3],
        /// Whether the first pair is combined by max (else min).
        pair_max: bool,
        /// Whether the result is combined with the third piece by max (else min).
        outer_max: bool,
    },
}

#[inline]
fn pick(max: bool, a: (f64, DVec3), b: (f64, DVec3)) -> (f64, DVec3) {
    if (a.0 >= b.0) == max { a } else { b }
}

impl LocalFunction {
    /// (Q(x), ∇Q(x)); for max/min combinations the gradient of the selected piece.
    #[inline]
    pub fn value_and_gradient(&self, x: DVec3) -> (f64, DVec3) {
        match self {
            LocalFunction::Smooth(q) => q.value_and_gradient(x),
            LocalFunction::Edge { pieces, convex } => pick(
                *convex,
                pieces[0].value_and_gradient(x),
                pieces[1].value_and_gradient(x),
            ),
            LocalFunction::Corner {
                pieces,
                order,
                pair_max,
                outer_max,
            } => {
                let q = |k: u8| pieces[k as usize].value_and_gradient(x);
                let pair = pick(*pair_max, q(order[0]), q(order[1]));
                pick(*outer_max, pair, q(order[2]))
            }
        }
    }

    /// Q(x).
    #[inline]
    pub fn value(&self, x: DVec3) -> f64 {
        match self {
            LocalFunction::Smooth(q) => q.value(x),
            _ => self.value_and_gradient(x).0,
        }
    }

    /// Taubin distance |Q| / |∇Q| at `x`, world units.
    pub fn taubin_distance(&self, x: DVec3) -> f64 {
        let (q, g) = self.value_and_gradient(x);
        crate::quadric::taubin(q, g)
    }

    /// Whether all coefficients are finite.
    pub fn is_finite(&self) -> bool {
        match self {
            LocalFunction::Smooth(q) => q.is_finite(),
            LocalFunction::Edge { pieces, .. } => pieces.iter().all(Quadric::is_finite),
            LocalFunction::Corner { pieces, .. } => pieces.iter().all(Quadric::is_finite),
        }
    }
}
