//! Particles out of core: each region (a tile, or a leaf above the tiles that holds points)
//! seeds its own surface leaves exactly as the whole sampling does — its MPU is assembled from
//! every cell's decision, so the octree, its leaf indices and f are the global ones, and it
//! reads the points of its leaves; the regions are seeded by octant of the root (a cluster's
//! task each, [`seed_octant`]) — and then all seeds relax at once on one MPU assembled from
//! the decisions with the points the memory allows: every input point when they fit (then the
//! particles are bitwise the whole sampling's), else a thinned subset for the relaxation's data
//! test. The particles are few (they follow the surface, not the input's density), so one
//! relaxation of them all fits where the points do not, and it has no seams. The ceiling on
//! spacing follows, its passes reading the input part by part (`cover_parts.rs`).

use std::collections::HashMap;
use std::time::Instant;

use glam::DVec3;

use psi_mpu::{BuildOptions, CellAddress, Mpu, MpuParams, Region};
use psi_octree::Monitor;
use psi_particles::{
    DensityField, ParticleParams, Particles, Quality, RelaxOptions, cover_from, measure_quality,
    relax, seed_leaves, spacing_ceiling,
};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::arena_order::arena_indices;
use crate::cover_parts::PartsCover;
use crate::decide_tile::tile_keys;
use crate::leaf_cover::LeafCover;
use crate::thinned_data::ThinnedData;
use crate::thinning::{Thinning, thinning};
use crate::{PointSource, TileError, TiledDecisions};

/// The unit directions of a ball's 6 axis extremes and 8 diagonal ones (±1/√3 on each axis).
const BALL_EXTREMES: [[f64; 3]; 14] = {
    const D: f64 = 0.577_350_269_189_625_8; // 1/√3
    [
        [1.0, 0.0, 0.0],
        [-1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, -1.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.0, 0.0, -1.0],
        [D, D, D],
        [-D, D, D],
        [D, -D, D],
        [-D, -D, D],
        [D, D, -D],
        [-D, D, -D],
        [D, -D, -D],
        [-D, -D, -D],
    ]
};

/// A region reads the points within this fraction of their own edge of its leaves (the seeds
/// read their leaf's points; the margin only absorbs rounding at the faces).
pub const SEED_MARGIN: f64 = 0.125;

/// What a tiled sampling did.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TileSampleReport {
    /// Regions seeded (tiles, and leaves above the tile depth holding points).
    pub regions: usize,
    /// Input points the regions read for their seeds (a point counts once for every region
    /// that reads it).
    pub points_read: usize,
    /// Points the relaxation's MPU held for its data test: every input point, or a thinned
    /// subset when they would not fit.
    pub relax_points: usize,
    /// Seconds seeding (all regions).
    pub seed_seconds: f64,
    /// Seconds relaxing.
    pub relax_seconds: f64,
    /// Seconds.
    pub seconds: f64,
    /// The ceiling on spacing.
    #[serde(default)]
    pub cover: TileCover,
}

/// What the ceiling on spacing did out of core ([`psi_particles::cover_from`]).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TileCover {
    /// Particles added where the relaxed ones left input points uncovered.
    pub added: usize,
    /// Particles taken out (σ̂ capped under the ceiling; replaced by the added ones).
    pub removed: usize,
    /// Passes over the input (one when every point is covered).
    pub passes: usize,
    /// Seconds.
    pub seconds: f64,
}

/// The particles of a tiled sampling.
#[derive(Clone, Debug)]
pub struct TiledSampling {
    /// The relaxed particles, in the whole sampling's order.
    pub particles: Particles,
    /// The seeds, before relaxation (bitwise those of the whole sampling).
    pub seeds: Particles,
    /// The density field (the whole sampling's).
    pub field: DensityField,
    /// The relaxed particles' quality, measured on the relaxation's MPU (f is the whole MPU's).
    pub after: Quality,
    /// What it did.
    pub report: TileSampleReport,
}

