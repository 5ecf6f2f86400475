//! Witkin–Heckbert repulsion sums of the moving particles: D_i (the desired velocity before
//! the surface constraint), E_i and c·∂E_i/∂c (how E_i follows the one σ scale c), with one
//! kernel per pair across depth levels (docs/notes/2026-11-24-relaxation.md).
//!
//! Within a level (σ_i = σ_j = σ) this is WH eq. 9 with the erratum's sign:
//! D_i = Σ_j r_ij (E_ij + E_ji) = Σ_j 2 E_ij r_ij, E_ij = α exp(−|r_ij|²/2σ²), r_ij = x_i − x_j,
//! over j within 3σ. Across levels a pair uses the larger radius s = max(σ_i, σ_j) — the
//! conflict rule of variable-radius Poisson-disk sets, so a coarse particle keeps finer ones
//! at its own spacing — and E = α exp(−|r|²/2s²) for both; the finer particle's share is
//! scaled by (σ_fine/σ_coarse)^`cross_level_exponents.0`, the coarser one's by
//! (σ_fine/σ_coarse)^`cross_level_exponents.1`.
//!
//! A pair across levels is found by its coarser member (its 3s reaches the finer one), which
//! also hands the finer one its share: every query stays within 3σ_i of its particle. Each
//! particle's sums are its own neighbours in index order, then the shares handed to it in the
//! order of the particles that found them, so the result is the same for any thread count.

use glam::DVec3;
use rayon::prelude::*;

use crate::neighbours::NeighbourIndex;
use crate::{ParticleParams, Particles};

/// Particles per parallel task.
const CHUNK: usize = 256;

/// Repulsion sums per particle (shape: N each; zero for particles that do not move).
#[derive(Clone, Debug, Default)]
pub(crate) struct Repulsion {
    /// D_i, world units (a length: WH's D scaled by σ_i²).
    pub(crate) push: Vec<DVec3>,
    /// E_i = Σ_j E_ij (dimensionless, in units of α's).
    pub(crate) energy: Vec<f64>,
    /// c·∂E_i/∂c = Σ_j |r_ij|² E_ij / s_ij² (dimensionless): every pair's kernel radius s_ij
    /// (σ_i within a level, the coarser σ across levels) is c times a target, so
    /// ∂E_ij/∂c = |r_ij|² E_ij / (s_ij³) · s_ij / c, for both members of the pair.
    pub(crate) de_dlnc: Vec<f64>,
}

/// A coarser particle's share of a pair, handed to the finer one.
#[derive(Clone, Copy, Debug)]
struct Share {
    target: u32,
    push: DVec3,
    energy: f64,
    de_dlnc: f64,
}

/// One particle's own sums and the shares it hands out.
#[derive(Clone, Copy, Debug, Default)]
struct Sums {
    push: DVec3,
    energy: f64,
    de_dlnc: f64,
}

/// The particles whose sums [`repulsion_into`] computes and those that hand them shares.
pub(crate) struct Movers<'a> {
    /// The moving particles (indices into the particle arrays).
    pub(crate) active: &'a [u32],
    /// Per particle: whether it moves (`None`: all do).
    pub(crate) movable: Option<&'a [bool]>,
    /// Fixed particles that may be the coarser member of a pair with a moving one: they only
    /// hand out shares.
    pub(crate) fixed_coarse: &'a [u32],
}

/// Fills `out`'s entries of `movers.active` with their repulsion sums (positions, normals and σ
/// from `state`, neighbours from `index`, which holds every particle); the other entries are
/// left as they were. Neighbours whose normals
/// oppose are ignored (thin sheets).
pub(crate) fn repulsion_into(
    out: &mut Repulsion,
    index: &NeighbourIndex<'_>,
    state: &Particles,
    movers: &Movers<'_>,
    params: &ParticleParams,
) {
    // Only the moving particles' entries are written (and read by the caller): a local
    // relaxation moves a few of many, so the rest is not cleared every iteration.
    let n = state.len();
    if out.push.len() != n {
        out.push = vec![DVec3::ZERO; n];
        out.energy = vec![0.0; n];
        out.de_dlnc = vec![0.0; n];
    }
    let moves = |j: usize| movers.movable.is_none_or(|m| m[j]);
    let own: Vec<(Vec<Sums>, Vec<Share>)> = movers
        .active
        .par_chunks(CHUNK)
        .map_init(Vec::new, |scratch, chunk| {
            let mut shares = Vec::new();
            let sums = chunk
                .iter()
                .map(|&i| {
                    let mut s = Sums::default();
                    pairs_of(i, index, state, params, scratch, false, |j, pair| {
                        s.push += pair.push;
                        s.energy += pair.energy;
                        s.de_dlnc += pair.de_dlnc;
                        if let Some(share) = pair.share
                            && moves(j as usize)
                        {
                            shares.push(share);
                        }
                    });
                    s
                })
                .collect();
            (sums, shares)
        })
        .collect();
    let fixed: Vec<Vec<Share>> = movers
        .fixed_coarse
        .par_chunks(CHUNK)
        .map_init(Vec::new, |scratch, chunk| {
            let mut shares = Vec::new();
            for &i in chunk {
                pairs_of(i, index, state, params, scratch, true, |_, pair| {
                    shares.extend(pair.share);
                });
            }
            shares
        })
        .collect();
    for (&i, s) in movers.active.iter().zip(own.iter().flat_map(|(s, _)| s)) {
        out.push[i as usize] = s.push;
        out.energy[i as usize] = s.energy;
        out.de_dlnc[i as usize] = s.de_dlnc;
    }
    let shares = own
        .iter()
        .flat_map(|(_, s)| s)
        .chain(fixed.iter().flatten());
    for s in shares {
        let t = s.target as usize;
        out.push[t] += s.push;
        out.energy[t] += s.energy;
        out.de_dlnc[t] += s.de_dlnc;
    }
}

