//! `cargo xtask figures [--models DIR] [--only builtin,bunny,uniform,edit]`: regenerates the
//! README's pictures in `docs/images/` with the release `psi` binary: the built-in model's
//! particles coloured by octree depth (`builtin`), the bunny's (`bunny`), adaptive beside
//! uniform sampling (`uniform`), and the bunny before and after a local brush edit (`edit`).
//! Models come from `--models`, `$PSI_MODELS` or `../shared/models`; the bunny figures are
//! skipped with a message when `bunny.ply` is not there.

use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{Context, Result};
use psi::DVec3;
use psi::render::{
    Legend, Pixmap, Ramp, RenderParams, View, append_legend, render_splats, scalar_colors,
    side_by_side,
};

use crate::release_binary::build_release;
use crate::{Flags, models_dir, project_root};

/// Side of a single picture, pixels.
const SIZE: &str = "800";
/// Side of each panel of a side-by-side picture, pixels.
const PANEL: u32 = 540;
/// The brush of the edit figure: centre (on the bunny's back, where it curves towards the
/// head), radius, and a displacement along the surface normal there (bunny units; the
/// bounding-box diagonal is 0.25).
const BRUSH: [f64; 7] = [-0.015, 0.106, 0.044, 0.02, -0.0014, 0.0048, 0.0067];
/// Half the side of the box the edit figure frames around the brush centre.
const ZOOM: f64 = 0.035;
/// How much of a kept particle's colour is replaced by white in the "after" panel.
const PALE: f64 = 0.65;
const WHITE: [u8; 4] = [255; 4];

/// Runs `psi` with `args`; fails with its error output.
fn psi_run(psi: &Path, args: &[&str]) -> Result<()> {
    let out = crate::release_binary::run_psi(Command::new(psi).args(args))?;
    print!("{}", String::from_utf8_lossy(&out.stdout));
    Ok(())
}

fn text(path: &Path) -> Result<&str> {
    path.to_str()
        .with_context(|| format!("{} is not UTF-8", path.display()))
}

/// A particle file to draw as one panel.
struct Panel {
    particles: psi::ParticleColumns,
    depth: Vec<f64>,
    sigma: Vec<f64>,
    /// Particles to draw pale (kept unchanged by an edit).
    pale: Vec<bool>,
}

impl Panel {
    fn load(path: &Path) -> Result<Panel> {
        let particles = psi::load_particles(path)?;
        let missing = |what: &str| format!("{}: no {what} column", path.display());
        let depth = particles.depth.clone().with_context(|| missing("depth"))?;
        let sigma = particles.sigma.clone().with_context(|| missing("sigma"))?;
        let pale = vec![false; depth.len()];
        Ok(Panel {
            particles,
            depth,
            sigma,
            pale,
        })
    }

    /// Draws the particles coloured by depth on the range of `legend`.
    fn render(&self, legend: &Legend, params: &RenderParams) -> Result<Pixmap> {
        let p = &self.particles;
        let mut colors = scalar_colors(&self.depth, Ramp::Depth, legend.min, legend.max);
        for (c, _) in colors.iter_mut().zip(&self.pale).filter(|(_, pale)| **pale) {
            *c = c.map(|v| (f64::from(v) + PALE * (255.0 - f64::from(v))).round() as u8);
        }
        Ok(render_splats(
            &p.positions,
            &p.normals,
            &colors,
            &self.sigma,
            params,
        )?)
    }
}

/// Renders `panels` with one framing and one depth range, side by side under `captions`, with
/// the depth legend on the right; writes the PNG.
fn compose(panels: &[&Panel], captions: &[&str], params: &RenderParams, out: &Path) -> Result<()> {
    let all: Vec<f64> = panels
        .iter()
        .flat_map(|p| p.depth.iter().copied())
        .collect();
    let legend = Legend::depth(&all);
    let images = panels
        .iter()
        .map(|p| p.render(&legend, params))
        .collect::<Result<Vec<_>>>()?;
    let row: Vec<(&Pixmap, &str)> = images.iter().zip(captions.iter().copied()).collect();
    let image = append_legend(&side_by_side(&row, params.background)?, &legend, WHITE)?;
    psi::save_png(out, &image)?;
    println!("wrote {}", out.display());
    Ok(())
}

