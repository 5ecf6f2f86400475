//! Turning parsed data into oriented points: face centroids or area-weighted vertex normals for
//! meshes, per-vertex normals for point clouds.

use glam::DVec3;
use psi_octree::OrientedPoint;
use rayon::prelude::*;

use crate::attributes::{self, PointAttributes};
use crate::error::ReadError;
use crate::free_aside::free_aside;
use crate::model::{NormalSource, Parsed, PointCloudFile, SourceInfo, TriangleMesh};
use crate::options::{MeshSampling, ReadOptions};

/// `v / |v|`, robust to lengths that under- or overflow when squared; `None` for a zero or
/// non-finite `v`.
pub(crate) fn unit(v: DVec3) -> Option<DVec3> {
    if !v.is_finite() {
        return None;
    }
    let len = v.length();
    if len.is_finite() && len >= 1e-150 {
        return Some(v / len);
    }
    let m = v.abs().max_element();
    if m == 0.0 {
        return None;
    }
    let w = v / m;
    Some(w / w.length())
}

/// The unnormalised normal `(b - a) × (c - a)` of a triangle, or `None` when the triangle is
/// degenerate: a repeated index, or a cross product that is zero or not finite.
fn face_cross(vertices: &[DVec3], [i, j, k]: [u32; 3]) -> Option<DVec3> {
    if i == j || j == k || i == k {
        return None;
    }
    let (a, b, c) = (
        vertices[i as usize],
        vertices[j as usize],
        vertices[k as usize],
    );
    let n = (b - a).cross(c - a);
    (n.is_finite() && n != DVec3::ZERO).then_some(n)
}

fn centroid(a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
    let m = (a + b + c) / 3.0;
    if m.is_finite() {
        m
    } else {
        a / 3.0 + b / 3.0 + c / 3.0
    }
}

/// One point per non-degenerate triangle; returns the points, the degenerate count and the
/// triangles that gave the points.
fn face_centroids(mesh: &TriangleMesh) -> (Vec<OrientedPoint>, usize, Vec<[u32; 3]>) {
    let v = &mesh.vertices;
    let mut points = Vec::with_capacity(mesh.faces.len());
    let mut kept = Vec::with_capacity(mesh.faces.len());
    let mut degenerate = 0;
    for &f in &mesh.faces {
        let point = face_cross(v, f).and_then(|n| {
            let p = centroid(v[f[0] as usize], v[f[1] as usize], v[f[2] as usize]);
            Some(OrientedPoint { p, n: unit(n)? })
        });
        match point {
            Some(p) => {
                points.push(p);
                kept.push(f);
            }
            None => degenerate += 1,
        }
    }
    (points, degenerate, kept)
}

/// One point per referenced vertex with its area-weighted normal; returns the points, the
/// degenerate-triangle count, the count of referenced vertices whose normal sums to zero and
/// the indices of the vertices that gave the points.
fn vertex_normals(mesh: &TriangleMesh) -> (Vec<OrientedPoint>, usize, usize, Vec<usize>) {
    let v = &mesh.vertices;
    let mut sums = vec![DVec3::ZERO; v.len()];
    let mut referenced = vec![false; v.len()];
    let mut degenerate = 0;
    for &f in &mesh.faces {
        for &i in &f {
            referenced[i as usize] = true;
        }
        match face_cross(v, f) {
            Some(n) => {
                for &i in &f {
                    sums[i as usize] += n;
                }
            }
            None => degenerate += 1,
        }
    }
    let mut points = Vec::with_capacity(v.len());
    let mut kept = Vec::with_capacity(v.len());
    let mut dropped = 0;
    for (i, &p) in v.iter().enumerate() {
        if !referenced[i] {
            continue;
        }
        match unit(sums[i]) {
            Some(n) => {
                points.push(OrientedPoint { p, n });
                kept.push(i);
            }
            None => dropped += 1,
        }
    }
    (points, degenerate, dropped, kept)
}

