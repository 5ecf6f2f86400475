//! `psi render`: a PNG picture of particles (coloured by depth, σ or normal) or of a mesh.

use std::path::PathBuf;

use anyhow::anyhow;
use clap::{Args, ValueEnum};
use psi::render::{
    Coloring, RenderParams, SplatStyle, View, render_mesh, render_splats, splat_radii,
};

use crate::Failure;

#[derive(Clone, Copy, Debug, ValueEnum)]
enum ViewArg {
    /// From +z (+y up).
    Front,
    /// From +x.
    Side,
    /// From +y, looking down.
    Top,
    /// From (1, 1, 1).
    Iso,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum ColorArg {
    /// Octree depth of each particle's leaf: shallow green to deep red (the paper's Fig. 5).
    Depth,
    /// Repulsion radius σ.
    Sigma,
    /// The normal as RGB.
    Normal,
    /// The colours the particles carry from a coloured input.
    Input,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum StyleArg {
    /// Coloured dots on a grey surface: the sampling density shows.
    Dots,
    /// Closed surface of coloured disks.
    Disks,
}

#[derive(Args)]
pub(crate) struct RenderArgs {
    /// Particles (PLY with x y z nx ny nz, and depth sigma as `psi sample` writes them; or XYZ),
    /// or a triangle mesh (PLY or OBJ with faces, as `psi mesh` writes it).
    input: PathBuf,
    /// Output picture (PNG).
    #[arg(short, long)]
    output: PathBuf,
    /// Width and height of the picture, pixels.
    #[arg(long, default_value_t = 1024, value_parser = clap::value_parser!(u32).range(16..=8192))]
    size: u32,
    /// Where the model is seen from (orthographic).
    #[arg(long, value_enum, default_value_t = ViewArg::Front)]
    view: ViewArg,
    /// What colours the particles (ignored for a mesh).
    #[arg(long, value_enum, default_value_t = ColorArg::Depth)]
    color: ColorArg,
    /// How particles are drawn.
    #[arg(long, value_enum, default_value_t = StyleArg::Dots)]
    style: StyleArg,
    /// Multiplies the splat radii (σ from the file, else an estimate from the point count).
    #[arg(long, default_value_t = 1.0)]
    splat_scale: f64,
    /// Leave out the colour bar.
    #[arg(long)]
    no_legend: bool,
}

fn usage(error: anyhow::Error) -> Failure {
    Failure { error, code: 2 }
}

pub(crate) fn run(args: &RenderArgs) -> Result<(), Failure> {
    if !(args.splat_scale.is_finite() && args.splat_scale > 0.0) {
        return Err(usage(anyhow!("--splat-scale must be a positive number")));
    }
    let name = args.input.display();
    let base = RenderParams::particles();
    let mut params = RenderParams {
        size: args.size,
        view: match args.view {
            ViewArg::Front => View::Front,
            ViewArg::Side => View::Side,
            ViewArg::Top => View::Top,
            ViewArg::Iso => View::Iso,
        },
        splat_scale: base.splat_scale * args.splat_scale,
        style: match args.style {
            StyleArg::Dots => base.style,
            StyleArg::Disks => SplatStyle::Disks,
        },
        ..base
    };

    crate::input::check_output(Some(&args.input), &args.output, "-o")?;
    let mesh = match psi::load_mesh(&args.input) {
        Ok(mesh) => Some(mesh),
        Err(psi::PsiError::Read {
            reason: psi::io::ReadError::NoFaces,
            ..
        }) => None,
        Err(e) => return Err(e.into()),
    };
    let (image, what) = if let Some(mesh) = mesh {
        let image = render_mesh(&mesh.vertices, &mesh.faces, &params)?;
        (image, format!("{} triangles", mesh.faces.len()))
    } else {
        let p = psi::load_particles(&args.input)?;
        let missing = |property: &str| {
            usage(anyhow!(
                "{name}: no `{property}` property to colour by; try --color normal"
            ))
        };
        let coloring = match args.color {
            ColorArg::Depth => Coloring::Depth,
            ColorArg::Sigma => Coloring::Sigma,
            ColorArg::Normal => Coloring::Normal,
            ColorArg::Input => Coloring::Input,
        };
        let input = p.attributes.colors.as_deref();
        let (colors, legend) = coloring
            .colors(p.depth.as_deref(), p.sigma.as_deref(), &p.normals, input)
            .ok_or_else(|| missing(coloring.name()))?;
        params.legend = legend.filter(|_| !args.no_legend);
        let radius = splat_radii(&p.positions, p.sigma.as_deref());
        let image = render_splats(&p.positions, &p.normals, &colors, &radius, &params)?;
        (image, format!("{} particles", p.positions.len()))
    };
    psi::save_png(&args.output, &image)?;
    println!(
        "{name}: {what} -> {} ({} x {} px, {:?} view)",
        args.output.display(),
        image.width(),
        image.height(),
        args.view
    );
    Ok(())
}
