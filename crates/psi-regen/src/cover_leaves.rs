//! The ceiling on spacing in a stroke's refitted leaves: where the sampling capped σ̂ under it
//! (a scene with flat regions, `psi_particles::cover_data`), the refitted leaves' input points
//! are covered under the same ceiling, so that a stroke over a flat region leaves it covered
//! as a sampling from scratch would. A scene without the cap is left as it was.

use psi_mpu::Mpu;
use psi_octree::PointAttributes;
use psi_particles::{DensityField, ParticleParams, Particles, cover_data, transfer_attributes};

/// Covers the input points of `leaves` (the stroke's refitted surface leaves) when `field` has
/// a ceiling and a cap, changing only `particles` from `kept` on (the freshly seeded ones): the
/// darts are placed right after the kept particles, final and fixed like them, with their
/// attributes carried from `points` (the input points' attributes) now; the rest relax and
/// get defaults until they settle. Extends `particle_attributes` (aligned with the kept
/// particles) to all of them. Returns the darts' count and the regenerated particles' count
/// (darts included).
#[allow(clippy::too_many_arguments)]
pub(crate) fn cover_refit_leaves(
    mpu: &Mpu,
    particles: &mut Particles,
    kept: usize,
    field: &DensityField,
    params: &ParticleParams,
    leaves: &[u32],
    points: &PointAttributes,
    particle_attributes: &mut PointAttributes,
) -> (usize, usize) {
    let mut darts = 0;
    if let (Some(ceiling), Some(_)) = (field.ceiling, field.cap) {
        let tree = mpu.octree();
        let mut inside: Vec<u32> = leaves
            .iter()
            .flat_map(|&l| tree.points_in(l))
            .copied()
            .collect();
        inside.sort_unstable();
        // (The field keeps the cap it has.)
        let mut field = *field;
        darts = cover_data(
            mpu,
            particles,
            kept,
            &mut field,
            ceiling,
            Some(&inside),
            params,
        )
        .0;
    }
    let regenerated = particles.len() - kept;
    if darts > 0 {
        let carried = transfer_attributes(mpu, &particles.range(kept..kept + darts), points);
        particle_attributes.extend(kept, &carried, darts);
    }
    let none = PointAttributes::default();
    particle_attributes.extend(kept + darts, &none, regenerated - darts);
    (darts, regenerated)
}
