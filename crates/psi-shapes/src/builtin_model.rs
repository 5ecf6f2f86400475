//! The built-in procedural model: a deterministic oriented point cloud of a closed, bumpy,
//! rounded-square torus with flat sides, strongly curved rims, a bumpy half and one thin neck.
//! It is every command's default input and most tests' input; no data file is involved.

use std::f64::consts::{PI, TAU};

use glam::DVec3;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64Mcg;

use psi_octree::{Monitor, OrientedPoint};

/// Number of points [`builtin_model`] returns.
pub const BUILTIN_MODEL_POINTS: usize = 80_000;

/// Radius of the tube's centre circle.
const MAJOR: f64 = 1.0;
/// Tube radius away from the neck.
const TUBE: f64 = 0.38;

/// Surface point for parameters `u` (around the z axis) and `t` (around the tube), both radians.
fn surface(u: f64, t: f64) -> DVec3 {
    // Thin neck centred at u = π: the tube shrinks to 20 % of its radius.
    let du = (u - PI + PI).rem_euclid(TAU) - PI;
    let neck = 1.0 - 0.8 * (-(du / 0.3).powi(2)).exp();
    // Rounded-square cross-section (polar superellipse, exponent 8): flat sides, tight rims.
    let (c, s) = (t.cos(), t.sin());
    let square = (c.powi(8) + s.powi(8)).powf(-1.0 / 8.0);
    // Bumps on the half 0 < u < π only; the other half stays smooth.
    let mask = u.sin().max(0.0).powi(2);
    let bumps = 1.0 + 0.07 * mask * (6.0 * u).sin() * (4.0 * t).sin();
    let rho = TUBE * neck * square * bumps;
    let radial = DVec3::new(u.cos(), u.sin(), 0.0);
    MAJOR * radial + rho * (c * radial + s * DVec3::Z)
}

/// Tangents by central differences (step 1e-6 rad; error ~1e-11 relative).
fn tangents(u: f64, t: f64) -> (DVec3, DVec3) {
    let h = 1e-6;
    let du = (surface(u + h, t) - surface(u - h, t)) / (2.0 * h);
    let dt = (surface(u, t + h) - surface(u, t - h)) / (2.0 * h);
    (du, dt)
}

/// The built-in model: [`BUILTIN_MODEL_POINTS`] area-uniform oriented points (rejection sampling
/// on the parameter domain, seeded, so every call returns the same points), outward normals.
/// World units: the body spans about 2.9 × 2.9 × 0.9.
pub fn builtin_model() -> Vec<OrientedPoint> {
    sample_builtin(BUILTIN_MODEL_POINTS, BUILTIN_MODEL_SEED)
}

/// Seed of [`builtin_model`].
pub const BUILTIN_MODEL_SEED: u64 = 0x5051_2007;

/// `n` points of the built-in surface from seed `seed` (the default model is
/// `sample_builtin(BUILTIN_MODEL_POINTS, 0x5051_2007)`); large `n` makes stress inputs.
pub fn sample_builtin(n: usize, seed: u64) -> Vec<OrientedPoint> {
    sample_builtin_with(n, seed, &Monitor::silent())
}

/// [`sample_builtin`], stopping early (fewer points: the caller checks the flag and discards
/// them) once `monitor`'s stop flag is set, checked every 65 536 points.
pub fn sample_builtin_with(n: usize, seed: u64, monitor: &Monitor<'_>) -> Vec<OrientedPoint> {
    // Largest area element over a parameter grid, with a margin.
    let mut jmax: f64 = 0.0;
    for i in 0..256 {
        for j in 0..256 {
            let (u, t) = (TAU * i as f64 / 256.0, TAU * j as f64 / 256.0);
            let (a, b) = tangents(u, t);
            jmax = jmax.max(a.cross(b).length());
        }
    }
    jmax *= 1.25;
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    let mut out = Vec::with_capacity(n);
    while out.len() < n {
        if out.len() % 65_536 == 0 && monitor.stopped() {
            break;
        }
        let u = TAU * rng.random::<f64>();
        let t = TAU * rng.random::<f64>();
        let w: f64 = rng.random();
        let (a, b) = tangents(u, t);
        let cross = a.cross(b);
        let j = cross.length();
        if w * jmax >= j || j == 0.0 {
            continue;
        }
        let p = surface(u, t);
        let centre = MAJOR * DVec3::new(u.cos(), u.sin(), 0.0);
        let mut n = cross / j;
        if n.dot(p - centre) < 0.0 {
            n = -n;
        }
        out.push(OrientedPoint { p, n });
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builtin_is_deterministic_and_oriented() {
        let a = sample_builtin(2000, 1);
        let b = sample_builtin(2000, 1);
        assert_eq!(a, b);
        for p in &a {
            crate::assert_near!(p.n.length(), 1.0, 1e-12);
            // Outward: the normal points away from the tube's centre circle.
            let radial = DVec3::new(p.p.x, p.p.y, 0.0).normalize();
            assert!(p.n.dot(p.p - MAJOR * radial) > 0.0);
        }
    }
}
