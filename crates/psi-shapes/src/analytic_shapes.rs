//! Analytic shapes with exact oriented samples and exact (or first-order) signed distances:
//! the independent oracles of the MPU and particle tests.

use std::f64::consts::TAU;

use glam::DVec3;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64Mcg;

use psi_octree::OrientedPoint;

/// A closed analytic surface centred at the origin.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AnalyticShape {
    /// Sphere of the given radius.
    Sphere {
        /// Radius.
        radius: f64,
    },
    /// Axis-aligned ellipsoid with semi-axes `radii`.
    Ellipsoid {
        /// Semi-axes along x, y, z.
        radii: DVec3,
    },
    /// Torus around the z axis.
    Torus {
        /// Distance from the centre to the tube's centre line.
        major: f64,
        /// Tube radius.
        minor: f64,
    },
    /// Axis-aligned box with sharp edges and corners (a cube when all halves agree; two close
    /// parallel sheets when one half is small).
    Box {
        /// Half-extents along x, y, z.
        half: DVec3,
    },
}

impl AnalyticShape {
    /// `n` area-uniform samples with exact outward unit normals, from a seeded generator
    /// (same seed, same points).
    pub fn sample(&self, n: usize, seed: u64) -> Vec<OrientedPoint> {
        let mut rng = Pcg64Mcg::seed_from_u64(seed);
        let mut out = Vec::with_capacity(n);
        while out.len() < n {
            let u: f64 = rng.random();
            let v: f64 = rng.random();
            let w: f64 = rng.random();
            if let Some(p) = self.candidate(u, v, w) {
                out.push(p);
            }
        }
        out
    }

    /// One rejection-sampling candidate from three uniform numbers in [0, 1).
    fn candidate(&self, u: f64, v: f64, w: f64) -> Option<OrientedPoint> {
        match *self {
            AnalyticShape::Sphere { radius } => {
                let d = sphere_direction(u, v);
                Some(OrientedPoint {
                    p: radius * d,
                    n: d,
                })
            }
            AnalyticShape::Ellipsoid { radii } => {
                let d = sphere_direction(u, v);
                // Area element of the map d -> radii*d relative to its maximum.
                let scale = (d / radii).length() * radii.min_element();
                (w < scale).then(|| {
                    let p = radii * d;
                    OrientedPoint {
                        p,
                        n: (p / (radii * radii)).normalize(),
                    }
                })
            }
            AnalyticShape::Torus { major, minor } => {
                let (a, b) = (TAU * u, TAU * v);
                let accept = (major + minor * b.cos()) / (major + minor);
                (w < accept).then(|| {
                    let n = DVec3::new(b.cos() * a.cos(), b.cos() * a.sin(), b.sin());
                    let c = DVec3::new(major * a.cos(), major * a.sin(), 0.0);
                    OrientedPoint {
                        p: c + minor * n,
                        n,
                    }
                })
            }
            AnalyticShape::Box { half } => {
                let areas = [half.y * half.z, half.x * half.z, half.x * half.y];
                let total = 2.0 * (areas[0] + areas[1] + areas[2]);
                let mut pick = w * total;
                let mut face = 0;
                for (i, a) in areas.iter().enumerate() {
                    face = i;
                    if pick < 2.0 * a {
                        break;
                    }
                    pick -= 2.0 * a;
                }
                let sign = if pick < areas[face] { 1.0 } else { -1.0 };
                let (i1, i2) = ((face + 1) % 3, (face + 2) % 3);
                let mut p = DVec3::ZERO;
                p[face] = sign * half[face];
                p[i1] = (2.0 * u - 1.0) * half[i1];
                p[i2] = (2.0 * v - 1.0) * half[i2];
                let mut n = DVec3::ZERO;
                n[face] = sign;
                Some(OrientedPoint { p, n })
            }
        }
    }

    /// Signed distance from `x` to the surface (negative inside), world units, plain (not
    /// squared). Exact for sphere, torus and box; for the ellipsoid the first-order estimate
    /// k0(k0 − 1)/k1 with k0 = |x/r|, k1 = |x/r²|, accurate to O(d²) near the surface.
    pub fn signed_distance(&self, x: DVec3) -> f64 {
        match *self {
            AnalyticShape::Sphere { radius } => x.length() - radius,
            AnalyticShape::Ellipsoid { radii } => {
                let k0 = (x / radii).length();
                let k1 = (x / (radii * radii)).length();
                if k1 == 0.0 {
                    -radii.min_element()
                } else {
                    k0 * (k0 - 1.0) / k1
                }
            }
            AnalyticShape::Torus { major, minor } => {
                let q = glam::DVec2::new(x.truncate().length() - major, x.z);
                q.length() - minor
            }
            AnalyticShape::Box { half } => {
                let q = x.abs() - half;
                q.max(DVec3::ZERO).length() + q.max_element().min(0.0)
            }
        }
    }

    /// Surface area, world units².
    pub fn area(&self) -> f64 {
        match *self {
            AnalyticShape::Sphere { radius } => 2.0 * TAU * radius * radius,
            AnalyticShape::Torus { major, minor } => TAU * TAU * major * minor,
            AnalyticShape::Box { half } => {
                8.0 * (half.x * half.y + half.y * half.z + half.x * half.z)
            }
            AnalyticShape::Ellipsoid { radii } => {
                // Knud Thomsen's approximation (relative error ≤ 1.1 %).
                let p = 1.6075;
                let (a, b, c) = (radii.x.powf(p), radii.y.powf(p), radii.z.powf(p));
                2.0 * TAU * ((a * b + a * c + b * c) / 3.0).powf(1.0 / p)
            }
        }
    }
}

/// Uniform direction on the unit sphere from two uniform numbers (Archimedes' projection).
fn sphere_direction(u: f64, v: f64) -> DVec3 {
    let z = 2.0 * u - 1.0;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = TAU * v;
    DVec3::new(r * phi.cos(), r * phi.sin(), z)
}
