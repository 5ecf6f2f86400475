//! The general 3D quadric fit with auxiliary points (Ohtake's `Quadric.cpp`;
//! algorithms.md §1.2 (a)).
//!
//! Minimises Σ_k w_k Q(p_k)² / Σ_k w_k + (1/9) Σ_j (Q(q_j) − d_j)² over the 10 coefficients,
//! where the q_j are the 8 corners and the centre of the cell cube, and d_j is the mean of
//! n_k·(q_j − p_k) over the 6 nearest points, used only when those six agree in sign.

use glam::{DMat3, DVec3};
use nalgebra::{SMatrix, SVector};

use crate::Quadric;
use crate::least_squares::solve_pseudo_inverse10;

/// Relative singular-value cut-off of the general quadric solve (Ohtake: 1e-7).
const CUTOFF: f64 = 1e-7;

/// Weight of each auxiliary row: 1/adN with adN = 9 whatever the number accepted (Ohtake).
const AUX_WEIGHT: f64 = 1.0 / 9.0;

#[inline]
fn basis(y: DVec3) -> SVector<f64, 10> {
    SVector::<f64, 10>::from([
        y.x * y.x,
        y.y * y.y,
        y.z * y.z,
        y.x * y.y,
        y.x * y.z,
        y.y * y.z,
        y.x,
        y.y,
        y.z,
        1.0,
    ])
}

/// The auxiliary targets: for each of the cube's 8 corners and centre, the signed distance
/// estimate d_j from the 6 nearest of `positions`/`normals` (local frame), or nothing when
/// the six disagree in sign. Returns (q_j, d_j) pairs.
pub(crate) fn auxiliary_points(
    center: DVec3,
    half: f64,
    positions: &[DVec3],
    normals: &[DVec3],
) -> Vec<(DVec3, f64)> {
    let mut out = Vec::with_capacity(9);
    let mut dist: Vec<(f64, u32)> = Vec::with_capacity(positions.len());
    for j in 0..9u32 {
        let q = if j == 8 {
            center
        } else {
            let s = |k: u32| if (j >> k) & 1 == 1 { 1.0 } else { -1.0 };
            center + half * DVec3::new(s(0), s(1), s(2))
        };
        dist.clear();
        dist.extend(
            positions
                .iter()
                .enumerate()
                .map(|(i, p)| ((*p - q).length_squared(), i as u32)),
        );
        let k = 6.min(dist.len());
        if k == 0 {
            continue;
        }
        if dist.len() > k {
            dist.select_nth_unstable_by(k - 1, |a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        }
        let mut sum = 0.0;
        let mut pos = 0;
        let mut neg = 0;
        for &(_, i) in &dist[..k] {
            let s = normals[i as usize].dot(q - positions[i as usize]);
            sum += s;
            if s > 0.0 {
                pos += 1;
            } else if s < 0.0 {
                neg += 1;
            }
        }
        if pos == k || neg == k {
            out.push((q, sum / k as f64));
        }
    }
    out
}

/// Fits a general quadric to `positions` (local frame) with `weights`, constrained by `aux`
/// (from [`auxiliary_points`]), in coordinates centred at `origin` and scaled by `scale`
/// (world units). `None` when no auxiliary point was accepted or the solve is degenerate.
pub(crate) fn fit_general_quadric(
    positions: &[DVec3],
    weights: &[f64],
    aux: &[(DVec3, f64)],
    origin: DVec3,
    scale: f64,
) -> Option<Quadric> {
    if aux.is_empty() {
        return None;
    }
    let inv = 1.0 / scale;
    let sum_w: f64 = weights.iter().sum();
    if sum_w <= 0.0 {
        return None;
    }
    let mut m = SMatrix::<f64, 10, 10>::zeros();
    let mut r = SVector::<f64, 10>::zeros();
    for (p, &w) in positions.iter().zip(weights) {
        if w > 0.0 {
            let phi = basis((*p - origin) * inv);
            m.syger(w / sum_w, &phi, &phi, 1.0);
        }
    }
    for &(q, d) in aux {
        let phi = basis((q - origin) * inv);
        m.syger(AUX_WEIGHT, &phi, &phi, 1.0);
        r += (AUX_WEIGHT * d * inv) * phi;
    }
    // syger fills the lower triangle only, all the solver reads.
    let c = solve_pseudo_inverse10(&m, &r, CUTOFF)?;
    // Q_world(y) = scale · Q_n(y / scale).
    let a = DMat3::from_cols(
        DVec3::new(c[0], 0.5 * c[3], 0.5 * c[4]),
        DVec3::new(0.5 * c[3], c[1], 0.5 * c[5]),
        DVec3::new(0.5 * c[4], 0.5 * c[5], c[2]),
    ) * inv;
    let q = Quadric {
        origin,
        a,
        b: DVec3::new(c[6], c[7], c[8]),
        c: c[9] * scale,
    };
    q.is_finite().then_some(q)
}

#[cfg(test)]
mod tests {
    use super::*;
    use psi_shapes::{AnalyticShape, assert_near};

    #[test]
    fn fits_a_sphere_patch_as_a_distance_like_quadric() {
        // A cell of half-edge 0.1 on a unit sphere, points within its support radius.
        let c = DVec3::new(0.0, 0.0, 1.0);
        let pts: Vec<_> = AnalyticShape::Sphere { radius: 1.0 }
            .sample(20_000, 5)
            .into_iter()
            .filter(|p| (p.p - c).length() < 0.26)
            .collect();
        let pos: Vec<DVec3> = pts.iter().map(|p| p.p).collect();
        let nrm: Vec<DVec3> = pts.iter().map(|p| p.n).collect();
        let w = vec![1.0; pos.len()];
        let aux = auxiliary_points(c, 0.1, &pos, &nrm);
        assert_eq!(aux.len(), 9);
        let q = fit_general_quadric(&pos, &w, &aux, c, 0.26).unwrap();
        for p in &pos {
            // The auxiliary targets are first-order distance estimates, so the fit trades a little
            // accuracy for them (Ohtake's formulation): 1.3e-4 measured.
            assert!(q.taubin_distance(*p) < 5e-4, "{}", q.taubin_distance(*p));
        }
        assert!(
            q.value(DVec3::new(0.0, 0.0, 0.9)) < 0.0 && q.value(DVec3::new(0.0, 0.0, 1.1)) > 0.0
        );
        assert_near!(q.value_and_gradient(c).1.length(), 1.0, 0.05);
    }
}
