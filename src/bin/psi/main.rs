//! The `psi` command-line tool: `psi info`, `psi mesh`, `psi sample`, `psi edit`, `psi render`.
//!
//! Exit codes: 0 success, 1 failure at run time, 2 bad input or usage. Errors print as one line
//! naming the file and the reason, with the cause chain.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Args, Parser, Subcommand};

mod arena_limit;
mod input;
mod run_edit;
mod run_info;
mod run_mesh;
mod run_render;
mod run_sample;
mod sample_out_of_core;
mod stage_clock;
mod strokes;
mod ui;

/// Point-set implicits: an MPU surface from oriented points, and adaptive particles on it.
#[derive(Parser)]
#[command(name = "psi", version, about, long_about = None, after_help = "\
Examples:
  psi info ../shared/models/bunny.ply --json
  psi sample -o particles.ply --json report.json      # the built-in model
  psi sample bunny.ply --uniform --count 10000 -o bunny_uniform.ply
  psi mesh bunny.ply -o surface.ply --resolution 256")]
struct Cli {
    /// Print nothing but errors (no progress bars, no summary).
    #[arg(long, short, global = true)]
    quiet: bool,
    /// Print timings of each stage on stderr.
    #[arg(long, short, global = true)]
    verbose: bool,
    #[command(subcommand)]
    command: Command,
}

/// The input every command reads.
#[derive(Args, Clone, Debug)]
pub(crate) struct InputArgs {
    /// Oriented points or a triangle mesh (PLY, OBJ, XYZ), or a scan (LAS, LAZ, E57, PCD).
    /// Without it, the built-in model.
    pub(crate) input: Option<PathBuf>,
    /// Read the input as this format (ply, obj, xyz, las, laz, e57, pcd), whatever its
    /// extension (default: by extension, else by content).
    #[arg(long, value_name = "FORMAT", value_parser = input_format, requires = "input")]
    pub(crate) format: Option<psi::io::Format>,
    /// From a mesh, one point per vertex with area-weighted normals (default: per triangle).
    #[arg(long)]
    pub(crate) per_vertex: bool,
    /// The built-in model with this many points instead of the default (stress tests).
    #[arg(long, hide = true, conflicts_with = "input")]
    pub(crate) builtin_points: Option<usize>,
    /// Make inconsistent given normals consistent by propagation over a neighbour graph.
    #[arg(long)]
    pub(crate) orient_normals: bool,
    /// Orient estimated normals toward this sensor position (a single range scan), `x,y,z`.
    #[arg(long, value_name = "X,Y,Z", value_parser = point3)]
    pub(crate) viewpoint: Option<Point3>,
    /// Keep points that no surface supports (default: found and left out of the fit, in point
    /// clouds; a mesh's triangles are connected).
    #[arg(long)]
    pub(crate) keep_outliers: bool,
    /// Refuse points without normals instead of estimating their normals.
    #[arg(long)]
    pub(crate) no_normal_estimation: bool,
    /// Do not estimate the noise (the MPU error threshold stays the paper's 0.005 unless
    /// --mpu-error is given).
    #[arg(long)]
    pub(crate) no_noise_estimate: bool,
    /// Keep the positions' noise (default: where it would raise the MPU error threshold, the
    /// points are moved onto local quadric fits first).
    #[arg(long)]
    pub(crate) no_denoise: bool,
    /// Keep one point per triangle of a coarse mesh (default: its large triangles get more, so
    /// that the implicit follows the mesh).
    #[arg(long)]
    pub(crate) no_densify: bool,
    /// Keep given normals that point inward as a whole (default: judged at the points on the
    /// convex hull and flipped outward, with a notice; keep them for a surface seen from
    /// inside, such as a room scanned from its middle).
    #[arg(long)]
    pub(crate) keep_inward_normals: bool,
}

/// Parses a `--format` name: ply, obj, xyz, las, laz, e57 or pcd.
fn input_format(text: &str) -> Result<psi::io::Format, String> {
    psi::io::Format::ALL
        .into_iter()
        .find(|f| f.name().eq_ignore_ascii_case(text.trim()))
        .ok_or_else(|| {
            let names: Vec<&str> = psi::io::Format::ALL.iter().map(|f| f.name()).collect();
            format!("{text}: expected one of {}", names.join(", "))
        })
}

/// A point `x,y,z` of the command line (world units).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Point3(pub(crate) [f64; 3]);

/// Parses `x,y,z` into three finite numbers.
fn point3(text: &str) -> Result<Point3, String> {
    let v = numbers(text, 3).map_err(|e| format!("{e} x,y,z"))?;
    Ok(Point3([v[0], v[1], v[2]]))
}

/// Parses `n` finite numbers separated by commas.
pub(crate) fn numbers(text: &str, n: usize) -> Result<Vec<f64>, String> {
    let v: Vec<f64> = text
        .split(',')
        .map(|t| t.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("{text} is not a list of numbers"))?;
    if v.len() != n || v.iter().any(|x| !x.is_finite()) {
        return Err(format!(
            "{text}: expected {n} finite numbers separated by commas"
        ));
    }
    Ok(v)
}

