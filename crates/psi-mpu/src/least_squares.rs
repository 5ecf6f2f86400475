//! Small symmetric least-squares solves by eigen-decomposition with a relative cut-off
//! (the pseudo-inverse of the normal matrix, as Ohtake's SVD solves).

use nalgebra::{SMatrix, SVector};

macro_rules! pseudo_inverse_solver {
    ($name:ident, $n:literal) => {
        /// Solves M x = r for symmetric positive semi-definite M by pseudo-inverse, dropping
        /// eigenvalues below `cutoff` × the largest. `None` when M is zero or not finite.
        /// Only M's lower triangle (with the diagonal) is used: callers may leave the upper
        /// one unset (nalgebra's symmetric eigen-decomposition reads no more; its scaling by
        /// the largest entry finds it on the diagonal, as M is semi-definite).
        pub(crate) fn $name(
            m: &SMatrix<f64, $n, $n>,
            r: &SVector<f64, $n>,
            cutoff: f64,
        ) -> Option<SVector<f64, $n>> {
            if !m.iter().all(|v| v.is_finite()) || !r.iter().all(|v| v.is_finite()) {
                return None;
            }
            let eig = m.symmetric_eigen();
            let largest = eig.eigenvalues.iter().fold(0.0f64, |a, &b| a.max(b.abs()));
            if largest <= 0.0 || !largest.is_finite() {
                return None;
            }
            let mut x = SVector::<f64, $n>::zeros();
            for i in 0..$n {
                let l = eig.eigenvalues[i];
                if l.abs() > cutoff * largest {
                    let v = eig.eigenvectors.column(i);
                    x += v * (v.dot(r) / l);
                }
            }
            x.iter().all(|v| v.is_finite()).then_some(x)
        }
    };
}

pseudo_inverse_solver!(solve_pseudo_inverse6, 6);
pseudo_inverse_solver!(solve_pseudo_inverse10, 10);
