//! More points for a coarse mesh: one point per triangle, at its centroid, is too sparse where
//! the triangles are large against the cells the implicit needs there, so a large triangle also
//! gets the centroids of a regular subdivision of itself (area-uniform), each with the face
//! normal. The implicit then follows the mesh's flat facets instead of bulging between the
//! centroids.

use glam::DVec3;
use psi_octree::{Aabb, OrientedPoint};
use serde::{Deserialize, Serialize};

use crate::median::median;

/// A mesh is coarse when the median standoff of its vertices from the plane of their triangles'
/// centroids reaches this share of its bounding-box diagonal D: a tenth of the paper's ε0 of
/// 0.005 D, so that a fine mesh's standoff (its roughness) stays below it (the measured
/// standoffs of the shared models: docs/notes/2026-11-24-real-scans.md).
const COARSE_STANDOFF: f64 = 5e-4;

/// A coarse mesh's triangles are cut down to about the area at which the median standoff would
/// be this share of D (the standoff grows with a triangle's area).
const TARGET_STANDOFF: f64 = COARSE_STANDOFF / 3.0;

/// Densification adds at most about twice this many points per triangle on average, whatever
/// the spread of areas: a single huge triangle (a filled hole, a ground plane) must not ask
/// for billions of points.
const MAX_PIECES_PER_FACE: f64 = 64.0;

/// How coarse a mesh is against the implicit's tolerance ([`mesh_coarseness`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct MeshCoarseness {
    /// The median, over the vertices used by a triangle, of the distance from the vertex to the
    /// plane through the centroids of its triangles (along its area-weighted normal), over D.
    /// Where the mesh bends, a vertex stands off that plane by about its triangles' sagitta.
    pub median_standoff: f64,
    /// The median triangle area over D².
    pub median_area: f64,
    /// For a coarse mesh, the largest triangle area (world units²) [`densify_mesh`] should
    /// leave uncut, never below the total area over 64 × the triangle count; `None` for a fine
    /// mesh.
    pub max_area: Option<f64>,
}

/// How coarse the mesh (`vertices`, shape V, world units; `faces`, shape F) is: the median
/// standoff of its vertices from the plane of their triangles' centroids, over D; the mesh is
/// coarse when that reaches 5e-4 (a tenth of the paper's ε0), and its triangles should then be
/// cut to the median area × (5e-4/3) / standoff — the standoff grows about as the area, so that
/// brings it to a third of the limit, but never below the total area over 64 × the triangle
/// count, so that [`densify_mesh`] adds at most about 130 points per triangle on average
/// (Σ⌈√(A/a)⌉² ≤ 2ΣA/a + 2F). `None` for a mesh without usable triangles.
///
/// ```
/// use glam::DVec3;
/// use psi_preprocess::mesh_coarseness;
///
/// // An octahedron: six vertices on a sphere, eight faces — as coarse as a mesh gets.
/// let v = [DVec3::X, DVec3::NEG_X, DVec3::Y, DVec3::NEG_Y, DVec3::Z, DVec3::NEG_Z];
/// let f = [[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]];
/// let c = mesh_coarseness(&v, &f).unwrap();
/// assert!(c.median_standoff > 0.1 && c.max_area.is_some());
/// ```
pub fn mesh_coarseness(vertices: &[DVec3], faces: &[[u32; 3]]) -> Option<MeshCoarseness> {
    let diagonal = Aabb::from_points(vertices.iter().copied())?.diagonal();
    let valid = |f: &[u32; 3]| f.iter().all(|&i| (i as usize) < vertices.len());
    let mut normal = vec![DVec3::ZERO; vertices.len()];
    let mut centroids = vec![DVec3::ZERO; vertices.len()];
    let mut count = vec![0u32; vertices.len()];
    let mut areas = Vec::with_capacity(faces.len());
    for f in faces.iter().filter(|f| valid(f)) {
        let [a, b, c] = f.map(|i| vertices[i as usize]);
        let cross = (b - a).cross(c - a);
        if !cross.is_finite() || cross == DVec3::ZERO {
            continue;
        }
        areas.push(0.5 * cross.length());
        let centroid = (a + b + c) / 3.0;
        for &i in f {
            normal[i as usize] += cross;
            centroids[i as usize] += centroid;
            count[i as usize] += 1;
        }
    }
    let mut standoffs: Vec<f64> = (0..vertices.len())
        .filter(|&i| count[i] > 0)
        .filter_map(|i| {
            let n = normal[i].try_normalize()?;
            let mean = centroids[i] / f64::from(count[i]);
            Some(n.dot(vertices[i] - mean).abs())
        })
        .collect();
    if standoffs.is_empty() || areas.is_empty() || diagonal <= 0.0 {
        return None;
    }
    let total_area: f64 = areas.iter().sum();
    let floor = total_area / (MAX_PIECES_PER_FACE * areas.len() as f64);
    let standoff = median(&mut standoffs) / diagonal;
    let area = median(&mut areas);
    Some(MeshCoarseness {
        median_standoff: standoff,
        median_area: area / (diagonal * diagonal),
        max_area: (standoff >= COARSE_STANDOFF)
            .then(|| (area * TARGET_STANDOFF / standoff).max(floor)),
    })
}

