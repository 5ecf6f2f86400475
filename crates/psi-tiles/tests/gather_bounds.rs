//! A store's gathers read only the tiles and sub-cells whose keys bound the box or ball
//! (`TileStore::keys_around`, no cell of slack): checked against brute force where it is
//! hardest, points on tile and sub-cell faces and boxes and balls whose boundary passes
//! exactly through a point, near the origin and a million units from it.

use std::path::PathBuf;

use glam::DVec3;
use psi_mpu::{MpuFrame, MpuParams};
use psi_octree::{Aabb, OrientedPoint};
use psi_shapes::AnalyticShape;
use psi_tiles::{PointSource, TileStore, TileWriter};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64Mcg;

/// Tile depth of the stores here; their sub-cells lie 3 levels deeper.
const DEPTH: u8 = 2;

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("psi-gather-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

fn frame_of(points: &[OrientedPoint]) -> MpuFrame {
    MpuFrame::for_points(points, &MpuParams::paper()).unwrap()
}

/// A torus moved by `offset`, with a third of its points moved onto the nearest sub-cell
/// face below them along every axis (those that leave the bounds as they are, so the frame is
/// unchanged; far from the origin, within a rounding of the face); the frame.
fn points_on_faces(offset: DVec3) -> (Vec<OrientedPoint>, MpuFrame) {
    let mut points = AnalyticShape::Torus {
        major: 1.0,
        minor: 0.35,
    }
    .sample(6_000, 5);
    for p in &mut points {
        p.p += offset;
    }
    let frame = frame_of(&points);
    let bounds = Aabb::from_points(points.iter().map(|p| p.p)).unwrap();
    let low = frame.origin + frame.root_center - DVec3::splat(frame.root_half);
    let edge = 2.0 * frame.root_half / f64::from(1u32 << (DEPTH + 3));
    let mut snapped_count = 0;
    for p in points.iter_mut().step_by(3) {
        let snapped = low + ((p.p - low) / edge).floor() * edge;
        if (0..3).all(|a| snapped[a] >= bounds.min[a] && p.p[a] < bounds.max[a]) {
            p.p = snapped;
            snapped_count += 1;
        }
    }
    assert!(snapped_count > 1500, "{snapped_count} points snapped");
    assert_eq!(
        frame_of(&points),
        frame,
        "the snapped points keep the frame"
    );
    (points, frame)
}

fn store_of(points: &[OrientedPoint], frame: MpuFrame, dir: &std::path::Path) -> TileStore {
    let mut w = TileWriter::create(dir, frame, DEPTH, 1000, "test").unwrap();
    for chunk in points.chunks(999) {
        w.push(chunk).unwrap();
    }
    w.finish().unwrap()
}

#[test]
fn boxes_and_balls_through_points_on_faces_miss_none() {
    for (name, offset) in [
        ("near", DVec3::ZERO),
        ("far", DVec3::new(1.0e6 + 0.37, -2.5e6, 7.0e5)),
    ] {
        let (points, frame) = points_on_faces(offset);
        let dir = scratch(name);
        let store = store_of(&points, frame, &dir);
        let mut rng = Pcg64Mcg::seed_from_u64(9);
        for round in 0..300 {
            // A point on the boundary: every third a snapped one (on three faces).
            let q = points[3 * rng.random_range(0..points.len() / 3) + (round % 3)].p;
            let jitter = DVec3::new(rng.random(), rng.random(), rng.random()) * 2.0 - 1.0;
            let local = q - frame.origin + jitter * frame.root_half * 0.15;
            let reach = (q - frame.origin - local).abs().max_element();
            let in_box: Vec<OrientedPoint> = points
                .iter()
                .copied()
                .filter(|p| (p.p - frame.origin - local).abs().max_element() <= reach)
                .collect();
            assert!(in_box.iter().any(|p| p.p == q), "the box passes through q");
            let got = store.gather_box(local, reach, 0.0).unwrap();
            assert_eq!(got, in_box, "{name}, round {round}: box");
            let c = local + frame.origin;
            let r = (q - c).length();
            let in_ball: Vec<OrientedPoint> = points
                .iter()
                .copied()
                .filter(|p| (p.p - c).length() <= r)
                .collect();
            assert!(
                in_ball.iter().any(|p| p.p == q),
                "the ball passes through q"
            );
            let got = store.gather_ball(c, r).unwrap();
            assert_eq!(got, in_ball, "{name}, round {round}: ball");
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
