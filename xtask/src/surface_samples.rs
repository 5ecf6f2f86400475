//! Seeded area-weighted samples of a triangle soup (a mesh, or the labelled parts of a
//! generated scene): the point sampler of the scan generators and of the density group.

use anyhow::{Result, bail};
use psi::{DVec3, OrientedPoint, TriangleMesh};
use rand::RngExt;
use rand_pcg::Pcg64Mcg;

/// Triangles (world units) ready for area-uniform sampling: one draw picks a triangle with
/// probability proportional to its area, then a uniform point on it.
pub(crate) struct TriangleSampler {
    triangles: Vec<[DVec3; 3]>,
    /// Running sum of the triangles' areas (shape: triangles), world units².
    cumulative: Vec<f64>,
}

impl TriangleSampler {
    /// A sampler over `triangles` (corners in world units); an error when their total area
    /// is zero.
    pub(crate) fn new(triangles: Vec<[DVec3; 3]>) -> Result<Self> {
        let mut total = 0.0;
        let cumulative: Vec<f64> = triangles
            .iter()
            .map(|[a, b, c]| {
                total += 0.5 * (*b - *a).cross(*c - *a).length();
                total
            })
            .collect();
        if !(total > 0.0 && total.is_finite()) {
            bail!("no triangle area to sample ({} triangles)", triangles.len());
        }
        Ok(Self {
            triangles,
            cumulative,
        })
    }

    /// A sampler over the faces of `mesh`.
    pub(crate) fn from_mesh(mesh: &TriangleMesh) -> Result<Self> {
        Self::new(
            mesh.faces
                .iter()
                .map(|f| f.map(|i| mesh.vertices[i as usize]))
                .collect(),
        )
    }

    /// Total area, world units².
    pub(crate) fn area(&self) -> f64 {
        self.cumulative.last().copied().unwrap_or(0.0)
    }

    /// One area-uniform sample: the point (world units) with its triangle's unit normal
    /// (counter-clockwise winding outward; zero for a degenerate triangle), and the triangle's
    /// index. Consumes three draws of `rng`.
    pub(crate) fn sample(&self, rng: &mut Pcg64Mcg) -> (OrientedPoint, usize) {
        let t = rng.random::<f64>() * self.area();
        let k = self
            .cumulative
            .partition_point(|&c| c <= t)
            .min(self.triangles.len() - 1);
        let [a, b, c] = self.triangles[k];
        let (mut u, mut v): (f64, f64) = (rng.random(), rng.random());
        if u + v > 1.0 {
            (u, v) = (1.0 - u, 1.0 - v);
        }
        let point = OrientedPoint {
            p: a + u * (b - a) + v * (c - a),
            n: (b - a).cross(c - a).normalize_or_zero(),
        };
        (point, k)
    }

    /// `n` samples ([`TriangleSampler::sample`]) without their triangle indices (shape: n).
    pub(crate) fn samples(&self, n: usize, rng: &mut Pcg64Mcg) -> Vec<OrientedPoint> {
        (0..n).map(|_| self.sample(rng).0).collect()
    }
}

/// `v` rotated by `angle` (radians) about the unit vector `axis` through the origin
/// (Rodrigues' formula).
pub(crate) fn rotate(v: DVec3, axis: DVec3, angle: f64) -> DVec3 {
    let (s, c) = angle.sin_cos();
    v * c + axis.cross(v) * s + axis * axis.dot(v) * (1.0 - c)
}

/// A uniformly distributed unit vector (normalised standard normal 3-vector).
pub(crate) fn random_unit(rng: &mut Pcg64Mcg) -> DVec3 {
    loop {
        let g = psi::shapes::gaussian_vector(rng);
        if g.length_squared() > 1e-12 {
            return g.normalize();
        }
    }
}

/// The faces of a cube whose corner i sits at bit 0 → x, bit 1 → y, bit 2 → z of i (low or
/// high side), each as four corners counter-clockwise seen from outside.
pub(crate) const CUBE_FACES: [[usize; 4]; 6] = [
    [0, 2, 3, 1],
    [4, 5, 7, 6],
    [0, 1, 5, 4],
    [2, 6, 7, 3],
    [0, 4, 6, 2],
    [1, 3, 7, 5],
];

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn samples_fall_on_triangles_in_proportion_to_area() {
        // A unit square (area 1) and a triangle of area 3 beside it, at z = 0 and z = 1.
        let sq = [
            [DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0)],
            [DVec3::ZERO, DVec3::new(1.0, 1.0, 0.0), DVec3::Y],
        ];
        let big = [
            DVec3::Z,
            DVec3::new(3.0, 0.0, 1.0),
            DVec3::new(0.0, 2.0, 1.0),
        ];
        let s = TriangleSampler::new(vec![sq[0], sq[1], big]).unwrap();
        assert!((s.area() - 4.0).abs() < 1e-12);
        let mut rng = Pcg64Mcg::seed_from_u64(3);
        let n = 40_000;
        let on_big = (0..n).filter(|_| s.sample(&mut rng).1 == 2).count();
        assert!((on_big as f64 / n as f64 - 0.75).abs() < 0.01, "{on_big}");
        for p in s.samples(100, &mut rng) {
            assert!(p.p.z == 0.0 || p.p.z == 1.0);
            assert!((p.n - DVec3::Z).length() < 1e-12);
        }
    }

    #[test]
    fn rotation_keeps_lengths_and_turns_by_the_angle() {
        let v = DVec3::new(1.0, 2.0, 3.0);
        let r = rotate(v, DVec3::Z, std::f64::consts::FRAC_PI_2);
        assert!((r - DVec3::new(-2.0, 1.0, 3.0)).length() < 1e-12);
        assert!((rotate(v, DVec3::X, 0.3).length() - v.length()).abs() < 1e-12);
    }
}
