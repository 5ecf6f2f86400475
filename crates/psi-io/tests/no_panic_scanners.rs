//! Property tests (seeded, 256 cases each) of the scanner readers: random bytes, and random
//! mutations, splices and truncations of valid LAS, LAZ, E57 and PCD files, read as each of
//! those formats, never panic; whatever is accepted satisfies the output invariants (finite
//! positions, unit or missing normals, attribute columns aligned with the points).
//!
//! `write_fuzz_seeds` (ignored) writes the same seeds to `fuzz/seeds/<target>/` for
//! cargo-fuzz: `cargo test -p psi-io --test no_panic_scanners -- --ignored`.

mod common;

use std::io::Cursor;
use std::ops::ControlFlow;

use common::config;
use common::mutation::{apply, binary_mutation};
use common::scans::{e57_file, e57_spherical, las_file, packed_rgb, pcd_file, scan_points};
use proptest::prelude::*;
use psi_io::{Format, NormalSource, PointCloudFile, PointStream, ReadOptions, read_points};

const FORMATS: [Format; 3] = [Format::Las, Format::E57, Format::Pcd];

fn check(file: &PointCloudFile) {
    assert!(!file.points.is_empty());
    for p in &file.points {
        assert!(p.p.is_finite());
        if file.normals == NormalSource::Missing {
            assert_eq!(p.n, glam::DVec3::ZERO);
        } else {
            assert!((p.n.length() - 1.0).abs() < 1e-12, "{:?}", p.n);
        }
    }
    assert!(file.attributes.fits(file.points.len()));
    if let Some(intensity) = &file.attributes.intensity {
        assert!(intensity.iter().all(|v| v.is_finite()));
    }
}

/// Reads `bytes` as every scanner format, whole and streamed in small chunks.
fn read_everything(bytes: &[u8]) {
    for format in FORMATS.into_iter().chain([Format::sniff(bytes)]) {
        if let Ok(file) = read_points(bytes, format, &ReadOptions::paper()) {
            check(&file);
        }
        if !format.is_streamed() {
            continue;
        }
        if let Ok(stream) = PointStream::open(Cursor::new(bytes.to_vec()), format) {
            let header = stream.header().clone();
            let _ = stream.for_each_chunk(3, |chunk| {
                assert!((1..=3).contains(&chunk.len()));
                assert!(chunk.positions.iter().all(|p| p.is_finite()));
                assert!(chunk.attributes.fits(chunk.len()));
                assert_eq!(chunk.normals.is_some(), header.normals);
                ControlFlow::Continue(())
            });
        }
    }
}

/// Small valid files of every scanner format and encoding: (fuzz target, bytes).
fn seeds() -> Vec<(&'static str, Vec<u8>)> {
    let points = scan_points(40, [5e5, 5e6, 100.0]);
    let rows: Vec<[f32; 8]> = (0..6)
        .map(|i| {
            let t = i as f32;
            [
                t,
                t * 0.5,
                1.0,
                0.0,
                0.0,
                1.0,
                packed_rgb([i as u8 * 40, 7, 200]),
                t * 9.0,
            ]
        })
        .collect();
    let few = scan_points(12, [0.0; 3]);
    let half = std::f64::consts::FRAC_1_SQRT_2;
    vec![
        (
            "read_las",
            las_file(&points, 2, 3, false, 0.01, [5e5, 5e6, 100.0]),
        ),
        (
            "read_las",
            las_file(&points, 4, 6, false, 0.001, [5e5, 5e6, 100.0]),
        ),
        (
            "read_las",
            las_file(&points, 2, 1, true, 0.01, [5e5, 5e6, 100.0]),
        ),
        (
            "read_las",
            las_file(&points, 4, 7, true, 0.001, [5e5, 5e6, 100.0]),
        ),
        (
            "read_e57",
            e57_file(&[
                (
                    ([half, 0.0, 0.0, half], [1.0, 2.0, 3.0]),
                    few.iter().map(|&p| (p, p.class != 3)).collect(),
                ),
                (
                    ([1.0, 0.0, 0.0, 0.0], [0.0; 3]),
                    few.iter().map(|&p| (p, true)).collect(),
                ),
            ]),
        ),
        (
            "read_e57",
            e57_spherical(&[[1.0, 0.5, 0.25], [2.0, -1.0, 0.5], [0.5, 3.0, -0.5]]),
        ),
        ("read_pcd", pcd_file("ascii", &rows, 3, 2)),
        ("read_pcd", pcd_file("binary", &rows, 3, 2)),
        ("read_pcd", pcd_file("binary_compressed", &rows, 6, 1)),
        (
            "read_pcd",
            b"VERSION .7\nFIELDS x y z rgba _ intensity\nSIZE 2 4 8 4 1 1\nTYPE I U F U U U\n\
              COUNT 1 1 1 1 3 1\nWIDTH 2\nHEIGHT 1\nPOINTS 2\nDATA ascii\n\
              -3 7 0.5 4294901760 1 2 3 200\n4 0 -1e3 16777215 0 0 0 0\n"
                .to_vec(),
        ),
    ]
}

