//! `psi info`.

use crate::input::load;
use crate::{Failure, InputArgs};

pub(crate) fn run(args: &InputArgs, json: bool, ui: crate::ui::Ui) -> Result<(), Failure> {
    let loaded = load(args, ui)?;
    let (input, j) = (&loaded.input, &loaded.input.json);
    if json {
        println!("{}", serde_json::to_string_pretty(j)?);
    } else {
        println!("input          {}", input.name);
        println!("vertices       {}", j["vertices"]);
        println!("faces          {}", j["faces"]);
        println!(
            "points         {} read, {} kept",
            input.points_read,
            input.points.len()
        );
        if j["degenerate_faces"].as_u64() > Some(0) {
            println!("skipped        {} degenerate faces", j["degenerate_faces"]);
        }
        println!("bbox min       {}", j["bbox_min"]);
        println!("bbox max       {}", j["bbox_max"]);
        println!("bbox diagonal  {}", j["bbox_diagonal"]);
        let p = &input.report;
        if let Some(c) = p.consistency {
            println!(
                "normals        {:.2} % of neighbouring pairs opposed",
                100.0 * c.opposed_fraction()
            );
        } else {
            println!("normals        estimated");
        }
        if p.normals_flipped > 0 {
            println!("reoriented     {} normals flipped", p.normals_flipped);
        }
        if let Some(o) = p.outliers {
            println!(
                "outliers       {} ({} far from the surface, {} off it)",
                o.removed, o.far, o.off_surface
            );
        }
        if let Some(rel) = p.noise_rel {
            println!(
                "noise          {rel:.2e} D (MPU error threshold {:.4} D)",
                p.error_rel
            );
        }
    }
    Ok(())
}