/// Particle i's part of one pair, and the finer particle's share when they differ in σ.
struct Pair {
    push: DVec3,
    energy: f64,
    de_dlnc: f64,
    share: Option<Share>,
}

/// Calls `visit(j, pair)` for every pair particle `i` carries: neighbours j within 3σ_i whose
/// normals do not oppose i's and whose σ_j ≤ σ_i (a coarser j carries the pair itself). With
/// `moving_only`, only moving neighbours are visited (a fixed particle handing out shares).
fn pairs_of(
    i: u32,
    index: &NeighbourIndex<'_>,
    state: &Particles,
    params: &ParticleParams,
    scratch: &mut Vec<u32>,
    moving_only: bool,
    mut visit: impl FnMut(u32, Pair),
) {
    let i = i as usize;
    let x = state.positions[i];
    let ni = state.normals[i];
    let si = state.sigma[i];
    let inv2 = 1.0 / (2.0 * si * si);
    let inv_si2 = 1.0 / (si * si);
    let radius = params.neighbour_radius * si;
    let mut each = |j: u32| {
        let ju = j as usize;
        let sj = state.sigma[ju];
        if ju == i || sj > si || ni.dot(state.normals[ju]) < 0.0 {
            return;
        }
        let r = x - state.positions[ju];
        let d2 = r.length_squared();
        let e = params.energy_alpha * (-d2 * inv2).exp();
        if sj == si {
            visit(
                j,
                Pair {
                    push: r * (2.0 * e),
                    energy: e,
                    de_dlnc: d2 * e * inv_si2,
                    share: None,
                },
            );
        } else {
            let ratio = sj / si;
            let (fine, coarse) = params.cross_level_exponents;
            visit(
                j,
                Pair {
                    push: r * (2.0 * e * power(ratio, coarse)),
                    energy: e,
                    de_dlnc: d2 * e * inv_si2,
                    share: Some(Share {
                        target: j,
                        push: r * (-2.0 * e * power(ratio, fine)),
                        energy: e,
                        // The pair's kernel is σ_i for the finer particle too.
                        de_dlnc: d2 * e * inv_si2,
                    }),
                },
            );
        }
    };
    if moving_only {
        index.for_each_moving_within(x, radius, scratch, &mut each);
    } else {
        index.for_each_within(x, radius, scratch, &mut each);
    }
}

