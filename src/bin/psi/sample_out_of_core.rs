//! `psi sample --max-memory SIZE`: the input sampled out of core ([`psi::sample_file_out_of_core`]),
//! its tile files in `--scratch` (default: beside the output).

use std::path::{Path, PathBuf};

use anyhow::{Context, anyhow};
use psi::{MpuParams, OutOfCore, ParticleParams};
use serde_json::json;

use crate::Failure;

/// Parses a memory size: a whole number of bytes, or with a unit KiB, MiB, GiB, TiB (powers of
/// 1024) or KB, MB, GB, TB (powers of 1000).
pub(crate) fn memory_size(text: &str) -> Result<u64, String> {
    let t = text.trim();
    let split = t.find(|c: char| !c.is_ascii_digit()).unwrap_or(t.len());
    let (digits, unit) = t.split_at(split);
    let n: u64 = digits
        .parse()
        .map_err(|_| format!("{text} is not a size such as 4GiB or 512MiB"))?;
    let factor: u64 = match unit.trim().to_ascii_lowercase().as_str() {
        "" | "b" => 1,
        "kib" | "k" => 1 << 10,
        "mib" | "m" => 1 << 20,
        "gib" | "g" => 1 << 30,
        "tib" | "t" => 1 << 40,
        "kb" => 1_000,
        "mb" => 1_000_000,
        "gb" => 1_000_000_000,
        "tb" => 1_000_000_000_000,
        other => {
            return Err(format!(
                "{text}: unknown unit `{other}` (use KiB, MiB, GiB, TiB)"
            ));
        }
    };
    let bytes = n
        .checked_mul(factor)
        .ok_or_else(|| format!("{text} is too large"))?;
    if bytes < 64 << 20 {
        return Err(format!(
            "{text} is below the 64 MiB a run out of core needs"
        ));
    }
    Ok(bytes)
}

/// The scratch directory: `--scratch`, else `<output>.psi-scratch` beside the output.
fn scratch_dir(scratch: Option<&Path>, output: Option<&Path>) -> Result<PathBuf, Failure> {
    match (scratch, output) {
        (Some(s), _) => Ok(s.to_path_buf()),
        (None, Some(o)) => {
            let name = o
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_else(|| "particles".into());
            Ok(o.with_file_name(format!("{name}.psi-scratch")))
        }
        (None, None) => Err(Failure {
            error: anyhow!("--max-memory needs -o or --scratch (where its tile files go)"),
            code: 2,
        }),
    }
}

/// What the out-of-core run needs from the command line.
pub(crate) struct Request<'a> {
    pub(crate) input: &'a Path,
    pub(crate) format: Option<psi::io::Format>,
    pub(crate) mpu: MpuParams,
    pub(crate) particles: ParticleParams,
    pub(crate) max_memory: u64,
    pub(crate) scratch: Option<&'a Path>,
    pub(crate) output: Option<&'a Path>,
    pub(crate) json: Option<&'a Path>,
}

pub(crate) fn run(req: &Request<'_>, ui: crate::ui::Ui) -> Result<(), Failure> {
    let scratch = scratch_dir(req.scratch, req.output)?;
    ui.notice(
        "--max-memory: the points are used as given: the outlier search, the noise estimate \
         and the inward-normals check read the whole input and are not done out of core yet",
    );
    let options = OutOfCore {
        max_memory: req.max_memory,
        scratch: scratch.clone(),
        tile_depth: None,
    };
    let bar = ui.bar("tiles", 1);
    let observe = |stage: &str, done: u64, total: u64| {
        bar.set_message(stage.to_owned());
        bar.set_length(total.max(1));
        bar.set_position(done);
    };
    let monitor = psi::octree::Monitor::new(Some(&observe), None);
    let run = psi::sample_file_out_of_core(
        req.input,
        req.format,
        &req.mpu,
        &req.particles,
        &options,
        &monitor,
    );
    bar.finish_and_clear();
    let run = run.with_context(|| "sampling out of core".to_string())?;
    if let Some(out) = req.output {
        psi::save_particles(out, &run.particles, &psi::io::PointAttributes::default())?;
    }
    if let Some(path) = req.json {
        let report = json!({
            "input": { "path": req.input.display().to_string(), "points": run.points,
                       "dropped_zero_normals": run.dropped },
            "mpu": { "error_rel": req.mpu.error_rel, "max_depth": req.mpu.max_depth },
            "particles": { "count": run.particles.len(), "k": req.particles.k,
                           "iterations": req.particles.iterations },
            "tiles": {
                "count": run.tiles.count,
                "depth": run.tiles.depth,
                "halo": run.tiles.halo,
                "points_per_tile": run.tiles.points_per_tile,
                "halo_points": run.tiles.halo_points,
                "halos_grown": run.tiles.halos_grown,
                "balls_fetched": run.tiles.balls_fetched,
                "crossing_cells": run.tiles.crossing_cells,
                "cells": run.tiles.cells,
                "resumed": run.resumed,
                "scratch": scratch.display().to_string(),
                "max_memory_bytes": req.max_memory,
                "seconds": { "read": run.seconds[0], "decide": run.seconds[1],
                             "sample": run.seconds[2], "stitch": run.sampling.stitch_seconds },
                "sampling": run.sampling,
                "preprocessing": "none (points used as given)",
            },
            "peak_memory_bytes": psi::report::peak_memory_bytes(),
        });
        psi::save_json(path, &report)?;
    }
    ui.summary(&format!(
        "{}: {} points in {} tiles (depth {}): {} cells, {} particles; read {:.2} s, MPU {:.2} s, particles {:.2} s{}",
        req.input.display(),
        run.points,
        run.tiles.count,
        run.tiles.depth,
        run.tiles.cells,
        run.particles.len(),
        run.seconds[0],
        run.seconds[1],
        run.seconds[2],
        req.output
            .map(|o| format!("; wrote {}", o.display()))
            .unwrap_or_default()
    ));
    Ok(())
}
