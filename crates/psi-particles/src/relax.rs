//! Witkin–Heckbert relaxation (as Foster et al. use it, algorithms.md §2.1–2.2): Gaussian
//! repulsion (one kernel per pair across depth levels, `repulsion.rs`), velocity constrained to
//! the surface with feedback φ, σ_i = c·σ̂_i with one scale c adapting toward Ê
//! (`sigma_scale.rs`), each move clamped, then a Newton polish. Jacobi-style: every particle
//! reads the previous iteration's state, so the result is identical for any thread count.

use glam::DVec3;
use psi_mpu::{DataAnchor, LeafEvaluation, Mpu};
use psi_octree::{Aabb, Monitor};
use rayon::prelude::*;

use crate::neighbours::{FixedSet, NeighbourIndex};
use crate::project::{Evaluated, newton_project, project_to_surface};
use crate::repulsion::{Movers, Repulsion, repulsion_into};
use crate::sigma_scale::{EnergySums, SigmaScale};
use crate::{DensityField, GRID_EDGE_FACTOR, ParticleParams, Particles};

/// A particle's state after a move (or its old state where the move was rejected).
struct Update {
    /// Position, f, ∇f and leaf there.
    at: Evaluated,
    depth: u8,
    /// An input point near the particle (see [`Mpu::near_data_from`]).
    anchor: Option<DataAnchor>,
}

/// How a relaxation runs beyond its parameters: which particles move and where, and who hears of
/// its progress. `RelaxOptions::default()` moves every particle anywhere, silently.
#[derive(Clone, Copy, Default)]
pub struct RelaxOptions<'a> {
    /// Which particles may move and where.
    pub region: RelaxRegion<'a>,
    /// Progress (stage `"relax"`: iterations done of `params.iterations`) and interruption:
    /// once its stop flag is set the iteration stops where it is (the caller checks and
    /// discards the particles).
    pub monitor: Monitor<'a>,
}

/// Which particles may move and where (local regeneration restricts both).
#[derive(Clone, Copy, Default)]
pub struct RelaxRegion<'a> {
    /// Per particle: whether it moves (others act as fixed neighbours). `None`: all move.
    pub movable: Option<&'a [bool]>,
    /// A move is accepted only if this returns true for the new world position.
    pub accept: Option<&'a (dyn Fn(DVec3) -> bool + Sync)>,
    /// A box (world units) holding every position `accept` accepts: fixed particles beyond the
    /// moving particles' largest neighbour reach from it and from their starting positions
    /// (which `accept` need not hold) are left out of the neighbour search.
    pub bounds: Option<Aabb>,
}

impl std::fmt::Debug for RelaxRegion<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RelaxRegion")
            .field("movable", &self.movable.map(<[bool]>::len))
            .finish()
    }
}

/// Relaxes `particles` on `mpu` for `params.iterations` steps. A particle's repulsion radius is
/// σ = c·σ̂, σ̂ from `field` at the depth of the leaf it is in and one scale c: read from the
/// particles at the start (seeds carry σ̂, so c = 1; a local relaxation reads the fixed
/// particles' c and keeps it) and, when none is fixed and `params.adapt_sigma`, adapted
/// toward Ê each iteration. The count never changes. `options` restrict the moves (local
/// regeneration) and report progress. ([`Relaxation`] runs the same steps a few at a time.)
pub fn relax(
    mpu: &Mpu,
    particles: &mut Particles,
    field: &DensityField,
    params: &ParticleParams,
    options: RelaxOptions<'_>,
) {
    let mut run = Relaxation::start(mpu, particles, field, params, options.region);
    run.run(mpu, particles, field, params, options, params.iterations);
    if !options.monitor.stopped() {
        run.finish(mpu, particles, field, params);
    }
}

