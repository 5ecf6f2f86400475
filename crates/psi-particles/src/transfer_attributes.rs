//! Attributes carried from the input points to the particles: each particle's colour and
//! intensity a weighted average of the input points near it on its side of the surface, its
//! classification their weighted majority.
//!
//! "Near" is the particle's own disk, σ_i (about half the local spacing), widened to √2·σ_i and
//! then 2σ_i (about one spacing) until it holds [`TRANSFER_POINTS`] input points on the
//! particle's side: averaging over them takes the noise of single points out (copying the
//! nearest point's colour would keep it) without blurring beyond about a spacing, so a particle
//! more than one spacing from a colour boundary reads only its own side of it. Where the data
//! are sparser than that the disk doubles further, twice at most. "Its side" is the
//! input points whose normal agrees with the particle's (n_j·n_i > 0), so that the two sheets of
//! a thin plate do not mix. The weight is Epanechnikov's 1 − (d/r)², which goes to zero at the
//! disk's edge and, of the kernels that do, averages noise out best for a given count (its
//! efficiency is about 0.75 of a plain mean's; a (1 − (d/r)²)² falloff's is about 0.45).

use glam::DVec3;
use psi_mpu::Mpu;
use psi_octree::PointAttributes;
use rayon::prelude::*;

use crate::Particles;

/// The disks tried, in σ_i: the first that holds [`TRANSFER_POINTS`] points on the particle's
/// side is used, else the last that holds any (then two more doublings for sparse data).
pub const TRANSFER_RADIUS_SIGMAS: [f64; 3] = [1.0, std::f64::consts::SQRT_2, 2.0];

/// Input points a particle's disk should hold for their mean to be free of their noise (±20
/// levels of uniform colour noise, deviation 11.5, average to about 2.4 over 32 points weighted
/// as here: under 1 % of the range).
pub const TRANSFER_POINTS: usize = 32;

/// The weighted neighbours of one particle of radius `sigma`: `(input index, weight)`, weights
/// summing to 1.
fn neighbours(mpu: &Mpu, x: DVec3, n: DVec3, sigma: f64, found: &mut Vec<u32>) -> Vec<(u32, f64)> {
    let points = mpu.points();
    let weigh = |r: f64, found: &[u32]| -> Vec<(u32, f64)> {
        found
            .iter()
            .filter(|&&j| points[j as usize].n.dot(n) > 0.0)
            .map(|&j| {
                let t = (points[j as usize].p - x).length_squared() / (r * r);
                (j, (1.0 - t).max(0.0))
            })
            .filter(|&(_, w)| w > 0.0)
            .collect()
    };
    let normalised = |weighted: Vec<(u32, f64)>| {
        let total: f64 = weighted.iter().map(|w| w.1).sum();
        weighted.into_iter().map(|(j, w)| (j, w / total)).collect()
    };
    let mut best = Vec::new();
    for k in TRANSFER_RADIUS_SIGMAS {
        mpu.inputs_within(x, k * sigma, found);
        let weighted = weigh(k * sigma, found);
        if weighted.len() >= TRANSFER_POINTS {
            return normalised(weighted);
        }
        if !weighted.is_empty() {
            best = weighted;
        }
    }
    if !best.is_empty() {
        return normalised(best);
    }
    // Sparser data than particles: two more doublings.
    let mut r = 2.0 * sigma;
    for _ in 0..2 {
        r *= 2.0;
        mpu.inputs_within(x, r, found);
        let weighted = weigh(r, found);
        if !weighted.is_empty() {
            return normalised(weighted);
        }
    }
    // No point on its side nearby: the nearest input point, whatever its side.
    mpu.nearest_input_index(x)
        .map(|j| vec![(j, 1.0)])
        .unwrap_or_default()
}

