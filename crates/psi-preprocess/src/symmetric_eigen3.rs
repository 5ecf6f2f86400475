//! The eigenvalues of a symmetric 3 × 3 matrix (a covariance) and its eigenvector of the least
//! one, in closed form: the trigonometric solution of the characteristic cubic (Smith 1961,
//! "Eigenvalues of a symmetric 3 × 3 matrix", CACM 4(4)) and the eigenvector as the largest
//! cross product of two rows of A − λ0·I (the rows span the space orthogonal to it; e.g.
//! Kopp 2008, "Efficient numerical diagonalization of hermitian 3 × 3 matrices", §2.2).
//! No iteration: a few hundred flops where an iterative solver takes several times that, and
//! the plane fits of the preprocessing take one per point (notes: 2026-12-04-exact-speedups).

use glam::{DMat3, DVec3};
use nalgebra::Matrix3;

/// The spectrum of a symmetric 3 × 3 matrix A, computed on A / s with s its largest absolute
/// entry (no underflow or overflow in the squares and the determinant).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Eigen3 {
    /// s, the scale: A's largest absolute entry (A's units).
    scale: f64,
    /// A / s.
    scaled: Matrix3<f64>,
    /// The eigenvalues of A / s, ascending, unclamped (dimensionless).
    values: [f64; 3],
}

impl Eigen3 {
    /// The spectrum of `a`, which must be symmetric (every entry is read). `None` when `a` is
    /// zero or has a non-finite entry.
    pub(crate) fn of(a: &Matrix3<f64>) -> Option<Self> {
        let largest = a.amax();
        if !(largest > 0.0 && a.iter().all(|v| v.is_finite())) {
            return None;
        }
        let c = a / largest;
        let off = c[(0, 1)].powi(2) + c[(0, 2)].powi(2) + c[(1, 2)].powi(2);
        let q = c.trace() / 3.0;
        let diag = (c[(0, 0)] - q).powi(2) + (c[(1, 1)] - q).powi(2) + (c[(2, 2)] - q).powi(2);
        let p = ((diag + 2.0 * off) / 6.0).sqrt();
        let mut e = if p > 0.0 {
            let b = (c - Matrix3::from_diagonal_element(q)) / p;
            let r = (b.determinant() / 2.0).clamp(-1.0, 1.0);
            let phi = r.acos() / 3.0;
            let largest = q + 2.0 * p * phi.cos();
            let smallest = q + 2.0 * p * (phi + 2.0 * std::f64::consts::FRAC_PI_3).cos();
            [smallest, 3.0 * q - largest - smallest, largest]
        } else {
            [q; 3]
        };
        e.sort_by(f64::total_cmp);
        Some(Eigen3 {
            scale: largest,
            scaled: c,
            values: e,
        })
    }

    /// The eigenvalues of A / s from the cubic, ascending, clamped at 0 (for a covariance,
    /// which has no negative ones but rounding): ratios between them are A's. Accurate to
    /// about ε where the eigenvalues are apart, to about √ε where two nearly coincide (the
    /// cubic's double root); [`Eigen3::decomposed`] is accurate to about ε throughout.
    pub(crate) fn shape(&self) -> [f64; 3] {
        self.values.map(|v| v.max(0.0))
    }

