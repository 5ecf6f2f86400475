//! `psi mesh`.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use psi::PolygonizeParams;

use crate::input::load;
use crate::{Failure, InputArgs};

#[derive(Args)]
pub(crate) struct MeshArgs {
    #[command(flatten)]
    input: InputArgs,
    #[command(flatten)]
    mpu: crate::MpuArgs,
    /// Output triangle mesh (binary PLY).
    #[arg(short, long)]
    output: PathBuf,
    /// Grid cells across the root cube.
    #[arg(long, default_value_t = 256, value_parser = clap::value_parser!(u32).range(2..=2048))]
    resolution: u32,
}

pub(crate) fn run(args: &MeshArgs, ui: crate::ui::Ui) -> Result<(), Failure> {
    let loaded = load(&args.input, ui)?;
    loaded.check_output(&args.output, "-o")?;
    let error_rel = loaded
        .input
        .report
        .error_threshold(args.mpu.mpu_error)
        .relative;
    let params = psi::MpuParams {
        error_rank: loaded.input.error_rank(error_rel),
        ..args.mpu.params(error_rel)
    };
    let mpu = crate::ui::build_mpu(ui, &loaded.input.points, &params)
        .with_context(|| format!("{}: building the MPU implicit", loaded.input.name))?;
    let t = std::time::Instant::now();
    let mesh = psi::polygonize(
        &mpu,
        &PolygonizeParams {
            resolution: args.resolution,
            ..PolygonizeParams::standard()
        },
    );
    let secs = t.elapsed().as_secs_f64();
    psi::save_mesh(&args.output, &mesh)?;
    let r = mpu.report();
    ui.timing("polygonization", secs);
    ui.summary(&format!(
        "{}: {} points -> MPU {} leaves (depth {}) in {:.3} s -> {} triangles in {:.3} s -> {}",
        loaded.input.name,
        r.points,
        r.leaves,
        r.max_depth,
        r.seconds,
        mesh.faces.len(),
        secs,
        args.output.display()
    ));
    Ok(())
}
