//! `psi sample`.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use psi::{DensityMode, ParticleParams};

use crate::input::load;
use crate::{Failure, InputArgs};

#[derive(Args)]
pub(crate) struct SampleArgs {
    #[command(flatten)]
    input: InputArgs,
    #[command(flatten)]
    mpu: crate::MpuArgs,
    /// Output particles: binary PLY (x y z nx ny nz depth sigma, and red green blue,
    /// intensity, classification when the input has them), or LAS/LAZ for a `.las`/`.laz`
    /// path (positions and those attributes).
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// Relaxation iterations.
    #[arg(long, default_value_t = 20, value_parser = crate::iterations)]
    iterations: usize,
    /// Particles seeded per surface-containing octree leaf (not with --count or --uniform,
    /// which set the count themselves).
    #[arg(long, default_value_t = 1, value_parser = |t: &str| crate::bounded(t, 1, 64),
        conflicts_with_all = ["count", "uniform"])]
    k: usize,
    /// Exactly this many particles (instead of k per leaf).
    #[arg(long, value_parser = |t: &str| crate::bounded(t, 1, 50_000_000))]
    count: Option<usize>,
    /// One constant spacing from the area and the count (blue noise) instead of depth-adaptive.
    #[arg(long)]
    uniform: bool,
    /// The ceiling on spacing, world units: particles are added where the data has none near,
    /// so flat regions are covered at about this spacing (`inf`: none) [default: 2.5 % of the
    /// bounding-box diagonal; not with --count or --uniform, which set their own spacing].
    #[arg(long, value_parser = crate::positive_length,
        conflicts_with_all = ["count", "uniform"])]
    max_spacing: Option<f64>,
    /// Seed of every random choice.
    #[arg(long, default_value_t = 2007)]
    seed: u64,
    /// Write the run's report as JSON.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Also write a picture of the particles coloured by octree depth (PNG).
    #[arg(long)]
    png: Option<PathBuf>,
    /// Also write the points the MPU was built from, after preprocessing (binary PLY:
    /// x y z nx ny nz).
    #[arg(long)]
    points_out: Option<PathBuf>,
    /// Also time one value_and_gradient per particle and report the simulation's cost against
    /// that floor (`particles.value_and_gradient_seconds`, `particles.evaluation_floor_ratio`).
    #[arg(long)]
    evaluation_floor: bool,
    /// Work out of core within this much memory (e.g. 4GiB, 512MiB): the input streamed into
    /// tile files, the MPU and the particles made tile by tile. The budget is the process's
    /// peak (about 24 MiB of it the process itself); an MPU with more cells than it holds is
    /// refused. Preprocessing tile by tile as in core (outliers, normals, the noise threshold,
    /// denoising). The ceiling on spacing (--max-spacing) as in core, its passes reading the
    /// tile files.
    #[arg(long, value_parser = psi::parse_memory_size,
        conflicts_with_all = ["count", "uniform", "png", "points_out", "evaluation_floor",
            "per_vertex", "orient_normals", "viewpoint", "no_normal_estimation"])]
    max_memory: Option<u64>,
    /// Where the tile files of --max-memory go (default: `<output>.psi-scratch` beside the
    /// output); a run finds the files of an earlier run on the same input there and resumes.
    #[arg(long, requires = "max_memory")]
    scratch: Option<PathBuf>,
}

