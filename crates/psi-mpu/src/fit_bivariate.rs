//! The bivariate quadratic fit: a height field h(u, v) over the tangent plane of the weighted
//! mean point and normal, Q = w − h(u, v), converted to a world-space quadric
//! (Ohtake's `QuadricO.cpp`; algorithms.md §1.2 (b)).

use glam::{DMat3, DVec3};
use nalgebra::{SMatrix, SVector};

use crate::Quadric;
use crate::least_squares::solve_pseudo_inverse6;

/// Relative singular-value cut-off of the bivariate solve (Ohtake: 1e-5).
const CUTOFF: f64 = 1e-5;

/// Two unit vectors completing `n` (unit) to a right-handed orthonormal frame.
pub(crate) fn tangent_frame(n: DVec3) -> (DVec3, DVec3) {
    let helper = if n.x.abs() < 0.6 {
        DVec3::X
    } else if n.y.abs() < 0.6 {
        DVec3::Y
    } else {
        DVec3::Z
    };
    let e1 = n.cross(helper).normalize();
    let e2 = n.cross(e1);
    (e1, e2)
}

/// Fits Q = w − h(u, v) around `origin` with w-axis `normal` (unit) to `points` (positions,
/// local frame) with weights `weights` (same length). `scale` (world units, ~ the support
/// radius) conditions the solve. Returns `None` when the system is degenerate.
pub(crate) fn fit_bivariate(
    points: &[DVec3],
    weights: &[f64],
    origin: DVec3,
    normal: DVec3,
    scale: f64,
) -> Option<Quadric> {
    let (e1, e2) = tangent_frame(normal);
    let inv = 1.0 / scale;
    // The lower triangle of the normal matrix, row by row (m[i][j], j ≤ i), and the right-hand
    // side.
    let mut m = [[0.0f64; 6]; 6];
    let mut r = [0.0f64; 6];
    for (p, &w) in points.iter().zip(weights) {
        if w <= 0.0 {
            continue;
        }
        let y = *p - origin;
        let (u, v, h) = (e1.dot(y) * inv, e2.dot(y) * inv, normal.dot(y) * inv);
        let phi = [1.0, u, v, u * u, u * v, v * v];
        // Rows w·φ: the normal equations weight residuals by w² (as Ohtake's code). Only the
        // lower triangle is accumulated: the symmetric eigen-solver reads nothing else. Each
        // entry gains φ_j·(w²φ_i) and r_i gains (w²h)·φ_i, the operations of nalgebra's
        // `syger(1, w²φ, φ, 1)` and `r += (w²h)·φ`, so the sums are theirs bit for bit.
        let w2 = w * w;
        let x = phi.map(|f| w2 * f);
        for i in 0..6 {
            for j in 0..=i {
                m[i][j] += phi[j] * x[i];
            }
        }
        let wh = w2 * h;
        for i in 0..6 {
            r[i] += wh * phi[i];
        }
    }
    let m = SMatrix::<f64, 6, 6>::from_fn(|i, j| if j <= i { m[i][j] } else { 0.0 });
    let c = solve_pseudo_inverse6(&m, &SVector::from(r), CUTOFF)?;
    // h(u,v) in world units: scale·h(u'/scale…) with u' = u·scale.
    let (c0, c1, c2) = (c[0] * scale, c[1], c[2]);
    let (c3, c4, c5) = (c[3] * inv, c[4] * inv, c[5] * inv);
    // Q(y) = n·y − c0 − c1 e1·y − c2 e2·y − c3 (e1·y)² − c4 (e1·y)(e2·y) − c5 (e2·y)².
    let outer = |a: DVec3, b: DVec3| DMat3::from_cols(a * b.x, a * b.y, a * b.z);
    let a =
        -(outer(e1, e1) * c3 + (outer(e1, e2) + outer(e2, e1)) * (0.5 * c4) + outer(e2, e2) * c5);
    let q = Quadric {
        origin,
        a,
        b: normal - c1 * e1 - c2 * e2,
        c: -c0,
    };
    q.is_finite().then_some(q)
}

#[cfg(test)]
mod tests {
    use super::*;
    use psi_shapes::assert_near;

    #[test]
    fn recovers_a_paraboloid_exactly() {
        // Surface z = 0.3 x² − 0.2 xy + 0.1 y² + 0.05 x, outward normal +z.
        let h = |x: f64, y: f64| 0.3 * x * x - 0.2 * x * y + 0.1 * y * y + 0.05 * x;
        let mut pts = Vec::new();
        for i in -5..=5 {
            for j in -5..=5 {
                let (x, y) = (i as f64 * 0.1, j as f64 * 0.1);
                pts.push(DVec3::new(x, y, h(x, y)));
            }
        }
        let w = vec![1.0; pts.len()];
        let q = fit_bivariate(&pts, &w, DVec3::ZERO, DVec3::Z, 0.5).unwrap();
        for p in &pts {
            assert_near!(q.value(*p), 0.0, 1e-12);
        }
        assert!(q.value(DVec3::new(0.0, 0.0, 1.0)) > 0.0);
    }
}
