//! `psi info`: what was read (format, scans, point count, attributes, coordinate ranges) and
//! what preprocessing made of it.

use psi::io::{FileSummary, NormalSource};
use serde_json::json;

use crate::input::load;
use crate::{Failure, InputArgs};

/// The file as read, for `--json`: the `file` object beside the reports' `input` fields.
fn file_json(file: &FileSummary) -> serde_json::Value {
    let normals = match file.normals {
        NormalSource::File => "file",
        NormalSource::Faces => "faces",
        NormalSource::Vertices => "vertices",
        NormalSource::Missing => "missing",
    };
    json!({
        "format": file.source.format.map(|f| f.name()),
        "detail": file.source.detail,
        "scans": file.source.scans,
        "points": file.points,
        "invalid_points": file.source.invalid_points,
        "normals": normals,
        "attributes": file.attributes.names(),
        "min": file.bounds.map(|b| b.0.to_array()),
        "max": file.bounds.map(|b| b.1.to_array()),
    })
}

pub(crate) fn run(args: &InputArgs, json: bool, ui: crate::ui::Ui) -> Result<(), Failure> {
    let loaded = load(args, ui)?;
    let (input, j, file) = (&loaded.input, &loaded.input.json, &loaded.file);
    if json {
        let mut j = j.clone();
        if let Some(object) = j.as_object_mut() {
            object.insert("file".to_owned(), file_json(file));
        }
        println!("{}", serde_json::to_string_pretty(&j)?);
    } else {
        println!("input          {}", input.name);
        let format = match (&file.source.detail, file.source.format) {
            (Some(detail), _) => detail.clone(),
            (None, Some(f)) => f.name().to_uppercase(),
            (None, None) => "built-in model".to_owned(),
        };
        println!("format         {format}");
        if let Some(scans) = file.source.scans {
            println!("scans          {scans}");
        }
        println!("vertices       {}", j["vertices"]);
        println!("faces          {}", j["faces"]);
        println!(
            "points         {} read, {} kept",
            input.points_read,
            input.points.len()
        );
        if file.source.invalid_points > 0 {
            let n = file.source.invalid_points;
            println!(
                "invalid        {n} record{} skipped (flagged invalid or not finite)",
                if n == 1 { "" } else { "s" }
            );
        }
        let names = file.attributes.names();
        println!(
            "attributes     {}",
            if names.is_empty() {
                "none".to_owned()
            } else {
                names.join(", ")
            }
        );
        if let Some((lo, hi)) = file.bounds {
            for (axis, (a, b)) in ["x", "y", "z"]
                .iter()
                .zip(lo.to_array().into_iter().zip(hi.to_array()))
            {
                println!("{axis} range        {a} .. {b}");
            }
        }
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
        if p.repeated > 0 {
            println!(
                "repeated       {} points (copies of earlier positions)",
                p.repeated
            );
        }
        if let Some(o) = p.outliers {
            println!(
                "outliers       {} ({} far from the surface, {} off it, {} in stray clumps)",
                o.removed, o.far, o.off_surface, o.clumps
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
