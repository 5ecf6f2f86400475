//! File IO: reading inputs by extension (or content sniffing) and writing outputs through a
//! temporary file renamed into place, so a failure never clobbers an existing file.

use std::fs;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use glam::DVec3;
use psi_io::{Format, PointCloudFile, ReadError, ReadOptions, TriangleMesh};

use crate::PsiError;

fn read_bytes(path: &Path) -> Result<Vec<u8>, PsiError> {
    let open = |reason| PsiError::Open {
        path: path.to_path_buf(),
        reason,
    };
    if path.is_dir() {
        return Err(open(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "is a directory, not a file",
        )));
    }
    fs::read(path).map_err(open)
}

fn format_of(path: &Path, bytes: &[u8]) -> Format {
    path.extension()
        .and_then(|e| e.to_str())
        .and_then(Format::from_extension)
        .unwrap_or_else(|| Format::sniff(bytes))
}

/// Reads oriented points from a PLY, OBJ or XYZ file (format from the extension, else sniffed).
/// A mesh gives one point per triangle (or per vertex, per `opts`).
pub fn load_points(path: &Path, opts: &ReadOptions) -> Result<PointCloudFile, PsiError> {
    let bytes = read_bytes(path)?;
    psi_io::read_points(&bytes, format_of(path, &bytes), opts).map_err(|reason| PsiError::Read {
        path: path.to_path_buf(),
        reason,
    })
}

/// The columns of a particle file (what [`save_particles`] writes), aligned index by index.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ParticleColumns {
    /// Positions (shape: N), world units.
    pub positions: Vec<DVec3>,
    /// Normals (shape: N) as stored (unit for psi's particles).
    pub normals: Vec<DVec3>,
    /// Octree depth of each particle's leaf (shape: N), when the file has a `depth` property.
    pub depth: Option<Vec<f64>>,
    /// Repulsion radius σ (shape: N, world units), when the file has a `sigma` property.
    pub sigma: Option<Vec<f64>>,
}

/// Reads particles: from a PLY its `vertex` columns `x y z nx ny nz` and, when present,
/// `depth` and `sigma`, every record kept (see [`psi_io::read_point_scalars`]); from any other
/// file the oriented points of [`load_points`] (no `depth` or `sigma`).
///
/// ```
/// let dir = std::env::temp_dir().join(format!("psi-doc-particles-{}", std::process::id()));
/// std::fs::create_dir_all(&dir).unwrap();
/// let path = dir.join("p.xyz");
/// std::fs::write(&path, "0 0 0 0 0 1\n1 0 0 0 0 1\n").unwrap();
/// let p = psi::load_particles(&path).unwrap();
/// assert_eq!((p.positions.len(), p.depth), (2, None));
/// ```
///
/// # Errors
///
/// [`PsiError::Open`] when the file cannot be read; [`PsiError::Read`] when it is malformed,
/// a PLY lacks `x y z` (a header error) or `nx ny nz` ([`ReadError::NoNormals`]), or a value
/// is NaN or infinite.
pub fn load_particles(path: &Path) -> Result<ParticleColumns, PsiError> {
    let bytes = read_bytes(path)?;
    let read_error = |reason| PsiError::Read {
        path: path.to_path_buf(),
        reason,
    };
    if format_of(path, &bytes) != Format::Ply {
        let file = psi_io::read_points(&bytes, format_of(path, &bytes), &ReadOptions::paper())
            .map_err(read_error)?;
        return Ok(ParticleColumns {
            positions: file.points.iter().map(|p| p.p).collect(),
            normals: file.points.iter().map(|p| p.n).collect(),
            depth: None,
            sigma: None,
        });
    }
    let names = ["x", "y", "z", "nx", "ny", "nz", "depth", "sigma"];
    let mut columns = psi_io::read_point_scalars(&bytes, &names).map_err(read_error)?;
    let sigma = columns.pop().flatten();
    let depth = columns.pop().flatten();
    let vectors = |c: &[Option<Vec<f64>>]| match c {
        [Some(x), Some(y), Some(z)] => Some(
            x.iter()
                .zip(y)
                .zip(z)
                .map(|((&x, &y), &z)| DVec3::new(x, y, z))
                .collect::<Vec<_>>(),
        ),
        _ => None,
    };
    let positions = vectors(&columns[..3]).ok_or_else(|| {
        read_error(ReadError::Header {
            reason: "the `vertex` element needs scalar properties `x y z`".to_owned(),
        })
    })?;
    let normals = vectors(&columns[3..]).ok_or_else(|| read_error(ReadError::NoNormals))?;
    Ok(ParticleColumns {
        positions,
        normals,
        depth,
        sigma,
    })
}