/// The file of `points` with their normals as read (any length; see [`orient_in_place`]) and
/// their `attributes` (aligned, or empty), from a file of `faces` (0) faces read as `source`.
fn file_of_points(
    mut points: Vec<OrientedPoint>,
    attributes: PointAttributes,
    faces: usize,
    source: SourceInfo,
) -> Result<PointCloudFile, ReadError> {
    let vertices = points.len();
    let kept = orient_in_place(&mut points)?;
    let attributes = match kept {
        Some(kept) if !attributes.is_empty() => attributes::select(&attributes, &kept),
        _ => attributes,
    };
    Ok(PointCloudFile {
        dropped_points: vertices - points.len(),
        points,
        normals: NormalSource::File,
        vertices,
        faces,
        degenerate_faces: 0,
        mesh: None,
        attributes,
        source,
    })
}

/// Makes each point's normal (as read: any length) unit and leaves out the points whose
/// normal is zero, in place and in parallel. Returns, when some were left out, the indices of
/// those kept.
///
/// Errors: [`ReadError::NonFinite`] naming the first point whose normal is not finite.
fn orient_in_place(points: &mut Vec<OrientedPoint>) -> Result<Option<Vec<usize>>, ReadError> {
    if let Some(index) = points.par_iter().position_first(|q| !q.n.is_finite()) {
        return Err(ReadError::NonFinite {
            element: "vertex",
            index,
            what: "normal",
            line: None,
        });
    }
    // A zero normal marks a point left out (`unit` never gives one).
    points
        .par_iter_mut()
        .for_each(|q| q.n = unit(q.n).unwrap_or(DVec3::ZERO));
    if points.par_iter().all(|q| q.n != DVec3::ZERO) {
        return Ok(None);
    }
    let kept = (0..points.len())
        .filter(|&i| points[i].n != DVec3::ZERO)
        .collect();
    points.retain(|q| q.n != DVec3::ZERO);
    Ok(Some(kept))
}

/// Oriented points from parsed data per `opts`; see [`crate::read_points`] for the rules.
pub(crate) fn to_point_cloud(
    parsed: Parsed,
    opts: &ReadOptions,
) -> Result<PointCloudFile, ReadError> {
    let vertices = parsed.vertices.len();
    let faces = parsed.faces.len();
    let source = parsed.source;
    let result = if let Some(points) = parsed.oriented {
        file_of_points(points, parsed.attributes, faces, source)?
    } else if faces > 0 {
        let mesh = TriangleMesh {
            vertices: parsed.vertices,
            faces: parsed.faces,
        };
        let (points, degenerate_faces, dropped_points, attributes) = match opts.sampling {
            MeshSampling::FaceCentroids => {
                let (points, degenerate, kept) = face_centroids(&mesh);
                (
                    points,
                    degenerate,
                    0,
                    attributes::per_face(&parsed.attributes, &kept),
                )
            }
            MeshSampling::VertexNormals => {
                let (points, degenerate, dropped, kept) = vertex_normals(&mesh);
                (
                    points,
                    degenerate,
                    dropped,
                    attributes::select(&parsed.attributes, &kept),
                )
            }
        };
        PointCloudFile {
            points,
            normals: match opts.sampling {
                MeshSampling::FaceCentroids => NormalSource::Faces,
                MeshSampling::VertexNormals => NormalSource::Vertices,
            },
            vertices,
            faces,
            degenerate_faces,
            dropped_points,
            mesh: Some(mesh),
            attributes,
            source,
        }
    } else if vertices == 0 {
        PointCloudFile {
            points: Vec::new(),
            normals: NormalSource::File,
            vertices,
            faces,
            degenerate_faces: 0,
            dropped_points: 0,
            mesh: None,
            attributes: parsed.attributes,
            source,
        }
    } else if parsed.normals.is_none() {
        // Positions only: normals are estimated later (psi-preprocess).
        let points = parsed
            .vertices
            .par_iter()
            .map(|&p| OrientedPoint { p, n: DVec3::ZERO })
            .collect();
        free_aside(parsed.vertices);
        PointCloudFile {
            points,
            normals: NormalSource::Missing,
            vertices,
            faces,
            degenerate_faces: 0,
            dropped_points: 0,
            mesh: None,
            attributes: parsed.attributes,
            source,
        }
    } else {
        let normals = parsed.normals.unwrap_or_default();
        let points = parsed
            .vertices
            .par_iter()
            .zip(&normals)
            .map(|(&p, &n)| OrientedPoint { p, n })
            .collect();
        free_aside(parsed.vertices);
        free_aside(normals);
        file_of_points(points, parsed.attributes, faces, source)?
    };
    if result.points.is_empty() {
        return Err(ReadError::NoPoints {
            vertices: result.vertices,
            faces: result.faces,
            degenerate_faces: result.degenerate_faces,
            dropped_points: result.dropped_points,
        });
    }
    Ok(result)
}