/// MPU parameters a user may change (defaults: Ohtake et al.'s, `MpuParams::paper()`).
#[derive(Args, Clone, Debug)]
pub(crate) struct MpuArgs {
    /// MPU error threshold ε0 relative to the bounding-box diagonal [default: from the noise
    /// estimate, 4σ/D, never below the paper's 0.005].
    #[arg(long, value_parser = positive_fraction)]
    pub(crate) mpu_error: Option<f64>,
    /// Maximum octree depth.
    #[arg(long, default_value_t = psi::MpuParams::paper().max_depth, value_parser = clap::value_parser!(u8).range(0..=16))]
    pub(crate) max_depth: u8,
    /// Disable sharp edge and corner fits.
    #[arg(long)]
    pub(crate) smooth: bool,
    /// Solve the local fits in units of each cell's radius: the same surface whatever the
    /// input's units (default: world units, as Ohtake's code and the paper).
    #[arg(long)]
    pub(crate) scale_invariant: bool,
}

/// A whole number in `lo..=hi`.
pub(crate) fn bounded(text: &str, lo: usize, hi: usize) -> Result<usize, String> {
    let v: usize = text
        .parse()
        .map_err(|_| format!("{text} is not a whole number"))?;
    if (lo..=hi).contains(&v) {
        Ok(v)
    } else {
        Err(format!("{text} is not in {lo}..={hi}"))
    }
}

/// A relaxation iteration count (0..=100 000).
pub(crate) fn iterations(text: &str) -> Result<usize, String> {
    bounded(text, 0, 100_000)
}

/// A length in world units: positive, or `inf` for none.
pub(crate) fn positive_length(text: &str) -> Result<f64, String> {
    let v: f64 = text
        .parse()
        .map_err(|_| format!("{text} is not a number"))?;
    if v > 0.0 && !v.is_nan() {
        Ok(v)
    } else {
        Err(format!("{text} is not a positive length (or inf)"))
    }
}

/// A relative error threshold: finite, in (0, 1].
fn positive_fraction(text: &str) -> Result<f64, String> {
    let v: f64 = text
        .parse()
        .map_err(|_| format!("{text} is not a number"))?;
    if v.is_finite() && v > 0.0 && v <= 1.0 {
        Ok(v)
    } else {
        Err(format!("{text} is not in (0, 1]"))
    }
}

impl MpuArgs {
    /// The MPU parameters with the error threshold ε0/D `error_rel`.
    pub(crate) fn params(&self, error_rel: f64) -> psi::MpuParams {
        psi::MpuParams {
            error_rel,
            max_depth: self.max_depth,
            sharp: !self.smooth,
            fit_unit: if self.scale_invariant {
                None
            } else {
                psi::MpuParams::paper().fit_unit
            },
            ..psi::MpuParams::paper()
        }
    }
}

#[derive(Subcommand)]
enum Command {
    /// Print what was read: vertices, faces, oriented points, bounding box and its diagonal.
    #[command(after_help = "Example:\n  psi info ../shared/models/bunny.ply --json")]
    Info {
        #[command(flatten)]
        input: InputArgs,
        /// Print JSON instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Build the MPU implicit and write its zero set as a triangle mesh (PLY).
    #[command(after_help = "Example:\n  psi mesh bunny.ply -o surface.ply --resolution 256")]
    Mesh(run_mesh::MeshArgs),
    /// Build the MPU implicit and scatter relaxed particles over it (the main job).
    #[command(
        after_help = "Examples:\n  psi sample -o particles.ply\n  psi sample bunny.ply --count 10000 --uniform -o p.ply --json report.json"
    )]
    Sample(run_sample::SampleArgs),
    /// Build and sample, apply shape edits locally, write the particles before and after.
    #[command(
        after_help = "Examples:\n  psi edit bunny.ply --brush=-0.02,0.1,0.05,0.02,0,0.005,0 --before before.ply -o after.ply --json edit.json\n  psi edit bunny.ply --strokes drag.json -o after.ply --points-after points.ply --json session.json"
    )]
    Edit(run_edit::EditArgs),
    /// Draw particles (coloured by octree depth, σ or normal) or a mesh into a PNG picture.
    #[command(
        after_help = "Examples:\n  psi render particles.ply -o view.png --view side --color depth\n  psi render surface.ply -o surface.png --size 800"
    )]
    Render(run_render::RenderArgs),
}

/// An error with the exit code it maps to.
pub(crate) struct Failure {
    pub(crate) error: anyhow::Error,
    pub(crate) code: u8,
}

impl<E: Into<anyhow::Error>> From<E> for Failure {
    fn from(e: E) -> Self {
        let error = e.into();
        let bad_input = error.chain().any(|c| {
            c.downcast_ref::<psi::PsiError>()
                .is_some_and(|p| !matches!(p, psi::PsiError::Write { .. }))
                || c.downcast_ref::<psi::MpuError>().is_some()
                || c.downcast_ref::<psi::regen::RegenError>().is_some()
        });
        Failure {
            error,
            code: if bad_input { 2 } else { 1 },
        }
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    if cli.verbose {
        // Stage timings: each library span (MPU build, seeding, relaxation, local
        // regeneration) is printed with its duration when it closes.
        tracing_subscriber::fmt()
            .with_writer(std::io::stderr)
            .with_span_events(tracing_subscriber::fmt::format::FmtSpan::CLOSE)
            .with_target(false)
            .init();
    }
    let ui = ui::Ui {
        quiet: cli.quiet,
        verbose: cli.verbose,
    };
    let result = match cli.command {
        Command::Info { input, json } => run_info::run(&input, json, ui),
        Command::Mesh(args) => run_mesh::run(&args, ui),
        Command::Sample(args) => run_sample::run(&args, ui),
        Command::Edit(args) => run_edit::run(&args, ui),
        Command::Render(args) => run_render::run(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(Failure { error, code }) => {
            eprintln!("psi: error: {error:#}");
            ExitCode::from(code)
        }
    }
}
