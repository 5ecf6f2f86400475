//! `cargo xtask check-reference`: the Rust (parry3d-f64) particle-to-mesh distances cross-checked
//! with Python libigl's `point_mesh_squared_distance`, in a virtual environment under target/.

use std::process::Command;

use anyhow::{Context, Result, bail};

use crate::paper::TABLE1;
use crate::reference::Reference;
use crate::release_binary::build_release;
use crate::tables::sample;
use crate::{Flags, models_dir, project_root};

const SCRIPT: &str = r#"
import sys, numpy as np, igl, trimesh
mesh = trimesh.load(sys.argv[1], process=False)
P = np.loadtxt(sys.argv[2], ndmin=2)
V = np.asarray(mesh.vertices, dtype=np.float64)
F = np.asarray(mesh.faces, dtype=np.int64)
sqrD, I, C = igl.point_mesh_squared_distance(P, V, F)
np.savetxt(sys.argv[3], np.sqrt(sqrD), fmt="%.17g")
"#;

fn venv_python() -> Result<std::path::PathBuf> {
    let venv = project_root().join("target/xtask-venv");
    let python = venv.join("bin/python");
    if !python.is_file() {
        let ok = Command::new("python3")
            .args(["-m", "venv"])
            .arg(&venv)
            .status()
            .context("python3 -m venv")?
            .success();
        if !ok {
            bail!("could not create a virtual environment with python3 -m venv");
        }
    }
    let ok = Command::new(&python)
        .args([
            "-m", "pip", "install", "--quiet", "numpy", "libigl", "trimesh",
        ])
        .status()
        .context("pip install")?
        .success();
    if !ok {
        bail!("pip install numpy libigl trimesh failed");
    }
    Ok(python)
}

pub(crate) fn run(flags: &Flags) -> Result<()> {
    let dir = models_dir(flags)?;
    let psi = build_release()?;
    let python = venv_python()?;
    let out_dir = project_root().join("target/xtask");
    std::fs::create_dir_all(&out_dir)?;
    let script = out_dir.join("igl_distance.py");
    std::fs::write(&script, SCRIPT)?;
    let only = flags.only.clone().unwrap_or_else(|| vec!["bunny".into()]);
    let mut worst: f64 = 0.0;
    for row in TABLE1.iter().filter(|r| only.iter().any(|o| o == r.model)) {
        let model = dir.join(row.file);
        let (report, ply) = sample(
            &psi,
            &model,
            flags.iterations,
            &out_dir,
            &format!("{}-check", row.model),
        )?;
        let points: Vec<_> = psi::load_points(&ply, &psi::ReadOptions::paper())?
            .points
            .iter()
            .map(|p| p.p)
            .collect();
        let reference = Reference::new(psi::load_mesh(&model)?)?;
        let ours = reference.distances(&points);
        let txt = out_dir.join(format!("{}-points.txt", row.model));
        std::fs::write(
            &txt,
            points
                .iter()
                .map(|p| format!("{:.17e} {:.17e} {:.17e}\n", p.x, p.y, p.z))
                .collect::<String>(),
        )?;
        let theirs_path = out_dir.join(format!("{}-igl.txt", row.model));
        let ok = Command::new(&python)
            .arg(&script)
            .arg(&model)
            .arg(&txt)
            .arg(&theirs_path)
            .status()?
            .success();
        if !ok {
            bail!("the libigl script failed on {}", row.model);
        }
        let theirs: Vec<f64> = std::fs::read_to_string(&theirs_path)?
            .lines()
            .map(|l| l.trim().parse())
            .collect::<Result<_, _>>()?;
        if theirs.len() != ours.len() {
            bail!(
                "{}: libigl returned {} distances for {} points",
                row.model,
                theirs.len(),
                ours.len()
            );
        }
        let diag = report["input"]["bbox_diagonal"].as_f64().unwrap_or(1.0);
        let diff = ours
            .iter()
            .zip(&theirs)
            .map(|(a, b)| (a - b).abs() / diag)
            .fold(0.0, f64::max);
        worst = worst.max(diff);
        println!(
            "{}: {} particles, max |rust − libigl| = {diff:.2e} D",
            row.model,
            ours.len()
        );
    }
    if worst > 1e-9 {
        bail!("Rust and libigl distances differ by {worst:.2e} D (> 1e-9 D)");
    }
    println!("Rust and libigl agree to {worst:.2e} D");
    Ok(())
}