/// The shared seeded config; `PSI_PROPTEST_CASES=n` runs `n` cases instead (a longer hunt).
fn scanner_config() -> proptest::test_runner::Config {
    let mut c = config();
    if let Some(n) = std::env::var("PSI_PROPTEST_CASES")
        .ok()
        .and_then(|n| n.parse().ok())
    {
        c.cases = n;
        c.rng_seed = proptest::test_runner::RngSeed::Random;
    }
    c
}

/// CRC-32C (Castagnoli), as E57 checksums its pages (ASTM E2807 §9.2).
fn crc32c(data: &[u8]) -> u32 {
    !data.iter().fold(!0u32, |crc, &byte| {
        (0..8).fold(crc ^ u32::from(byte), |c, _| {
            if c & 1 == 1 {
                (c >> 1) ^ 0x82F6_3B78
            } else {
                c >> 1
            }
        })
    })
}

/// Rewrites the checksum of every whole 1024-byte E57 page (the last 4 bytes, big-endian), so
/// that a mutation reaches the XML and binary sections instead of failing the page check.
fn repair_e57_pages(bytes: &mut [u8]) {
    for page in bytes.chunks_exact_mut(1024) {
        let crc = crc32c(&page[..1020]);
        page[1020..].copy_from_slice(&crc.to_be_bytes());
    }
}

/// Replaces the digit run around a position with `digits` (counts and offsets in XML).
fn replace_digits(bytes: &mut Vec<u8>, at: usize, digits: &str) {
    if bytes.is_empty() {
        return;
    }
    let Some(i) = (at % bytes.len()..bytes.len()).find(|&k| bytes[k].is_ascii_digit()) else {
        return;
    };
    let end = (i..bytes.len())
        .find(|&k| !bytes[k].is_ascii_digit())
        .unwrap_or(bytes.len());
    bytes.splice(i..end, digits.bytes());
}

proptest! {
    #![proptest_config(scanner_config())]

    #[test]
    fn e57_mutations_behind_valid_checksums_never_panic(
        spherical in any::<bool>(),
        mutations in prop::collection::vec(binary_mutation(), 0..4),
        numbers in prop::collection::vec((any::<usize>(), "[0-9]{1,20}"), 0..4),
    ) {
        let seeds = seeds();
        let e57: Vec<&Vec<u8>> = seeds.iter().filter(|s| s.0 == "read_e57").map(|s| &s.1).collect();
        let mut bytes = e57[usize::from(spherical)].clone();
        for (at, digits) in &numbers {
            // The XML section follows the binary one: aim at the file's second half.
            let at = bytes.len() / 2 + at % (bytes.len() / 2).max(1);
            replace_digits(&mut bytes, at, digits);
        }
        for m in &mutations {
            apply(&mut bytes, m);
        }
        repair_e57_pages(&mut bytes);
        read_everything(&bytes);
    }

    #[test]
    fn random_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..600)) {
        read_everything(&bytes);
        for magic in [&b"LASF"[..], b"ASTM-E57", b"# .PCD v0.7\nVERSION 0.7\n"] {
            let mut with_magic = magic.to_vec();
            with_magic.extend_from_slice(&bytes);
            read_everything(&with_magic);
        }
    }

    #[test]
    fn mutated_valid_files_never_panic(
        seed in 0usize..1000,
        mutations in prop::collection::vec(binary_mutation(), 1..6),
    ) {
        let seeds = seeds();
        let mut bytes = seeds[seed % seeds.len()].1.clone();
        for m in &mutations {
            apply(&mut bytes, m);
        }
        read_everything(&bytes);
    }

    #[test]
    fn every_truncation_of_valid_files_is_handled(seed in 0usize..1000, keep in 0.0f64..1.0) {
        let seeds = seeds();
        let base = &seeds[seed % seeds.len()].1;
        read_everything(&base[..(keep * base.len() as f64) as usize]);
    }
}

#[test]
fn repaired_e57_seeds_stay_valid() {
    for (_, mut seed) in seeds().into_iter().filter(|s| s.0 == "read_e57") {
        let before = seed.clone();
        repair_e57_pages(&mut seed);
        assert_eq!(
            seed, before,
            "the checksum is CRC-32C, big-endian, per 1024-byte page"
        );
    }
}

#[test]
fn seeds_are_valid() {
    for (i, (_, seed)) in seeds().iter().enumerate() {
        let file = read_points(seed, Format::sniff(seed), &ReadOptions::paper());
        assert!(file.is_ok(), "seed {i}: {file:?}");
        check(&file.unwrap());
    }
}

/// Writes the seeds as cargo-fuzz seed corpora (`fuzz/seeds/<target>/seed-<n>`).
#[test]
#[ignore = "writes files: run to refresh the fuzz corpora"]
fn write_fuzz_seeds() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fuzz/seeds");
    for (n, (target, bytes)) in seeds().iter().enumerate() {
        let dir = root.join(target);
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join(format!("seed-{n}")), bytes).unwrap();
    }
}
