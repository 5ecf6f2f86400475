//! How to edit a shape and keep its particles up to date: a `Scene` holds the points, their MPU
//! and their particles; each edit refits only the cells it reaches and regenerates only their
//! particles, and the result equals a build from scratch of the edited points.
//!
//! `cargo run --release --example brush_edit`

use psi::regen::{Edit, Scene};
use psi::{DVec3, MpuParams, ParticleParams};

fn main() -> anyhow::Result<()> {
    let points = psi::builtin_model();
    let (mut scene, _) = Scene::new(points, &MpuParams::paper(), &ParticleParams::paper())?;
    let before = scene.particles().clone();

    // Push the surface out by 0.05 around a point of the model's outer rim.
    let centre = scene.points()[0].p;
    let brush = Edit::Brush {
        center: centre,
        radius: 0.25,
        displacement: 0.05 * scene.points()[0].n,
    };
    let report = scene.apply(&brush)?;
    println!(
        "refitted {} of {} cells, regenerated {} of {} particles in {:.1} ms",
        report.refit_cells,
        scene.mpu().octree().cells().len(),
        report.particles_regenerated,
        scene.particles().len(),
        1e3 * report.seconds
    );

    // Particles away from the brush are the ones from before, bit for bit.
    let far = |p: &DVec3| (*p - centre).length() > 1.0;
    let kept = before.positions.iter().filter(|p| far(p)).count();
    let still = scene
        .particles()
        .positions
        .iter()
        .filter(|p| far(p) && before.positions.contains(p))
        .count();
    println!("{still} of the {kept} particles far from the brush are unchanged");
    Ok(())
}
