//! Helpers shared by the facade's integration tests: running the `psi` binary and scratch
//! folders.

#![allow(dead_code)]

use std::path::PathBuf;
use std::process::{Command, Output};

/// Runs the `psi` binary with `args`.
pub(crate) fn psi(args: &[&str]) -> Output {
    psi_env(args, &[])
}

/// Runs the `psi` binary with `args` and extra environment variables.
pub(crate) fn psi_env(args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_psi"));
    cmd.args(args);
    for (k, v) in env {
        cmd.env(k, v);
    }
    cmd.output().expect("run psi")
}

/// A fresh folder for one test (named by process and test).
pub(crate) fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("psi-test-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}