pub(crate) fn run(args: &SampleArgs, ui: crate::ui::Ui) -> Result<(), Failure> {
    if let Some(max_memory) = args.max_memory {
        crate::arena_limit::limit_arenas();
        return run_out_of_core(args, max_memory, ui);
    }
    if let Some(input) = &args.input.input {
        psi::check_fits_in_memory(input, args.input.format)?;
    }
    let loaded = load(&args.input, ui)?;
    for (path, flag) in [
        (&args.output, "-o"),
        (&args.json, "--json"),
        (&args.png, "--png"),
        (&args.points_out, "--points-out"),
    ] {
        if let Some(path) = path {
            loaded.check_output(path, flag)?;
        }
    }
    let threshold = loaded.input.report.error_threshold(args.mpu.mpu_error);
    let mpu = crate::ui::build_mpu(
        ui,
        &loaded.input.points,
        &psi::MpuParams {
            error_rank: loaded.input.error_rank(threshold.relative),
            ..args.mpu.params(threshold.relative)
        },
    )
    .with_context(|| format!("{}: building the MPU implicit", loaded.input.name))?;
    let params = ParticleParams {
        k: args.k,
        count: args.count,
        iterations: args.iterations,
        density: if args.uniform {
            DensityMode::Uniform
        } else {
            DensityMode::Adaptive
        },
        max_spacing: args.max_spacing,
        seed: args.seed,
        ..ParticleParams::paper()
    };
    let run = crate::ui::sample(ui, &mpu, &params);
    // Colours, intensities and classes of a scan, carried to the particles.
    crate::stage_clock::enter("write");
    let attributes =
        psi::particles::transfer_attributes(&mpu, &run.particles, &loaded.input.attributes);
    if let Some(out) = &args.output {
        psi::save_particles(out, &run.particles, &attributes)?;
    }
    if let Some(path) = &args.points_out {
        psi::save_points(path, &loaded.input.points)?;
    }
    if let Some(png) = &args.png {
        psi::render_particles_png(png, &run.particles, &psi::render::RenderParams::particles())?;
    }
    let r = mpu.report();
    let s = &run.report;
    // The evaluation floor, when asked: one value_and_gradient per particle, timed on the final
    // particles; the simulation against N × iterations such evaluations.
    let floor = args.evaluation_floor.then(|| {
        crate::stage_clock::enter("evaluation_floor");
        let t = std::time::Instant::now();
        for x in &run.particles.positions {
            std::hint::black_box(mpu.value_and_gradient(*x));
        }
        t.elapsed().as_secs_f64() / run.particles.len().max(1) as f64
    });
    if let Some(path) = &args.json {
        let mut report = psi::report::sample_json(&psi::report::SampleFacts {
            input: &loaded.input.json,
            mpu: &mpu,
            threshold,
            sampling: s,
            params: &params,
            evaluation_floor: floor,
            peak_memory_bytes: psi::report::peak_memory_bytes(),
        });
        // Wall and CPU time per stage, from reading the input to writing the outputs.
        report["stage_seconds"] = crate::stage_clock::report();
        psi::save_json(path, &report)?;
    }
    ui.summary(&format!(
        "{}: {} points, MPU {} leaves (depth {}) in {:.3} s; {} particles: seeding {:.3} s, {} iterations {:.3} s",
        loaded.input.name,
        r.points,
        r.leaves,
        r.max_depth,
        r.seconds,
        s.count,
        s.init_seconds,
        s.iterations,
        s.simulate_seconds
    ));
    let levels: Vec<String> = s
        .after
        .levels
        .iter()
        .map(|l| format!("{}:{:.3}", l.depth, l.spacing.cv))
        .collect();
    ui.summary(&format!(
        "  nearest-neighbour CV {:.3} -> {:.3} (per depth level {}); max |f|/|grad f| {:.1e} D{}",
        s.before.spacing.cv,
        s.after.spacing.cv,
        levels.join(" "),
        s.after.max_surface_distance,
        args.output
            .as_ref()
            .map(|o| format!("; wrote {}", o.display()))
            .unwrap_or_default()
    ));
    Ok(())
}

/// `--max-memory`: the same parameters, out of core.
fn run_out_of_core(args: &SampleArgs, max_memory: u64, ui: crate::ui::Ui) -> Result<(), Failure> {
    let Some(input) = args.input.input.as_deref() else {
        return Err(Failure {
            error: anyhow::anyhow!("--max-memory needs an input file"),
            code: 2,
        });
    };
    for (path, flag) in [(&args.output, "-o"), (&args.json, "--json")] {
        if let Some(path) = path {
            crate::input::check_output(Some(input), path, flag)?;
        }
    }
    let relative = args
        .mpu
        .mpu_error
        .unwrap_or(psi::MpuParams::paper().error_rel);
    let request = crate::sample_out_of_core::Request {
        input,
        format: args.input.format,
        preprocess: crate::input::preprocess_params(&args.input),
        mpu: psi::OutOfCoreMpu::given(args.mpu.params(relative), args.mpu.mpu_error),
        particles: ParticleParams {
            k: args.k,
            iterations: args.iterations,
            seed: args.seed,
            max_spacing: args.max_spacing,
            ..ParticleParams::paper()
        },
        max_memory,
        scratch: args.scratch.as_deref(),
        output: args.output.as_deref(),
        json: args.json.as_deref(),
    };
    crate::sample_out_of_core::run(&request, ui)
}
