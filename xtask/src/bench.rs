//! `cargo xtask bench <program> [args]`: timing and tuning programs of the library itself (the
//! paper's tables time the `psi` binary instead: `reproduce-tables`). Timings mean nothing in a
//! debug build, so a debug xtask runs itself again built with `--release`.
//!
//! * `relax [MODEL] [ROUNDS] [warm|prefill]`: medians of the relaxation on fresh MPUs;
//! * `eval [MODEL]`: one `value_and_gradient` near the surface;
//! * `edit [MODELS] [SEEDS] [STROKES]`: editing sessions, seeded drags, frames and settling;
//! * `tune [MODEL]`: relaxation constants varied one at a time;
//! * `tune-shapes`: step sizes and σ adaptation on a sphere and a torus;
//! * `level-cv [MODEL] [p,q ...]`: the per-level nearest-neighbour CV split into a level's
//!   inside and its boundaries;
//! * `formats [POINTS]`: decoding speed of LAZ and LAS files written by psi (a survey-like
//!   tile, 10 M points by default), read through the streaming reader;
//! * `scale [N,N,...] [MAX_MEMORY]`: in core against out of core at growing sizes;
//! * `throughput [N,N,...] [normals,xyz]`: cost per point and per stage on dense scans.
//!
//! MODEL (a path relative to the workspace root, or absolute) defaults to
//! `../shared/models/bunny.ply`.

use anyhow::{Context, Result, bail};

pub(crate) mod edit;
mod eval;
mod formats;
mod level_cv;
mod relax;
mod scale;
mod throughput;
mod tune;
mod tune_shapes;

/// The points of the model file `path` (relative to the workspace root, where the release
/// rerun works), or of the shared bunny when `None`; read as the paper reads meshes.
fn load_model(path: Option<&String>) -> Result<Vec<psi::OrientedPoint>> {
    let path = match path {
        Some(p) => crate::project_root().join(p),
        None => crate::project_root().join("../shared/models/bunny.ply"),
    };
    let file = psi::load_points(&path, &psi::ReadOptions::paper())
        .with_context(|| format!("reading {}", path.display()))?;
    Ok(file.points)
}

pub(crate) fn run(args: &[String]) -> Result<()> {
    if cfg!(debug_assertions) {
        let status = std::process::Command::new(env!("CARGO"))
            .current_dir(crate::project_root())
            .args(["run", "--release", "--quiet", "--package", "xtask", "--"])
            .arg("bench")
            .args(args)
            .status()
            .context("running the release build of xtask")?;
        if !status.success() {
            bail!("the release build of `xtask bench` failed ({status})");
        }
        return Ok(());
    }
    let (program, rest) = args.split_first().context(
        "bench needs a program: relax, eval, edit, tune, tune-shapes, level-cv, formats, scale or throughput",
    )?;
    match program.as_str() {
        "relax" => relax::run(rest),
        "eval" => eval::run(rest),
        "edit" => edit::run(rest),
        "scale" => scale::run(rest),
        "tune" => tune::run(rest),
        "tune-shapes" => tune_shapes::run(),
        "level-cv" => level_cv::run(rest),
        "formats" => formats::run(rest),
        "throughput" => throughput::run(rest),
        other => {
            bail!(
                "unknown bench program {other}: relax, eval, edit, tune, tune-shapes, level-cv, formats, scale or throughput"
            )
        }
    }
}