    /// A's eigenvalues (ascending, clamped at 0; A's units) and a unit eigenvector of the least
    /// (sign arbitrary), to about ε · ‖A‖ in A·n − λ0·n. The eigenvector of an eigenvalue the
    /// other two are far from is found first, from the cubic's root (the null direction of
    /// A / s − λ·I, [`null_direction`]) refined by its Rayleigh quotient nᵀ(A / s)n (accurate
    /// to about ε where the root was only to √ε); the other two eigenvalues, and the least's
    /// vector when it was not the first, are those of A / s restricted to the plane across it
    /// (a 2 × 2 symmetric matrix, [`Restricted`]). The first is the least's unless λ1 lies
    /// within [`NEAR_DOUBLE`] of λ0 and farther from λ2 (a near-double least eigenvalue,
    /// whose cubic root and null direction would be only to √ε: then the largest's). Where
    /// λ0 is (numerically) repeated the vector is one of its eigenspace's.
    pub(crate) fn decomposed(&self) -> ([f64; 3], DVec3) {
        // (Symmetric: its columns are its rows.)
        let c = DMat3::from_cols_slice(self.scaled.as_slice());
        let quotient = |n: DVec3| n.dot(c * n);
        let [l0, l1, l2] = self.values;
        let near_double = l1 - l0 < NEAR_DOUBLE && l2 - l1 > l1 - l0;
        let first = null_direction(&c, if near_double { l2 } else { l0 });
        let first = null_direction(&c, quotient(first));
        let across = Restricted::across(&c, first);
        let (low, high) = across.values();
        let (mut values, n) = if near_double {
            ([low, high, quotient(first)], across.low_vector(low))
        } else {
            ([quotient(first), low, high], first)
        };
        values.sort_by(f64::total_cmp);
        (values.map(|v| v.max(0.0) * self.scale), n)
    }
}

/// λ1 − λ0 (of A / s, whose largest entry is 1) below which [`Eigen3::decomposed`] takes a
/// near-double least eigenvalue from the plane across the largest's vector.
const NEAR_DOUBLE: f64 = 1e-4;

/// A symmetric matrix restricted to the plane across a unit eigenvector n: in an orthonormal
/// basis u, w of the plane, [[uu, uw], [uw, ww]].
struct Restricted {
    u: DVec3,
    w: DVec3,
    uu: f64,
    ww: f64,
    uw: f64,
}

impl Restricted {
    /// The symmetric `c` across the unit `n` (an eigenvector of it).
    fn across(c: &DMat3, n: DVec3) -> Self {
        let u = n.any_orthonormal_vector();
        let w = n.cross(u);
        Restricted {
            u,
            w,
            uu: u.dot(*c * u),
            ww: w.dot(*c * w),
            uw: u.dot(*c * w),
        }
    }

    /// Its two eigenvalues, ascending.
    fn values(&self) -> (f64, f64) {
        let mid = (self.uu + self.ww) / 2.0;
        let radius = ((self.uu - self.ww) / 2.0).hypot(self.uw);
        (mid - radius, mid + radius)
    }

    /// A unit eigenvector (in space) of its lower eigenvalue `low`: the longer of the two
    /// rows' null directions in the basis (u where both vanish: every vector of the plane is
    /// then one).
    fn low_vector(&self, low: f64) -> DVec3 {
        let (a, b) = ((self.uw, low - self.uu), (low - self.ww, self.uw));
        let (x, y) = if a.0.hypot(a.1) >= b.0.hypot(b.1) {
            a
        } else {
            b
        };
        let length = x.hypot(y);
        if length > 0.0 {
            (x * self.u + y * self.w) / length
        } else {
            self.u
        }
    }
}