/// The extra points for the triangles of a mesh (`vertices`, shape V, world units; `faces`,
/// shape F, indices into `vertices`, counter-clockwise seen from outside) whose area exceeds
/// `max_area` (world units²): a triangle of area A is cut into m² similar triangles,
/// m = ⌈√(A / max_area)⌉, and each piece's centroid (but the one that is the triangle's own
/// centroid, which the mesh's one point per triangle already has: there is one unless 3
/// divides m) becomes a point with the unit face normal. Triangles of at most
/// `max_area`, and degenerate ones, give none: the result is empty for a fine mesh. Order:
/// by face, then by piece. Indices out of range are skipped.
///
/// ```
/// use glam::DVec3;
/// use psi_preprocess::densify_mesh;
///
/// let v = [DVec3::ZERO, DVec3::X, DVec3::Y];
/// // Area 0.5: with pieces of at most 0.5/4 it is cut into four; one piece's centroid is the
/// // triangle's, so three extra points.
/// let extra = densify_mesh(&v, &[[0, 1, 2]], 0.5 / 4.0);
/// assert_eq!(extra.len(), 3);
/// assert!(extra.iter().all(|p| p.n == DVec3::Z && p.p.z == 0.0));
/// assert!(densify_mesh(&v, &[[0, 1, 2]], 1.0).is_empty());
/// ```
pub fn densify_mesh(vertices: &[DVec3], faces: &[[u32; 3]], max_area: f64) -> Vec<OrientedPoint> {
    densify_mesh_with_sources(vertices, faces, max_area).0
}

