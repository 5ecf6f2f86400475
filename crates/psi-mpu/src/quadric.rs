//! The quadric Q(x) = yᵀAy + b·y + c with y = x − origin, every local fit's building block.

use glam::{DMat3, DVec3};
use serde::{Deserialize, Serialize};

/// A quadric in world units around its own origin (A symmetric). Q > 0 outside.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Quadric {
    /// The point y = 0, in the MPU's local frame.
    pub origin: DVec3,
    /// Symmetric quadratic part.
    pub a: DMat3,
    /// Linear part.
    pub b: DVec3,
    /// Constant.
    pub c: f64,
}

impl Quadric {
    /// The plane through `origin` with unit normal `n`: Q = n·(x − origin).
    pub fn plane(origin: DVec3, n: DVec3) -> Self {
        Self {
            origin,
            a: DMat3::ZERO,
            b: n,
            c: 0.0,
        }
    }

    /// Q(x).
    #[inline]
    pub fn value(&self, x: DVec3) -> f64 {
        let y = x - self.origin;
        y.dot(self.a * y) + self.b.dot(y) + self.c
    }

    /// (Q(x), ∇Q(x)).
    #[inline]
    pub fn value_and_gradient(&self, x: DVec3) -> (f64, DVec3) {
        let y = x - self.origin;
        let ay = self.a * y;
        (y.dot(ay) + self.b.dot(y) + self.c, 2.0 * ay + self.b)
    }

    /// Taubin's first-order distance |Q(x)| / |∇Q(x)|, world units (∞ where ∇Q = 0 and Q ≠ 0).
    #[inline]
    pub fn taubin_distance(&self, x: DVec3) -> f64 {
        let (q, g) = self.value_and_gradient(x);
        taubin(q, g)
    }

    /// Whether every coefficient is finite.
    pub fn is_finite(&self) -> bool {
        self.a.is_finite() && self.b.is_finite() && self.c.is_finite() && self.origin.is_finite()
    }
}

/// |q| / |g| with the conventions 0/0 = 0 and q/0 = ∞ (Taubin's first-order distance from a
/// value and a gradient).
#[inline]
pub(crate) fn taubin(q: f64, g: DVec3) -> f64 {
    let gl = g.length();
    if gl > 0.0 {
        q.abs() / gl
    } else if q == 0.0 {
        0.0
    } else {
        f64::INFINITY
    }
}
