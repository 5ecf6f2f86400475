//! File IO: reading inputs by extension (or content: signatures, then text sniffing; the
//! scanner formats streamed from the file) and writing outputs through a temporary file
//! renamed into place, so a failure never clobbers an existing file.

use std::fs;
use std::io::{BufReader, BufWriter, Write};
use std::path::{Path, PathBuf};

use glam::DVec3;
use psi_io::{Format, PointCloudFile, ReadError, ReadOptions, TriangleMesh};

use psi_octree::PointAttributes;

use crate::PsiError;

pub(crate) fn open_error(path: &Path, reason: std::io::Error) -> PsiError {
    PsiError::Open {
        path: path.to_path_buf(),
        reason,
    }
}

pub(crate) fn read_error(path: &Path) -> impl FnOnce(ReadError) -> PsiError + '_ {
    move |reason| PsiError::Read {
        path: path.to_path_buf(),
        reason,
    }
}

pub(crate) fn check_not_dir(path: &Path) -> Result<(), PsiError> {
    if path.is_dir() {
        return Err(open_error(
            path,
            std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                "is a directory, not a file",
            ),
        ));
    }
    Ok(())
}

fn read_bytes(path: &Path) -> Result<Vec<u8>, PsiError> {
    check_not_dir(path)?;
    crate::read_file::read_file(path).map_err(|e| open_error(path, e))
}

/// The format its extension names (`ply`, `obj`, `xyz`/`pts`/`txt`, `las`, `laz`, `e57`,
/// `pcd`, any case), if any.
pub(crate) fn extension_format(path: &Path) -> Option<Format> {
    path.extension()
        .and_then(|e| e.to_str())
        .and_then(Format::from_extension)
}

/// The format of a file: its extension's; else the signature of its content (PLY, LAS/LAZ,
/// E57, PCD); else, for text, OBJ or XYZ as sniffed. Binary content that neither names is
/// [`ReadError::UnknownFormat`] rather than a text reader's complaint about its bytes.
fn format_of(path: &Path, bytes: &[u8]) -> Result<Format, ReadError> {
    if let Some(format) = extension_format(path).or_else(|| Format::detect(bytes)) {
        return Ok(format);
    }
    if Format::looks_binary(bytes) {
        return Err(ReadError::UnknownFormat {
            extension: path.extension().map(|e| e.to_string_lossy().into_owned()),
        });
    }
    Ok(Format::sniff(bytes))
}

/// Reads oriented points from a PLY, OBJ, XYZ, LAS/LAZ, E57 or PCD file (format from the
/// extension, else from the content). A mesh gives one point per triangle (or per vertex,
/// per `opts`). See [`load_points_as`].
pub fn load_points(path: &Path, opts: &ReadOptions) -> Result<PointCloudFile, PsiError> {
    load_points_as(path, None, opts)
}

/// Reads oriented points from a file as `format`, or when `None` as its extension (else its
/// content) says. LAS/LAZ, E57 and PCD files are read from the file in bounded chunks
/// ([`psi_io::read_points_from`]), not loaded whole first; their colour, intensity and
/// classification are in [`PointCloudFile::attributes`], their format, scans and invalid
/// records in [`PointCloudFile::source`].
///
/// ```
/// let dir = std::env::temp_dir().join(format!("psi-doc-as-{}", std::process::id()));
/// std::fs::create_dir_all(&dir).unwrap();
/// let path = dir.join("cloud.data");
/// std::fs::write(&path, "0 0 0 0 0 1\n1 0 0 0 0 1\n").unwrap();
/// let file = psi::load_points_as(&path, Some(psi::io::Format::Xyz), &psi::ReadOptions::paper()).unwrap();
/// assert_eq!(file.points.len(), 2);
/// std::fs::write(&path, [0u8, 159, 146, 150]).unwrap();
/// let err = psi::load_points(&path, &psi::ReadOptions::paper()).unwrap_err();
/// assert!(err.to_string().contains("unknown file extension `.data`"), "{err}");
/// ```
///
/// # Errors
///
/// [`PsiError::Open`] when the file cannot be opened; [`PsiError::Read`] when it is
/// malformed, truncated, or binary in no format psi knows ([`ReadError::UnknownFormat`]).
pub fn load_points_as(
    path: &Path,
    format: Option<Format>,
    opts: &ReadOptions,
) -> Result<PointCloudFile, PsiError> {
    match format.or_else(|| extension_format(path)) {
        Some(format) if format.is_streamed() => {
            check_not_dir(path)?;
            let file = fs::File::open(path).map_err(|e| open_error(path, e))?;
            psi_io::read_points_from(BufReader::new(file), format, opts).map_err(read_error(path))
        }
        Some(format) => {
            let bytes = read_bytes(path)?;
            let file = psi_io::read_points(&bytes, format, opts).map_err(read_error(path));
            psi_io::free_aside(bytes);
            file
        }
        None => {
            let bytes = read_bytes(path)?;
            let format = format_of(path, &bytes).map_err(read_error(path))?;
            psi_io::read_points(&bytes, format, opts).map_err(read_error(path))
        }
    }
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
    /// Colours, intensities and LAS classes (aligned; empty when the file has none): a PLY's
    /// `red green blue` (0–255), `intensity` and `classification`, or another format's
    /// attributes.
    pub attributes: PointAttributes,
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
    let format = format_of(path, &bytes).map_err(read_error)?;
    if format != Format::Ply {
        let file =
            psi_io::read_points(&bytes, format, &ReadOptions::paper()).map_err(read_error)?;
        return Ok(ParticleColumns {
            positions: file.points.iter().map(|p| p.p).collect(),
            normals: file.points.iter().map(|p| p.n).collect(),
            depth: None,
            sigma: None,
            attributes: file.attributes,
        });
    }
    let names = [
        "x",
        "y",
        "z",
        "nx",
        "ny",
        "nz",
        "depth",
        "sigma",
        "red",
        "green",
        "blue",
        "intensity",
        "classification",
    ];
    let mut columns = psi_io::read_point_scalars(&bytes, &names).map_err(read_error)?;
    let classification = columns.pop().flatten();
    let intensity = columns.pop().flatten();
    let rgb: Vec<Option<Vec<f64>>> = columns.split_off(8);
    let sigma = columns.pop().flatten();
    let depth = columns.pop().flatten();
    let byte = |v: f64| v.round().clamp(0.0, 255.0) as u8;
    let colors = match &rgb[..] {
        [Some(r), Some(g), Some(b)] => Some(
            r.iter()
                .zip(g)
                .zip(b)
                .map(|((&r, &g), &b)| [byte(r), byte(g), byte(b)])
                .collect(),
        ),
        _ => None,
    };
    let attributes = PointAttributes {
        colors,
        intensity: intensity.map(|v| v.into_iter().map(|x| x as f32).collect()),
        classification: classification.map(|v| v.into_iter().map(byte).collect()),
    };
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
        attributes,
    })
}