/// [`densify_mesh`], and for each extra point the index of its triangle's own point among the
/// mesh's one point per triangle (`psi-io` gives one to every triangle without a repeated
/// index and with a finite, non-zero cross product, in face order): what the extra point
/// inherits attributes from.
pub fn densify_mesh_with_sources(
    vertices: &[DVec3],
    faces: &[[u32; 3]],
    max_area: f64,
) -> (Vec<OrientedPoint>, Vec<u32>) {
    let mut out = Vec::new();
    let mut sources = Vec::new();
    if max_area.is_nan() || max_area <= 0.0 {
        return (out, sources);
    }
    let mut own = 0u32;
    for f in faces {
        let [Some(a), Some(b), Some(c)] = f.map(|i| vertices.get(i as usize).copied()) else {
            continue;
        };
        let cross = (b - a).cross(c - a);
        let repeated = f[0] == f[1] || f[1] == f[2] || f[0] == f[2];
        let has_point = !repeated && cross.is_finite() && cross != DVec3::ZERO;
        let point = own;
        own += u32::from(has_point);
        let area = 0.5 * cross.length();
        if area.is_nan() || area <= max_area || !area.is_finite() {
            continue;
        }
        let n = cross / (2.0 * area);
        let m = (area / max_area).sqrt().ceil() as usize;
        let (eu, ev) = ((b - a) / m as f64, (c - a) / m as f64);
        let centroid = (a + b + c) / 3.0;
        for i in 0..m {
            for j in 0..m - i {
                // The piece with corner (i, j) pointing like the triangle, then the one
                // pointing the other way (there is one fewer of those per row).
                let up = a + (i as f64 + 1.0 / 3.0) * eu + (j as f64 + 1.0 / 3.0) * ev;
                let mut pieces = vec![up];
                if j + 1 < m - i {
                    pieces.push(a + (i as f64 + 2.0 / 3.0) * eu + (j as f64 + 2.0 / 3.0) * ev);
                }
                for p in pieces {
                    if (p - centroid).length() > 1e-9 * (b - a).length() {
                        out.push(OrientedPoint { p, n });
                        sources.push(point);
                    }
                }
            }
        }
    }
    (out, sources)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The pieces' centroids sample the triangle area-uniformly: m² of them (one fewer unless 3
    /// divides m: then one piece's centroid is the triangle's), all in its plane, and their
    /// mean, with the triangle's centroid where it was left out, is the triangle's centroid.
    #[test]
    fn pieces_cover_the_triangle_evenly() {
        let (a, b, c) = (
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(0.0, 2.0, 0.0),
            DVec3::new(0.0, 0.0, 3.0),
        );
        let area = 0.5 * (b - a).cross(c - a).length();
        for m in 2..7usize {
            let extra = densify_mesh(&[a, b, c], &[[0, 1, 2]], area / (m * m) as f64 * 1.0001);
            let skipped = m % 3 != 0;
            let expected = m * m - usize::from(skipped);
            assert_eq!(extra.len(), expected, "m = {m}");
            let centroid = (a + b + c) / 3.0;
            let mean = (extra.iter().map(|p| p.p).sum::<DVec3>()
                + if skipped { centroid } else { DVec3::ZERO })
                / (m * m) as f64;
            assert!((mean - centroid).length() < 1e-12, "m = {m}");
            let n = (b - a).cross(c - a).normalize();
            for p in &extra {
                assert!((p.p - a).dot(n).abs() < 1e-12);
                assert!((p.n - n).length() < 1e-12);
            }
        }
    }

    /// A crumpled grid of tiny triangles (coarse: its vertices stand far off their
    /// neighbours' plane) beside one large triangle: cutting the large one to the tiny ones'
    /// scale would give millions of points; the cap keeps the total near 64 per triangle.
    #[test]
    fn one_huge_triangle_does_not_explode_the_point_count() {
        let n = 30u32;
        let mut v: Vec<DVec3> = (0..n * n)
            .map(|k| {
                let (i, j) = (k % n, k / n);
                let z = if (i + j) % 2 == 0 { 4e-3 } else { 0.0 };
                DVec3::new(f64::from(i) * 1e-3, f64::from(j) * 1e-3, z)
            })
            .collect();
        let mut f = Vec::new();
        for j in 0..n - 1 {
            for i in 0..n - 1 {
                let k = j * n + i;
                f.push([k, k + 1, k + n + 1]);
                f.push([k, k + n + 1, k + n]);
            }
        }
        let base = v.len() as u32;
        v.extend([
            DVec3::new(0.0, 0.0, -0.5),
            DVec3::new(1.0, 0.0, -0.5),
            DVec3::new(0.0, 1.0, -0.5),
        ]);
        f.push([base, base + 1, base + 2]);
        let c = mesh_coarseness(&v, &f).unwrap();
        let max_area = c.max_area.expect("coarse");
        // Without the floor, the median rule would cut the large triangle (area 0.5) into
        // over a million pieces the size of the tiny ones.
        let d2 = Aabb::from_points(v.iter().copied())
            .unwrap()
            .diagonal()
            .powi(2);
        let uncapped = c.median_area * d2 * TARGET_STANDOFF / c.median_standoff;
        assert!(0.5 / uncapped > 1e6, "{c:?}");
        let extra = densify_mesh(&v, &f, max_area);
        assert!(!extra.is_empty());
        assert!(
            extra.len() <= 130 * f.len(),
            "{} points for {} triangles",
            extra.len(),
            f.len()
        );
    }
}
