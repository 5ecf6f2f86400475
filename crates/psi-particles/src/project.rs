//! Newton projection onto the zero set, x ← x − f∇f/|∇f|², with backtracking: a step that does
//! not decrease |f| is halved (up to 6 times), so the iteration also converges at the kinks that
//! sharp MPU pieces (max/min of quadrics) put in f.

use glam::DVec3;
use psi_mpu::Mpu;

/// A position with f and ∇f there and the leaf containing it (world units).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Evaluated {
    pub(crate) position: DVec3,
    pub(crate) f: f64,
    pub(crate) gradient: DVec3,
    /// The leaf containing `position`, `None` outside the root cube.
    pub(crate) leaf: Option<u32>,
}

impl Evaluated {
    /// `mpu`'s f, ∇f and leaf at world `x`, from a guess of the leaf (see
    /// [`Mpu::value_and_gradient_from`]).
    fn at(mpu: &Mpu, x: DVec3, hint: Option<u32>) -> Self {
        let e = mpu.value_and_gradient_from(x, hint);
        Self {
            position: x,
            f: e.f,
            gradient: e.gradient,
            leaf: e.leaf,
        }
    }

    /// |f|/|∇f|, world units: about the distance to the zero set.
    fn distance(&self) -> f64 {
        self.f.abs() / self.gradient.length().max(f64::MIN_POSITIVE)
    }
}

/// Projects world position `x` onto f = 0 with at most `steps` Newton steps, stopping once
/// |f|/|∇f| ≤ `tolerance` (world units). Each step is clamped to `max_step` (world units).
/// Returns the position with f, ∇f and its leaf there. `hint` is a guess of the leaf containing
/// `x` (see [`Mpu::value_and_gradient_from`]); the result does not depend on it.
pub(crate) fn newton_project(
    mpu: &Mpu,
    x: DVec3,
    tolerance: f64,
    steps: usize,
    max_step: f64,
    hint: Option<u32>,
) -> Evaluated {
    let mut at = Evaluated::at(mpu, x, hint);
    for _ in 0..steps {
        let (f, g) = (at.f, at.gradient);
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
            let next = Evaluated::at(mpu, at.position - step, at.leaf);
            if next.f.abs() < f.abs() {
                at = next;
                accepted = true;
                break;
            }
            step *= 0.5;
        }
        if !accepted {
            break;
        }
    }
    at
}

/// [`project_robust`], and where it finds no root near x (a fold of f just short of zero, as
/// MPU blending can make in thin parts), the same from the nearest input point, which lies
/// within ε0 of the surface, searching four times as far. The result with the smaller |f|/|∇f|
/// wins.
pub(crate) fn project_to_surface(mpu: &Mpu, x: DVec3, tolerance: f64, max_step: f64) -> Evaluated {
    let first = project_robust(mpu, x, tolerance, max_step);
    if first.distance() <= tolerance {
        return first;
    }
    let Some(q) = mpu.nearest_input(x) else {
        return first;
    };
    let second = project_robust(mpu, q.p, tolerance, 4.0 * max_step);
    if second.distance() < first.distance() {
        second
    } else {
        first
    }
}

/// Newton projection, then, where it stalls (kinks, nearly flat f), a bracket and bisection: f
/// is continuous, so along a direction where its sign changes within 4 × `max_step` the root is
/// halved down to rounding. Directions tried: against the gradient (by the sign of f), then the
/// six axis directions (at a ridge of max(Q1, Q2) the selected piece's gradient may point along
/// the ridge); the nearest sign change wins.
pub(crate) fn project_robust(mpu: &Mpu, x: DVec3, tolerance: f64, max_step: f64) -> Evaluated {
    let newton = newton_project(mpu, x, tolerance, 12, max_step, None);
    let (x, f, g) = (newton.position, newton.f, newton.gradient);
    let gl = g.length();
    if f.abs() <= tolerance * gl || f == 0.0 {
        return newton;
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
        return newton;
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
    Evaluated::at(mpu, x + hi * dir, None)
}