/// A relaxation in progress ([`relax`] split into steps): the state one iteration hands the
/// next (velocities, data anchors, f and ∇f, the fixed neighbours' index). Starting, running
/// the iterations in any number of [`Relaxation::run`] calls and finishing gives bitwise the
/// particles of one [`relax`] call, so that an editor can settle a stroke over several frames.
/// Every call must be given the same MPU, particles (changed by nothing else), field,
/// parameters and region as [`Relaxation::start`].
#[derive(Clone)]
pub struct Relaxation {
    /// The moving particles, ascending.
    active: Vec<u32>,
    scale: SigmaScale,
    adapt: bool,
    /// Per moving particle (in `active` order, so that a local relaxation keeps nothing per
    /// fixed particle): f and ∇f at its position, the leaf it is in (a guess for the next
    /// lookup), its last displacement (momentum) and an input point near it.
    fg: Vec<(f64, DVec3)>,
    leaf: Vec<Option<u32>>,
    velocity: Vec<DVec3>,
    anchor: Vec<Option<DataAnchor>>,
    /// Grid cube edge of the neighbour search, fixed at the start (world units).
    grid_edge: f64,
    /// The fixed particles that can be a moving one's neighbour, indexed once.
    fixed: Option<FixedSet>,
    /// Fixed particles that may be the coarser member of a pair with a moving one.
    fixed_coarse: Vec<u32>,
    /// Iterations done.
    done: usize,
}

impl std::fmt::Debug for Relaxation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Relaxation")
            .field("moving", &self.active.len())
            .field("done", &self.done)
            .finish()
    }
}

impl Relaxation {
    /// Sets the moving particles' σ and evaluates f and ∇f there (no iteration yet).
    pub fn start(
        mpu: &Mpu,
        particles: &mut Particles,
        field: &DensityField,
        params: &ParticleParams,
        region: RelaxRegion<'_>,
    ) -> Relaxation {
        let n = particles.len();
        // The moving particles: all, or the movable ones (local regeneration moves few of many,
        // and no per-iteration work is spent on the others).
        let active: Vec<u32> = match region.movable {
            Some(m) => (0..n as u32).filter(|&i| m[i as usize]).collect(),
            None => (0..n as u32).collect(),
        };
        // σ = c·σ̂: c read from the fixed particles of a local relaxation, which keeps their c, or
        // else from all particles (seeds carry σ̂: c = 1) and adapted.
        let fixed_ones = |m: &[bool]| (0..n).filter(|&i| !m[i]).collect::<Vec<usize>>();
        let fixed_ids = region.movable.map(fixed_ones).unwrap_or_default();
        let adapt = params.adapt_sigma && fixed_ids.is_empty();
        let scale = if fixed_ids.is_empty() {
            SigmaScale::from_particles(field, &particles.depth, &particles.sigma, 0..n)
        } else {
            SigmaScale::from_particles(
                field,
                &particles.depth,
                &particles.sigma,
                fixed_ids.iter().copied(),
            )
        };
        for &i in &active {
            let i = i as usize;
            particles.sigma[i] = scale.sigma(field, particles.depth[i]);
        }
        // f and ∇f of the moving particles (the fixed ones are never updated), and the leaf each
        // is in, a guess for the next lookup (most moves stay in the leaf).
        let initial: Vec<LeafEvaluation> = active
            .par_iter()
            .map(|&i| mpu.value_and_gradient_from(particles.positions[i as usize], None))
            .collect();
        let fg: Vec<(f64, DVec3)> = initial.iter().map(|e| (e.f, e.gradient)).collect();
        let leaf: Vec<Option<u32>> = initial.iter().map(|e| e.leaf).collect();
        // The farthest any particle looks: 3σ, σ at most its clamp above the largest σ̂.
        let reach = params.neighbour_radius
            * (scale.scale().max(params.sigma_clamp.1) * field.max_target_sigma());
        // (The margin covers rounding in σ̂'s bound.)
        let reach = reach * (1.0 + 1e-9);
        let near = region.bounds.map(|b| {
            let start = active.iter().map(|&i| particles.positions[i as usize]);
            let b = Aabb::from_points(start.chain([b.min, b.max])).unwrap_or(b);
            Aabb {
                min: b.min - DVec3::splat(reach),
                max: b.max + DVec3::splat(reach),
            }
        });
        // Grid cubes: a fixed fraction of the mean query radius at the start (any edge gives the
        // same neighbours).
        let grid_edge = GRID_EDGE_FACTOR * params.neighbour_radius * mean(&particles.sigma);
        let fixed = region
            .movable
            .map(|m| FixedSet::new(&particles.positions, m, near, grid_edge));
        // Fixed particles that may be the coarser member of a pair with a moving one: every one
        // within reach of the moving region (a moving particle's σ follows its depth each
        // iteration, so a σ bound taken at the start could drop pairs); pairs_of keeps only those
        // with a finer moving neighbour, and they hand out shares.
        let fixed_coarse: Vec<u32> = match region.movable {
            Some(m) => (0..n as u32)
                .filter(|&i| {
                    let i = i as usize;
                    !m[i] && near.is_none_or(|b| b.contains(particles.positions[i]))
                })
                .collect(),
            None => Vec::new(),
        };
        let moving = active.len();
        Relaxation {
            active,
            scale,
            adapt,
            fg,
            leaf,
            velocity: vec![DVec3::ZERO; moving],
            anchor: vec![None; moving],
            grid_edge,
            fixed,
            fixed_coarse,
            done: 0,
        }
    }