/// Reads a triangle mesh (a reference mesh, say) from a PLY or OBJ file.
pub fn load_mesh(path: &Path) -> Result<TriangleMesh, PsiError> {
    let bytes = read_bytes(path)?;
    let format = format_of(path, &bytes).map_err(read_error(path))?;
    psi_io::read_mesh(&bytes, format).map_err(read_error(path))
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

/// Writes particles and their `attributes` (aligned, or empty) by the path's extension: LAS or
/// LAZ for `.las`/`.laz` ([`psi_io::write_las`]: positions and attributes), else binary
/// little-endian PLY with `x y z nx ny nz depth sigma` (doubles) and the attribute columns.
pub fn save_particles(
    path: &Path,
    particles: &psi_particles::Particles,
    attributes: &PointAttributes,
) -> Result<(), PsiError> {
    let depth: Vec<f64> = particles.depth.iter().map(|&d| f64::from(d)).collect();
    let scalars = [("depth", &depth[..]), ("sigma", &particles.sigma[..])];
    write_particles(
        path,
        &particles.positions,
        &particles.normals,
        &scalars,
        attributes,
    )
}

/// Writes particle columns as [`save_particles`] does, `depth` and `sigma` only when present
/// (particles from arrays or another tool may lack them).
pub fn save_particle_columns(path: &Path, columns: &ParticleColumns) -> Result<(), PsiError> {
    let mut scalars: Vec<(&str, &[f64])> = Vec::new();
    if let Some(d) = &columns.depth {
        scalars.push(("depth", d));
    }
    if let Some(s) = &columns.sigma {
        scalars.push(("sigma", s));
    }
    write_particles(
        path,
        &columns.positions,
        &columns.normals,
        &scalars,
        &columns.attributes,
    )
}

/// Whether `path` names a LAS or LAZ file (`Some(compressed)`) by its extension.
fn las_output(path: &Path) -> Option<bool> {
    let ext = path.extension()?.to_str()?.to_ascii_lowercase();
    match ext.as_str() {
        "las" => Some(false),
        "laz" => Some(true),
        _ => None,
    }
}

/// The one writer of particle files: LAS/LAZ by extension (built in memory, which a LAS
/// header's last-written counts need), else PLY; through a temporary file renamed into place.
fn write_particles(
    path: &Path,
    positions: &[DVec3],
    normals: &[DVec3],
    scalars: &[(&str, &[f64])],
    attributes: &PointAttributes,
) -> Result<(), PsiError> {
    if let Some(compressed) = las_output(path) {
        let mut bytes = std::io::Cursor::new(Vec::new());
        psi_io::write_las(&mut bytes, positions, attributes, compressed).map_err(|e| {
            PsiError::Write {
                path: path.to_path_buf(),
                reason: to_io(e),
            }
        })?;
        return write_atomically(path, |w| w.write_all(bytes.get_ref()));
    }
    write_atomically(path, |w| {
        let mut w = w;
        psi_io::write_points_ply_with_attributes(&mut w, positions, normals, scalars, attributes)
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
