//! Stray points for the scan cases: 1 % of a model's points added uniformly in its bounding
//! box with random unit normals, from a seeded generator.

use anyhow::{Context, Result};
use psi::{DVec3, OrientedPoint};
use rand::RngExt;
use rand_pcg::Pcg64Mcg;

/// `clean` (shape: N, world units, unit normals) followed by N / 100 points drawn uniformly in
/// its bounding box, each with a uniformly random unit normal (shape: N + N / 100).
pub(crate) fn with_uniform_outliers(
    clean: &[OrientedPoint],
    rng: &mut Pcg64Mcg,
) -> Result<Vec<OrientedPoint>> {
    let bounds = psi::Aabb::from_points(clean.iter().map(|p| p.p)).context("empty model")?;
    let mut stray = clean.to_vec();
    for _ in 0..clean.len() / 100 {
        let t = DVec3::new(rng.random(), rng.random(), rng.random());
        stray.push(OrientedPoint {
            p: bounds.min + t * bounds.extent(),
            n: psi::shapes::gaussian_vector(rng).normalize(),
        });
    }
    Ok(stray)
}
