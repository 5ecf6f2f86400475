//! Particles tile by tile: each region (a tile, or a leaf above the tiles that holds points)
//! seeds its own surface leaves exactly as the whole sampling does — its MPU is assembled from
//! every cell's decision, so the octree, its leaf indices and f are the global ones, and its
//! leaves hold all their points — and relaxes them, colour by colour: with the particles of the
//! regions finished before it fixed, and a band of fresh seeds in the neighbouring leaves of
//! the others, which it then drops. The particles come back in the whole sampling's order (by
//! leaf index), the seeds bitwise the whole sampling's.

use std::collections::HashMap;
use std::time::Instant;

use glam::DVec3;
use psi_mpu::{BuildOptions, CellAddress, Mpu, MpuParams, Region};
use psi_octree::Monitor;
use psi_particles::{
    DensityField, ParticleParams, Particles, Quality, RelaxOptions, RelaxRegion,
    quality_from_surface_distances, relax, seed_leaves, surface_distances,
};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::decide_tile::tile_keys;
use crate::leaf_cover::LeafCover;
use crate::tile_records::tile_key;
use crate::{PointSource, TileError, TiledDecisions};

/// The band a region relaxes with: the surface leaves outside it within this many of their own
/// edges (about their particles' spacing) of its cube.
pub const BAND: f64 = 3.0;

/// A region gathers the points within at most this fraction of its edge around it for its band.
pub const BAND_HALO: f64 = 0.5;

/// A region also moves the finished particles outside it within this many of their spacings
/// (2σ̂) of its cube, where that is less than half its edge (so that no two regions of one
/// colour move the same particle): the stitch across its faces.
pub const STITCH: f64 = 1.5;

/// A region reads the points within this many of their own edges of the leaves whose particles
/// it moves (the band's included): the seeds read their leaf's points, the relaxation the data
/// around each particle ([`psi_mpu::Mpu::near_data_from`]), which moves about a spacing (a
/// leaf's edge for one seed per leaf); the fits come from the decisions. (Two edges read 1.7 ×
/// the points and spaced them no better: notes 2026-11-26-leaf-cover.)
pub const LEAF_MARGIN: f64 = 1.0;

/// What a tiled sampling did.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TileSampleReport {
    /// Regions sampled (tiles, and leaves above the tile depth holding points).
    pub regions: usize,
    /// The widest halo a region gathered, world units.
    pub band: f64,
    /// Particles seeded in the bands (relaxed as neighbours, then dropped), all regions.
    pub band_particles: usize,
    /// Input points read for the regions' MPUs, relaxing and stitching (a point counts once
    /// for every region that reads it).
    pub points_read: usize,
    /// Seconds stitching: relaxing the regions after the first colour, which meet finished
    /// ones.
    pub stitch_seconds: f64,
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
    /// The relaxed particles' quality, each measured in the region that moved it last.
    pub after: Quality,
    /// What it did.
    pub report: TileSampleReport,
}

/// What [`sample_region`] does: seed only, or seed and relax next to the regions finished.
#[derive(Clone, Copy)]
enum Pass<'a> {
    Seed,
    Relax(&'a Finished<'a>),
}

/// The regions relaxed so far.
struct Finished<'a> {
    /// Region index by the address of its top cell.
    owner: &'a HashMap<CellAddress, usize>,
    /// The particles of each region finished.
    done: &'a [Option<RegionParticles>],
    /// The tile depth.
    depth: u8,
}

impl Finished<'_> {
    /// Whether the region holding leaf `(d, key)` is finished.
    fn holds(&self, (d, key): CellAddress) -> bool {
        let top = if d >= self.depth {
            (self.depth, key.map(|k| k >> (d - self.depth)))
        } else {
            (d, key)
        };
        self.owner
            .get(&top)
            .is_some_and(|&r| self.done[r].is_some())
    }
}

/// One region's particles, with the leaf each was seeded in.
struct RegionParticles {
    leaves: Vec<u32>,
    seeds: Particles,
    relaxed: Particles,
    /// |f|/|∇f| / D of each relaxed particle.
    surface: Vec<f64>,
    band: usize,
    halo: f64,
    /// Input points read.
    read: usize,
    /// Finished particles this region moved: (region, index, the particle, its surface
    /// distance).
    moved: Vec<(usize, usize, Particles, f64)>,
}

