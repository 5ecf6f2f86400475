//! The partition of a file into tile files (the first step out of core) written in parts side
//! by side, as a cluster's tasks write it, is byte for byte the partition written whole; a file
//! that changes between the two passes is refused by name.

mod common;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use psi::octree::Monitor;
use psi::tiles::StorePart;
use psi::{MpuParams, OutOfCore, PartitionStart};

/// The point files and the manifest of the store under `scratch`, by name.
fn store_bytes(scratch: &Path) -> BTreeMap<String, Vec<u8>> {
    std::fs::read_dir(scratch.join("tiles"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter_map(|p| {
            let name = p.file_name()?.to_string_lossy().into_owned();
            (name.ends_with(".pts") || name == "manifest.json")
                .then(|| (name, std::fs::read(&p).unwrap()))
        })
        .collect()
}

fn options(scratch: PathBuf) -> OutOfCore {
    OutOfCore {
        max_memory: 64 << 20,
        scratch,
        tile_depth: Some(3),
    }
}

#[test]
fn a_partition_in_parts_is_the_partition_written_whole() {
    let dir = common::scratch("partition-parts");
    let input = dir.join("builtin.ply");
    psi::save_points(&input, &psi::builtin_file(30_000).points).unwrap();
    let inputs = [input.clone()];
    let (params, silent) = (MpuParams::paper(), Monitor::silent());

    let whole = options(dir.join("whole"));
    let found = psi::partition_files(&inputs, None, &params, &whole, &silent).unwrap();
    assert!(!found.resumed && found.points == 30_000);
    assert!(found.store.manifest().tiles.len() >= 16);
    let expected = store_bytes(&whole.scratch);

    let parted = options(dir.join("parted"));
    let PartitionStart::Planned { points, .. } =
        psi::partition_start(&inputs, None, &params, &parted, &silent).unwrap()
    else {
        panic!("a new scratch directory holds no store");
    };
    for index in [2, 0, 1] {
        let part = StorePart::new(index, 3).unwrap();
        psi::partition_part(&inputs, None, part, &parted, &silent).unwrap();
    }
    let assembled = psi::partition_assemble(&inputs, 3, Some(points), &parted).unwrap();
    assert_eq!(assembled.store.manifest(), found.store.manifest());
    assert_eq!(store_bytes(&parted.scratch), expected);
    // Started again on the finished store: found, nothing to write.
    let again = psi::partition_start(&inputs, None, &params, &parted, &silent).unwrap();
    assert!(matches!(again, PartitionStart::Found(p) if p.resumed && p.points == 30_000));

    // The file changes after the first pass: its part is refused, naming the file.
    let changing = options(dir.join("changing"));
    psi::partition_start(&inputs, None, &params, &changing, &silent).unwrap();
    psi::save_points(&input, &psi::builtin_file(29_000).points).unwrap();
    let refused = psi::partition_part(&inputs, None, StorePart::WHOLE, &changing, &silent)
        .unwrap_err()
        .to_string();
    assert!(
        refused.contains("builtin.ply") && refused.contains("changed"),
        "{refused}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
