//! The repulsion radius σ_i = c·σ̂_i of every particle: σ̂_i from its leaf's depth (paper eq. 1,
//! [`DensityField`]) and one scale c, shared by all particles, adapting toward Witkin–Heckbert's
//! target energy Ê on the particles' mean energy (docs/notes/2026-11-24-relaxation.md: why one
//! scale and not one σ per particle).

use crate::{DensityField, ParticleParams};

/// Largest relative change of the scale in one adaptation step: WH's rule, applied to a mean
/// over all particles with a step larger than WH's, overshoots when the seeds' energy is far
/// above Ê (a step of 0.3 oscillated without this bound).
const MAX_RELATIVE_STEP: f64 = 0.25;

/// The scale c of σ = c·σ̂.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct SigmaScale {
    c: f64,
}

/// Sums over particles for [`SigmaScale::adapt`]: Σ E_i, Σ ∂E_i/∂c and their count.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct EnergySums {
    /// Σ E_i.
    pub(crate) energy: f64,
    /// Σ ∂E_i/∂c (dimensionless: the repulsion's c·∂E_i/∂c over c).
    pub(crate) de_dc: f64,
    /// Particles summed.
    pub(crate) count: usize,
}

impl SigmaScale {
    /// The scale read from particles `which`: the mean of σ_i/σ̂_i (σ̂ from `field` at
    /// `depth[i]`; seeds carry σ̂, so 1), or 1 when `which` is empty.
    pub(crate) fn from_particles(
        field: &DensityField,
        depth: &[u8],
        sigma: &[f64],
        which: impl Iterator<Item = usize>,
    ) -> Self {
        let (sum, count) = which.fold((0.0, 0usize), |(s, n), i| {
            (s + sigma[i] / field.target_sigma(depth[i]), n + 1)
        });
        let c = if count > 0 { sum / count as f64 } else { 1.0 };
        Self {
            c: if c.is_finite() && c > 0.0 { c } else { 1.0 },
        }
    }

    /// The scale c (dimensionless).
    pub(crate) fn scale(&self) -> f64 {
        self.c
    }

    /// σ = c·σ̂ of a particle at `depth` (world units).
    pub(crate) fn sigma(&self, field: &DensityField, depth: u8) -> f64 {
        self.c * field.target_sigma(depth)
    }

    /// One step of Witkin–Heckbert's adaptation (WH eq. 10–11, algorithms.md §2.1) on the
    /// mean energy Ē and mean ∂E/∂σ, applied to σ_ref = c·σ̂_max (world units, σ̂_max the
    /// largest target): σ̇_ref = −ρ(Ē − Ê)/(∂Ē/∂σ_ref + β), σ_ref ← σ_ref + σ̇_ref·dt, the
    /// change bounded by [`MAX_RELATIVE_STEP`] and c clamped to `params.sigma_clamp`.
    pub(crate) fn adapt(
        &mut self,
        sums: &EnergySums,
        field: &DensityField,
        params: &ParticleParams,
    ) {
        if sums.count == 0 {
            return;
        }
        let n = sums.count as f64;
        let reference = field.max_target_sigma();
        let e_hat = params.target_energy_ratio * params.energy_alpha;
        // ∂E/∂σ_ref = (∂E/∂c)/σ̂_max.
        let rate =
            -params.rho * (sums.energy / n - e_hat) / (sums.de_dc / n / reference + params.beta);
        let old = self.c * reference;
        // (The bound also keeps σ positive, which WH's |·| does for one particle.)
        let new = (old + params.sigma_dt * rate).clamp(
            old * (1.0 - MAX_RELATIVE_STEP),
            old * (1.0 + MAX_RELATIVE_STEP),
        );
        self.c = (new / reference).clamp(params.sigma_clamp.0, params.sigma_clamp.1);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use psi_shapes::assert_near;

    fn field() -> DensityField {
        DensityField {
            d_min: 4,
            d_max: 7,
            root_edge: 1.0,
            scale: 1.0,
            uniform: None,
            cap: None,
            ceiling: None,
        }
    }

    #[test]
    fn the_scale_is_read_from_the_particles() {
        let f = field();
        let depth = [5, 6, 7];
        let sigma = [
            0.6 * f.target_sigma(5),
            0.6 * f.target_sigma(6),
            0.6 * f.target_sigma(7),
        ];
        let s = SigmaScale::from_particles(&f, &depth, &sigma, 0..3);
        assert_near!(s.scale(), 0.6, 1e-15);
        assert_near!(s.sigma(&f, 4), 0.6 * f.target_sigma(4), 1e-15);
        assert_near!(
            SigmaScale::from_particles(&f, &depth, &sigma, 0..0).scale(),
            1.0,
            0.0
        );
    }

    #[test]
    fn adaptation_moves_toward_the_target_energy_within_bounds() {
        let f = field();
        let params = ParticleParams::paper();
        let e_hat = params.target_energy_ratio * params.energy_alpha;
        let mut s = SigmaScale { c: 1.0 };
        // Crowded (E above Ê): σ shrinks; sparse: it grows.
        let crowded = EnergySums {
            energy: 1.5 * e_hat,
            de_dc: 20.0,
            count: 1,
        };
        s.adapt(&crowded, &f, &params);
        assert!(s.scale() < 1.0);
        let sparse = EnergySums {
            energy: 0.5 * e_hat,
            de_dc: 20.0,
            count: 1,
        };
        let before = s.scale();
        s.adapt(&sparse, &f, &params);
        assert!(s.scale() > before);
        // A huge push moves at most MAX_RELATIVE_STEP per step and never leaves the clamp.
        let huge = EnergySums {
            energy: 1e9,
            de_dc: 0.0,
            count: 1,
        };
        let before = s.scale();
        s.adapt(&huge, &f, &params);
        assert_near!(s.scale(), before * (1.0 - MAX_RELATIVE_STEP), 1e-12);
        for _ in 0..100 {
            s.adapt(&huge, &f, &params);
        }
        assert_near!(s.scale(), params.sigma_clamp.0, 1e-15);
    }
}