/// Samples the MPU `decisions` describe, region by region, reading points from `source`, with
/// `params` (k particles per surface leaf; exact counts and uniform mode throw darts over the
/// whole input and are refused here). Regions run in parallel; the result does not depend on
/// their order or the thread count. Progress: stage `"sample tiles"`.
///
/// Errors: [`TileError::BadParameter`] for an exact count or uniform mode, the point source's
/// errors, an interruption.
pub fn sample_tiled(
    source: &dyn PointSource,
    decisions: &TiledDecisions,
    mpu_params: &MpuParams,
    params: &ParticleParams,
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
    let depths = decisions.surface.iter().map(|a| a.0);
    let mut field = DensityField {
        d_min: depths.clone().min().unwrap_or(0),
        d_max: depths.max().unwrap_or(0),
        root_edge: 2.0 * frame.root_half,
        scale: 1.0,
        uniform: None,
        cap: None,
        ceiling: None,
    };
    let counted = std::sync::atomic::AtomicU64::new(0);
    let total = regions.len() as u64;
    let per_region = |region: &Region, field: &DensityField, pass: Pass<'_>| {
        let out = sample_region(
            source, decisions, mpu_params, params, field, region, pass, monitor,
        );
        let k = counted.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
        monitor.report("sample tiles", k, total);
        out
    };
    if params.k > 1 {
        // σ̂'s scale is 1/√(seeds per leaf), and a leaf may give fewer than k seeds: count
        // them first, as the whole sampling does.
        let counts: Vec<Result<RegionParticles, TileError>> = regions
            .par_iter()
            .map(|r| per_region(r, &field, Pass::Seed))
            .collect();
        let mut seeds = 0usize;
        for c in counts {
            seeds += c?.seeds.len();
        }
        let per_leaf = seeds as f64 / decisions.surface.len().max(1) as f64;
        field.scale = 1.0 / per_leaf.max(1e-12).sqrt();
        counted.store(0, std::sync::atomic::Ordering::Relaxed);
    }
    // Colour by colour (tiles by the parity of their key, so that one colour's tiles do not
    // touch; the leaves above the tiles last): a region relaxes with the particles of the
    // regions finished before fixed, so the first colour's σ scale c adapts and the others
    // take it from their neighbours. A colour's regions run at once, each reading only the
    // colours before it: the result does not depend on their order. (This replaces a
    // relaxation of every region followed by a stitch of their faces, which built every
    // region's MPU twice: notes 2026-11-26-leaf-cover.)
    monitor.report("sample tiles", 0, total);
    let owner: HashMap<CellAddress, usize> = regions
        .iter()
        .enumerate()
        .map(|(i, r)| ((r.depth, r.key), i))
        .collect();
    let mut done: Vec<Option<RegionParticles>> = (0..regions.len()).map(|_| None).collect();
    let mut t1 = Instant::now();
    for c in 0..9 {
        if c == 1 {
            t1 = Instant::now();
        }
        let members: Vec<usize> = (0..regions.len())
            .filter(|&r| colour(&regions[r], depth) == c)
            .collect();
        let finished = Finished {
            owner: &owner,
            done: &done,
            depth,
        };
        let outs: Vec<Result<RegionParticles, TileError>> = members
            .par_iter()
            .map(|&r| per_region(&regions[r], &field, Pass::Relax(&finished)))
            .collect();
        let mut moved = std::collections::HashSet::new();
        for (&r, out) in members.iter().zip(outs) {
            let mut out = out?;
            // (No two regions of a colour move the same particle: [`STITCH`].)
            for (q, i, p, s) in std::mem::take(&mut out.moved) {
                debug_assert!(
                    moved.insert((q, i)),
                    "particle {i} of region {q} moved twice"
                );
                let other = done[q].as_mut().expect("finished");
                set_one(&mut other.relaxed, i, &p);
                other.surface[i] = s;
            }
            done[r] = Some(out);
        }
    }
    let stitch_seconds = t1.elapsed().as_secs_f64();
    // Back in the whole sampling's order: by leaf index, a leaf's particles in seeding order.
    let mut all: Vec<(u32, usize, usize)> = Vec::new();
    let mut parts = Vec::with_capacity(done.len());
    let (mut band_particles, mut band, mut points_read) = (0, 0.0f64, 0);
    for (r, out) in done.into_iter().enumerate() {
        let out = out.expect("every colour relaxed");
        band_particles += out.band;
        points_read += out.read;
        band = band.max(out.halo);
        all.extend(out.leaves.iter().enumerate().map(|(i, &l)| (l, r, i)));
        parts.push(out);
    }
    all.sort_unstable();
    let mut seeds = Particles::default();
    let mut particles = Particles::default();
    let mut surface = Vec::with_capacity(all.len());
    for &(_, r, i) in &all {
        copy_one(&parts[r].seeds, i, &mut seeds);
        copy_one(&parts[r].relaxed, i, &mut particles);
        surface.push(parts[r].surface[i]);
    }
    Ok(TiledSampling {
        after: quality_from_surface_distances(&particles, &surface),
        particles,
        seeds,
        field,
        report: TileSampleReport {
            regions: regions.len(),
            band,
            band_particles,
            points_read,
            stitch_seconds,
            seconds: t0.elapsed().as_secs_f64(),
        },
    })
}

