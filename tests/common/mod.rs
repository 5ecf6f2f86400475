//! Helpers shared by the facade's integration tests: running the `psi` binary, scratch
//! folders, the shared models, and the check every rejected input must pass.

#![allow(dead_code)]

use std::path::{Path, PathBuf};
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

/// `../shared/models`, or `None` (with a message: the test is skipped) when it is absent.
pub(crate) fn models() -> Option<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/models");
    if dir.is_dir() {
        Some(dir)
    } else {
        eprintln!("skipped: ../shared/models not found");
        None
    }
}

/// A run on bad input `name` failed as every command must: exit code 2, one error line on
/// stderr naming the file (notices may precede it), and the output file `kept` (holding "precious") left untouched. `what`
/// labels the failure messages.
pub(crate) fn assert_rejected(out: &Output, name: &str, kept: &Path, what: &str) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{what}: {err}");
    assert!(
        err.contains(name),
        "{what}: error does not name the file: {err}"
    );
    let errors = err.lines().filter(|l| l.starts_with("psi: error:")).count();
    assert_eq!(errors, 1, "{what}: not one error line: {err}");
    assert!(
        err.lines().all(|l| l.starts_with("psi: ")),
        "{what}: stray output: {err}"
    );
    assert_eq!(
        std::fs::read(kept).unwrap(),
        b"precious",
        "{what} clobbered the output"
    );
}

/// `../shared/models/<name>`, or `None` (skipped, with a message) when it is absent.
pub(crate) fn model(name: &str) -> Option<PathBuf> {
    let path = models()?.join(name);
    path.is_file().then_some(path).or_else(|| {
        eprintln!("skipped: {name} not found in ../shared/models");
        None
    })
}

/// `points` as XYZ text: one `x y z nx ny nz` line per point, each number written so that
/// it reads back exactly.
pub(crate) fn xyz_text(points: &[psi::OrientedPoint]) -> String {
    points
        .iter()
        .map(|p| {
            format!(
                "{} {} {} {} {} {}\n",
                p.p.x, p.p.y, p.p.z, p.n.x, p.n.y, p.n.z
            )
        })
        .collect()
}

/// Writes `points` to `path` as XYZ text (see [`xyz_text`]).
pub(crate) fn write_xyz(path: &Path, points: &[psi::OrientedPoint]) {
    std::fs::write(path, xyz_text(points)).unwrap();
}

/// Asserts that the run `out` exited successfully, showing its stderr when it did not.
pub(crate) fn assert_success(out: &Output) {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}
