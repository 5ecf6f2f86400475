//! The local-edit section of `reproduce-tables`: `psi edit` on the bunny with a brush covering
//! about 1 % and one covering about 5 % of the surface, several runs each (the first edit of a
//! process, as the CLI reports it: no edit before it has warmed anything), beside a full rebuild
//! and sampling. The editing session (`session.rs`) follows it.

use crate::median::median;
use std::path::Path;
use std::process::Command;

use anyhow::Result;
use psi::DVec3;
use serde_json::{Value, json};

use crate::reference::Reference;
use crate::release_binary::run_psi_report;

/// The brushes: a name, then centre, radius and displacement (world units, as `--brush`).
/// The first is the brush of the issue "Local regeneration" (its centre 8 mm off the surface);
/// the second is centred on the surface with the radius that covers 5 % of it.
pub(crate) const BRUSHES: [(&str, [f64; 7]); 2] = [
    ("small", [-0.016, 0.11, 0.05, 0.015, 0.0, 0.0, 0.004]),
    (
        "5 % of the surface",
        [-0.01416, 0.10815, 0.0427, 0.029, -0.0006, 0.0012, 0.0038],
    ),
];

/// Runs per brush (each a fresh process: the first edit).
const RUNS: usize = 7;

/// Fraction of the reference mesh's area whose triangles have their centroid within `radius` of
/// `center` (world units).
fn covered_fraction(reference: &Reference, center: DVec3, radius: f64) -> f64 {
    let v = &reference.mesh.vertices;
    let (mut inside, mut total) = (0.0, 0.0);
    for f in &reference.mesh.faces {
        let area = reference.face_area(f);
        total += area;
        let centroid = f.iter().map(|&i| v[i as usize]).sum::<DVec3>() / 3.0;
        if (centroid - center).length() < radius {
            inside += area;
        }
    }
    inside / total
}

/// Runs the brushes on `model` (the bunny) with the release binary `psi`, writing scratch files
/// to `out_dir`. Returns the Markdown section and its JSON.
pub(crate) fn local_edits(psi: &Path, model: &Path, out_dir: &Path) -> Result<(String, Value)> {
    let reference = Reference::new(psi::load_mesh(model)?)?;
    let mut md = String::from(
        "\n## Local edits on the bunny (`psi edit`, first edit of a process, median of 7 runs)\n\n| brush | surface covered | marked cells | particles regenerated | local ms | full rebuild and sampling s | local / full |\n|---|---|---|---|---|---|---|\n",
    );
    let mut rows = Vec::new();
    for (name, b) in BRUSHES {
        let brush = b.map(|v| v.to_string()).join(",");
        let json_path = out_dir.join("bunny-edit.json");
        let (mut local, mut full, mut ratio) = (Vec::new(), Vec::new(), Vec::new());
        let mut last = Value::Null;
        for _ in 0..RUNS {
            let report = run_psi_report(
                Command::new(psi)
                    .arg("edit")
                    .arg(model)
                    .arg(format!("--brush={brush}"))
                    .arg("-o")
                    .arg(out_dir.join("bunny-edit.ply"))
                    .arg("--json")
                    .arg(&json_path)
                    .arg("-q"),
                &json_path,
            )?;
            let (l, f) = (
                report["local"]["seconds"].as_f64().unwrap_or(f64::NAN),
                report["full"]["seconds"].as_f64().unwrap_or(f64::NAN),
            );
            local.push(l);
            full.push(f);
            ratio.push(l / f);
            last = report;
        }
        let covered = covered_fraction(&reference, DVec3::new(b[0], b[1], b[2]), b[3]);
        let (local, full, ratio) = (median(&local), median(&full), median(&ratio));
        let edit = &last["local"];
        md.push_str(&format!(
            "| {name} (`--brush={brush}`) | {:.1} % | {} | {} | {:.1} | {full:.3} | {:.1} % |\n",
            100.0 * covered,
            edit["marked_cells"],
            edit["particles_regenerated"],
            1e3 * local,
            100.0 * ratio
        ));
        rows.push(json!({
            "brush": name, "parameters": b, "surface_covered": covered,
            "marked_cells": edit["marked_cells"], "particles_regenerated": edit["particles_regenerated"],
            "local_seconds_median": local, "full_seconds_median": full, "ratio_median": ratio,
            "runs": RUNS, "last_report": last,
        }));
    }
    Ok((md, Value::Array(rows)))
}