    /// Iterations done so far.
    pub fn done(&self) -> usize {
        self.done
    }

    /// Iterations left of `params.iterations`.
    pub fn remaining(&self, params: &ParticleParams) -> usize {
        params.iterations.saturating_sub(self.done)
    }

    /// Runs up to `iterations` more iterations (never beyond `params.iterations` in all);
    /// returns how many ran. Stops early, the state consistent, once `options.monitor`'s stop
    /// flag is set.
    pub fn run(
        &mut self,
        mpu: &Mpu,
        particles: &mut Particles,
        field: &DensityField,
        params: &ParticleParams,
        options: RelaxOptions<'_>,
        iterations: usize,
    ) -> usize {
        let RelaxOptions { region, monitor } = options;
        let total = params.iterations as u64;
        let _span = tracing::info_span!(
            "relaxation",
            particles = particles.len(),
            iterations = params.iterations
        )
        .entered();
        let tol = params.newton_tolerance * mpu.diagonal();
        let Relaxation {
            active,
            scale,
            adapt,
            fg,
            leaf,
            velocity,
            anchor,
            grid_edge,
            fixed,
            fixed_coarse,
            done,
        } = self;
        let grid_edge = *grid_edge;
        let mut forces = Repulsion::default();
        // Each iteration's new states, in `active` order (one buffer for all iterations).
        let mut updates: Vec<Update> = Vec::with_capacity(active.len());
        let first = *done;
        let last = first.saturating_add(iterations).min(params.iterations);
        for iteration in first..last {
            monitor.report("relax", iteration as u64, total);
            if monitor.stopped() {
                return iteration - first;
            }
            let index = match (&*fixed, region.movable) {
                (Some(f), Some(_)) => {
                    NeighbourIndex::split(f, &particles.positions, active, grid_edge)
                }
                _ => {
                    // Cubes follow σ as its scale adapts.
                    let edge = GRID_EDGE_FACTOR * params.neighbour_radius * mean(&particles.sigma);
                    NeighbourIndex::new(params.neighbours, mpu, &particles.positions, edge)
                }
            };
            let movers = Movers {
                active,
                movable: region.movable,
                fixed_coarse,
            };
            repulsion_into(&mut forces, &index, particles, &movers, params);
            let state = &*particles;
            let forces_ref = &forces;
            let fg_ref = &*fg;
            let vel = &*velocity;
            let anchors = &*anchor;
            let leaves = &*leaf;
            active
                .par_iter()
                .enumerate()
                .map(|(k, &i)| {
                    let i = i as usize;
                    let x = state.positions[i];
                    let ni = state.normals[i];
                    let si = state.sigma[i];
                    let d = forces_ref.push[i];
                    let (f, g) = fg_ref[k];
                    let g2 = g.length_squared();
                    let v = if g2 > 1e-24 {
                        d - ((g.dot(d) + params.phi * f) / g2) * g
                    } else {
                        d
                    };
                    // Per-particle step dt_i = dt / ΣE_ij: on a hexagonal lattice at spacing 2σ
                    // the repulsion's stiffness is 2·ΣE_ij, so dt = 0.5 makes this a Newton step
                    // (derivation in docs/notes/2026-11-24-relaxation.md).
                    let dt_i = params.dt / (forces_ref.energy[i] + 1e-3 * params.energy_alpha);
                    // Heavy-ball momentum: the previous displacement, projected onto the tangent
                    // plane.
                    let prev = vel[k] - ni * vel[k].dot(ni);
                    let mut step = dt_i * v + params.momentum * prev;
                    let len = step.length();
                    let cap = params.max_move * si;
                    if len > cap {
                        step *= cap / len;
                    }
                    let moved =
                        newton_project(mpu, x + step, tol, params.newton_steps, si, leaves[k]);
                    let x1 = moved.position;
                    let floor = params.data_floor * si;
                    let test = mpu.near_data_from(x1, params.data_reach, floor, anchors[k]);
                    let (on_data, new_anchor) = (test.inside, test.anchor);
                    let ok = moved.gradient.length_squared() > 0.0
                        && on_data
                        && region.accept.is_none_or(|a| a(x1));
                    // The leaf of the particle's position: found by the evaluation at x1, or kept.
                    let at = if ok {
                        moved
                    } else {
                        Evaluated {
                            position: x,
                            f,
                            gradient: g,
                            leaf: leaves[k],
                        }
                    };
                    let depth = at
                        .leaf
                        .map_or(state.depth[i], |l| mpu.octree().cell(l).depth);
                    Update {
                        at,
                        depth,
                        anchor: if ok { new_anchor } else { anchors[k] },
                    }
                })
                .collect_into_vec(&mut updates);
            if *adapt {
                // The scale steps toward Ê on this iteration's energies (summed in index order).
                let mut sums = EnergySums::default();
                for &i in active.iter() {
                    let i = i as usize;
                    sums.energy += forces.energy[i];
                    sums.de_dc += forces.de_dlnc[i] / scale.scale();
                    sums.count += 1;
                }
                scale.adapt(&sums, field, params);
            }
            for (k, (&i, u)) in active.iter().zip(&updates).enumerate() {
                let i = i as usize;
                let Evaluated {
                    position: x,
                    f,
                    gradient: g,
                    leaf: l,
                } = u.at;
                let depth = u.depth;
                anchor[k] = u.anchor;
                leaf[k] = l;
                velocity[k] = x - particles.positions[i];
                particles.positions[i] = x;
                particles.normals[i] = g.normalize_or(particles.normals[i]);
                particles.depth[i] = depth;
                particles.sigma[i] = scale.sigma(field, depth);
                particles.target[i] = field.target_sigma(depth);
                fg[k] = (f, g);
            }
            *done = iteration + 1;
        }
        monitor.report("relax", *done as u64, total);
        last - first
    }

