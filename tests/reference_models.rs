//! Particles on the shared models checked against their reference meshes with an independent
//! oracle (parry3d-f64 point-to-triangle-mesh distance): the share within 2e-3 D that issue #6
//! asks of every model, here for the three small ones (`cargo xtask reproduce-tables` checks
//! all seven). Skipped, with a message, when `../shared/models` is absent.

use std::path::Path;

mod common;
use common::model;

use parry3d_f64::query::PointQuery;
use parry3d_f64::shape::TriMesh;
use psi::{Mpu, MpuParams, ParticleParams, ReadOptions};

/// Share of the paper pipeline's particles within `tol` × D of the mesh the points came from.
fn share_within(path: &Path, tol: f64) -> f64 {
    let points = psi::load_points(path, &ReadOptions::paper())
        .unwrap()
        .points;
    let mpu = Mpu::build(&points, &MpuParams::paper()).unwrap();
    let run = psi::sample(&mpu, &ParticleParams::paper());
    let mesh = psi::load_mesh(path).unwrap();
    let shape = TriMesh::new(mesh.vertices, mesh.faces).unwrap();
    let limit = tol * mpu.diagonal();
    let near = run
        .particles
        .positions
        .iter()
        .filter(|p| shape.distance_to_local_point(**p, false) <= limit)
        .count();
    near as f64 / run.particles.len() as f64
}

#[test]
fn bunny_and_horse_particles_lie_on_their_meshes() {
    for name in ["bunny.ply", "horse.ply"] {
        let Some(path) = model(name) else { return };
        let share = share_within(&path, 2e-3);
        assert!(
            share >= 0.995,
            "{name}: {:.2} % within 2e-3 D",
            100.0 * share
        );
    }
}

#[test]
fn cow_particles_stay_on_its_thin_ears_and_horns() {
    // The cow's ears and horns are plates thinner than ε0; with a lenient data footprint the
    // particles slid off their rims onto the MPU's extrapolation (99.2 % within 2e-3 D).
    let Some(path) = model("cow.ply") else { return };
    let share = share_within(&path, 2e-3);
    assert!(share >= 0.995, "{:.2} % within 2e-3 D", 100.0 * share);
}
