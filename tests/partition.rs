//! The partition of a file into tile files (the first step out of core) written in parts side
//! by side, as a cluster's tasks write it, is the partition written whole (the same manifest:
//! every file's checksums); a file that changes between the two passes is refused by name. The
//! outlier step in batches, as a cluster's tasks run it, is the step run whole.

mod common;

use std::path::PathBuf;

use psi::octree::Monitor;
use psi::tiles::StorePart;
use psi::{GivenStage, MpuParams, OutOfCore, PartitionStart};

const PLAIN: GivenStage = GivenStage::Plain;

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
        psi::partition_start(&inputs, None, &params, &parted, PLAIN, &silent).unwrap()
    else {
        panic!("a new scratch directory holds no store");
    };
    for index in [2, 0, 1] {
        let part = StorePart::new(index, 3).unwrap();
        psi::partition_part(&inputs, None, part, &parted, PLAIN, &silent).unwrap();
    }
    let assembled = psi::partition_assemble(&inputs, 3, Some(points), &parted, PLAIN).unwrap();
    // The manifests hold every file's size and the SHA-256 of each of its runs: equal
    // manifests are equal files.
    assert_eq!(assembled.store.manifest(), found.store.manifest());
    // Started again on the finished store: found, nothing to write.
    let again = psi::partition_start(&inputs, None, &params, &parted, PLAIN, &silent).unwrap();
    assert!(matches!(again, PartitionStart::Found(p) if p.resumed && p.points == 30_000));

    // The file changes after the first pass: its part is refused, naming the file.
    let changing = options(dir.join("changing"));
    psi::partition_start(&inputs, None, &params, &changing, PLAIN, &silent).unwrap();
    psi::save_points(&input, &psi::builtin_file(29_000).points).unwrap();
    let refused = psi::partition_part(&inputs, None, StorePart::WHOLE, &changing, PLAIN, &silent)
        .unwrap_err()
        .to_string();
    assert!(
        refused.contains("builtin.ply") && refused.contains("changed"),
        "{refused}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// All points stored in parts, the outlier step's passes over 3 batches of tiles (run out of
/// order), the verdicts joined and the kept points stored in parts: the same verdicts and the
/// same final store as the step run whole on this machine.
#[test]
fn the_outlier_step_in_batches_is_the_step_run_whole() {
    let dir = common::scratch("strays-batches");
    let input = dir.join("strays.ply");
    let mut points = psi::builtin_file(30_000).points;
    let n = points.len();
    for k in 0..40 {
        // Points lifted well off the surface, and repeats.
        let p = points[k * 601];
        points.push(psi::OrientedPoint {
            p: p.p + (0.05 + 0.002 * k as f64) * p.n,
            n: p.n,
        });
        points.push(points[k * 307]);
    }
    psi::save_points(&input, &points).unwrap();
    let inputs = [input.clone()];
    let (params, silent) = (MpuParams::paper(), Monitor::silent());
    let whole = options(dir.join("whole"));
    let preprocess = psi::preprocess::PreprocessParams::scan();
    let done =
        psi::partition_preprocessed(&inputs, None, &preprocess, &params, &whole, &silent).unwrap();
    let tally = done.strays.unwrap();
    assert_eq!(tally.repeated, 40);
    assert!(tally.removed() >= 70, "{tally:?}");
    assert_eq!(done.partition.points, (n + 80) as u64 - tally.removed());

    let parted = options(dir.join("parted"));
    let scratch = &parted.scratch;
    let store_in_parts = |stage: GivenStage| {
        let PartitionStart::Planned { points } =
            psi::partition_start(&inputs, None, &params, &parted, stage, &silent).unwrap()
        else {
            panic!("a new scratch directory holds no store");
        };
        for index in [1, 0] {
            let part = StorePart::new(index, 2).unwrap();
            psi::partition_part(&inputs, None, part, &parted, stage, &silent).unwrap();
        }
        psi::partition_assemble(&inputs, 2, Some(points), &parted, stage).unwrap()
    };
    let all = store_in_parts(GivenStage::All);
    let batches = 3;
    let mut searched = 0;
    for b in [2, 0, 1] {
        searched += psi::stray_standings(&all.store, scratch, (b, batches), true, &silent).unwrap();
    }
    let stats = psi::stray_stats(scratch, batches).unwrap();
    assert_eq!(stats.points, searched);
    assert_eq!(searched, (n + 40) as u64);
    for b in [1, 2, 0] {
        let work = (true, stats);
        psi::stray_verdicts_of_batch(&all.store, scratch, (b, batches), work, &silent).unwrap();
    }
    let joined = psi::stray_join(&all.store, scratch, batches, &silent).unwrap();
    assert_eq!(joined, tally);
    let verdicts = |o: &OutOfCore| std::fs::read(o.scratch.join("strays.bin")).unwrap();
    assert_eq!(verdicts(&parted), verdicts(&whole));
    let kept = store_in_parts(GivenStage::Kept);
    assert_eq!(kept.store.manifest(), done.partition.store.manifest());
    // Both scratch directories now hold a finished run: a cluster would partition nothing.
    let found = |o: &OutOfCore| {
        psi::out_of_core_preprocessing(&inputs, None, &preprocess, o)
            .map(|p| p == psi::OutOfCorePreprocessing::Found)
    };
    assert!(found(&whole).unwrap() && found(&parted).unwrap());
    let fresh = options(dir.join("fresh"));
    assert!(!found(&fresh).unwrap());
    let plan = psi::out_of_core_preprocessing(&inputs, None, &preprocess, &fresh).unwrap();
    assert_eq!(plan, psi::OutOfCorePreprocessing::Outliers);

    // Verdicts another input left (the right length, another source) are never trusted: the
    // run redoes the step and writes its own.
    let right = verdicts(&whole);
    let mut wrong = right.clone();
    wrong[7] = 2;
    std::fs::write(whole.scratch.join("strays.bin"), &wrong).unwrap();
    std::fs::write(whole.scratch.join("strays.source"), "another input").unwrap();
    assert!(!found(&whole).unwrap());
    let again =
        psi::partition_preprocessed(&inputs, None, &preprocess, &params, &whole, &silent).unwrap();
    assert_eq!(again.strays, Some(tally));
    assert_eq!(verdicts(&whole), right);

    // A step not done out of core (reorienting given normals) is refused, naming the file.
    let reorient = psi::preprocess::PreprocessParams {
        orient_given_normals: true,
        ..preprocess
    };
    let refused = psi::partition_preprocessed(&inputs, None, &reorient, &params, &fresh, &silent)
        .unwrap_err();
    let said = refused.to_string();
    assert!(
        said.contains("strays.ply") && said.contains("not done out of core"),
        "{said}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