/// The triangle mesh of parsed data; [`ReadError::NoFaces`] when there are no faces.
pub(crate) fn to_mesh(parsed: Parsed) -> Result<TriangleMesh, ReadError> {
    if parsed.faces.is_empty() {
        return Err(ReadError::NoFaces);
    }
    Ok(TriangleMesh {
        vertices: parsed.vertices,
        faces: parsed.faces,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `orient_in_place` of the points of `positions` with `normals` (as read).
    fn raw_oriented(
        positions: &[DVec3],
        normals: &[DVec3],
    ) -> Result<(Vec<OrientedPoint>, Option<Vec<usize>>), ReadError> {
        let mut points: Vec<OrientedPoint> = positions
            .iter()
            .zip(normals)
            .map(|(&p, &n)| OrientedPoint { p, n })
            .collect();
        let kept = orient_in_place(&mut points)?;
        Ok((points, kept))
    }

    /// The parallel points against a plain loop: unit normals, zero ones left out with the
    /// indices of the kept, the first non-finite normal named.
    #[test]
    fn oriented_points_are_the_plain_loops() {
        let n = 100_003;
        let positions: Vec<DVec3> = (0..n).map(|i| DVec3::new(i as f64, 1.0, 2.0)).collect();
        for zeros in [vec![], vec![0, 5, 70_000, n - 1]] {
            let normals: Vec<DVec3> = (0..n)
                .map(|i| {
                    if zeros.contains(&i) {
                        DVec3::ZERO
                    } else {
                        DVec3::new(1.0, (i % 7) as f64, -3.0)
                    }
                })
                .collect();
            let (points, kept) = raw_oriented(&positions, &normals).unwrap();
            let want: Vec<usize> = (0..n).filter(|i| !zeros.contains(i)).collect();
            assert_eq!(points.len(), want.len());
            for (q, &i) in points.iter().zip(&want) {
                assert_eq!(q.p, positions[i]);
                assert_eq!(Some(q.n), unit(normals[i]));
            }
            assert_eq!(kept, (!zeros.is_empty()).then_some(want));
        }
        let mut normals = vec![DVec3::Z; n];
        normals[90_000] = DVec3::new(f64::INFINITY, 0.0, 0.0);
        normals[60_000] = DVec3::new(0.0, f64::NAN, 0.0);
        let err = raw_oriented(&positions, &normals).unwrap_err();
        assert!(err.to_string().contains("60000"), "{err}");
    }

    #[test]
    fn unit_handles_tiny_and_huge_vectors() {
        let n = unit(DVec3::new(3e-200, 4e-200, 0.0)).unwrap();
        assert!((n - DVec3::new(0.6, 0.8, 0.0)).length() < 1e-15);
        let n = unit(DVec3::new(3e200, 4e200, 0.0)).unwrap();
        assert!((n - DVec3::new(0.6, 0.8, 0.0)).length() < 1e-15);
        assert_eq!(unit(DVec3::ZERO), None);
        assert_eq!(unit(DVec3::new(f64::NAN, 0.0, 1.0)), None);
    }

    #[test]
    fn huge_coordinates_give_finite_centroids() {
        let a = DVec3::splat(1.5e308);
        assert!(centroid(a, a, a).is_finite());
    }
}
