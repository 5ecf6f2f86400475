//! The release build of the `psi` binary, which every command that times or checks the CLI
//! runs, and running it.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use anyhow::{Context, Result, bail};

use crate::project_root;

/// Builds the release `psi` binary and returns its path.
pub(crate) fn build_release() -> Result<PathBuf> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let status = Command::new(cargo)
        .args(["build", "--release", "--bin", "psi"])
        .current_dir(project_root())
        .status()
        .context("running cargo build --release")?;
    if !status.success() {
        bail!("cargo build --release --bin psi failed");
    }
    Ok(project_root().join("target/release/psi"))
}

/// Runs `cmd` (a `psi` invocation) to completion; when it fails, the error names the command
/// and shows its stderr.
pub(crate) fn run_psi(cmd: &mut Command) -> Result<Output> {
    let out = cmd.output().with_context(|| format!("running {cmd:?}"))?;
    if !out.status.success() {
        bail!("{cmd:?} failed: {}", String::from_utf8_lossy(&out.stderr));
    }
    Ok(out)
}

/// [`run_psi`], then the JSON report the command wrote to `report`.
pub(crate) fn run_psi_report(cmd: &mut Command, report: &Path) -> Result<serde_json::Value> {
    run_psi(cmd)?;
    let text = std::fs::read(report).with_context(|| format!("reading {}", report.display()))?;
    serde_json::from_slice(&text)
        .with_context(|| format!("{}: not a JSON report", report.display()))
}
