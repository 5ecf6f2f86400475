//! A store written in parts side by side (a cluster's partition tasks) is byte for byte the
//! store written whole, whatever the number of parts, also when a part is cut off halfway and
//! run again; the manifest is refused while a part is missing.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use psi_mpu::{MpuFrame, MpuParams};
use psi_octree::OrientedPoint;
use psi_shapes::AnalyticShape;
use psi_tiles::{StorePart, StorePlan, TileStore, TileWriter};

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("psi-parts-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// Every point file of the store in `dir` (tile files, the coarse file) and its manifest, by
/// name; the plan and the parts' records left out.
fn store_bytes(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter_map(|p| {
            let name = p.file_name()?.to_string_lossy().into_owned();
            (name.ends_with(".pts") || name == "manifest.json")
                .then(|| (name, std::fs::read(&p).unwrap()))
        })
        .collect()
}

/// Writes part `part` of the store planned in `dir` from `points`, in chunks of 999, with a
/// buffer of 500 points (so files are appended to many times).
fn write_part(dir: &Path, plan: &StorePlan, part: StorePart, points: &[OrientedPoint]) {
    let mut w = TileWriter::create_part(dir, plan, part, 500).unwrap();
    for chunk in points.chunks(999) {
        w.push(chunk).unwrap();
    }
    let written = w.finish_part().unwrap();
    assert_eq!(written.population, points.len() as u64);
    assert_eq!(written.coarse.is_some(), part.index == 0);
}

#[test]
fn a_store_written_in_parts_is_the_store_written_whole() {
    let points = AnalyticShape::Torus {
        major: 1.0,
        minor: 0.4,
    }
    .sample(20_000, 5);
    let frame = MpuFrame::for_points(&points, &MpuParams::paper()).unwrap();
    let whole_dir = scratch("whole");
    let mut w = TileWriter::create(&whole_dir, frame, 3, 700, "torus").unwrap();
    for chunk in points.chunks(1234) {
        w.push(chunk).unwrap();
    }
    let whole = w.finish().unwrap();
    assert!(whole.manifest().tiles.len() >= 16);
    let expected = store_bytes(&whole_dir);

    for count in [2, 3, 5] {
        let dir = scratch(&format!("in-{count}"));
        let plan = StorePlan::new("torus", &frame, 3);
        plan.start(&dir).unwrap();
        // Every part writes some tiles.
        for index in 0..count {
            let part = StorePart::new(index, count).unwrap();
            assert!(whole.manifest().tiles.iter().any(|t| part.holds(t.key)));
        }
        // Part 1 is cut off halfway (its files half appended, no record), like a task whose
        // worker died; its retry must start afresh.
        let cut = StorePart::new(1, count).unwrap();
        let mut w = TileWriter::create_part(&dir, &plan, cut, 300).unwrap();
        w.push(&points[..points.len() / 2]).unwrap();
        drop(w);
        // The manifest waits for every part.
        let refused = TileStore::assemble(&dir, count).unwrap_err().to_string();
        assert!(refused.contains("part-0-of-"), "{refused}");
        // The parts in reverse order, part 1 again among them.
        for index in (0..count).rev() {
            write_part(&dir, &plan, StorePart::new(index, count).unwrap(), &points);
        }
        let store = TileStore::assemble(&dir, count).unwrap();
        assert_eq!(store.manifest(), whole.manifest());
        assert_eq!(store_bytes(&dir), expected, "{count} parts");
        assert_eq!(
            store.coarse_points().unwrap(),
            whole.coarse_points().unwrap()
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
    std::fs::remove_dir_all(&whole_dir).unwrap();
}

#[test]
fn parts_that_counted_different_inputs_are_refused() {
    let points = AnalyticShape::Sphere { radius: 1.0 }.sample(4_000, 2);
    let frame = MpuFrame::for_points(&points, &MpuParams::paper()).unwrap();
    let dir = scratch("disagree");
    let plan = StorePlan::new("sphere", &frame, 2);
    plan.start(&dir).unwrap();
    write_part(&dir, &plan, StorePart::new(0, 2).unwrap(), &points);
    write_part(&dir, &plan, StorePart::new(1, 2).unwrap(), &points[..3_000]);
    let refused = TileStore::assemble(&dir, 2).unwrap_err().to_string();
    assert!(
        refused.contains("part-1-of-2.json") && refused.contains("disagree"),
        "{refused}"
    );
    // A new start removes the parts' records and files: nothing of the old store is left
    // that a later manifest could pick up.
    plan.start(&dir).unwrap();
    assert!(TileStore::assemble(&dir, 2).is_err());
    let left: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(left, vec!["plan.json".to_owned()]);
    std::fs::remove_dir_all(&dir).unwrap();
}