    /// The final polish (whatever iterations are left are not run): a particle whose moves
    /// were all rejected still sits where it was seeded, on an input point, which can be up
    /// to ε0 off the zero set; it is projected onto the surface.
    pub fn finish(
        self,
        mpu: &Mpu,
        particles: &mut Particles,
        field: &DensityField,
        params: &ParticleParams,
    ) {
        let tol = params.newton_tolerance * mpu.diagonal();
        let Relaxation {
            active, scale, fg, ..
        } = self;
        let polished: Vec<Option<(DVec3, DVec3)>> = active
            .par_iter()
            .zip(&fg)
            .map(|(&i, &(f, g))| {
                let i = i as usize;
                if f.abs() <= tol * g.length() {
                    return None;
                }
                let on = project_to_surface(mpu, particles.positions[i], tol, particles.sigma[i]);
                Some((on.position, on.gradient))
            })
            .collect();
        for (&i, p) in active.iter().zip(polished) {
            let i = i as usize;
            if let Some((x, g)) = p {
                particles.positions[i] = x;
                particles.normals[i] = g.normalize_or(particles.normals[i]);
                if let Some(l) = mpu.leaf_containing(x) {
                    let depth = mpu.octree().cell(l).depth;
                    particles.depth[i] = depth;
                    particles.sigma[i] = scale.sigma(field, depth);
                    particles.target[i] = field.target_sigma(depth);
                }
            }
        }
    }
}

/// The mean of `values` (0 when empty).
fn mean(values: &[f64]) -> f64 {
    values.iter().sum::<f64>() / values.len().max(1) as f64
}
