//! Binary little-endian PLY writers for oriented points (with scalar channels and attribute
//! columns) and meshes.

use std::collections::HashSet;
use std::io::Write;

use glam::DVec3;

use crate::attributes::PointAttributes;
use crate::error::WriteError;
use crate::model::TriangleMesh;

/// Bytes gathered before each `write_all`, so an unbuffered writer sees few large writes.
const CHUNK: usize = 1 << 16;

/// Writes oriented points as a binary little-endian PLY: one `vertex` element with
/// `property double x y z nx ny nz`, then one `property double <name>` per scalar channel in
/// the given order. MeshLab, Open3D and trimesh read it.
///
/// * `positions`: N points, world units.
/// * `normals`: N normals, written as given (not normalised).
/// * `scalars`: channels `(name, values)`, each with N values (e.g. `("depth", ..)`,
///   `("sigma", ..)`). Names must be PLY identifiers (`[A-Za-z_][A-Za-z0-9_-]*`), unique, and
///   not one of `x y z nx ny nz`.
///
/// Values are written bit-exactly, including NaN or infinity (which [`crate::read_points`]
/// would then reject). Nothing is written when an argument is invalid.
///
/// ```
/// use glam::DVec3;
/// use psi_io::{read_points, write_points_ply, Format, ReadOptions};
///
/// let positions = [DVec3::new(0.0, 0.0, 1.0), DVec3::new(1.0, 0.0, 0.0)];
/// let normals = [DVec3::Z, DVec3::X];
/// let depth = [0.0, 1.0];
/// let mut bytes = Vec::new();
/// write_points_ply(&mut bytes, &positions, &normals, &[("depth", &depth)]).unwrap();
/// let back = read_points(&bytes, Format::Ply, &ReadOptions::paper()).unwrap();
/// assert_eq!(back.points[1].p, positions[1]);
/// assert_eq!(back.points[1].n, normals[1]);
/// ```
pub fn write_points_ply(
    out: &mut impl Write,
    positions: &[DVec3],
    normals: &[DVec3],
    scalars: &[(&str, &[f64])],
) -> Result<(), WriteError> {
    write_points_ply_with_attributes(
        out,
        positions,
        normals,
        scalars,
        &PointAttributes::default(),
    )
}

/// Writes oriented points with their attributes as a binary little-endian PLY: the columns of
/// [`write_points_ply`] (`x y z nx ny nz` and the scalar channels, doubles), then, for each
/// attribute column present, `property uchar red green blue` (colour), `property float
/// intensity` and `property uchar classification`, in that order. These are the names psi's
/// readers, CloudCompare and MeshLab use for colour and intensity.
///
/// * `positions`, `normals`, `scalars`: as for [`write_points_ply`].
/// * `attributes`: each present column with N entries, written as stored (8-bit colour,
///   intensity bit-exact as f32, classification byte); absent columns are not declared.
///   Scalar channel names must not be those of a present attribute column.
///
/// With no attribute column the bytes are those of [`write_points_ply`]. Nothing is written
/// when an argument is invalid.
///
/// ```
/// use glam::DVec3;
/// use psi_io::{read_point_scalars, read_points, write_points_ply_with_attributes, Format,
///              PointAttributes, ReadOptions};
///
/// let positions = [DVec3::ZERO, DVec3::X];
/// let normals = [DVec3::Z, DVec3::Z];
/// let attributes = PointAttributes {
///     colors: Some(vec![[255, 0, 0], [0, 0, 255]]),
///     intensity: Some(vec![0.5, 1200.0]),
///     classification: Some(vec![2, 6]),
/// };
/// let mut bytes = Vec::new();
/// write_points_ply_with_attributes(&mut bytes, &positions, &normals, &[("sigma", &[0.1, 0.2])], &attributes)
///     .unwrap();
/// let back = read_points(&bytes, Format::Ply, &ReadOptions::paper()).unwrap();
/// assert_eq!(back.attributes.colors, attributes.colors);
/// assert_eq!(back.attributes.intensity, attributes.intensity);
/// let columns = read_point_scalars(&bytes, &["classification", "sigma"]).unwrap();
/// assert_eq!(columns[0], Some(vec![2.0, 6.0]));
/// ```
pub fn write_points_ply_with_attributes(
    out: &mut impl Write,
    positions: &[DVec3],
    normals: &[DVec3],
    scalars: &[(&str, &[f64])],
    attributes: &PointAttributes,
) -> Result<(), WriteError> {
    let n = positions.len();
    check_length("normals", n, normals.len())?;
    check_attribute_lengths(attributes, n)?;
    let attribute_names = attribute_properties(attributes);
    let mut seen = HashSet::new();
    for &(name, values) in scalars {
        check_name(name)?;
        if !seen.insert(name) {
            return Err(WriteError::InvalidName {
                name: name.to_owned(),
                reason: "the name is used by two channels",
            });
        }
        if attribute_names.iter().any(|&(_, a)| a == name) {
            return Err(WriteError::InvalidName {
                name: name.to_owned(),
                reason: "the name is taken by an attribute column",
            });
        }
        check_length(name, n, values.len())?;
    }

    let mut header = format!(
        "ply\nformat binary_little_endian 1.0\ncomment written by psi-io\nelement vertex {n}\n"
    );
    for name in ["x", "y", "z", "nx", "ny", "nz"]
        .into_iter()
        .chain(scalars.iter().map(|&(name, _)| name))
    {
        header.push_str("property double ");
        header.push_str(name);
        header.push('\n');
    }
    for (ty, name) in &attribute_names {
        header.push_str(&format!("property {ty} {name}\n"));
    }
    header.push_str("end_header\n");
    out.write_all(header.as_bytes())?;

    let mut buf = Vec::with_capacity(CHUNK + 64);
    for i in 0..n {
        let (p, nv) = (positions[i], normals[i]);
        for v in [p.x, p.y, p.z, nv.x, nv.y, nv.z] {
            buf.extend_from_slice(&v.to_le_bytes());
        }
        for &(_, values) in scalars {
            buf.extend_from_slice(&values[i].to_le_bytes());
        }
        if let Some(colors) = &attributes.colors {
            buf.extend_from_slice(&colors[i]);
        }
        if let Some(intensity) = &attributes.intensity {
            buf.extend_from_slice(&intensity[i].to_le_bytes());
        }
        if let Some(classes) = &attributes.classification {
            buf.push(classes[i]);
        }
        flush_full(out, &mut buf)?;
    }
    out.write_all(&buf)?;
    out.flush()?;
    Ok(())
}

