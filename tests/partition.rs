//! The partition of a file into tile files (the first step out of core) written in parts side
//! by side, as a cluster's tasks write it, is the partition written whole (the same manifest:
//! every file's checksums); a file that changes between the two passes is refused by name.

mod common;

use std::path::PathBuf;

use psi::octree::Monitor;
use psi::tiles::StorePart;
use psi::{MpuParams, OutOfCore, PartitionStart};

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

    let parted = options(dir.join("parted"));
    let PartitionStart::Planned { points } =
        psi::partition_start(&inputs, None, &params, &parted, &silent).unwrap()
    else {
        panic!("a new scratch directory holds no store");
    };
    for index in [2, 0, 1] {
        let part = StorePart::new(index, 3).unwrap();
        psi::partition_part(&inputs, None, part, &parted, &silent).unwrap();
    }
    let assembled = psi::partition_assemble(&inputs, 3, Some(points), &parted).unwrap();
    // The manifests hold every file's size and the SHA-256 of each of its runs: equal
    // manifests are equal files.
    assert_eq!(assembled.store.manifest(), found.store.manifest());
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
