//! Normals out of core for points whose noise asks for a coarser level (dense noisy scans):
//! the in-core estimate fits the planes among the level's points (one in 4^L, by a hash of the
//! position), orients them among themselves, and gives every point the plane and the side of
//! the nearest level point around its place in the level's Morton order
//! (psi-preprocess `estimate_normals.rs`, `orient_from_level.rs`). Here the level's points are
//! gathered from the store's tiles (in input order), their planes and orientation edges found
//! tile by tile among the level points of each tile and its halo, the edges joined once, and
//! the level held whole for the lookup ([`LevelIndex`]) while the final store is written: each
//! point's normal from its position. Bitwise the in-core preprocessing. Progress: stages
//! `"level"`, `"level planes"`, `"level sides"` (tiles done of tiles).

use std::path::Path;

use glam::DVec3;
use psi_octree::{Monitor, OrientedPoint};
use psi_preprocess::{
    LEVEL_POINTS, LevelIndex, PartEdges, in_level, orientation_flips, part_normals,
    part_orientation_edges,
};
use psi_tiles::{TileStore, TileWithHalo};

use crate::PsiError;
use crate::partition::{Input, Keep, Normals, Partition, Points, failure};
use crate::tile_parts::{Halos, by_tile, each_tile, first_halo};

/// Bytes a level point takes while the final store is written: its position and input index
/// (28), its plane and oriented normal (48), the lookup's index (about 40), the orientation's
/// join (65, freed before).
const LEVEL_BYTES: u64 = 116 + 65;

/// The level's points of the store, in input order: their input indices and positions.
struct Level {
    ids: Vec<u32>,
    positions: Vec<DVec3>,
}

impl Level {
    /// The level's points among a tile's and its halo's (`ids` their input indices,
    /// ascending), numbered by their rank in the level, and which are the tile's own; those
    /// `with` admits (by rank) only.
    fn in_part(
        &self,
        tile: &TileWithHalo,
        ids: &[u32],
        level: u32,
        with: impl Fn(usize) -> bool,
    ) -> (Vec<usize>, Vec<usize>) {
        let mut at = Vec::new();
        let mut ranks = Vec::new();
        for (k, p) in tile.points.iter().enumerate() {
            if in_level(p.p, level)
                && let Ok(r) = self.ids.binary_search(&ids[k])
                && with(r)
            {
                at.push(k);
                ranks.push(r);
            }
        }
        (at, ranks)
    }
}