/// A unit vector n with (c − λ·I)·n ≈ 0 for the symmetric `c` (an eigenvector of λ, sign
/// arbitrary): the largest of the cross products of two rows of c − λ·I, which are orthogonal
/// to it. Where those rows are parallel (λ a double eigenvalue) any unit vector orthogonal to
/// the largest row, and where they vanish (c = λ·I) the x axis: every such vector is then an
/// eigenvector. Accurate to about ε · ‖c‖ / (the gap from λ to the other eigenvalues) radians.
fn null_direction(c: &DMat3, lambda: f64) -> DVec3 {
    let rows = [
        c.x_axis - lambda * DVec3::X,
        c.y_axis - lambda * DVec3::Y,
        c.z_axis - lambda * DVec3::Z,
    ];
    let longest_of = |vs: [DVec3; 3]| {
        vs.into_iter()
            .max_by(|a, b| a.length_squared().total_cmp(&b.length_squared()))
            .unwrap_or(DVec3::ZERO)
    };
    let best = longest_of([
        rows[0].cross(rows[1]),
        rows[0].cross(rows[2]),
        rows[1].cross(rows[2]),
    ]);
    let longest = longest_of(rows);
    // A cross product of rows about as long as the rounding of their entries is noise: λ is
    // then (numerically) a repeated eigenvalue.
    let noise = 64.0 * f64::EPSILON * longest.length_squared();
    if best.is_finite() && best.length() > noise {
        best.normalize()
    } else if longest.is_finite() && longest.length_squared() > 0.0 {
        longest.normalize().any_orthonormal_vector()
    } else {
        DVec3::X
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use psi_shapes::assert_near;
    use rand::{RngExt, SeedableRng};

    /// A random rotation (columns orthonormal) from a random unit quaternion.
    fn rotation(rng: &mut rand_pcg::Pcg64Mcg) -> Matrix3<f64> {
        let q = nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
            rng.random::<f64>() - 0.5,
            rng.random::<f64>() - 0.5,
            rng.random::<f64>() - 0.5,
            rng.random::<f64>() - 0.5,
        ));
        *q.to_rotation_matrix().matrix()
    }

    /// Against matrices of known spectra Q·diag(λ)·Qᵀ: flat ones (the plane fits' case), thin
    /// ones, isotropic ones, repeated eigenvalues, over twelve decades of scale; and against
    /// nalgebra's iterative decomposition (the brute-force twin).
    #[test]
    fn spectra_and_least_vectors_match_known_and_iterative_ones() {
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(11);
        let spectra: [[f64; 3]; 15] = [
            [1e-3, 0.6, 1.0],
            [1e-9, 0.3, 1.0],
            [0.0, 0.5, 1.0],
            [0.2, 0.5, 1.0],
            [0.3, 0.3, 1.0],
            [1e-6, 1e-6, 1.0],
            [1.0, 1.0, 1.0],
            [0.999, 1.0, 1.0],
            [1e-12, 1e-3, 1.0],
            [0.3, 0.3 + 1e-9, 1.0],
            [0.3, 0.3 + 1e-8, 1.0],
            [0.3, 0.3 + 1e-7, 1.0],
            [0.3, 0.3 + 2e-4, 1.0],
            [1e-6, 1.01e-6, 1.0],
            [1e-3, 0.5, 0.5 + 1e-8],
        ];
        for trial in 0..300 {
            let lambda = spectra[trial % spectra.len()];
            let scale = 10f64.powf(rng.random::<f64>() * 12.0 - 6.0);
            let q = rotation(&mut rng);
            let d = Matrix3::from_diagonal(&nalgebra::Vector3::from(lambda.map(|v| v * scale)));
            let a = q * d * q.transpose();
            let a = (a + a.transpose()) / 2.0;
            let eig = Eigen3::of(&a).unwrap();
            let (values, n) = eig.decomposed();
            let iterative = a.symmetric_eigen();
            let mut expected: Vec<f64> = iterative.eigenvalues.iter().map(|v| v.max(0.0)).collect();
            expected.sort_by(f64::total_cmp);
            for k in 0..3 {
                assert_near!(values[k], lambda[k] * scale, 1e-13 * scale);
                assert_near!(values[k], expected[k], 1e-13 * scale);
            }
            assert_near!(n.length(), 1.0, 1e-14);
            let v = nalgebra::Vector3::new(n.x, n.y, n.z);
            // An eigenvector of λ0 whatever the gaps (near-double ones included): A·n = λ0·n
            // to rounding …
            let residual = (a * v - v * lambda[0] * scale).norm();
            assert!(residual <= 1e-13 * scale, "{trial}: {residual:e}");
            // … and, where λ0 is simple, the known one up to sign.
            if lambda[1] - lambda[0] > 1e-4 {
                let truth = q.column(0);
                assert_near!(v.dot(&truth).abs(), 1.0, 1e-12);
            }
        }
    }

    #[test]
    fn zero_and_non_finite_matrices_have_none() {
        assert!(Eigen3::of(&Matrix3::zeros()).is_none());
        for bad in [f64::INFINITY, f64::NAN] {
            let mut a = Matrix3::identity();
            (a[(1, 2)], a[(2, 1)]) = (bad, bad);
            assert!(Eigen3::of(&a).is_none());
        }
    }
}
