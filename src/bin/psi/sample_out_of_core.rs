//! `psi sample --max-memory SIZE`: the input sampled out of core ([`psi::sample_file_out_of_core`]),
//! its tile files in `--scratch` (default: beside the output).

use std::path::{Path, PathBuf};

use anyhow::{Context, anyhow};
use psi::{OutOfCore, ParticleParams};

use crate::Failure;

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
    pub(crate) preprocess: psi::preprocess::PreprocessParams,
    pub(crate) mpu: psi::OutOfCoreMpu,
    pub(crate) particles: ParticleParams,
    pub(crate) max_memory: u64,
    pub(crate) scratch: Option<&'a Path>,
    pub(crate) output: Option<&'a Path>,
    pub(crate) json: Option<&'a Path>,
}

pub(crate) fn run(req: &Request<'_>, ui: crate::ui::Ui) -> Result<(), Failure> {
    let scratch = scratch_dir(req.scratch, req.output)?;
    let options = OutOfCore {
        max_memory: req.max_memory,
        scratch,
        tile_depth: None,
    };
    let bar = ui.bar_with_eta("out of core", 1);
    let stage_now = std::sync::Mutex::new(String::new());
    let observe = |stage: &str, done: u64, total: u64| {
        let mut now = stage_now.lock().expect("not poisoned");
        if *now != stage {
            // A new stage: its own clock, so the time left is the stage's.
            now.replace_range(.., stage);
            bar.reset();
            bar.set_message(stage.to_owned());
        }
        bar.set_length(total.max(1));
        bar.set_position(done);
    };
    let monitor = psi::octree::Monitor::new(Some(&observe), None);
    let run = psi::sample_file_out_of_core(
        req.input,
        req.format,
        &req.preprocess,
        &req.mpu,
        &req.particles,
        &options,
        &monitor,
    );
    bar.finish_and_clear();
    let run = run.with_context(|| "sampling out of core".to_string())?;
    let name = req.input.display();
    if run.checks.inward_normals_flipped {
        ui.notice(&psi::preprocess::inward_flip_notice(&name.to_string()));
    }
    if let Some(opposed) = run.checks.inconsistent_normals() {
        eprintln!(
            "psi: warning: {name}: {:.1} % of neighbouring normals point to opposite sides, so the points were not denoised; --orient-normals (in core, without --max-memory) repairs them",
            100.0 * opposed
        );
    }
    if let Some(out) = req.output {
        psi::save_particles(out, &run.particles, &psi::io::PointAttributes::default())?;
    }
    if let Some(path) = req.json {
        let inputs = [req.input.to_path_buf()];
        let report = psi::out_of_core_json(&inputs, &req.particles, &options, &run);
        psi::save_json(path, &report)?;
    }
    ui.summary(&format!(
        "{}: {} points{} in {} tiles (depth {}): {} cells, {} particles; read {:.2} s{}, MPU {:.2} s, particles {:.2} s{}",
        req.input.display(),
        run.points,
        run.strays
            .map(|t| format!(" ({} left out: {} repeated, {} far, {} off the surface, {} in clumps)",
                t.removed(), t.repeated, t.far, t.off_surface, t.clumps))
            .unwrap_or_default(),
        run.tiles.count,
        run.tiles.depth,
        run.tiles.cells,
        run.particles.len(),
        run.seconds[0],
        if run.normals_estimated {
            " (normals estimated and oriented tile by tile)"
        } else {
            ""
        },
        run.seconds[1],
        run.seconds[2],
        req.output
            .map(|o| format!("; wrote {}", o.display()))
            .unwrap_or_default()
    ));
    Ok(())
}
