//! Loading the input (a file or the built-in model) and preparing it for the MPU (outliers,
//! normals, noise), with a description for reports.

use std::path::{Path, PathBuf};

use anyhow::Context;
use psi::io::NormalSource;
use psi::preprocess::{NormalTreatment, PreprocessParams};
use psi::{MeshSampling, PreparedInput, ReadOptions};

use crate::{Failure, InputArgs};

/// What was loaded and how it was prepared.
pub(crate) struct Loaded {
    /// The input file (`None` for the built-in model).
    pub(crate) path: Option<PathBuf>,
    /// The prepared points, their name and their report.
    pub(crate) input: PreparedInput,
    /// The file as read, before preprocessing (`psi info` prints it).
    pub(crate) file: psi::io::FileSummary,
}

impl Loaded {
    /// Refuses `output` when it names the input file (it would be overwritten).
    pub(crate) fn check_output(&self, output: &Path, flag: &str) -> Result<(), Failure> {
        check_output(self.path.as_deref(), output, flag)
    }
}

/// Refuses `output` when it names `input` (it would be overwritten).
pub(crate) fn check_output(input: Option<&Path>, output: &Path, flag: &str) -> Result<(), Failure> {
    if let Some(input) = input
        && psi::same_file(input, output)
    {
        return Err(Failure {
            error: anyhow::anyhow!(
                "{flag} {} names the input file; choose another output",
                output.display()
            ),
            code: 2,
        });
    }
    Ok(())
}

/// The preprocessing steps the flags ask for.
pub(crate) fn preprocess_params(args: &InputArgs) -> PreprocessParams {
    PreprocessParams {
        remove_outliers: !args.keep_outliers,
        estimate_normals: !args.no_normal_estimation,
        viewpoint: args.viewpoint.map(|v| psi::DVec3::from_array(v.0)),
        orient_given_normals: args.orient_normals,
        estimate_noise: !args.no_noise_estimate,
        denoise: !args.no_denoise,
        densify_meshes: !args.no_densify,
        flip_inward_normals: !args.keep_inward_normals,
    }
}

pub(crate) fn load(args: &InputArgs, ui: crate::ui::Ui) -> Result<Loaded, Failure> {
    crate::stage_clock::enter("read");
    let (name, file) = match &args.input {
        None => {
            let n = args
                .builtin_points
                .unwrap_or(psi::shapes::BUILTIN_MODEL_POINTS);
            ("builtin".to_owned(), psi::builtin_file(n))
        }
        Some(path) => {
            let sampling = if args.per_vertex {
                MeshSampling::VertexNormals
            } else {
                MeshSampling::FaceCentroids
            };
            let file = psi::load_points_as(path, args.format, &ReadOptions { sampling })
                .context("reading the input")?;
            (path.display().to_string(), file)
        }
    };
    let missing = file.normals == NormalSource::Missing;
    if missing && !args.no_normal_estimation {
        ui.notice(&format!(
            "{name}: the points have no normals; estimating them{}",
            if args.viewpoint.is_some() {
                " and orienting them toward the viewpoint"
            } else {
                " and orienting them by propagation (--viewpoint for a single range scan)"
            }
        ));
    }
    let summary = file.summary();
    let params = preprocess_params(args);
    crate::stage_clock::enter("prepare");
    let monitor = psi::octree::Monitor::new(Some(&crate::stage_clock::observe), None);
    let input = psi::prepare_input(name.clone(), file, &params, &monitor).map_err(|e| Failure {
        error: match e {
            psi::preprocess::PreprocessError::NoNormals => {
                anyhow::anyhow!("{name}: {e}; drop --no-normal-estimation or give oriented points")
            }
            e => anyhow::anyhow!("{name}: {e}"),
        },
        code: 2,
    })?;
    let prep = &input.report;
    if let Some(notice) = prep.inward_notice(&input.name) {
        ui.notice(&format!("{notice} (--keep-inward-normals to keep them)"));
    }
    if let Some(opposed) = prep.inconsistent_normals() {
        eprintln!(
            "psi: warning: {}: {:.1} % of neighbouring normals point to opposite sides; try --orient-normals",
            input.name,
            100.0 * opposed
        );
    }
    ui.timing("mesh densification", prep.seconds.mesh);
    ui.timing("outliers", prep.seconds.outliers);
    ui.timing("normals", prep.seconds.normals);
    ui.timing("noise estimate", prep.seconds.noise);
    ui.timing("denoising", prep.seconds.denoise);
    if ui.verbose {
        if let Some(m) = prep.mesh {
            eprintln!(
                "psi: mesh: median vertex standoff {:.1e} D ({}); {} points added on large triangles",
                m.coarseness.median_standoff,
                if m.coarseness.max_area.is_some() {
                    "coarse"
                } else {
                    "fine"
                },
                m.points_added
            );
        }
        if prep.repeated > 0 {
            eprintln!(
                "psi: repeated points: {} left out (each the copy of an earlier point's position)",
                prep.repeated
            );
        }
        if let Some(o) = prep.outliers {
            eprintln!(
                "psi: outliers: {} removed ({} far from the surface, {} off it, {} in stray clumps)",
                o.removed, o.far, o.off_surface, o.clumps
            );
        }
        let treatment = match prep.normals {
            NormalTreatment::Given => "as given",
            NormalTreatment::GivenReoriented => "given, reoriented by propagation",
            NormalTreatment::EstimatedPropagated => "estimated, oriented by propagation",
            NormalTreatment::EstimatedTowardViewpoint => "estimated, oriented toward the viewpoint",
        };
        eprintln!(
            "psi: normals: {treatment}; {} flipped",
            prep.normals_flipped
        );
        if let (Some(n), Some(rel)) = (prep.noise, prep.noise_rel) {
            eprintln!("psi: noise estimate: {:.3e} ({rel:.2e} D)", n.sigma);
        }
        if let (Some(d), Some(rel)) = (prep.denoised, prep.noise_rel_after) {
            eprintln!(
                "psi: denoised: {} points moved by {:.2e} (RMS) onto quadrics of {} neighbours; noise left {rel:.2e} D",
                d.moved, d.rms_move, d.neighbours
            );
        }
        eprintln!(
            "psi: suggested MPU error threshold: {:.4} D",
            prep.error_rel
        );
    }
    Ok(Loaded {
        path: args.input.clone(),
        input,
        file: summary,
    })
}
