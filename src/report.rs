//! The JSON reports of a run, assembled in one place so that the CLI's `--json` files and the
//! Python package's `report` dictionaries are the same objects. Wiring only: every number comes
//! from a layer's report.

use psi_io::{NormalSource, PointCloudFile};
use psi_mpu::Mpu;
use psi_octree::{Aabb, OrientedPoint};
use psi_particles::{ParticleParams, SampleReport};
use psi_preprocess::{ErrorThreshold, PreprocessReport};
use serde_json::{Value, json};

/// What was read and how it was prepared: the facts behind a report's `input` object.
#[derive(Clone, Copy, Debug)]
pub struct InputFacts<'a> {
    /// The input's name: the file as given, `builtin`, or the caller's name for arrays.
    pub name: &'a str,
    /// What the file held (its points may have been moved out; only the counts are read).
    pub file: &'a PointCloudFile,
    /// Points read from the file, before preprocessing.
    pub points_read: usize,
    /// The points passed to the MPU, after preprocessing.
    pub points: &'a [OrientedPoint],
    /// What preprocessing did.
    pub prep: &'a PreprocessReport,
}

/// The report's `input` object (what `psi info --json` prints): counts, bounding box of the
/// prepared points, the normals' source and treatment, outliers, noise, denoising and the
/// preprocessing's seconds.
pub fn input_json(input: &InputFacts<'_>) -> Value {
    let bbox = Aabb::from_points(input.points.iter().map(|p| p.p));
    let p = input.prep;
    let file = input.file;
    let source = match file.normals {
        NormalSource::File => "file",
        NormalSource::Faces => "faces",
        NormalSource::Vertices => "vertices",
        NormalSource::Missing => "estimated",
    };
    json!({
        "source": input.name,
        "points": input.points.len(),
        "points_read": input.points_read,
        "vertices": file.vertices,
        "faces": file.faces,
        "degenerate_faces": file.degenerate_faces,
        "mesh_coarseness": p.mesh.map(|m| m.coarseness),
        "mesh_points_added": p.mesh.map_or(0, |m| m.points_added),
        "dropped_points": file.dropped_points,
        "bbox_min": bbox.map(|b| b.min.to_array()),
        "bbox_max": bbox.map(|b| b.max.to_array()),
        "bbox_diagonal": bbox.map_or(0.0, |b| b.diagonal()),
        "normals": {
            "source": source,
            "treatment": p.normals,
            "pairs_checked": p.consistency.map(|c| c.pairs),
            "opposed_fraction": p.consistency.map(|c| c.opposed_fraction()),
            "flipped": p.normals_flipped,
        },
        "inward_normals_flipped": p.inward_normals_flipped,
        "repeated_points": p.repeated,
        "outliers": p.outliers,
        "noise_estimate": p.noise.map(|n| json!({
            "sigma": n.sigma,
            "relative": p.noise_rel,
            "samples": n.samples,
            "relative_after_denoising": p.noise_rel_after,
        })),
        "denoised": p.denoised,
        "preprocess_seconds": p.seconds,
    })
}

/// A sampling run: what [`sample_json`] reports on.
#[derive(Clone, Copy, Debug)]
pub struct SampleFacts<'a> {
    /// The `input` object ([`input_json`]).
    pub input: &'a Value,
    /// The MPU that was sampled.
    pub mpu: &'a Mpu,
    /// Its error threshold and where it came from.
    pub threshold: ErrorThreshold,
    /// The sampling's report.
    pub sampling: &'a SampleReport,
    /// The sampling's parameters.
    pub params: &'a ParticleParams,
    /// Seconds of one `value_and_gradient` at a particle, when measured.
    pub evaluation_floor: Option<f64>,
    /// Peak resident memory of the process when the run ended ([`peak_memory_bytes`]).
    pub peak_memory_bytes: Option<u64>,
}

/// The report `psi sample --json` writes: the `input`, `mpu` (with the share of its zero set
/// backed by data, [`psi_mpu::data_coverage`], computed here) and `particles` objects and the
/// peak memory.
pub fn sample_json(run: &SampleFacts<'_>) -> Value {
    let mpu = run.mpu;
    let r = mpu.report();
    let s = run.sampling;
    let evals = (s.count * s.iterations.max(1)) as f64;
    let floor = run.evaluation_floor;
    json!({
        "input": run.input,
        "mpu": {
            "build_seconds": r.seconds,
            "leaves": r.leaves,
            "surface_leaves": r.surface_leaves,
            "max_depth": r.max_depth,
            "error_threshold": {
                "relative": run.threshold.relative,
                "world": r.eps0,
                "source": run.threshold.source,
            },
            "report": r,
            "params": mpu.params(),
            "data_coverage": psi_mpu::data_coverage(mpu),
        },
        "particles": {
            "count": s.count,
            "init_seconds": s.init_seconds,
            "simulate_seconds": s.simulate_seconds,
            "simulate_seconds_per_particle_iteration": s.simulate_seconds / evals,
            "value_and_gradient_seconds": floor,
            "evaluation_floor_ratio": floor.map(|e| s.simulate_seconds / evals / e.max(1e-12)),
            "iterations": s.iterations,
            "density": s.density,
            "before": s.before,
            "after": s.after,
            "separation": s.separation,
            // The ceiling on spacing applied (null with an exact count or in uniform mode).
            "max_spacing": s.density.ceiling,
            "added_by_ceiling": s.added_by_ceiling,
            "replaced_by_ceiling": s.replaced_by_ceiling,
            "params": run.params,
        },
        "peak_memory_bytes": run.peak_memory_bytes,
    })
}

/// Peak resident memory of this process so far (Linux `VmHWM`), bytes; `None` elsewhere.
pub fn peak_memory_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}