/// The attributes of `particles` (on `mpu`, world units) from `input`, the attributes of
/// `mpu`'s input points ([`Mpu::points`], aligned): for each particle i, the input points j
/// within r of it on its side (n_j·n_i > 0), weighted by 1 − d²/r², give its colour and
/// intensity (weighted means, colours rounded) and its classification (the class of largest
/// total weight, the smaller code on a tie); r is the first of σ_i, √2·σ_i, 2σ_i whose disk
/// holds [`TRANSFER_POINTS`] such points (else the largest holding any, else 4σ_i or 8σ_i);
/// past that the nearest input point gives the particle its attributes.
/// Columns absent from `input` stay absent. Deterministic for any thread count (neighbours
/// summed in index order).
///
/// # Panics
///
/// When a present column of `input` does not have one row per input point.
pub fn transfer_attributes(
    mpu: &Mpu,
    particles: &Particles,
    input: &PointAttributes,
) -> PointAttributes {
    assert!(
        input.fits(mpu.points().len()),
        "attributes must have one row per input point"
    );
    if input.is_empty() {
        return PointAttributes::default();
    }
    let rows: Vec<([u8; 3], f32, u8)> = (0..particles.len())
        .into_par_iter()
        .map_init(Vec::new, |found, i| {
            let (x, n) = (particles.positions[i], particles.normals[i]);
            let w = neighbours(mpu, x, n, particles.sigma[i], found);
            let mut color = [0.0f64; 3];
            let mut intensity = 0.0f64;
            let mut votes: Vec<(u8, f64)> = Vec::new();
            for &(j, wj) in &w {
                let j = j as usize;
                if let Some(c) = &input.colors {
                    for (k, v) in color.iter_mut().enumerate() {
                        *v += wj * f64::from(c[j][k]);
                    }
                }
                if let Some(t) = &input.intensity {
                    intensity += wj * f64::from(t[j]);
                }
                if let Some(c) = &input.classification {
                    match votes.iter_mut().find(|v| v.0 == c[j]) {
                        Some(v) => v.1 += wj,
                        None => votes.push((c[j], wj)),
                    }
                }
            }
            let class = votes
                .iter()
                .max_by(|a, b| a.1.total_cmp(&b.1).then(b.0.cmp(&a.0)))
                .map_or(0, |v| v.0);
            let rgb = color.map(|v| v.round().clamp(0.0, 255.0) as u8);
            (rgb, intensity as f32, class)
        })
        .collect();
    PointAttributes {
        colors: input
            .colors
            .as_ref()
            .map(|_| rows.iter().map(|r| r.0).collect()),
        intensity: input
            .intensity
            .as_ref()
            .map(|_| rows.iter().map(|r| r.1).collect()),
        classification: input
            .classification
            .as_ref()
            .map(|_| rows.iter().map(|r| r.2).collect()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{ParticleParams, sample};
    use psi_mpu::MpuParams;
    use psi_shapes::AnalyticShape;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64Mcg;

    /// Colour channels that span 0–255 over the unit sphere.
    fn truth(p: DVec3) -> [f64; 3] {
        [
            127.5 * (1.0 + p.x),
            127.5 * (1.0 + p.y),
            127.5 * (1.0 - p.z),
        ]
    }

    #[test]
    fn colours_follow_the_noiseless_function_not_the_nearest_point() {
        let points = AnalyticShape::Sphere { radius: 1.0 }.sample(100_000, 3);
        let mut rng = Pcg64Mcg::seed_from_u64(9);
        let noisy: Vec<[u8; 3]> = points
            .iter()
            .map(|p| {
                truth(p.p).map(|v| {
                    (v + rng.random_range(-20.0..=20.0))
                        .round()
                        .clamp(0.0, 255.0) as u8
                })
            })
            .collect();
        let mpu = Mpu::build(&points, &MpuParams::paper()).unwrap();
        let run = sample(&mpu, &ParticleParams::paper());
        let input = PointAttributes {
            colors: Some(noisy.clone()),
            ..Default::default()
        };
        let got = transfer_attributes(&mpu, &run.particles, &input);
        let colors = got.colors.unwrap();
        let mut errors: Vec<f64> = run
            .particles
            .positions
            .iter()
            .zip(&colors)
            .flat_map(|(&x, c)| {
                let t = truth(x);
                (0..3).map(move |k| (f64::from(c[k]) - t[k]).abs() / 255.0)
            })
            .collect();
        errors.sort_by(f64::total_cmp);
        let p99 = errors[errors.len() * 99 / 100];
        let sigma = run.particles.sigma.iter().sum::<f64>() / run.particles.len() as f64;
        assert!(
            p99 <= 0.03,
            "99th percentile error {p99} ({} particles, mean sigma {sigma})",
            run.particles.len()
        );
        // The nearest point's colour, as an oracle that must fail the same bound.
        let mut nearest: Vec<f64> = run
            .particles
            .positions
            .iter()
            .flat_map(|&x| {
                let q = points
                    .iter()
                    .enumerate()
                    .min_by(|a, b| {
                        (a.1.p - x)
                            .length_squared()
                            .total_cmp(&(b.1.p - x).length_squared())
                    })
                    .unwrap()
                    .0;
                let t = truth(x);
                let c = noisy[q];
                (0..3).map(move |k| (f64::from(c[k]) - t[k]).abs() / 255.0)
            })
            .collect();
        nearest.sort_by(f64::total_cmp);
        assert!(nearest[nearest.len() * 99 / 100] > 0.03);
    }

    #[test]
    fn two_halves_do_not_mix_away_from_their_boundary() {
        let points = AnalyticShape::Sphere { radius: 1.0 }.sample(40_000, 5);
        let red = [255, 0, 0];
        let blue = [0, 0, 255];
        let colors: Vec<[u8; 3]> = points
            .iter()
            .map(|p| if p.p.x < 0.0 { red } else { blue })
            .collect();
        let classes: Vec<u8> = points
            .iter()
            .map(|p| if p.p.x < 0.0 { 2 } else { 6 })
            .collect();
        let mpu = Mpu::build(&points, &MpuParams::paper()).unwrap();
        let run = sample(&mpu, &ParticleParams::paper());
        let input = PointAttributes {
            colors: Some(colors),
            intensity: None,
            classification: Some(classes),
        };
        let got = transfer_attributes(&mpu, &run.particles, &input);
        let (colors, classes) = (got.colors.unwrap(), got.classification.unwrap());
        let mut far = 0;
        for (i, &x) in run.particles.positions.iter().enumerate() {
            // Distance to the boundary circle x = 0 along the sphere, about |x| near it.
            let spacing = 2.0 * run.particles.sigma[i];
            if x.x.abs() > spacing {
                far += 1;
                let want = if x.x < 0.0 { (red, 2) } else { (blue, 6) };
                assert_eq!((colors[i], classes[i]), want, "particle {i} at {x}");
            }
        }
        assert!(far > run.particles.len() / 2);
    }
}