/// The seeds of the regions in one octant of the root ([`seed_octant`]), in region order.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct OctantSeeds {
    /// The leaf each seed was seeded in (its index in the decisions' octree).
    pub leaves: Vec<u32>,
    /// The seeds (their σ not yet scaled: [`sample_tiled_from`] sets it).
    pub seeds: Particles,
    /// Regions seeded.
    pub regions: usize,
    /// Input points read (a point counts once for every region that reads it).
    pub read: usize,
    /// The octant's share of the relaxation's data when the input does not fit it
    /// ([`ThinnedData`]; empty when it does).
    pub thinned: ThinnedData,
}

/// The regions of a tiled sampling: the tiles, then the surface leaves above the tile depth.
fn regions_of(decisions: &TiledDecisions) -> Vec<Region> {
    let depth = decisions.report.depth;
    let mut regions: Vec<Region> = tile_keys(&decisions.cells, depth)
        .into_iter()
        .map(|key| Region::tile(depth, key))
        .collect();
    regions.extend(
        decisions
            .surface
            .iter()
            .filter(|a| a.0 < depth)
            .map(|&(d, key)| Region::tile(d, key)),
    );
    regions
}

/// The octant of the root (its key at depth 1) that holds `region`.
fn octant_of(region: &Region) -> [u32; 3] {
    region.key.map(|k| k >> region.depth.saturating_sub(1))
}

/// The octants of the root that hold regions to seed, in key order: the tasks of
/// [`seed_octant`].
pub fn seed_octants(decisions: &TiledDecisions) -> Vec<[u32; 3]> {
    let mut octants: Vec<[u32; 3]> = regions_of(decisions).iter().map(octant_of).collect();
    octants.sort_unstable();
    octants.dedup();
    octants
}

/// The density field of the seeds: the depth range of the surface leaves
/// ([`psi_particles::depth_range`], as in core), σ not yet scaled.
fn base_field(decisions: &TiledDecisions) -> DensityField {
    let (d_min, d_max) = psi_particles::depth_range(decisions.surface.iter().map(|a| a.0));
    DensityField {
        d_min,
        d_max,
        root_edge: 2.0 * decisions.frame.root_half,
        scale: 1.0,
        uniform: None,
        cap: None,
        ceiling: None,
    }
}

/// Seeds the regions in the octant `octant` (key at depth 1) of the MPU `decisions` describe,
/// reading points from `source` (in parallel; the result does not depend on the thread
/// count). One task of [`sample_tiled`]; its seeds are bitwise those the whole sampling seeds
/// in these regions' leaves. When the relaxation may hold fewer than all input points
/// (`relax_points`), the octant's share of its thinned data comes with them.
///
/// Errors: the point source's, an interruption.
pub fn seed_octant(
    source: &dyn PointSource,
    decisions: &TiledDecisions,
    mpu_params: &MpuParams,
    params: &ParticleParams,
    relax_points: usize,
    octant: [u32; 3],
    monitor: &Monitor<'_>,
) -> Result<OctantSeeds, TileError> {
    let field = base_field(decisions);
    let thin = thinning(decisions, &field, params, source.population(), relax_points);
    // (The leaves of this octant alone: a map of the whole table per octant would be large.
    // Only a region that builds the cells near it names its leaves by the map: one seed a
    // leaf, `seed_region`.)
    let in_octant = |(d, key): CellAddress| d == 0 || key.map(|k| k >> (d - 1)) == octant;
    let arena = match params.k <= 1 {
        true => arena_indices(&decisions.cells, mpu_params.max_depth, &in_octant),
        false => HashMap::new(),
    };
    let regions: Vec<Region> = regions_of(decisions)
        .into_iter()
        .filter(|r| octant_of(r) == octant)
        .collect();
    let outs: Vec<Result<OctantSeeds, TileError>> = regions
        .par_iter()
        .map(|region| {
            let seeding = Seeding {
                mpu_params,
                params,
                field: &field,
                thin,
                arena: &arena,
            };
            seed_region(source, decisions, &seeding, region, monitor)
        })
        .collect();
    let mut all = OctantSeeds {
        regions: regions.len(),
        ..OctantSeeds::default()
    };
    let thinned = outs.iter().flatten().map(|o| o.thinned.len()).sum();
    all.thinned.reserve_exact(thinned);
    for out in outs {
        let out = out?;
        all.leaves.extend(out.leaves);
        all.seeds.extend(&out.seeds);
        all.read += out.read;
        all.thinned.extend(out.thinned);
    }
    Ok(all)
}

