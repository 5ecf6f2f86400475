//! The depth-adaptive target radius: paper eq. 1 with its two quirks fixed, turned into a
//! per-particle target σ̂ (docs/ARCHITECTURE.md, "Density").
//!
//! δ = weight((d − d_min)/(d_max − d_min)), weight(t) with u = 1.05t: 1 − 3u² for u < 1/3,
//! 1.5(1 − u)² for 1/3 ≤ u < 1, 0 for u ≥ 1 (the printed formula branches at t = 1/3 and rises
//! again past u = 1). σ̂ = ½[s(d_max) + δ (s(d_min) − s(d_max))], s(d) the cell edge at depth
//! d: one particle per cell at both ends of the depth range, since equilibrium spacing ≈ 2σ.

use serde::{Deserialize, Serialize};

/// Paper eq. 1's weight function, quirks fixed. Input t in [0, 1]; output in [0, 1].
pub fn paper_weight(t: f64) -> f64 {
    let u = 1.05 * t;
    if u >= 1.0 {
        0.0
    } else if u < 1.0 / 3.0 {
        1.0 - 3.0 * u * u
    } else {
        1.5 * (1.0 - u) * (1.0 - u)
    }
}

/// Maps an octree depth to the target radius σ̂ (world units).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct DensityField {
    /// Shallowest depth of the surface leaves' range at seeding ([`crate::depth_range`]).
    pub d_min: u8,
    /// Deepest depth of that range.
    pub d_max: u8,
    /// Root cube edge, world units (s(d) = root_edge / 2^d).
    pub root_edge: f64,
    /// Factor on σ̂ (1 for k = 1; sqrt(seeded/requested) for exact counts).
    pub scale: f64,
    /// A constant σ̂ (uniform mode) overriding the depth rule.
    pub uniform: Option<f64>,
    /// The largest σ̂ of the depth rule, world units: set when the ceiling on spacing added
    /// particles (`cover_data.rs`), so that those in shallow, flat cells repel at the ceiling's
    /// spacing rather than their cell's. `None`: no cap.
    #[serde(default)]
    pub cap: Option<f64>,
    /// The ceiling on spacing in effect, world units (`cover_data.rs`): local regeneration
    /// covers its region under the same one. `None`: no ceiling.
    #[serde(default)]
    pub ceiling: Option<f64>,
}

impl DensityField {
    /// Cell edge at depth `d`, world units.
    pub fn edge(&self, d: u8) -> f64 {
        self.root_edge / f64::from(1u32 << d.min(31))
    }

    /// δ for depth `d` (depths outside [d_min, d_max] are clamped).
    pub fn delta(&self, d: u8) -> f64 {
        if self.d_max <= self.d_min {
            return 1.0;
        }
        let t = (f64::from(d.clamp(self.d_min, self.d_max)) - f64::from(self.d_min))
            / f64::from(self.d_max - self.d_min);
        paper_weight(t)
    }

    /// Target radius σ̂ for a particle in a leaf at depth `d`, world units (half the spacing).
    pub fn target_sigma(&self, d: u8) -> f64 {
        self.target_sigma_at(f64::from(d))
    }

    /// The largest target radius σ̂ at any depth, world units.
    pub fn max_target_sigma(&self) -> f64 {
        // The weight is 1 at d_min and never rises, so σ̂ is largest there.
        self.target_sigma(self.d_min)
    }

    /// Target radius σ̂ at a fractional depth (Ohtake's blended level(x)), world units: the same
    /// rule with t = (d − d_min)/(d_max − d_min) clamped to [0, 1], so σ̂ varies continuously
    /// across the boundaries between depth levels instead of jumping.
    pub fn target_sigma_at(&self, d: f64) -> f64 {
        if let Some(s) = self.uniform {
            return s;
        }
        let delta = if self.d_max <= self.d_min {
            1.0
        } else {
            paper_weight(
                ((d - f64::from(self.d_min)) / f64::from(self.d_max - self.d_min)).clamp(0.0, 1.0),
            )
        };
        let (fine, coarse) = (self.edge(self.d_max), self.edge(self.d_min));
        let sigma = self.scale * 0.5 * (fine + delta * (coarse - fine));
        self.cap.map_or(sigma, |cap| sigma.min(cap))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use psi_shapes::assert_near;

    #[test]
    fn weight_has_the_published_values_and_no_quirks() {
        assert_near!(paper_weight(0.0), 1.0, 1e-15);
        assert_near!(paper_weight(0.25), 0.793_281_25, 1e-9);
        assert_near!(paper_weight(0.5), 1.5 * 0.475 * 0.475, 1e-12);
        // Continuous where 1.05t = 1/3, zero (not rising) beyond 1/1.05.
        let b = 1.0 / 3.0 / 1.05;
        assert_near!(paper_weight(b - 1e-12), paper_weight(b + 1e-12), 1e-9);
        assert_near!(paper_weight(1.0), 0.0, 0.0);
        assert_near!(paper_weight(0.99), 0.0, 0.0);
        // Non-increasing.
        let mut last = 2.0;
        for i in 0..=100 {
            let w = paper_weight(i as f64 / 100.0);
            assert!(w <= last + 1e-15);
            last = w;
        }
    }

    #[test]
    fn one_particle_per_cell_at_both_ends() {
        let field = DensityField {
            d_min: 4,
            d_max: 8,
            root_edge: 1.6,
            scale: 1.0,
            uniform: None,
            cap: None,
            ceiling: None,
        };
        assert_near!(field.target_sigma(4), 0.5 * field.edge(4), 1e-15);
        assert_near!(field.target_sigma(8), 0.5 * field.edge(8), 1e-15);
        assert!(field.target_sigma(6) < field.target_sigma(5));
        // A cap bounds σ̂ at the shallow end only, and the largest σ̂ with it.
        let capped = DensityField {
            cap: Some(field.target_sigma(6)),
            ..field
        };
        assert_near!(capped.target_sigma(4), field.target_sigma(6), 0.0);
        assert_near!(capped.max_target_sigma(), field.target_sigma(6), 0.0);
        assert_near!(capped.target_sigma(7), field.target_sigma(7), 0.0);
    }
}