/// Particle `i` of `to` set to the first of `from`.
fn set_one(to: &mut Particles, i: usize, from: &Particles) {
    to.positions[i] = from.positions[0];
    to.normals[i] = from.normals[0];
    to.depth[i] = from.depth[0];
    to.sigma[i] = from.sigma[0];
    to.target[i] = from.target[0];
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

/// One region: its surface leaves seeded and (unless `pass` only seeds) relaxed with the
/// particles of the finished regions near it fixed and fresh seeds in its band (the surface
/// leaves of the other regions within [`BAND`] of their edges of its cube), which are then
/// dropped; its MPU from the points around its own and the fresh band's leaves.
#[allow(clippy::too_many_arguments)]
fn sample_region(
    source: &dyn PointSource,
    decisions: &TiledDecisions,
    mpu_params: &MpuParams,
    params: &ParticleParams,
    field: &DensityField,
    region: &Region,
    pass: Pass<'_>,
    monitor: &Monitor<'_>,
) -> Result<RegionParticles, TileError> {
    let (mut near, reach) = band_of(decisions, region);
    let finished = match pass {
        Pass::Seed => None,
        Pass::Relax(f) => Some(f),
    };
    // (Where a region is finished its particles stand in for the band's seeds.)
    near.retain(|&a| finished.is_none_or(|f| !f.holds(a)));
    let frame = decisions.frame;
    let (center, half) = region.cube(&frame);
    let stitching = region_stitches(region, decisions.report.depth);
    // The finished particles near the cube: (region, index, movable).
    let mut fixed: Vec<(usize, usize, bool)> = Vec::new();
    for (q, other) in finished.iter().flat_map(|f| f.done.iter().enumerate()) {
        let Some(other) = other else { continue };
        for (i, &x) in other.relaxed.positions.iter().enumerate() {
            let out = ((x - frame.origin - center).abs() - DVec3::splat(half)).max_element();
            if out <= reach {
                let w = STITCH * 2.0 * other.relaxed.target[i];
                fixed.push((q, i, stitching && out < w && w < half));
            }
        }
    }
    let moving: Vec<CellAddress> = fixed
        .iter()
        .filter(|f| f.2)
        .map(|&(q, i, _)| {
            let p = &finished.expect("finished particles").done[q]
                .as_ref()
                .expect("finished")
                .relaxed;
            let d = p.depth[i];
            (d, tile_key(&frame, d, p.positions[i]))
        })
        .collect();
    let own_cells: Vec<CellAddress> = decisions
        .surface
        .iter()
        .copied()
        .filter(|&(d, key)| inside(d, key, region))
        .collect();
    let gathered: Vec<CellAddress> = own_cells
        .iter()
        .chain(&near)
        .chain(&moving)
        .copied()
        .collect();
    let cover = LeafCover::new(&decisions.frame, &gathered, LEAF_MARGIN);
    let halo = cover
        .as_ref()
        .map_or(0.0, |c| reach_beyond(c, region, decisions));
    let empty = || RegionParticles {
        leaves: Vec::new(),
        seeds: Particles::default(),
        relaxed: Particles::default(),
        surface: Vec::new(),
        band: 0,
        halo,
        read: 0,
        moved: Vec::new(),
    };
    if own_cells.is_empty() {
        return Ok(empty());
    }
    let Some(mpu) = region_mpu(source, decisions, mpu_params, cover.as_ref(), monitor)? else {
        return Ok(empty());
    };
    let tree = mpu.octree();
    let own: Vec<u32> = mpu
        .surface_leaves()
        .filter(|&l| inside(tree.cell(l).depth, tree.cell(l).key, region))
        .collect();
    if own.is_empty() {
        return Ok(empty());
    }
    let near: Vec<u32> = near
        .iter()
        .filter_map(|&(d, key)| tree.cell_at(d, key))
        .collect();
    // Seeds leaf by leaf, to know each particle's leaf (a leaf may give fewer than k).
    let mut leaves = Vec::new();
    let mut seeds = Particles::default();
    for &l in &own {
        let s = seed_leaves(&mpu, &[l], field, params);
        leaves.extend(std::iter::repeat_n(l, s.len()));
        seeds.extend(&s);
    }
    let Some(finished) = finished else {
        return Ok(RegionParticles {
            leaves,
            seeds,
            ..empty()
        });
    };
    let neighbours = seed_leaves(&mpu, &near, field, params);
    let mut particles = seeds.clone();
    particles.extend(&neighbours);
    let mut movable = vec![true; particles.len()];
    let start = particles.len();
    for &(q, i, m) in &fixed {
        let other = &finished.done[q].as_ref().expect("finished").relaxed;
        copy_one(other, i, &mut particles);
        movable.push(m);
    }
    let options = RelaxOptions {
        region: RelaxRegion {
            movable: Some(&movable),
            ..Default::default()
        },
        monitor: monitor.quiet(),
    };
    relax(&mpu, &mut particles, field, params, options);
    monitor.check()?;
    let mut moved = Vec::new();
    for (k, &(q, i, m)) in fixed.iter().enumerate() {
        if m {
            let mut p = Particles::default();
            copy_one(&particles, start + k, &mut p);
            let s = surface_distances(&mpu, &p.positions)[0];
            moved.push((q, i, p, s));
        }
    }
    let n = seeds.len();
    let keep: Vec<bool> = (0..particles.len()).map(|i| i < n).collect();
    particles.retain_mask(&keep);
    Ok(RegionParticles {
        leaves,
        seeds,
        surface: surface_distances(&mpu, &particles.positions),
        relaxed: particles,
        band: neighbours.len(),
        halo,
        read: mpu.points().len(),
        moved,
    })
}

/// The band of `region`: the surface leaves outside it within [`BAND`] of their edges of its
/// cube (and within [`BAND_HALO`] of its edge, with a margin of their own edge for the footprint
/// test), and how far they reach beyond it.
fn band_of(decisions: &TiledDecisions, region: &Region) -> (Vec<CellAddress>, f64) {
    let frame = decisions.frame;
    let (center, half) = region.cube(&frame);
    // The points gathered stay within a fraction of the region's size (the memory a region
    // takes is what bounds a run out of core): a coarse leaf that would need more is left out
    // of the band.
    let cap = BAND_HALO * 2.0 * half;
    let mut near = Vec::new();
    let mut halo = 0.0f64;
    for &(d, key) in &decisions.surface {
        if inside(d, key, region) {
            continue;
        }
        let (c, h) = Region::tile(d, key).cube(&frame);
        let gap = ((c - center).abs() - DVec3::splat(h + half))
            .max_element()
            .max(0.0);
        let reach = gap + 4.0 * h;
        if gap < BAND * 2.0 * h && reach <= cap {
            near.push((d, key));
            halo = halo.max(reach);
        }
    }
    (near, halo)
}

/// How far (∞-norm, world units) `cover` reaches beyond `region`'s cube.
fn reach_beyond(cover: &LeafCover, region: &Region, decisions: &TiledDecisions) -> f64 {
    let (c, h) = region.cube(&decisions.frame);
    let (cc, ch) = cover.bounding_cube(&decisions.frame);
    ((cc - c).abs() + DVec3::splat(ch - h))
        .max_element()
        .max(0.0)
}

/// An MPU with every cell from the decisions (so the global octree, leaf indices and f) and
/// the points `cover` holds (`None` without any).
fn region_mpu(
    source: &dyn PointSource,
    decisions: &TiledDecisions,
    mpu_params: &MpuParams,
    cover: Option<&LeafCover>,
    monitor: &Monitor<'_>,
) -> Result<Option<Mpu>, TileError> {
    let Some(cover) = cover else {
        return Ok(None);
    };
    let (center, half) = cover.bounding_cube(&decisions.frame);
    let points = source.gather_box_where(center, half, 0.0, &|p| cover.holds(p))?;
    if points.is_empty() {
        return Ok(None);
    }
    let options = BuildOptions {
        frame: Some(decisions.frame),
        known_cells: Some(&decisions.cells),
        monitor: monitor.quiet(),
        ..Default::default()
    };
    Ok(Some(Mpu::build_with(points, mpu_params, options)?))
}

/// Whether `region` moves finished particles: the tiles do; the leaves above them (the last
/// colour, which may touch one another) do not.
fn region_stitches(region: &Region, tile_depth: u8) -> bool {
    region.depth == tile_depth
}

/// The stitching colour of a region: tiles by the parity of their key (tiles of one colour do
/// not touch), the leaves above the tiles last.
fn colour(region: &Region, tile_depth: u8) -> usize {
    if region.depth != tile_depth {
        return 8;
    }
    let k = region.key;
    ((k[0] & 1) | ((k[1] & 1) << 1) | ((k[2] & 1) << 2)) as usize
}