/// What every region of a seeding reads.
struct Seeding<'a> {
    mpu_params: &'a MpuParams,
    params: &'a ParticleParams,
    field: &'a DensityField,
    /// [`thinning`].
    thin: Option<Thinning>,
    /// The decisions' octree's arena index of each leaf of the octant ([`arena_indices`]).
    arena: &'a HashMap<CellAddress, u32>,
}

/// Samples the MPU `decisions` describe, reading points from `source`, with `params` (k
/// particles per surface leaf; exact counts and uniform mode throw darts over the whole input
/// and are refused here): the regions' seeds (by octant, in parallel), then one relaxation of
/// them all whose MPU holds at most `relax_points` input points (all of them when there are no
/// more: then the particles are bitwise [`psi_particles::sample`]'s), then the ceiling on
/// spacing over every input point, read part by part ([`psi_particles::cover_from`]). The
/// result does not depend on the order of the octants or the thread count.
/// Progress: stage `"sample tiles"` (octants seeded), then `"relax"`, then `"cover"`.
///
/// Errors: [`TileError::BadParameter`] for an exact count or uniform mode, the point source's
/// errors, an interruption.
pub fn sample_tiled(
    source: &dyn PointSource,
    decisions: &TiledDecisions,
    mpu_params: &MpuParams,
    params: &ParticleParams,
    relax_points: usize,
    monitor: &Monitor<'_>,
) -> Result<TiledSampling, TileError> {
    let seeds_of = |octant| {
        seed_octant(
            source,
            decisions,
            mpu_params,
            params,
            relax_points,
            octant,
            monitor,
        )
    };
    sample_tiled_from(
        source,
        decisions,
        mpu_params,
        params,
        relax_points,
        &seeds_of,
        monitor,
    )
}