/// The bounding box of the particles of several panels.
fn union_bounds(panels: &[&Panel]) -> [DVec3; 2] {
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for p in panels.iter().flat_map(|p| &p.particles.positions) {
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    [lo, hi]
}

/// Where the figures go and the intermediate particle files.
struct Dirs {
    psi: PathBuf,
    images: PathBuf,
    work: PathBuf,
}

impl Dirs {
    fn png(&self, name: &str) -> PathBuf {
        self.images.join(name)
    }
    fn ply(&self, name: &str) -> PathBuf {
        self.work.join(name)
    }
}

/// The built-in model, coloured by depth, seen from (1, 1, 1).
fn builtin(d: &Dirs) -> Result<()> {
    let ply = d.ply("builtin.ply");
    psi_run(&d.psi, &["sample", "-o", text(&ply)?])?;
    psi_run(
        &d.psi,
        &[
            "render",
            text(&ply)?,
            "-o",
            text(&d.png("builtin-depth.png"))?,
            "--size",
            SIZE,
            "--view",
            "iso",
        ],
    )
}

/// The bunny's depth-adaptive particles (the paper's Fig. 5 colouring); returns the count.
fn bunny(d: &Dirs, model: &str) -> Result<u64> {
    let (ply, report) = (d.ply("bunny.ply"), d.ply("bunny.json"));
    psi_run(
        &d.psi,
        &["sample", model, "-o", text(&ply)?, "--json", text(&report)?],
    )?;
    psi_run(
        &d.psi,
        &[
            "render",
            text(&ply)?,
            "-o",
            text(&d.png("bunny-depth.png"))?,
            "--size",
            SIZE,
        ],
    )?;
    let report: serde_json::Value = serde_json::from_slice(&std::fs::read(&report)?)?;
    report["particles"]["count"]
        .as_u64()
        .context("the sample report has no particle count")
}

/// Adaptive beside uniform sampling with the same number of particles, framed on the head
/// and back.
fn uniform(d: &Dirs, model: &str, count: u64) -> Result<()> {
    psi_run(
        &d.psi,
        &[
            "sample",
            model,
            "--uniform",
            "--count",
            &count.to_string(),
            "-o",
            text(&d.ply("bunny-uniform.ply"))?,
        ],
    )?;
    let adaptive = Panel::load(&d.ply("bunny.ply"))?;
    let uniform = Panel::load(&d.ply("bunny-uniform.ply"))?;
    // The head, ears and back: flat and detailed parts side by side, dots large enough to
    // count.
    let [lo, hi] = union_bounds(&[&adaptive, &uniform]);
    let part = |t: DVec3| lo + t * (hi - lo);
    let params = RenderParams {
        size: PANEL,
        bounds: Some([
            part(DVec3::new(0.0, 0.35, 0.0)),
            part(DVec3::new(0.75, 1.0, 1.0)),
        ]),
        margin: 0.02,
        ..RenderParams::particles()
    };
    compose(
        &[&adaptive, &uniform],
        &["ADAPTIVE", "UNIFORM, SAME COUNT"],
        &params,
        &d.png("bunny-adaptive-uniform.png"),
    )
}

/// The bunny before and after a local brush edit, framed on the brush; after the edit the
/// particles it left untouched (bitwise) are pale.
fn edit(d: &Dirs, model: &str) -> Result<()> {
    let brush = BRUSH.map(|v| v.to_string()).join(",");
    let (before, after) = (d.ply("edit-before.ply"), d.ply("edit-after.ply"));
    psi_run(
        &d.psi,
        &[
            "edit",
            model,
            &format!("--brush={brush}"),
            "--before",
            text(&before)?,
            "-o",
            text(&after)?,
            "--json",
            text(&d.ply("edit.json"))?,
        ],
    )?;
    let before = Panel::load(&before)?;
    let mut after = Panel::load(&after)?;
    let key = |p: &DVec3| p.to_array().map(f64::to_bits);
    let old: HashSet<[u64; 3]> = before.particles.positions.iter().map(key).collect();
    after.pale = after
        .particles
        .positions
        .iter()
        .map(|p| old.contains(&key(p)))
        .collect();
    let regenerated = after.pale.iter().filter(|&&kept| !kept).count();
    let center = DVec3::new(BRUSH[0], BRUSH[1], BRUSH[2]);
    let params = RenderParams {
        size: PANEL,
        view: View::Front,
        bounds: Some([center - DVec3::splat(ZOOM), center + DVec3::splat(ZOOM)]),
        margin: 0.0,
        ..RenderParams::particles()
    };
    compose(
        &[&before, &after],
        &["BEFORE", &format!("AFTER: {regenerated} NEW")],
        &params,
        &d.png("bunny-edit.png"),
    )
}

pub(crate) fn run(flags: &Flags) -> Result<()> {
    let wanted = |f: &str| flags.only.as_ref().is_none_or(|o| o.iter().any(|x| x == f));
    let d = Dirs {
        psi: build_release()?,
        images: project_root().join("docs/images"),
        work: project_root().join("target/xtask/figures"),
    };
    std::fs::create_dir_all(&d.images)?;
    std::fs::create_dir_all(&d.work)?;
    if wanted("builtin") {
        builtin(&d)?;
    }
    if !["bunny", "uniform", "edit"].iter().any(|f| wanted(f)) {
        return Ok(());
    }
    let model: Option<PathBuf> = models_dir(flags)
        .ok()
        .map(|dir| dir.join("bunny.ply"))
        .filter(|p| p.is_file());
    let Some(model) = model else {
        eprintln!(
            "skipping the bunny figures: bunny.ply not found (pass --models DIR or set PSI_MODELS)"
        );
        return Ok(());
    };
    let model = text(&model)?;
    if wanted("bunny") || wanted("uniform") {
        let count = bunny(&d, model)?;
        if wanted("uniform") {
            uniform(&d, model, count)?;
        }
    }
    if wanted("edit") {
        edit(&d, model)?;
    }
    Ok(())
}
