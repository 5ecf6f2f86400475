//! psi's development tasks, run as `cargo xtask <task>` (the cargo-xtask pattern: a plain
//! binary in the workspace, aliased in `.cargo/config.toml`).
//!
//! * `reproduce-tables [--models DIR] [--only a,b] [--iterations 20] [--json FILE]`: the paper's
//!   Tables 1 and 2 on the shared models, timed with the release `psi` binary, each particle set
//!   checked against its reference mesh (parry3d-f64 point projection).
//! * `check-reference [--models DIR] [--only a,b]`: cross-checks the Rust distances with Python
//!   libigl (`point_mesh_squared_distance`) in a virtual environment the task creates.
//! * `memory [--points N]`: the built-in model with N points (5 000 000 by default) through
//!   `psi sample`, reporting time and peak memory.
//! * `figures [--models DIR]`: regenerates the README's pictures in `docs/images/` (built-in
//!   model and bunny coloured by octree depth, a brush edit, uniform beside adaptive).
//! * `scans [--models DIR] [--only a,b] [--seed S] [--seeds A..B] [--json FILE]`: psi on
//!   scan-like inputs checked against reference surfaces (`scans.rs`): variants of the shared
//!   models (noise, stray points, positions alone, one view), a coarse mesh, the real dragon
//!   scan, generated multi-view scans and flat scenes; `--only outliers --seeds 0..20` (the 1 %
//!   outlier case over seeds) and `--only density` (the dragon at 1–10 M points) on request.
//! * `session [--models DIR] [--json FILE]`: an editing session on the bunny (20 strokes
//!   through `psi edit --strokes`), per-edit times, locality and accuracy (`session.rs`).
//! * `bench <program> [args]`: timing and tuning programs of the library (`bench.rs`), run
//!   from a release build.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};

mod bench;
mod check_reference;
mod checks;
mod coverage;
mod edits;
mod figures;
mod flat_scenes;
mod host;
mod median;
mod memory;
mod multiview;
mod outliers;
mod paper;
mod reference;
mod release_binary;
mod scan_case;
mod scans;
mod scans_density;
mod scans_flat;
mod scans_mesh;
mod session;
mod surface_samples;
mod tables;
mod tidy;
mod visibility;

/// Command-line flags shared by the tasks.
pub(crate) struct Flags {
    pub(crate) models: Option<PathBuf>,
    pub(crate) only: Option<Vec<String>>,
    pub(crate) iterations: usize,
    pub(crate) json: Option<PathBuf>,
    pub(crate) seed: Option<u64>,
    /// `--seeds A..B` (B excluded; `A..=B` includes it; a single `A` is `A..A+1`).
    pub(crate) seeds: Option<std::ops::Range<u64>>,
}

/// Parses a seed range: `A..B` (B excluded), `A..=B` or a single seed `A`.
fn seed_range(text: &str) -> Result<std::ops::Range<u64>> {
    let whole = |t: &str| -> Result<u64> {
        t.trim()
            .parse()
            .with_context(|| format!("--seeds {text}: {t} is not a whole number"))
    };
    let range = if let Some((a, b)) = text.split_once("..=") {
        whole(a)?..whole(b)?.saturating_add(1)
    } else if let Some((a, b)) = text.split_once("..") {
        whole(a)?..whole(b)?
    } else {
        let a = whole(text)?;
        a..a.saturating_add(1)
    };
    if range.is_empty() {
        bail!("--seeds {text} holds no seed");
    }
    Ok(range)
}

fn parse(args: &[String]) -> Result<Flags> {
    let mut flags = Flags {
        models: None,
        only: None,
        iterations: 20,
        json: None,
        seed: None,
        seeds: None,
    };
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = || it.next().with_context(|| format!("{a} needs a value"));
        match a.as_str() {
            "--models" => flags.models = Some(PathBuf::from(value()?)),
            "--only" => flags.only = Some(value()?.split(',').map(str::to_owned).collect()),
            "--iterations" => {
                flags.iterations = value()?
                    .parse()
                    .context("--iterations takes a whole number")?
            }
            "--json" => flags.json = Some(PathBuf::from(value()?)),
            "--seed" => flags.seed = Some(value()?.parse().context("--seed takes a whole number")?),
            "--seeds" => flags.seeds = Some(seed_range(value()?)?),
            other => bail!("unknown flag {other}"),
        }
    }
    Ok(flags)
}

/// The workspace root (the parent of this crate).
pub(crate) fn project_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("xtask lives in the workspace")
        .to_path_buf()
}

/// The models folder: `--models`, else `$PSI_MODELS`, else `../shared/models`.
pub(crate) fn models_dir(flags: &Flags) -> Result<PathBuf> {
    let candidates = [
        flags.models.clone(),
        std::env::var_os("PSI_MODELS").map(PathBuf::from),
        Some(project_root().join("../shared/models")),
    ];
    for c in candidates.into_iter().flatten() {
        if c.is_dir() {
            return Ok(c);
        }
    }
    bail!(
        "no models folder: pass --models DIR, set PSI_MODELS, or put the shared models at ../shared/models"
    )
}

fn main() -> std::process::ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let result = match args.first().map(String::as_str) {
        Some("reproduce-tables") => parse(&args[1..]).and_then(|f| tables::run(&f)),
        Some("check-reference") => parse(&args[1..]).and_then(|f| check_reference::run(&f)),
        Some("figures") => parse(&args[1..]).and_then(|f| figures::run(&f)),
        Some("scans") => parse(&args[1..]).and_then(|f| scans::run(&f)),
        Some("session") => parse(&args[1..]).and_then(|f| session::run(&f)),
        Some("bench") => bench::run(&args[1..]),
        Some("memory") => {
            let points = match args.get(1).map(String::as_str) {
                Some("--points") => args
                    .get(2)
                    .and_then(|n| n.parse().ok())
                    .unwrap_or(5_000_000),
                _ => 5_000_000,
            };
            memory::run(points)
        }
        _ => {
            eprintln!(
                "usage: cargo xtask reproduce-tables|check-reference|figures|scans|session [--models DIR] [--only a,b] [--iterations N] [--seed S] [--seeds A..B] [--json FILE]\n       cargo xtask memory [--points N]\n       cargo xtask bench relax|eval|edit|tune|tune-shapes|level-cv|formats|scale|throughput [args]"
            );
            return std::process::ExitCode::from(2);
        }
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("xtask: error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
