//! The quadratic B-spline weight of the partition of unity and its gradient.
//!
//! b(t) = 0.75 − t² (t < 0.5), 0.5(1.5 − t)² (0.5 ≤ t < 1.5), 0 beyond; the cell weight is
//! w(x) = b(1.5·|x − c|/R), zero at |x − c| = R (Ohtake's `weight()`; algorithms.md §1.3).

use glam::DVec3;

/// b(t) for t ≥ 0.
#[inline]
pub(crate) fn bspline(t: f64) -> f64 {
    if t < 0.5 {
        0.75 - t * t
    } else if t < 1.5 {
        let s = 1.5 - t;
        0.5 * s * s
    } else {
        0.0
    }
}

/// Weight of a cell with centre `c` and support radius `r` at `x`, from the squared distance
/// `d2 = |x − c|²` (world units²). Returns (w, ∇w).
#[inline]
pub(crate) fn weight_and_gradient(x: DVec3, c: DVec3, r: f64, d2: f64) -> (f64, DVec3) {
    weight_and_gradient_r2(x, c, r * r, d2)
}

/// As [`weight_and_gradient`], from the squared support radius `r2` (no square root on the
/// common inner branch).
#[inline]
pub(crate) fn weight_and_gradient_r2(x: DVec3, c: DVec3, r2: f64, d2: f64) -> (f64, DVec3) {
    weight_and_gradient_inv_r2(x, c, 1.0 / r2, d2)
}

/// As [`weight_and_gradient_r2`], from `inv_r2` = 1 / R² computed once (no division on the
/// inner branch; the same rounding as computing it here).
#[inline]
pub(crate) fn weight_and_gradient_inv_r2(x: DVec3, c: DVec3, inv_r2: f64, d2: f64) -> (f64, DVec3) {
    let t2 = 2.25 * d2 * inv_r2;
    if t2 < 0.25 {
        (0.75 - t2, (-4.5 * inv_r2) * (x - c))
    } else if t2 < 2.25 {
        let t = t2.sqrt();
        let s = 1.5 - t;
        (0.5 * s * s, (-2.25 * s / t * inv_r2) * (x - c))
    } else {
        (0.0, DVec3::ZERO)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use psi_shapes::assert_near;

    #[test]
    fn spline_is_continuous_and_zero_at_the_support() {
        assert_near!(bspline(0.5 - 1e-12), bspline(0.5 + 1e-12), 1e-10);
        assert_near!(bspline(1.5), 0.0, 0.0);
        assert_near!(bspline(0.0), 0.75, 0.0);
    }

    #[test]
    fn gradient_matches_finite_differences() {
        let c = DVec3::new(0.1, -0.2, 0.3);
        let r = 0.7;
        for x in [
            DVec3::new(0.2, -0.1, 0.35),
            DVec3::new(0.5, 0.1, 0.5),
            DVec3::new(0.1, 0.3, 0.0),
        ] {
            let (w, g) = weight_and_gradient(x, c, r, (x - c).length_squared());
            assert_near!(w, bspline(1.5 * (x - c).length() / r), 1e-15);
            let h = 1e-6;
            for k in 0..3 {
                let mut e = DVec3::ZERO;
                e[k] = h;
                let f = |y: DVec3| weight_and_gradient(y, c, r, (y - c).length_squared()).0;
                assert_near!((f(x + e) - f(x - e)) / (2.0 * h), g[k], 1e-6);
            }
        }
    }
}