/// The final store (in `final_dir`) of the points of `store` (the kept positions of `input`,
/// which `keep` keeps) with normals estimated at `level` > 0, bitwise the in-core estimate
/// and orientation; `None` when the level holds fewer than [`LEVEL_POINTS`] points (the
/// in-core estimate then works at level 0). `halos` holds each tile's halo so far.
///
/// # Errors
///
/// [`PsiError::OutOfCore`] naming the first file: the level does not fit in `--max-memory`, a
/// store cannot be read, or the partition's errors.
pub(crate) fn partition_from_level(
    input: Input<'_>,
    (store, keep, level): (&TileStore, Option<Keep<'_>>, u32),
    halos: &mut Halos,
    final_dir: &Path,
    monitor: &Monitor<'_>,
) -> Result<Option<Partition>, PsiError> {
    let (fail, options) = (failure(&input.paths[0]), input.options);
    let interrupted = || fail("interrupted".into());
    let keys = store.tile_keys();
    // The level's points, from each tile's own (gathered with a halo: a point on a face of
    // its tile's cube, as the cube's rounded centre places it, is still gathered).
    let mut chosen: Vec<(u32, DVec3)> = Vec::new();
    for (done, &key) in keys.iter().enumerate() {
        monitor.report("level", done as u64, keys.len() as u64);
        let tile = store
            .tile_with_halo(key, first_halo(store, key))
            .map_err(|e| fail(e.to_string()))?;
        chosen.extend(
            tile.own_points()
                .filter(|(_, p)| in_level(p.p, level))
                .map(|(i, p)| (i as u32, p.p)),
        );
        monitor.check().map_err(|_| interrupted())?;
    }
    chosen.sort_unstable_by_key(|c| c.0);
    if chosen.len() < LEVEL_POINTS {
        return Ok(None);
    }
    let need = chosen.len() as u64 * LEVEL_BYTES;
    if need > options.max_memory {
        return Err(fail(format!(
            "its points have no normals, and their noise asks for them among {} of them held \
             at once: about {} MiB, more than the {} MiB of --max-memory; give more, or give \
             the points with normals",
            chosen.len(),
            need.div_ceil(1 << 20),
            options.max_memory >> 20
        )));
    }
    let level_points = Level {
        ids: chosen.iter().map(|c| c.0).collect(),
        positions: chosen.into_iter().map(|c| c.1).collect(),
    };
    let m = level_points.ids.len();
    // The planes among the level's points.
    let mut planes = vec![DVec3::ZERO; m];
    let first = |key| first_halo(store, key);
    let found = each_tile(
        &keys,
        (halos, &first),
        ("level planes", monitor),
        &|key, halo| {
            let (_, found) = by_tile(store, key, halo, |t, ids, holds| {
                let (at, ranks) = level_points.in_part(t, ids, level, |_| true);
                let positions: Vec<DVec3> = at.iter().map(|&k| t.points[k].p).collect();
                let own: Vec<bool> = at.iter().map(|&k| t.own[k]).collect();
                let ranks32: Vec<u32> = ranks.iter().map(|&r| r as u32).collect();
                let normals = part_normals(&positions, &ranks32, &own, holds)?;
                let mine = ranks
                    .into_iter()
                    .zip(own)
                    .filter_map(|(r, o)| o.then_some(r));
                Ok(mine.zip(normals).collect::<Vec<_>>())
            })?;
            Ok(found)
        },
    )
    .map_err(&fail)?;
    for (r, n) in found.into_iter().flatten() {
        planes[r] = n;
    }
    // The level's points with a plane are oriented among themselves (numbered among those).
    let with_plane: Vec<usize> = (0..m).filter(|&r| planes[r] != DVec3::ZERO).collect();
    if with_plane.len() < LEVEL_POINTS {
        return Err(fail(format!(
            "only {} of its level's {m} points have a plane to orient: the in-core estimate then \
             orients all points at once, which a run out of core does not do; run without \
             --max-memory",
            with_plane.len()
        )));
    }
    let mut oriented_rank = vec![u32::MAX; m];
    for (o, &r) in with_plane.iter().enumerate() {
        oriented_rank[r] = o as u32;
    }
    let mut parts: Vec<PartEdges> = Vec::new();
    let mut x = vec![0.0; with_plane.len()];
    let mut x_negative = vec![false; with_plane.len()];
    let found = each_tile(
        &keys,
        (halos, &first),
        ("level sides", monitor),
        &|key, halo| {
            let (_, found) = by_tile(store, key, halo, |t, ids, holds| {
                let has_plane = |r: usize| oriented_rank[r] != u32::MAX;
                let (at, ranks) = level_points.in_part(t, ids, level, has_plane);
                let points: Vec<OrientedPoint> = at
                    .iter()
                    .zip(&ranks)
                    .map(|(&k, &r)| OrientedPoint {
                        p: t.points[k].p,
                        n: planes[r],
                    })
                    .collect();
                let own: Vec<bool> = at.iter().map(|&k| t.own[k]).collect();
                let numbers: Vec<u32> = ranks.iter().map(|&r| oriented_rank[r]).collect();
                let edges = part_orientation_edges(&points, &numbers, &own, holds)?;
                let mine: Vec<(u32, OrientedPoint)> = numbers
                    .into_iter()
                    .zip(points)
                    .zip(own)
                    .filter_map(|(p, o)| o.then_some(p))
                    .collect();
                Ok((edges, mine))
            })?;
            Ok(found)
        },
    )
    .map_err(&fail)?;
    for (edges, mine) in found {
        for (o, p) in mine {
            x[o as usize] = p.p.x;
            x_negative[o as usize] = p.n.x < 0.0;
        }
        parts.push(edges);
    }
    let flips = orientation_flips(with_plane.len(), &parts, &|i| x[i as usize], &|i| {
        x_negative[i as usize]
    });
    drop((parts, x, x_negative));
    let sides: Vec<DVec3> = with_plane
        .iter()
        .zip(&flips)
        .map(|(&r, &f)| if f { -planes[r] } else { planes[r] })
        .collect();
    // Each point's plane from the nearest level point, its side from the nearest oriented one
    // (the same lookup unless some level point had no plane).
    let lookup = LevelIndex::new(&level_points.positions);
    let oriented_lookup = (with_plane.len() < m).then(|| {
        let positions: Vec<DVec3> = with_plane
            .iter()
            .map(|&r| level_points.positions[r])
            .collect();
        LevelIndex::new(&positions)
    });
    drop(level_points);
    let normal_at = |p: DVec3| -> Result<DVec3, String> {
        let Some(r) = lookup.nearest(p) else {
            return Ok(DVec3::ZERO);
        };
        let n = planes[r as usize];
        if n == DVec3::ZERO {
            return Ok(n);
        }
        let o = match &oriented_lookup {
            Some(l) => l.nearest(p),
            None => Some(oriented_rank[r as usize]),
        };
        let turn = o.is_some_and(|o| n.dot(sides[o as usize]) < 0.0);
        Ok(if turn { -n } else { n })
    };
    let partition = {
        let points = Points {
            normals: Normals::Located(&normal_at),
            keep,
            kept_from: None,
        };
        input.stage("orient", final_dir, points, monitor)?
    };
    Ok(Some(partition))
}
