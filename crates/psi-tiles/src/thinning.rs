//! How the seeding thins the relaxation's data when the input does not fit its budget: the
//! points each place needs for the particles' data floor first, within the budget, then a
//! uniform share by position hash (`thinned_data.rs` keeps and trims;
//! docs/notes/2026-12-04-thinned-finest-level.md).

use psi_particles::{DensityField, ParticleParams};

use crate::TiledDecisions;

/// How the seeding thins the relaxation's data (`ThinnedData`) when the points do not all fit
/// its budget of `relax_points`: `None` when every one of `population` points fits. A point
/// outside the bands along the data's edge is kept when its position hash lies below
/// `max(uniform, need_scale × need)`, its need the rate its place needs for the particles'
/// data floor there ([`Floors::at`], `thinned_data::needed_rate`). The needs come first: how
/// many points they take is estimated from the surface leaves before any point is read
/// ([`estimated_need`]), scaled down alike when they would not fit, and the uniform share is
/// what is left of [`KEEP_HEADROOM`] × the budget, so that the regions keep about that and not
/// more, and the trim to the budget (`ThinnedData::at_most`, needs first) has the estimate's
/// error to take from (docs/notes/2026-12-04-thinned-finest-level.md). A function of the
/// decisions, the seeds' density field `field` (σ̂ not yet scaled), the parameters and the
/// budget: every octant's task finds the same.
pub(crate) fn thinning(
    decisions: &TiledDecisions,
    field: &DensityField,
    params: &ParticleParams,
    population: usize,
    relax_points: usize,
) -> Option<Thinning> {
    if population <= relax_points {
        return None;
    }
    let floors = Floors::new(field, params);
    let need = estimated_need(decisions, &floors, population);
    let room = relax_points as f64;
    let kept = KEEP_HEADROOM * room;
    let need_scale = if need > kept { kept / need } else { 1.0 };
    Some(Thinning {
        rate: room / population as f64,
        uniform: (kept - need).max(0.0) / population as f64,
        need_scale,
        floors,
    })
}

/// The regions keep about this many times the relaxation's budget of points, which the trim
/// then takes to the budget: the needs' estimate errs by a fraction either way (an area of
/// [`AREA_PER_LEAF_FACE`] per leaf face; the bands are not counted), and what the regions did
/// not keep the trim cannot take. The seeding's share of the budget is far below the
/// relaxation's (docs/notes/2026-12-04-thinned-finest-level.md).
const KEEP_HEADROOM: f64 = 1.25;

/// The particles' data floor at each depth, at its least before the relaxation (world units).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Floors {
    field: DensityField,
    /// `data_reach` × `data_floor` × 1/√k.
    factor: f64,
}

impl Floors {
    fn new(field: &DensityField, params: &ParticleParams) -> Floors {
        // The test refuses beyond `data_reach` × the floor; σ̂'s scale, set once every region
        // is seeded, is at least 1/√k (`sample_tiled_from`). (The relaxation's own scale c
        // adapts about 1 within its clamp; it is not known before.)
        Floors {
            field: *field,
            factor: params.data_reach * params.data_floor / (params.k.max(1) as f64).sqrt(),
        }
    }

    /// The floor at depth `depth`.
    pub(crate) fn at(&self, depth: u8) -> f64 {
        self.factor * self.field.target_sigma(depth)
    }
}

/// The points the needs of the places take ([`Thinning`]), estimated from the surface leaves
/// alone: the input's points shared among the leaves by their faces' area (e², e a leaf's
/// edge), the input's spacing s from that area, taken as [`AREA_PER_LEAF_FACE`] × Σ e² (an
/// over-estimate, so that the needs leave room), and each leaf's points times the rate its
/// depth's floor needs at spacing s.
fn estimated_need(decisions: &TiledDecisions, floors: &Floors, population: usize) -> f64 {
    let edge = |d: u8| 2.0 * decisions.frame.root_half / f64::from(1u32 << d);
    let faces: f64 = decisions.surface.iter().map(|a| edge(a.0).powi(2)).sum();
    if faces <= 0.0 || population == 0 {
        return 0.0;
    }
    let n = population as f64;
    let spacing = (AREA_PER_LEAF_FACE * faces / (std::f64::consts::PI * n)).sqrt();
    decisions
        .surface
        .iter()
        .map(|a| n * edge(a.0).powi(2) / faces * needed_rate(spacing, floors.at(a.0)))
        .sum()
}

/// The surface's area in a leaf over its face's (e²): a plane through a cube cuts at most
/// √2·e², a random one about two thirds of e²; 2 allows for curved and folded leaves.
pub(crate) const AREA_PER_LEAF_FACE: f64 = 2.0;

/// How the seeding thins ([`thinning`]).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Thinning {
    /// The budget over the population: the share of the points the relaxation holds.
    pub(crate) rate: f64,
    /// The hash below which any point is kept.
    pub(crate) uniform: f64,
    /// The needs' scale (1 unless they would not fit).
    pub(crate) need_scale: f64,
    /// The particles' data floor by depth.
    pub(crate) floors: Floors,
}

/// The subset's spacing is at most this share of the particles' data floor where it can be
/// (`needed_rate`).
pub(crate) const SUBSET_SPACING_PER_FLOOR: f64 = 1.0 / 3.0;

/// The rate at which a subset of an input of spacing `spacing` (world units, `d₈·√(π/8)`: the
/// radius of the disc that holds one point) has its spacing at most a third of `floor`, the
/// distance within which the particles there take the input as present (world units:
/// `data_reach` × `data_floor` × σ at the leaf's depth): `min(1, (3·spacing/floor)²)`; 0 for
/// a floor of 0 or less or a spacing that is not finite.
///
/// The footprint test refuses a position whose nearest input point lies beyond
/// `data_reach` × max(spacing, floor). In a random sampling of spacing s, the nearest point to
/// a position on the surface lies beyond x with probability e^(−x²/s²) (the nearest-neighbour
/// distance of a Poisson process of density 1/(πs²)): at a floor of three subset spacings the
/// subset refuses e^−9 ≈ 1e-4 of the positions for its own gaps, where a subset whose spacing
/// is about the floor refuses far more moves than the whole input
/// (docs/notes/2026-12-04-thinned-finest-level.md). The points a place needs are about
/// 9A/(π·floor²) for its area A: some tens a particle, whatever the input's size.
pub(crate) fn needed_rate(spacing: f64, floor: f64) -> f64 {
    if floor > 0.0 && spacing.is_finite() {
        (spacing / (SUBSET_SPACING_PER_FLOOR * floor))
            .powi(2)
            .min(1.0)
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The needed rate: the subset's spacing (spacing/√rate) a third of the floor, at most 1.
    #[test]
    fn the_needed_rate_puts_three_subset_spacings_in_the_floor() {
        for (spacing, floor) in [(1e-4, 1.2e-3), (3e-5, 4e-4), (2.0, 50.0)] {
            let r = needed_rate(spacing, floor);
            psi_shapes::assert_near!(spacing / r.sqrt(), floor / 3.0, 1e-12 * floor);
        }
        assert_eq!(needed_rate(1e-4, 2e-4), 1.0);
        assert_eq!(needed_rate(1e-4, 0.0), 0.0);
        assert_eq!(needed_rate(f64::NAN, 1.0), 0.0);
    }
}
