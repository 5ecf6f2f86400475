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
        pieces: [Quadric; 2],
        /// Convex edge (max) or concave (min).
        convex: bool,
    },
    /// Corner: `op_outer(op_pair(Q[order[0]], Q[order[1]]), Q[order[2]])`.
    Corner {
        /// The three pieces.
        pieces: [Quadric; 3],
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

/// An edge: max (convex) or min of its two pieces, with the selected piece's gradient.
#[inline]
fn edge(pieces: &[Quadric], convex: bool, x: DVec3) -> (f64, DVec3) {
    pick(
        convex,
        pieces[0].value_and_gradient(x),
        pieces[1].value_and_gradient(x),
    )
}

/// A corner: the pair `order[0..2]` combined first (max or min), then with `order[2]`.
#[inline]
fn corner(
    pieces: &[Quadric],
    order: [u8; 3],
    (pair_max, outer_max): (bool, bool),
    x: DVec3,
) -> (f64, DVec3) {
    let q = |k: u8| pieces[k as usize].value_and_gradient(x);
    let pair = pick(pair_max, q(order[0]), q(order[1]));
    pick(outer_max, pair, q(order[2]))
}

impl LocalFunction {
    /// (Q(x), ∇Q(x)); for max/min combinations the gradient of the selected piece.
    #[inline]
    pub fn value_and_gradient(&self, x: DVec3) -> (f64, DVec3) {
        match self {
            LocalFunction::Smooth(q) => q.value_and_gradient(x),
            LocalFunction::Edge { pieces, convex } => edge(pieces, *convex, x),
            LocalFunction::Corner {
                pieces,
                order,
                pair_max,
                outer_max,
            } => corner(pieces, *order, (*pair_max, *outer_max), x),
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

/// A leaf's local function as an MPU stores it: a sharp function's pieces live in one table of
/// quadrics beside the fits (`pieces`), named by the index of the first. Copying a leaf into a
/// rebuilt MPU then copies plain values (a shared pointer per sharp leaf would cost a cache miss
/// each to count).
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum StoredFunction {
    Smooth(Quadric),
    Edge {
        first: u32,
        convex: bool,
    },
    Corner {
        first: u32,
        order: [u8; 3],
        pair_max: bool,
        outer_max: bool,
    },
}

impl StoredFunction {
    /// Stores `f`, appending its pieces to `pieces`.
    pub(crate) fn store(f: LocalFunction, pieces: &mut Vec<Quadric>) -> Self {
        let first = pieces.len() as u32;
        match f {
            LocalFunction::Smooth(q) => StoredFunction::Smooth(q),
            LocalFunction::Edge { pieces: p, convex } => {
                pieces.extend(p);
                StoredFunction::Edge { first, convex }
            }
            LocalFunction::Corner {
                pieces: p,
                order,
                pair_max,
                outer_max,
            } => {
                pieces.extend(p);
                StoredFunction::Corner {
                    first,
                    order,
                    pair_max,
                    outer_max,
                }
            }
        }
    }

    /// This function (its pieces in `from`) stored again with its pieces appended to `to`.
    pub(crate) fn copy(&self, from: &[Quadric], to: &mut Vec<Quadric>) -> Self {
        let first = to.len() as u32;
        match *self {
            StoredFunction::Smooth(q) => StoredFunction::Smooth(q),
            StoredFunction::Edge { first: f, convex } => {
                to.extend_from_slice(&from[f as usize..f as usize + 2]);
                StoredFunction::Edge { first, convex }
            }
            StoredFunction::Corner {
                first: f,
                order,
                pair_max,
                outer_max,
            } => {
                to.extend_from_slice(&from[f as usize..f as usize + 3]);
                StoredFunction::Corner {
                    first,
                    order,
                    pair_max,
                    outer_max,
                }
            }
        }
    }

    /// The function as a value (its pieces read from `pieces`).
    pub(crate) fn load(&self, pieces: &[Quadric]) -> LocalFunction {
        let at = |f: u32, k: usize| pieces[f as usize + k];
        match *self {
            StoredFunction::Smooth(q) => LocalFunction::Smooth(q),
            StoredFunction::Edge { first, convex } => LocalFunction::Edge {
                pieces: [at(first, 0), at(first, 1)],
                convex,
            },
            StoredFunction::Corner {
                first,
                order,
                pair_max,
                outer_max,
            } => LocalFunction::Corner {
                pieces: [at(first, 0), at(first, 1), at(first, 2)],
                order,
                pair_max,
                outer_max,
            },
        }
    }

    /// (Q(x), ∇Q(x)) as [`LocalFunction::value_and_gradient`], pieces read from `pieces`.
    #[inline]
    pub(crate) fn value_and_gradient(&self, pieces: &[Quadric], x: DVec3) -> (f64, DVec3) {
        match *self {
            StoredFunction::Smooth(ref q) => q.value_and_gradient(x),
            StoredFunction::Edge { first, convex } => {
                edge(&pieces[first as usize..first as usize + 2], convex, x)
            }
            StoredFunction::Corner {
                first,
                order,
                pair_max,
                outer_max,
            } => corner(
                &pieces[first as usize..first as usize + 3],
                order,
                (pair_max, outer_max),
                x,
            ),
        }
    }

    /// Q(x) as [`LocalFunction::value`].
    #[inline]
    pub(crate) fn value(&self, pieces: &[Quadric], x: DVec3) -> f64 {
        match self {
            StoredFunction::Smooth(q) => q.value(x),
            _ => self.value_and_gradient(pieces, x).0,
        }
    }
}