/// [`sample_tiled`] with each octant's seeds from `seeds_of` ([`seed_octant`]'s, or those a
/// cluster's task wrote to a file).
///
/// Errors as [`sample_tiled`], and `seeds_of`'s.
pub fn sample_tiled_from(
    source: &dyn PointSource,
    decisions: &TiledDecisions,
    mpu_params: &MpuParams,
    params: &ParticleParams,
    relax_points: usize,
    seeds_of: &(dyn Fn([u32; 3]) -> Result<OctantSeeds, TileError> + Sync),
    monitor: &Monitor<'_>,
) -> Result<TiledSampling, TileError> {
    if params.count.is_some() || params.density == psi_particles::DensityMode::Uniform {
        return Err(TileError::BadParameter(
            "a tiled sampling seeds k particles per leaf; an exact count or uniform spacing \
             needs the whole input in memory"
                .into(),
        ));
    }
    let t0 = Instant::now();
    let frame = decisions.frame;
    let mut field = base_field(decisions);
    let octants = seed_octants(decisions);
    let counted = std::sync::atomic::AtomicU64::new(0);
    let total = octants.len() as u64;
    monitor.report("sample tiles", 0, total);
    let outs: Vec<Result<OctantSeeds, TileError>> = octants
        .par_iter()
        .map(|&octant| {
            let out = seeds_of(octant);
            let k = counted.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
            monitor.report("sample tiles", k, total);
            out
        })
        .collect();
    // The whole sampling's order: by leaf index, a leaf's particles in seeding order.
    let mut all: Vec<(u32, usize, usize)> = Vec::new();
    let mut parts = Vec::with_capacity(outs.len());
    let (mut points_read, mut regions) = (0, 0);
    let mut thinned = Vec::with_capacity(outs.len());
    for (r, out) in outs.into_iter().enumerate() {
        let mut out = out?;
        points_read += out.read;
        regions += out.regions;
        thinned.push(std::mem::take(&mut out.thinned));
        all.extend(out.leaves.iter().enumerate().map(|(i, &l)| (l, r, i)));
        parts.push(out);
    }
    all.sort_unstable();
    let mut seeds = Particles::default();
    for &(_, r, i) in &all {
        copy_one(&parts[r].seeds, i, &mut seeds);
    }
    drop(parts);
    // σ̂'s scale is 1/√(seeds per leaf), a leaf giving fewer than k seeds where it has fewer
    // points, as the whole sampling sets it (`psi_particles::initialize`).
    let per_leaf = seeds.len() as f64 / decisions.surface.len().max(1) as f64;
    field.scale = 1.0 / per_leaf.max(1e-12).sqrt();
    for i in 0..seeds.len() {
        seeds.target[i] = field.target_sigma(seeds.depth[i]);
        seeds.sigma[i] = seeds.target[i];
    }
    let seed_seconds = t0.elapsed().as_secs_f64();
    let t1 = Instant::now();
    // Every input point when they fit, else the octants' thinned data.
    let base = base_field(decisions);
    let (points, footprints) =
        match thinning(decisions, &base, params, source.population(), relax_points) {
            None => (source.relaxation_points(relax_points)?, None),
            Some(thin) => {
                let data = ThinnedData::at_most(thinned, relax_points, thin.uniform, seeds.len());
                (data.points, Some(data.footprints))
            }
        };
    let held = points.len();
    let mut particles = seeds.clone();
    let mut cover = TileCover::default();
    let after = if points.is_empty() {
        Quality::default()
    } else {
        let options = BuildOptions {
            frame: Some(frame),
            known_cells: Some(&decisions.cells),
            whole_footprint: footprints.as_deref(),
            monitor: monitor.quiet(),
            ..Default::default()
        };
        let mpu = Mpu::build_with(points, mpu_params, options)?;
        let options = RelaxOptions {
            monitor: *monitor,
            ..Default::default()
        };
        relax(&mpu, &mut particles, &field, params, options);
        monitor.check()?;
        // The ceiling on spacing, as the whole sampling applies it: its passes read every
        // input point, tile by tile.
        let ceiling = Some(spacing_ceiling(&mpu, params.max_spacing)).filter(|s| s.is_finite());
        field.ceiling = ceiling;
        if let Some(s) = ceiling {
            monitor.report("cover", 0, 1);
            let t = Instant::now();
            let source = PartsCover { source, monitor };
            let covered = cover_from(
                &mpu,
                &source,
                None,
                &mut particles,
                0,
                &mut field,
                s,
                params,
            )?;
            monitor.check()?;
            monitor.report("cover", 1, 1);
            cover = TileCover {
                added: covered.added,
                removed: covered.removed,
                passes: covered.passes,
                seconds: t.elapsed().as_secs_f64(),
            };
        }
        measure_quality(&mpu, &particles)
    };
    Ok(TiledSampling {
        particles,
        seeds,
        field,
        after,
        report: TileSampleReport {
            regions,
            points_read,
            relax_points: held,
            seed_seconds,
            relax_seconds: t1.elapsed().as_secs_f64() - cover.seconds,
            seconds: t0.elapsed().as_secs_f64(),
            cover,
        },
    })
}

fn copy_one(from: &Particles, i: usize, to: &mut Particles) {
    to.positions.push(from.positions[i]);
    to.normals.push(from.normals[i]);
    to.depth.push(from.depth[i]);
    to.sigma.push(from.sigma[i]);
    to.target.push(from.target[i]);
}

