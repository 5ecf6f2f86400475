//! Newton projection onto the zero set: x ← x − f∇f/|∇f|².

use glam::DVec3;
use psi_mpu::Mpu;

/// Projects world position `x` onto f = 0 with at most `steps` Newton steps, stopping once
/// |f|/|∇f| ≤ `tolerance` (world units). Each step is clamped to `max_step` (world units).
/// Returns the position, f and ∇f there.
pub(crate) fn newton_project(
    mpu: &Mpu,
    mut x: DVec3,
    tolerance: f64,
    steps: usize,
    max_step: f64,
) -> (DVec3, f64, DVec3) {
    let (mut f, mut g) = mpu.value_and_gradient(x);
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
        x -= step;
        (f, g) = mpu.value_and_gradient(x);
    }
    (x, f, g)
}
