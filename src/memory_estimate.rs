//! Whether an input fits in memory before it is read: its point count from its header (or its
//! size), the memory an in-core run of that many points takes, and the memory available. A run
//! that would not fit says so up front and suggests `--max-memory`, instead of being killed.

use std::fs;
use std::io::BufReader;
use std::path::Path;

use psi_io::{Format, PointStream};

use crate::PsiError;
use crate::files::{extension_format, open_error};

/// Bytes of an in-core run beyond its points (the program, the tables of a small input).
const BASE_BYTES: u64 = 40 << 20;
/// Bytes a point with normals costs in core besides the data footprint's table (from measured
/// peaks: docs/results/2026-11-25-scale, `cargo xtask bench scale`;
/// docs/results/2026-11-29-shared-index for the table's share).
const BYTES_PER_POINT: u64 = 180;
/// The data footprint's table: 64 bytes a point for inputs of up to
/// [`psi_mpu::FOOTPRINT_SPARSE_ABOVE`] points; larger inputs' tables are sparse (the entries
/// near particles, a few megabytes).
const TABLE_BYTES_PER_POINT: u64 = 64;
/// Bytes a point without normals costs (normals estimated and oriented; issue 30's 30 M-point
/// measurement).
const BYTES_PER_BARE_POINT: u64 = 350;
/// Bytes of a line of XYZ text, for a count from the file's size.
const XYZ_LINE_BYTES: u64 = 40;

/// The points in the file at `path` (read as `format`, or as its extension says) and whether
/// they carry normals (`None`: not known before reading): from the header of LAS/LAZ, E57,
/// PCD and PLY point clouds, else from the file's size.
pub fn estimate_points(
    path: &Path,
    format: Option<Format>,
) -> Result<(u64, Option<bool>), PsiError> {
    let len = fs::metadata(path).map_err(|e| open_error(path, e))?.len();
    let format = format.or_else(|| extension_format(path));
    let streamed = matches!(
        format,
        Some(Format::Las | Format::Laz | Format::E57 | Format::Pcd | Format::Ply)
    );
    if let Some(f) = format.filter(|_| streamed) {
        let file = fs::File::open(path).map_err(|e| open_error(path, e))?;
        if let Ok(stream) = PointStream::open(BufReader::new(file), f) {
            let h = stream.header();
            return Ok((h.announced_points, Some(h.normals)));
        }
    }
    // XYZ, OBJ and PLY meshes: about a point per line or per triangle's worth of bytes.
    Ok((len / XYZ_LINE_BYTES, None))
}

/// Bytes an in-core `psi sample` of `points` points takes at its peak (within about 25 %),
/// with or without normals in the file.
pub fn estimate_in_core_bytes(points: u64, normals: bool) -> u64 {
    if !normals {
        // (The peak is the orientation's, before the MPU and its table.)
        return BASE_BYTES.saturating_add(points.saturating_mul(BYTES_PER_BARE_POINT));
    }
    let table = if points <= psi_mpu::FOOTPRINT_SPARSE_ABOVE as u64 {
        points * TABLE_BYTES_PER_POINT
    } else {
        0
    };
    BASE_BYTES
        .saturating_add(points.saturating_mul(BYTES_PER_POINT))
        .saturating_add(table)
}

/// The memory available to a new run (Linux `MemAvailable`), bytes; `PSI_AVAILABLE_MEMORY`
/// overrides it (tests); `None` when unknown.
pub fn available_memory_bytes() -> Option<u64> {
    if let Some(v) = std::env::var("PSI_AVAILABLE_MEMORY")
        .ok()
        .and_then(|v| v.parse().ok())
    {
        return Some(v);
    }
    let info = fs::read_to_string("/proc/meminfo").ok()?;
    let line = info.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// Refuses, before anything is read, an in-core run on the file at `path` that would need
/// more memory than is available, naming both and suggesting `--max-memory`.
///
/// # Errors
///
/// [`PsiError::OutOfCore`] when it would not fit; [`PsiError::Open`] when the file cannot be
/// read.
pub fn check_fits_in_memory(path: &Path, format: Option<Format>) -> Result<(), PsiError> {
    let Some(available) = available_memory_bytes() else {
        return Ok(());
    };
    let (points, normals) = estimate_points(path, format)?;
    let need = estimate_in_core_bytes(points, normals.unwrap_or(true));
    if need > available {
        return Err(PsiError::OutOfCore {
            path: path.to_path_buf(),
            reason: format!(
                "about {points} points need about {} in memory and {} is available: run out \
                 of core with --max-memory SIZE (Python: sample_files)",
                size_text(need),
                size_text(available)
            ),
        });
    }
    Ok(())
}

/// `bytes` as MiB or GiB, one decimal.
fn size_text(bytes: u64) -> String {
    let mib = bytes as f64 / f64::from(1u32 << 20);
    if mib < 1024.0 {
        format!("{mib:.1} MiB")
    } else {
        format!("{:.1} GiB", mib / 1024.0)
    }
}
