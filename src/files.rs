//! File IO: reading inputs by extension (or content sniffing) and writing outputs through a
//! temporary file renamed into place, so a failure never clobbers an existing file.

use std::fs;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use psi_io::{Format, PointCloudFile, ReadOptions, TriangleMesh};

use crate::PsiError;

fn read_bytes(path: &Path) -> Result<Vec<u8>, PsiError> {
    let open = |source| PsiError::Open {
        path: path.to_path_buf(),
        source,
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
    psi_io::read_points(&bytes, format_of(path, &bytes), opts).map_err(|source| PsiError::Read {
        path: path.to_path_buf(),
        source,
    })
}

/// Reads a triangle mesh (a reference mesh, say) from a PLY or OBJ file.
pub fn load_mesh(path: &Path) -> Result<TriangleMesh, PsiError> {
    let bytes = read_bytes(path)?;
    psi_io::read_mesh(&bytes, format_of(path, &bytes)).map_err(|source| PsiError::Read {
        path: path.to_path_buf(),
        source,
    })
}

/// Writes `path` by calling `write` on a buffered temporary file in the same directory, then
/// renaming it into place. On any failure the temporary file is removed and `path` is untouched.
pub fn write_atomically(
    path: &Path,
    write: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<(), PsiError> {
    let fail = |source| PsiError::Write {
        path: path.to_path_buf(),
        source,
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
