//! House rules checked as tests (the rust-analyzer way): every source file opens with a `//!`
//! line and stays within 600 lines, no two files of a crate import each other, and the two
//! front documents stay short enough to read.

#![cfg(test)]

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use crate::project_root;

/// The `.rs` files under `dir`, recursively, skipping `target`.
fn rust_files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let Ok(entries) = std::fs::read_dir(dir) else {
        return out;
    };
    for e in entries.flatten() {
        let p = e.path();
        let name = p.file_name().and_then(|n| n.to_str()).unwrap_or_default();
        if p.is_dir() {
            if name != "target" && !name.starts_with('.') {
                out.extend(rust_files(&p));
            }
        } else if name.ends_with(".rs") {
            out.push(p);
        }
    }
    out.sort();
    out
}

/// The workspace's source folders: each crate's `src`, the facade's, xtask's and the Python
/// extension's, with their subfolders (a binary's, a module's submodules).
fn source_dirs() -> Vec<PathBuf> {
    let root = project_root();
    let mut dirs: Vec<PathBuf> = std::fs::read_dir(root.join("crates"))
        .expect("crates/")
        .flatten()
        .map(|e| e.path().join("src"))
        .filter(|p| p.is_dir())
        .collect();
    dirs.push(root.join("src"));
    dirs.push(root.join("xtask/src"));
    if root.join("python/src").is_dir() {
        dirs.push(root.join("python/src"));
    }
    let mut all = Vec::new();
    for dir in dirs {
        let mut folders: BTreeSet<PathBuf> = rust_files(&dir)
            .iter()
            .filter_map(|f| f.parent().map(Path::to_path_buf))
            .collect();
        folders.insert(dir);
        all.extend(folders);
    }
    all.sort();
    all
}

#[test]
fn every_source_file_opens_with_a_doc_line_and_stays_short() {
    let mut bad = Vec::new();
    for dir in source_dirs() {
        for f in rust_files(&dir)
            .into_iter()
            .filter(|f| f.parent() == Some(&dir))
        {
            let text = std::fs::read_to_string(&f).unwrap();
            if !text.starts_with("//!") {
                bad.push(format!("{}: no `//!` first line", f.display()));
            }
            let lines = text.lines().count();
            if lines > 600 {
                bad.push(format!("{}: {lines} lines (at most 600)", f.display()));
            }
        }
    }
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

/// The names a file's code (not its comments, not its `#[cfg(test)]` tail) takes from
/// `prefix` (`crate::` in a crate's root folder, `super::` among a module's submodules).
fn crate_names(text: &str, prefix: &str) -> BTreeSet<String> {
    let code: String = text
        .split("#[cfg(test)]")
        .next()
        .unwrap_or_default()
        .lines()
        .filter(|l| !l.trim_start().starts_with("//"))
        .collect::<Vec<_>>()
        .join("\n");
    let mut names = BTreeSet::new();
    let ident = |s: &str| {
        s.chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect::<String>()
    };
    for (i, _) in code.match_indices(prefix) {
        let rest = &code[i + prefix.len()..];
        if let Some(list) = rest.strip_prefix('{') {
            let end = list.find('}').unwrap_or(list.len());
            for item in list[..end].split(',') {
                let first = ident(item.trim());
                if !first.is_empty() {
                    names.insert(first);
                }
            }
        } else {
            names.insert(ident(rest));
        }
    }
    names
}

/// Per module file in the folder `src`: the modules of that folder it takes names from (a
/// folder holding `lib.rs` or `main.rs` is a crate root, any other one a module's submodules).
fn module_graph(src: &Path) -> BTreeMap<String, BTreeSet<String>> {
    let files: BTreeMap<String, String> = std::fs::read_dir(src)
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "rs"))
        .map(|p| {
            let module = p.file_stem().unwrap().to_string_lossy().into_owned();
            (module, std::fs::read_to_string(&p).unwrap())
        })
        .collect();
    // Which module owns a name: the root's `pub use module::{…}` re-exports, then the items
    // each file defines.
    let mut owner: BTreeMap<String, String> = BTreeMap::new();
    let is_root = files.contains_key("lib") || files.contains_key("main");
    let prefix = if is_root { "crate::" } else { "super::" };
    let root = files
        .get("lib")
        .or_else(|| files.get("main"))
        .cloned()
        .unwrap_or_default();
    for line in root.split(';') {
        let line = line.trim();
        let Some(rest) = line
            .strip_prefix("pub use ")
            .or_else(|| line.strip_prefix("pub(crate) use "))
        else {
            continue;
        };
        let Some((module, items)) = rest.split_once("::") else {
            continue;
        };
        let items = items.trim_start_matches('{').trim_end_matches('}');
        for item in items.split(',') {
            let name = item.trim();
            if !name.is_empty() && !name.contains("::") {
                owner.insert(name.to_owned(), module.to_owned());
            }
        }
    }
    for (module, text) in &files {
        for line in text.lines() {
            let words: Vec<&str> = line.split_whitespace().collect();
            for w in words.windows(2) {
                if ["struct", "enum", "fn", "const", "type", "trait"].contains(&w[0]) {
                    let name: String = w[1]
                        .chars()
                        .take_while(|c| c.is_alphanumeric() || *c == '_')
                        .collect();
                    owner.entry(name).or_insert_with(|| module.clone());
                }
            }
        }
    }
    files
        .iter()
        .filter(|(m, _)| *m != "lib" && *m != "main")
        .map(|(module, text)| {
            let deps = crate_names(text, prefix)
                .into_iter()
                .filter_map(|n| {
                    if files.contains_key(&n) {
                        Some(n)
                    } else {
                        owner.get(&n).cloned()
                    }
                })
                .filter(|d| d != module)
                .collect();
            (module.clone(), deps)
        })
        .collect()
}

