//! The release build of the `psi` binary, which every command that times or checks the CLI
//! runs.

use std::path::PathBuf;
use std::process::Command;

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
