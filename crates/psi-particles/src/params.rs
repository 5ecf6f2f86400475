//! Parameters of seeding and relaxation, with the published constants.

use serde::{Deserialize, Serialize};

/// How the target spacing is chosen.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum DensityMode {
    /// Depth-adaptive (paper eq. 1): denser where the octree is deeper.
    Adaptive,
    /// One constant spacing from the surface area and the count (a blue-noise sampler).
    Uniform,
}

/// Which structure finds a particle's neighbours.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum NeighbourSearch {
    /// The MPU octree as an adaptive grid, particles bucketed per leaf (the paper's way).
    Octree,
    /// A kiddo kd-tree rebuilt every iteration.
    KdTree,
    /// A uniform grid of cubes ([`crate::GRID_EDGE_FACTOR`] × the mean query radius), rebuilt
    /// every iteration: the fastest (`benches/neighbours.rs`, `cargo xtask bench tune`).
    Grid,
}

/// Every parameter of sampling. Construct with [`ParticleParams::paper`].
///
/// Sources (`../shared/reference/algorithms.md` §2 and §5): Witkin–Heckbert 1994 via Wickbert
/// (α = 6, Ê = 0.8α, ρ = 15, β = 10, φ = 15, 3σ neighbourhood); Proença et al. (k = 1, 20 iterations).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ParticleParams {
    /// Particles seeded per surface-containing leaf (paper: 1).
    pub k: usize,
    /// Exact particle count instead of k per leaf.
    pub count: Option<usize>,
    /// Relaxation iterations (paper: 20).
    pub iterations: usize,
    /// Adaptive or uniform density.
    pub density: DensityMode,
    /// Neighbour search structure.
    pub neighbours: NeighbourSearch,
    /// Repulsion amplitude α of E = α·exp(−r²/2σ²) (WH: 6).
    pub energy_alpha: f64,
    /// Target energy Ê as a fraction of α (WH: 0.8).
    pub target_energy_ratio: f64,
    /// Energy feedback rate ρ of the σ adaptation (WH: 15).
    pub rho: f64,
    /// Regulariser β of the σ adaptation (WH: 10).
    pub beta: f64,
    /// Whether σ adapts toward Ê (WH's rule on the mean energy of all particles, applied to one
    /// scale c with σ_i = c·σ̂_i, `sigma_scale.rs`); c stays within `sigma_clamp`.
    pub adapt_sigma: bool,
    /// Bounds of σ as multiples of the target σ̂: (low, high).
    pub sigma_clamp: (f64, f64),
    /// Surface feedback φ in the constrained velocity (WH: 15).
    pub phi: f64,
    /// Step gain: particle i moves dt/ΣE_ij × its constrained velocity (0.5 = a Newton step
    /// on a hexagonal lattice).
    pub dt: f64,
    /// Heavy-ball momentum: the fraction of a particle's previous displacement added to its
    /// step (0 = WH's first-order dynamics).
    pub momentum: f64,
    /// Time step of the σ adaptation (WH: 0.03 per particle; 0.1 for the one shared scale,
    /// see docs/notes/2026-11-24-relaxation.md).
    pub sigma_dt: f64,
    /// A pair of particles at different levels repels with the larger σ; the finer one's push
    /// is scaled by (σ_fine/σ_coarse)^`.0`, the coarser one's by (σ_fine/σ_coarse)^`.1` (2, 1;
    /// docs/notes/2026-11-24-relaxation.md).
    pub cross_level_exponents: (f64, f64),
    /// Largest move per iteration as a multiple of σ_i (0.5).
    pub max_move: f64,
    /// Neighbours are searched within this multiple of σ_i (3).
    pub neighbour_radius: f64,
    /// Newton polish tolerance on |f|/|∇f|, relative to D (1e-4).
    pub newton_tolerance: f64,
    /// Newton polish step limit per iteration.
    pub newton_steps: usize,
    /// A move is rejected when it ends farther from every input point than this multiple of the
    /// local input spacing: particles stay where there is data (open scans, holes). 1 (see
    /// docs/notes/2026-11-24-relaxation.md, for why not more).
    pub data_reach: f64,
    /// The data test reads the input spacing as at least this multiple of the particle's σ_i
    /// (0.5): a gap in the data narrower than that is a gap of the input's sampling, not a
    /// hole the particles resolve, and a move into it is not refused. Without it, a dense
    /// input refuses the e^−π ≈ 4 % of positions that fall in a random sampling's gaps at its
    /// own spacing, and which moves are refused depends on the sampling (a thinned subset out
    /// of core refuses other moves than the whole input: docs/notes/2026-12-02-data-floor.md).
    #[serde(default = "default_data_floor")]
    pub data_floor: f64,
    /// The ceiling on spacing, world units: after relaxation, particles are added where input
    /// points lie farther than [`crate::COVER_RADIUS`] × this from every particle, so that flat
    /// regions (one big octree cell each) are covered at about this spacing. `None`: 2.5 % of
    /// the bounding-box diagonal ([`crate::MAX_SPACING`]); `Some(f64::INFINITY)`: no ceiling.
    /// Adaptive mode with k per leaf only (an exact count or uniform mode set their own
    /// spacing).
    #[serde(default)]
    pub max_spacing: Option<f64>,
    /// Seed of every random choice.
    pub seed: u64,
}

/// [`ParticleParams::data_floor`]'s value in the paper's set-up (also what a serialized
/// parameter set without it reads).
fn default_data_floor() -> f64 {
    0.5
}

impl ParticleParams {
    /// The paper's set-up: k = 1, 20 iterations, depth-adaptive density, Witkin–Heckbert
    /// constants. Neighbours come from a uniform grid, the fastest of the three searches
    /// (`benches/neighbours.rs`, `cargo xtask bench tune`; all three give the same
    /// particles).
    pub fn paper() -> Self {
        Self {
            k: 1,
            count: None,
            iterations: 20,
            density: DensityMode::Adaptive,
            neighbours: NeighbourSearch::Grid,
            energy_alpha: 6.0,
            target_energy_ratio: 0.8,
            rho: 15.0,
            beta: 10.0,
            adapt_sigma: true,
            sigma_clamp: (0.5, 2.0),
            phi: 15.0,
            dt: 0.3,
            sigma_dt: 0.1,
            cross_level_exponents: (2.0, 1.0),
            momentum: 0.7,
            max_move: 0.5,
            neighbour_radius: 3.0,
            newton_tolerance: 1e-4,
            newton_steps: 4,
            data_reach: 1.0,
            data_floor: default_data_floor(),
            max_spacing: None,
            seed: 2007,
        }
    }
}