#[test]
fn no_two_files_import_each_other() {
    let mut cycles = Vec::new();
    for dir in source_dirs() {
        let graph = module_graph(&dir);
        for (a, deps) in &graph {
            for b in deps {
                if a < b && graph.get(b).is_some_and(|d| d.contains(a)) {
                    cycles.push(format!("{}: {a} <-> {b}", dir.display()));
                }
            }
        }
    }
    assert!(cycles.is_empty(), "{}", cycles.join("\n"));
}

#[test]
fn the_import_check_sees_a_cycle() {
    let a = "//! a\nuse crate::b::B;\npub(crate) struct A;\n";
    let b = "//! b\n/// [`crate::a::A`] only in a comment\npub(crate) struct B;\n";
    assert!(crate_names(a, "crate::").contains("b"));
    assert!(crate_names(b, "crate::").is_empty());
    let c = "//! c\nuse crate::{a, Thing};\nfn f() { crate::d::g() }\n#[cfg(test)]\nuse crate::e;";
    let names = crate_names(c, "crate::");
    assert_eq!(
        names.into_iter().collect::<Vec<_>>(),
        ["Thing", "a", "d"].map(String::from)
    );
}

#[test]
fn front_documents_stay_short() {
    let root = project_root();
    for (file, limit) in [("docs/ARCHITECTURE.md", 250), ("README.md", 130)] {
        let lines = std::fs::read_to_string(root.join(file))
            .unwrap()
            .lines()
            .count();
        assert!(lines <= limit, "{file}: {lines} lines (at most {limit})");
    }
}

/// Each package of a `cargo tree -f '{p} [{f}]' --prefix none` listing with its features:
/// `name version` → the feature names.
fn features_by_package(tree: &str) -> BTreeMap<String, BTreeSet<String>> {
    let mut out: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for line in tree.lines() {
        let Some((package, rest)) = line.split_once(" [") else {
            continue;
        };
        let mut words = package.split_whitespace();
        let (Some(name), Some(version)) = (words.next(), words.next()) else {
            continue;
        };
        let features = rest.split(']').next().unwrap_or_default();
        out.entry(format!("{name} {version}")).or_default().extend(
            features
                .split(',')
                .filter(|f| !f.is_empty())
                .map(String::from),
        );
    }
    out
}

/// The packages both listings hold with different features, one line each.
fn feature_differences(workspace: &str, package: &str) -> Vec<String> {
    let ws = features_by_package(workspace);
    features_by_package(package)
        .into_iter()
        .filter_map(|(p, f)| {
            let w = ws.get(&p)?;
            (w != &f).then(|| {
                let only_ws: Vec<_> = w.difference(&f).collect();
                let only_p: Vec<_> = f.difference(w).collect();
                format!("{p}: test build only {only_ws:?}, package only {only_p:?}")
            })
        })
        .collect()
}

/// `cargo tree` over the workspace with `edges`, or over one package.
fn cargo_tree(package: Option<&str>, edges: &str) -> String {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let mut cmd = std::process::Command::new(cargo);
    cmd.current_dir(project_root())
        .args(["tree", "--offline", "--prefix", "none", "-e", edges])
        .args(["-f", "{p} [{f}]"]);
    match package {
        Some(p) => cmd.args(["-p", p]),
        None => cmd.arg("--workspace"),
    };
    let out = cmd.output().expect("cargo tree runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).expect("cargo tree prints UTF-8")
}

/// CI builds the Python package's wheel in the dev profile after `cargo test --workspace`
/// (README): it reuses the test build's crates only where it resolves every shared dependency
/// with the same features (the root Cargo.toml names the ones the test build adds).
#[test]
fn the_python_package_resolves_the_test_builds_features() {
    let differences = feature_differences(
        &cargo_tree(None, "normal,build,dev"),
        &cargo_tree(Some("psi-python"), "normal,build"),
    );
    assert!(differences.is_empty(), "{}", differences.join("\n"));
}

#[test]
fn the_feature_check_sees_a_difference() {
    let ws = "glam v0.33.12 [approx,std]\nrayon v1.12.0 []\npsi v0.1.0 (/w) [default]\n";
    let py = "glam v0.33.12 [std]\nrayon v1.12.0 []\npsi v0.1.0 (/w) [default] (*)\n";
    assert_eq!(
        feature_differences(ws, py),
        [r#"glam v0.33.12: test build only ["approx"], package only []"#]
    );
    assert!(feature_differences(ws, ws).is_empty());
}