/// Whether the cell at `depth` with `key` lies inside `region`'s cube.
fn inside(depth: u8, key: [u32; 3], region: &Region) -> bool {
    depth >= region.depth && (0..3).all(|a| key[a] >> (depth - region.depth) == region.key[a])
}

/// One region's surface leaves seeded, leaf by leaf (to know each particle's leaf: a leaf may
/// give fewer than k), on an MPU from the decisions and the points of its leaves.
fn seed_region(
    source: &dyn PointSource,
    decisions: &TiledDecisions,
    seeding: &Seeding<'_>,
    region: &Region,
    monitor: &Monitor<'_>,
) -> Result<OctantSeeds, TileError> {
    let Seeding {
        mpu_params,
        params,
        field,
        thin,
        arena,
    } = *seeding;
    let own: Vec<CellAddress> = decisions
        .surface
        .iter()
        .copied()
        .filter(|&(d, key)| inside(d, key, region))
        .collect();
    let empty = OctantSeeds::default();
    let Some(cover) = LeafCover::new(&decisions.frame, &own, SEED_MARGIN) else {
        return Ok(empty);
    };
    let (center, half) = cover.bounding_cube(&decisions.frame);
    let points = source.gather_box_where(center, half, 0.0, &|p| cover.holds(p))?;
    if points.is_empty() {
        return Ok(empty);
    }
    let read = points.len();
    // With one seed a leaf (its point nearest the centre), only the cells near the region's
    // cube are built (the points there are the whole build's; its leaves are named by their
    // index in the whole octree). More seeds take random positions keyed by the leaf's index
    // and Newton steps that may leave the cube: the whole octree then.
    let near_only = params.k <= 1;
    let options = BuildOptions {
        frame: Some(decisions.frame),
        known_cells: Some(&decisions.cells),
        known_within: near_only.then_some((center, half)),
        monitor: monitor.quiet(),
        ..Default::default()
    };
    let mut mpu = Mpu::build_with(points, mpu_params, options)?;
    monitor.check()?;
    let tree = mpu.octree();
    let mut leaves = Vec::new();
    let mut seeds = Particles::default();
    let mut own_leaves = Vec::new();
    for l in mpu.surface_leaves() {
        let cell = tree.cell(l);
        if !inside(cell.depth, cell.key, region) {
            continue;
        }
        let whole = match near_only {
            false => l,
            true => *arena.get(&(cell.depth, cell.key)).ok_or_else(|| {
                TileError::BadParameter(format!(
                    "the decisions lack the leaf at depth {}, key {:?}",
                    cell.depth, cell.key
                ))
            })?,
        };
        let s = seed_leaves(&mpu, &[l], field, params);
        leaves.extend(std::iter::repeat_n(whole, s.len()));
        seeds.extend(&s);
        own_leaves.push(l);
    }
    let mut thinned = ThinnedData::default();
    if let Some(thin) = thin {
        // Every input point lies in a surface leaf, and the region's own are in the cover:
        // a ball holds no point the region lacks when its 6 axis extremes and 8 diagonal ones
        // lie in the cover or in the region's cube (the cover's cells are cubes far larger
        // than the ball).
        let (rc, rh) = region.cube(&decisions.frame);
        let in_region = |x: DVec3| {
            let t = (x - decisions.frame.origin - rc).abs();
            t.max_element() <= rh
        };
        let complete = |x: DVec3, r: f64| {
            BALL_EXTREMES.iter().all(|&[a, b, c]| {
                let y = x + DVec3::new(a, b, c) * r;
                in_region(y) || cover.holds(y)
            })
        };
        thinned.keep_from_region(&mut mpu, &own_leaves, &thin, &complete);
    }
    Ok(OctantSeeds {
        leaves,
        seeds,
        regions: 1,
        read,
        thinned,
    })
}
