//! Gaussian deviates from a seeded generator, for making clean samples noisy in tests and
//! experiments.

use glam::DVec3;
use rand::RngExt;
use rand_pcg::Pcg64Mcg;

/// A standard normal deviate (mean 0, standard deviation 1), by the Box–Muller transform.
/// Consumes two draws of `rng`.
pub fn gaussian(rng: &mut Pcg64Mcg) -> f64 {
    let u: f64 = rng.random::<f64>().max(1e-300);
    let v: f64 = rng.random();
    (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
}

/// A standard normal 3-vector: three independent [`gaussian`] deviates (x, y, z in order), so
/// isotropic with standard deviation 1 per axis.
pub fn gaussian_vector(rng: &mut Pcg64Mcg) -> DVec3 {
    let x = gaussian(rng);
    let y = gaussian(rng);
    let z = gaussian(rng);
    DVec3::new(x, y, z)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    /// Mean, variance and the fraction within one standard deviation match the standard
    /// normal's (0, 1, 68.27 %) to within the sampling error of 200 000 draws.
    #[test]
    fn deviates_have_the_standard_normal_moments() {
        let mut rng = Pcg64Mcg::seed_from_u64(11);
        let n = 200_000;
        let draws: Vec<f64> = (0..n).map(|_| gaussian(&mut rng)).collect();
        let mean = draws.iter().sum::<f64>() / n as f64;
        let var = draws.iter().map(|d| (d - mean).powi(2)).sum::<f64>() / n as f64;
        let within = draws.iter().filter(|d| d.abs() < 1.0).count() as f64 / n as f64;
        assert!(mean.abs() < 0.01, "{mean}");
        assert!((var - 1.0).abs() < 0.01, "{var}");
        assert!((within - 0.682_69).abs() < 0.005, "{within}");
    }
}