/// x^e for x > 0, without `powf`'s cost for the default exponents 1 and 2 (the same value).
#[inline]
fn power(x: f64, e: f64) -> f64 {
    if e == 1.0 {
        x
    } else if e == 2.0 {
        x * x
    } else {
        x.powf(e)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ParticleGrid;
    use crate::neighbours::FixedSet;
    use psi_shapes::assert_near;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64Mcg;

    /// Particles on the plane z = 0 (normals +z, a few −z), at two σ levels.
    fn scene() -> Particles {
        let mut rng = Pcg64Mcg::seed_from_u64(3);
        let mut p = Particles::default();
        for i in 0..600 {
            let x = DVec3::new(rng.random::<f64>(), rng.random::<f64>(), 0.0);
            let n = if i % 37 == 0 { -DVec3::Z } else { DVec3::Z };
            let sigma = if x.x < 0.5 { 0.02 } else { 0.035 };
            p.push(x, n, if x.x < 0.5 { 7 } else { 6 }, sigma);
        }
        p
    }

    /// The brute-force oracle: every ordered pair within 3·max(σ_i, σ_j), the formulas of
    /// the module doc written out per particle.
    fn brute(p: &Particles, params: &ParticleParams, i: usize) -> Sums {
        let mut s = Sums::default();
        for j in 0..p.len() {
            if j == i || p.normals[i].dot(p.normals[j]) < 0.0 {
                continue;
            }
            let (si, sj) = (p.sigma[i], p.sigma[j]);
            let big = si.max(sj);
            let r = p.positions[i] - p.positions[j];
            let d2 = r.length_squared();
            if d2 > (params.neighbour_radius * big).powi(2) {
                continue;
            }
            let e = params.energy_alpha * (-d2 / (2.0 * big * big)).exp();
            let ratio = si.min(sj) / big;
            let w = if si == sj {
                1.0
            } else if si < sj {
                ratio.powf(params.cross_level_exponents.0)
            } else {
                ratio.powf(params.cross_level_exponents.1)
            };
            s.push += r * (2.0 * e * w);
            s.energy += e;
            s.de_dlnc += d2 * e / (big * big);
        }
        s
    }

    #[test]
    fn sums_equal_the_brute_force_pair_sums() {
        let p = scene();
        let params = ParticleParams::paper();
        let n = p.len();
        let active: Vec<u32> = (0..n as u32).collect();
        let index = NeighbourIndex::Grid(ParticleGrid::new(&p.positions, 0.05));
        let mut out = Repulsion::default();
        repulsion_into(
            &mut out,
            &index,
            &p,
            &Movers {
                active: &active,
                movable: None,
                fixed_coarse: &[],
            },
            &params,
        );
        for i in 0..n {
            let want = brute(&p, &params, i);
            assert_near!(out.push[i].x, want.push.x, 1e-12);
            assert_near!(out.push[i].y, want.push.y, 1e-12);
            assert_near!(out.energy[i], want.energy, 1e-12);
            assert_near!(out.de_dlnc[i], want.de_dlnc, 1e-12);
        }
    }

    /// c·∂E/∂c against a finite difference of the brute-force energies with every σ scaled
    /// by c: across levels the finer particle's energy follows the coarser one's σ.
    #[test]
    fn the_scale_derivative_is_the_finite_difference_of_the_energy() {
        let base = scene();
        let params = ParticleParams::paper();
        let n = base.len();
        let scaled = |c: f64| {
            let mut p = base.clone();
            p.sigma.iter_mut().for_each(|s| *s *= c);
            p
        };
        let energy = |c: f64| -> Vec<f64> {
            let p = scaled(c);
            (0..n).map(|i| brute(&p, &params, i).energy).collect()
        };
        let c = 0.8;
        let p = scaled(c);
        let active: Vec<u32> = (0..n as u32).collect();
        let index = NeighbourIndex::Grid(ParticleGrid::new(&p.positions, 0.05));
        let mut out = Repulsion::default();
        let movers = Movers {
            active: &active,
            movable: None,
            fixed_coarse: &[],
        };
        repulsion_into(&mut out, &index, &p, &movers, &params);
        let h = 1e-6;
        let (up, down) = (energy(c + h), energy(c - h));
        let mut crossing = 0;
        for i in 0..n {
            let fd = c * (up[i] - down[i]) / (2.0 * h);
            // (A pair at the 3σ cut-off jumps in or out between c ± h: none here.)
            assert_near!(out.de_dlnc[i], fd, 1e-6 * (1.0 + fd.abs()));
            crossing += usize::from((0..n).any(|j| {
                j != i
                    && p.sigma[j] > p.sigma[i]
                    && (p.positions[i] - p.positions[j]).length()
                        < params.neighbour_radius * p.sigma[j]
            }));
        }
        assert!(
            crossing > 10,
            "{crossing} particles with a coarser neighbour"
        );
    }

    #[test]
    fn moving_particles_among_fixed_ones_get_the_same_sums() {
        // A third of the particles move; the fixed ones are indexed once, and those coarser
        // than some moving neighbour hand out shares.
        let p = scene();
        let params = ParticleParams::paper();
        let n = p.len();
        let movable: Vec<bool> = (0..n).map(|i| i % 3 == 0).collect();
        let active: Vec<u32> = (0..n as u32).filter(|&i| movable[i as usize]).collect();
        let fixed_coarse: Vec<u32> = (0..n as u32)
            .filter(|&i| !movable[i as usize] && p.sigma[i as usize] > 0.02)
            .collect();
        let fixed = FixedSet::new(&p.positions, &movable, None, 0.05);
        let index = NeighbourIndex::split(&fixed, &p.positions, &active, 0.05);
        let mut out = Repulsion::default();
        repulsion_into(
            &mut out,
            &index,
            &p,
            &Movers {
                active: &active,
                movable: Some(&movable),
                fixed_coarse: &fixed_coarse,
            },
            &params,
        );
        for &i in &active {
            let i = i as usize;
            let want = brute(&p, &params, i);
            assert_near!(out.push[i].x, want.push.x, 1e-12);
            assert_near!(out.push[i].y, want.push.y, 1e-12);
            assert_near!(out.energy[i], want.energy, 1e-12);
            assert_near!(out.de_dlnc[i], want.de_dlnc, 1e-12);
        }
        // Fixed particles get nothing.
        assert!(
            (0..n)
                .filter(|&i| !movable[i])
                .all(|i| out.energy[i] == 0.0)
        );
    }
}
