//! Checks a particle set against the reference mesh: point-to-mesh distances (parry3d-f64
//! point projection, unsigned) and coverage of the mesh by the particles.

use parry3d_f64::query::PointQuery;
use parry3d_f64::shape::TriMesh;
use psi::octree::PointIndex;
use psi::{DVec3, TriangleMesh};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64Mcg;
use rayon::prelude::*;
use serde_json::json;

/// A reference mesh ready for distance queries.
pub(crate) struct Reference {
    pub(crate) mesh: TriangleMesh,
    shape: TriMesh,
}

impl Reference {
    pub(crate) fn new(mesh: TriangleMesh) -> anyhow::Result<Self> {
        let shape = TriMesh::new(mesh.vertices.clone(), mesh.faces.clone())
            .map_err(|e| anyhow::anyhow!("reference mesh: {e:?}"))?;
        Ok(Self { mesh, shape })
    }

    /// Unsigned distance from each point to the mesh surface (world units, plain).
    pub(crate) fn distances(&self, points: &[DVec3]) -> Vec<f64> {
        points
            .par_iter()
            .map(|p| self.shape.distance_to_local_point(*p, false))
            .collect()
    }

    /// Area of face `f` (vertex indices) of the mesh, world units².
    pub(crate) fn face_area(&self, f: &[u32; 3]) -> f64 {
        let [a, b, c] = f.map(|i| self.mesh.vertices[i as usize]);
        0.5 * (b - a).cross(c - a).length()
    }

    /// `n` area-uniform samples of the mesh surface (seeded).
    pub(crate) fn surface_samples(&self, n: usize, seed: u64) -> Vec<DVec3> {
        if self.mesh.faces.is_empty() {
            return Vec::new();
        }
        let tri = |f: &[u32; 3]| f.map(|i| self.mesh.vertices[i as usize]);
        let mut cumulative = Vec::with_capacity(self.mesh.faces.len());
        let mut total = 0.0;
        for f in &self.mesh.faces {
            total += self.face_area(f);
            cumulative.push(total);
        }
        let mut rng = Pcg64Mcg::seed_from_u64(seed);
        (0..n)
            .map(|_| {
                let t = rng.random::<f64>() * total;
                let k = cumulative
                    .partition_point(|&c| c < t)
                    .min(self.mesh.faces.len() - 1);
                let [a, b, c] = tri(&self.mesh.faces[k]);
                let (mut u, mut v): (f64, f64) = (rng.random(), rng.random());
                if u + v > 1.0 {
                    (u, v) = (1.0 - u, 1.0 - v);
                }
                a + u * (b - a) + v * (c - a)
            })
            .collect()
    }
}

/// Area-uniform samples per surface in [`metro_stats`], and their seed.
pub(crate) const METRO_SAMPLES: (usize, u64) = (200_000, 29);

/// Distance from a surface to surface `to` as Metro measures it (Cignoni et al. 1998): mean,
/// p99 and share within 2e-3 D over `from_samples` (area-uniform samples of the surface,
/// [`Reference::surface_samples`] with [`METRO_SAMPLES`]), the maximum over those samples and
/// `from_vertices` (its vertices, where a one-sided Hausdorff maximum often sits). Over D.
pub(crate) fn metro_stats(
    from_samples: &[DVec3],
    from_vertices: &[DVec3],
    to: &Reference,
    diag: f64,
) -> serde_json::Value {
    let samples = to.distances(from_samples);
    let vertex_max = to.distances(from_vertices).into_iter().fold(0.0, f64::max);
    let mut stats = distance_stats(&samples, diag);
    let max = stats["max"].as_f64().unwrap_or(0.0).max(vertex_max / diag);
    stats["max"] = json!(max);
    stats
}

/// Distance statistics over D: mean, 99th percentile, max, and the share within 2e-3 D.
pub(crate) fn distance_stats(d: &[f64], diag: f64) -> serde_json::Value {
    let mut s: Vec<f64> = d.iter().map(|x| x / diag).collect();
    s.sort_by(f64::total_cmp);
    let n = s.len().max(1);
    let pct = |q: f64| {
        s.get(((q * (n - 1) as f64).round() as usize).min(n - 1))
            .copied()
            .unwrap_or(0.0)
    };
    json!({
        "mean": s.iter().sum::<f64>() / n as f64,
        "p99": pct(0.99),
        "max": s.last().copied().unwrap_or(0.0),
        "within_2e-3": s.iter().filter(|x| **x <= 2e-3).count() as f64 / n as f64,
        "beyond_1e-2": s.iter().filter(|x| **x > 1e-2).count(),
    })
}

/// Total area of the reference mesh, world units².
pub(crate) fn area(reference: &Reference) -> f64 {
    reference
        .mesh
        .faces
        .iter()
        .map(|f| reference.face_area(f))
        .sum()
}

/// The largest distance from an area-uniform sample of the reference surface to its nearest
/// particle (the worst gap), world units.
pub(crate) fn worst_gap(reference: &Reference, particles: &[DVec3]) -> f64 {
    let samples = reference.surface_samples(100_000, 23);
    let index = PointIndex::new(particles);
    samples
        .par_iter()
        .map(|s| {
            index
                .nearest(*s, 1)
                .first()
                .map_or(f64::INFINITY, |n| n.1.sqrt())
        })
        .reduce(|| 0.0, f64::max)
}

/// Share of the reference surface (by area-uniform samples) within `radius` of a particle.
pub(crate) fn coverage(reference: &Reference, particles: &[DVec3], radius: f64) -> f64 {
    let samples = reference.surface_samples(100_000, 17);
    let index = PointIndex::new(particles);
    let covered = samples
        .par_iter()
        .filter(|s| {
            index
                .nearest(**s, 1)
                .first()
                .is_some_and(|n| n.1 <= radius * radius)
        })
        .count();
    covered as f64 / samples.len() as f64
}