/// The PLY properties (type, name) of the attribute columns present, in the order written.
fn attribute_properties(attributes: &PointAttributes) -> Vec<(&'static str, &'static str)> {
    let mut properties = Vec::new();
    if attributes.colors.is_some() {
        properties.extend([("uchar", "red"), ("uchar", "green"), ("uchar", "blue")]);
    }
    if attributes.intensity.is_some() {
        properties.push(("float", "intensity"));
    }
    if attributes.classification.is_some() {
        properties.push(("uchar", "classification"));
    }
    properties
}

/// Writes a triangle mesh as a binary little-endian PLY: `element vertex` with
/// `property float x y z` (positions rounded to f32, world units), then `element face` with
/// `property list uchar int vertex_indices` (always 3 indices). This is the layout of the
/// models in `shared/models`.
///
/// Fails with [`WriteError::IndexOutOfRange`] (before writing anything) when a face refers to
/// a missing vertex or to an index above `i32::MAX`.
///
/// ```
/// use glam::DVec3;
/// use psi_io::{read_mesh, write_mesh_ply, Format, TriangleMesh};
///
/// let mesh = TriangleMesh {
///     vertices: vec![DVec3::ZERO, DVec3::X, DVec3::Y],
///     faces: vec![[0, 1, 2]],
/// };
/// let mut bytes = Vec::new();
/// write_mesh_ply(&mut bytes, &mesh).unwrap();
/// assert_eq!(read_mesh(&bytes, Format::Ply).unwrap(), mesh);
/// ```
pub fn write_mesh_ply(out: &mut impl Write, mesh: &TriangleMesh) -> Result<(), WriteError> {
    let vertices = mesh.vertices.len();
    for (face, f) in mesh.faces.iter().enumerate() {
        if let Some(&vertex) = f
            .iter()
            .find(|&&i| i as usize >= vertices || i > i32::MAX as u32)
        {
            return Err(WriteError::IndexOutOfRange {
                face,
                vertex,
                vertices,
            });
        }
    }
    let header = format!(
        "ply\nformat binary_little_endian 1.0\ncomment written by psi-io\n\
         element vertex {vertices}\nproperty float x\nproperty float y\nproperty float z\n\
         element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        mesh.faces.len()
    );
    out.write_all(header.as_bytes())?;

    let mut buf = Vec::with_capacity(CHUNK + 64);
    for v in &mesh.vertices {
        for c in [v.x, v.y, v.z] {
            buf.extend_from_slice(&(c as f32).to_le_bytes());
        }
        flush_full(out, &mut buf)?;
    }
    for f in &mesh.faces {
        buf.push(3);
        for &i in f {
            // Checked above: i <= i32::MAX.
            buf.extend_from_slice(&(i as i32).to_le_bytes());
        }
        flush_full(out, &mut buf)?;
    }
    out.write_all(&buf)?;
    out.flush()?;
    Ok(())
}

/// Writes `buf` out and empties it once it holds a chunk (the writers' buffering).
fn flush_full(out: &mut impl Write, buf: &mut Vec<u8>) -> std::io::Result<()> {
    if buf.len() >= CHUNK {
        out.write_all(buf)?;
        buf.clear();
    }
    Ok(())
}

/// Checks that every present attribute column has `n` entries.
pub(crate) fn check_attribute_lengths(
    attributes: &PointAttributes,
    n: usize,
) -> Result<(), WriteError> {
    let lengths = [
        ("colors", attributes.colors.as_ref().map(Vec::len)),
        ("intensity", attributes.intensity.as_ref().map(Vec::len)),
        (
            "classification",
            attributes.classification.as_ref().map(Vec::len),
        ),
    ];
    for (what, len) in lengths {
        if let Some(got) = len {
            check_length(what, n, got)?;
        }
    }
    Ok(())
}

fn check_length(what: &str, expected: usize, got: usize) -> Result<(), WriteError> {
    if expected == got {
        Ok(())
    } else {
        Err(WriteError::LengthMismatch {
            what: what.to_owned(),
            expected,
            got,
        })
    }
}

/// A scalar channel name must be a PLY identifier that does not clash with the fixed columns.
fn check_name(name: &str) -> Result<(), WriteError> {
    let invalid = |reason| {
        Err(WriteError::InvalidName {
            name: name.to_owned(),
            reason,
        })
    };
    let mut chars = name.chars();
    match chars.next() {
        None => return invalid("the name is empty"),
        Some(c) if !(c.is_ascii_alphabetic() || c == '_') => {
            return invalid("a name starts with an ASCII letter or `_`");
        }
        Some(_) => {}
    }
    if !chars.all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-') {
        return invalid("a name holds only ASCII letters, digits, `_` and `-`");
    }
    if ["x", "y", "z", "nx", "ny", "nz"].contains(&name) {
        return invalid("the name is taken by a position or normal column");
    }
    Ok(())
}
