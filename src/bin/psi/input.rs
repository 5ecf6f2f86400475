//! Loading the input (a file or the built-in model) with a description for reports.

use anyhow::Context;
use psi::{MeshSampling, OrientedPoint, PointCloudFile, ReadOptions};
use serde_json::json;

use crate::InputArgs;

/// Peak resident memory of this process so far (Linux `VmHWM`), bytes; `None` elsewhere.
pub(crate) fn peak_memory_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// What was loaded.
pub(crate) struct Loaded {
    pub(crate) name: String,
    pub(crate) file: PointCloudFile,
    /// Same-sheet neighbour pairs with opposed normals (before any reorientation).
    pub(crate) normals: psi::preprocess::NormalConsistency,
    /// Normals flipped by `--orient-normals`.
    pub(crate) flipped: usize,
}

impl Loaded {
    pub(crate) fn points(&self) -> &[OrientedPoint] {
        &self.file.points
    }

    /// The report's `input` object.
    pub(crate) fn json(&self) -> serde_json::Value {
        let bbox = psi::Aabb::from_points(self.file.points.iter().map(|p| p.p));
        json!({
            "source": self.name,
            "points": self.file.points.len(),
            "vertices": self.file.vertices,
            "faces": self.file.faces,
            "degenerate_faces": self.file.degenerate_faces,
            "dropped_points": self.file.dropped_points,
            "bbox_min": bbox.map(|b| b.min.to_array()),
            "bbox_max": bbox.map(|b| b.max.to_array()),
            "bbox_diagonal": bbox.map_or(0.0, |b| b.diagonal()),
            "normals": {
                "pairs_checked": self.normals.pairs,
                "opposed_fraction": self.normals.opposed_fraction(),
                "flipped_by_orient_normals": self.flipped,
            },
        })
    }
}

pub(crate) fn load(args: &InputArgs) -> anyhow::Result<Loaded> {
    let (name, mut file) = match &args.input {
        None => {
            let n = args
                .builtin_points
                .unwrap_or(psi::shapes::BUILTIN_MODEL_POINTS);
            let points = psi::shapes::sample_builtin(n, psi::shapes::BUILTIN_MODEL_SEED);
            (
                "builtin".to_owned(),
                PointCloudFile {
                    points,
                    vertices: n,
                    faces: 0,
                    degenerate_faces: 0,
                    dropped_points: 0,
                    mesh: None,
                },
            )
        }
        Some(path) => {
            let sampling = if args.per_vertex {
                MeshSampling::VertexNormals
            } else {
                MeshSampling::FaceCentroids
            };
            let file =
                psi::load_points(path, &ReadOptions { sampling }).context("reading the input")?;
            (path.display().to_string(), file)
        }
    };
    let normals = psi::preprocess::check_normal_consistency(&file.points, 20_000);
    let mut flipped = 0;
    if args.orient_normals {
        flipped = psi::preprocess::orient_normals(&mut file.points);
    } else if normals.opposed_fraction() > 0.01 {
        eprintln!(
            "psi: warning: {name}: {:.1} % of neighbouring normals point to opposite sides; try --orient-normals",
            100.0 * normals.opposed_fraction()
        );
    }
    Ok(Loaded {
        name,
        file,
        normals,
        flipped,
    })
}
