//! The one tolerance policy of the workspace: named tolerances and the `assert_near!` macro.
//!
//! Every crate's tests compare floating-point values through [`assert_near!`](crate::assert_near) (absolute
//! tolerance) or [`assert_rel_near!`](crate::assert_rel_near) (relative to a scale, usually the bounding-box diagonal
//! `D`), never with a bare `==` unless bitwise identity is the property under test.

/// Tolerance for quantities that should agree to rounding (accelerated vs brute-force sums).
pub const EXACT: f64 = 1e-12;

/// Tolerance for finite-difference checks of analytic gradients, relative to |∇f|.
pub const FINITE_DIFFERENCE: f64 = 1e-5;

/// Asserts `|a - b| <= tol`, printing both values and the difference on failure.
///
/// ```
/// psi_shapes::assert_near!(1.0, 1.0 + 1e-13, psi_shapes::tolerance::EXACT);
/// ```
#[macro_export]
macro_rules! assert_near {
    ($a:expr, $b:expr, $tol:expr $(,)?) => {{
        let (a, b, tol): (f64, f64, f64) = ($a, $b, $tol);
        assert!(
            (a - b).abs() <= tol,
            "assert_near failed: {} = {a}, {} = {b}, |diff| = {} > tol {tol}",
            stringify!($a),
            stringify!($b),
            (a - b).abs()
        );
    }};
    ($a:expr, $b:expr, $tol:expr, $($msg:tt)+) => {{
        let (a, b, tol): (f64, f64, f64) = ($a, $b, $tol);
        assert!(
            (a - b).abs() <= tol,
            "assert_near failed: {a} vs {b}, |diff| = {} > tol {tol}: {}",
            (a - b).abs(),
            format_args!($($msg)+)
        );
    }};
}

/// Asserts `|a - b| <= tol * scale` (a tolerance relative to a length scale such as `D`).
///
/// ```
/// psi_shapes::assert_rel_near!(2.0, 2.001, 1e-3, 2.0);
/// ```
#[macro_export]
macro_rules! assert_rel_near {
    ($a:expr, $b:expr, $tol:expr, $scale:expr $(,)?) => {{
        let (a, b, tol, scale): (f64, f64, f64, f64) = ($a, $b, $tol, $scale);
        assert!(
            (a - b).abs() <= tol * scale,
            "assert_rel_near failed: {a} vs {b}, |diff|/scale = {} > {tol}",
            (a - b).abs() / scale
        );
    }};
}