/// Reads a triangle mesh (a reference mesh, say) from a PLY or OBJ file.
pub fn load_mesh(path: &Path) -> Result<TriangleMesh, PsiError> {
    let bytes = read_bytes(path)?;
    psi_io::read_mesh(&bytes, format_of(path, &bytes)).map_err(|reason| PsiError::Read {
        path: path.to_path_buf(),
        reason,
    })
}

/// Whether `a` and `b` name the same existing file (after resolving links and relative
/// parts); false when either does not exist.
///
/// ```
/// let dir = std::env::temp_dir();
/// let file = dir.join(format!("psi-doc-same-{}.txt", std::process::id()));
/// std::fs::write(&file, b"x").unwrap();
/// assert!(psi::same_file(&file, &dir.join(".").join(file.file_name().unwrap())));
/// assert!(!psi::same_file(&file, &dir.join("no-such-file")));
/// ```
pub fn same_file(a: &Path, b: &Path) -> bool {
    match (fs::canonicalize(a), fs::canonicalize(b)) {
        (Ok(a), Ok(b)) => a == b,
        _ => false,
    }
}

/// Writes `path` by calling `write` on a buffered temporary file in the same directory, then
/// renaming it into place. On any failure the temporary file is removed and `path` is untouched.
pub fn write_atomically(
    path: &Path,
    write: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<(), PsiError> {
    let fail = |reason| PsiError::Write {
        path: path.to_path_buf(),
        reason,
    };
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let name = path.file_name().ok_or_else(|| {
        fail(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "not a file name",
        ))
    })?;
    let tmp = dir.join(format!(
        ".{}.tmp{}",
        name.to_string_lossy(),
        std::process::id()
    ));
    let result = (|| {
        let file = fs::File::create(&tmp)?;
        let mut out = BufWriter::new(file);
        write(&mut out)?;
        out.flush()?;
        out.get_ref().sync_all()?;
        drop(out);
        fs::rename(&tmp, path)
    })();
    if let Err(e) = result {
        let _ = fs::remove_file(&tmp);
        return Err(fail(e));
    }
    Ok(())
}

fn to_io(e: psi_io::WriteError) -> std::io::Error {
    match e {
        psi_io::WriteError::Io(e) => e,
        other => std::io::Error::new(std::io::ErrorKind::InvalidData, other.to_string()),
    }
}

/// Writes particles as binary little-endian PLY: x y z nx ny nz depth sigma (doubles).
pub fn save_particles(path: &Path, particles: &psi_particles::Particles) -> Result<(), PsiError> {
    let depth: Vec<f64> = particles.depth.iter().map(|&d| f64::from(d)).collect();
    write_atomically(path, |w| {
        let mut w = w;
        psi_io::write_points_ply(
            &mut w,
            &particles.positions,
            &particles.normals,
            &[("depth", &depth), ("sigma", &particles.sigma)],
        )
        .map_err(to_io)
    })
}

/// Writes particle columns as binary little-endian PLY: x y z nx ny nz, then `depth` and
/// `sigma` (doubles) when present (particles from arrays or another tool may lack them).
pub fn save_particle_columns(path: &Path, columns: &ParticleColumns) -> Result<(), PsiError> {
    let mut extra: Vec<(&str, &[f64])> = Vec::new();
    if let Some(d) = &columns.depth {
        extra.push(("depth", d));
    }
    if let Some(s) = &columns.sigma {
        extra.push(("sigma", s));
    }
    write_atomically(path, |w| {
        let mut w = w;
        psi_io::write_points_ply(&mut w, &columns.positions, &columns.normals, &extra)
            .map_err(to_io)
    })
}

/// Writes oriented points as binary little-endian PLY: x y z nx ny nz (doubles), through a
/// temporary file renamed into place.
pub fn save_points(path: &Path, points: &[psi_octree::OrientedPoint]) -> Result<(), PsiError> {
    let positions: Vec<DVec3> = points.iter().map(|p| p.p).collect();
    let normals: Vec<DVec3> = points.iter().map(|p| p.n).collect();
    write_atomically(path, |w| {
        let mut w = w;
        psi_io::write_points_ply(&mut w, &positions, &normals, &[]).map_err(to_io)
    })
}

/// Writes a triangle mesh as binary little-endian PLY.
pub fn save_mesh(path: &Path, mesh: &psi_mpu::TriangleSoup) -> Result<(), PsiError> {
    let mesh = TriangleMesh {
        vertices: mesh.vertices.clone(),
        faces: mesh.faces.clone(),
    };
    write_atomically(path, |w| {
        let mut w = w;
        psi_io::write_mesh_ply(&mut w, &mesh).map_err(to_io)
    })
}

/// Writes a JSON value, pretty-printed.
pub fn save_json(path: &Path, value: &serde_json::Value) -> Result<(), PsiError> {
    write_atomically(path, |w| {
        serde_json::to_writer_pretty(&mut *w, value).map_err(std::io::Error::other)?;
        w.write_all(b"\n")
    })
}
