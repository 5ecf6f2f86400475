//! Newton projection onto the zero set, x ← x − f∇f/|∇f|², with backtracking: a step that does
//! not decrease |f| is halved (up to 6 times), so the iteration also converges at the kinks that
//! sharp MPU pieces (max/min of quadrics) put in f.

use glam::DVec3;
use psi_mpu::Mpu;

/// Projects world position `x` onto f = 0 with at most `steps` Newton steps, stopping once
/// |f|/|∇f| ≤ `tolerance` (world units). Each step is clamped to `max_step` (world units).
/// Returns the position, f and ∇f there.
pub(crate) fn newton_project(
    mpu: &Mpu,
    x: DVec3,
    tolerance: f64,
    steps: usize,
    max_step: f64,
) -> (DVec3, f64, DVec3) {
    let (x, f, g, _) = newton_project_from(mpu, x, tolerance, steps, max_step, None);
    (x, f, g)
}

/// [`newton_project`] with a guess of the leaf containing `x` (see
/// [`Mpu::value_and_gradient_from`]); also returns the leaf containing the result. The
/// position, f and ∇f are bitwise equal to `newton_project`'s.
pub(crate) fn newton_project_from(
    mpu: &Mpu,
    mut x: DVec3,
    tolerance: f64,
    steps: usize,
    max_step: f64,
    hint: Option<u32>,
) -> (DVec3, f64, DVec3, Option<u32>) {
    let (mut f, mut g, mut leaf) = mpu.value_and_gradient_from(x, hint);
    for _ in 0..steps {
        let g2 = g.length_squared();
        if g2 <= 1e-24 || f.abs() <= tolerance * g2.sqrt() {
            break;
        }
        let mut step = (f / g2) * g;
        let len = step.length();
        if len > max_step {
            step *= max_step / len;
        }
        let mut accepted = false;
        for _ in 0..7 {
            let y = x - step;
            let (fy, gy, ly) = mpu.value_and_gradient_from(y, leaf);
            if fy.abs() < f.abs() {
                (x, f, g, leaf) = (y, fy, gy, ly);
                accepted = true;
                break;
            }
            step *= 0.5;
        }
        if !accepted {
            break;
        }
    }
    (x, f, g, leaf)
}

/// [`project_robust`], and where it finds no root near x (a fold of f just short of zero, as
/// MPU blending can make in thin parts), the same from the nearest input point, which lies
/// within ε0 of the surface, searching four times as far. The result with the smaller |f|/|∇f|
/// wins.
pub(crate) fn project_to_surface(
    mpu: &Mpu,
    x: DVec3,
    tolerance: f64,
    max_step: f64,
) -> (DVec3, f64, DVec3) {
    let first = project_robust(mpu, x, tolerance, max_step);
    let ratio = |r: &(DVec3, f64, DVec3)| r.1.abs() / r.2.length().max(f64::MIN_POSITIVE);
    if ratio(&first) <= tolerance {
        return first;
    }
    let Some(q) = mpu.nearest_input(x) else {
        return first;
    };
    let second = project_robust(mpu, q.p, tolerance, 4.0 * max_step);
    if ratio(&second) < ratio(&first) {
        second
    } else {
        first
    }
}

/// Newton projection, then, where it stalls (kinks, nearly flat f), a bracket and bisection: f
/// is continuous, so along a direction where its sign changes within 4 × `max_step` the root is
/// halved down to rounding. Directions tried: against the gradient (by the sign of f), then the
/// six axis directions (at a ridge of max(Q1, Q2) the selected piece's gradient may point along
/// the ridge); the nearest sign change wins. Returns the position, f and ∇f there.
pub(crate) fn project_robust(
    mpu: &Mpu,
    x: DVec3,
    tolerance: f64,
    max_step: f64,
) -> (DVec3, f64, DVec3) {
    let (x, f, g) = newton_project(mpu, x, tolerance, 12, max_step);
    let gl = g.length();
    if f.abs() <= tolerance * gl || f == 0.0 {
        return (x, f, g);
    }
    let mut directions = Vec::with_capacity(7);
    if gl > 0.0 {
        directions.push(-f.signum() * g / gl);
    }
    for axis in [DVec3::X, DVec3::Y, DVec3::Z] {
        directions.push(axis);
        directions.push(-axis);
    }
    let start = if gl > 0.0 {
        (f.abs() / gl).min(max_step)
    } else {
        max_step / 64.0
    };
    let mut best: Option<(f64, DVec3)> = None;
    for dir in directions {
        let mut t = start;
        while t <= 4.0 * max_step && best.is_none_or(|b| t < b.0) {
            if mpu.value(x + t * dir).signum() != f.signum() {
                best = Some((t, dir));
                break;
            }
            t *= 2.0;
        }
    }
    let Some((mut hi, dir)) = best else {
        return (x, f, g);
    };
    let mut lo = 0.0;
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if mpu.value(x + mid * dir).signum() == f.signum() {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let y = x + hi * dir;
    let (fy, gy) = mpu.value_and_gradient(y);
    (y, fy, gy)
}
