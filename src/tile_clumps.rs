//! The stray-clump search of a run out of core (psi-preprocess's `clumps_by_parts`), after the
//! outlier search and among the points it keeps, bitwise the in-core search: its sampled
//! points found in the tile files and each one's spacing measured in a cube around it read from
//! the store, the cubes of edge h/(2√3) counted tile file by tile file (two at a time), the few
//! candidates' surroundings gathered from the store. `stray_join`
//! (`tile_outliers.rs`) marks the clumps' points in `strays.bin` with the outliers. Progress:
//! stage `"clumps"`.

use glam::DVec3;
use psi_octree::{Aabb, Monitor};
use psi_preprocess::{ClumpCubes, ClumpScale, clump_spacing_in_cube, clumps_of_candidates};
use psi_tiles::{PointSource, TileStore};
use rayon::prelude::*;

use crate::tile_parts::first_halo;
use crate::two_at_a_time::two_at_a_time;

/// The points `verdicts` keeps (verdict 0), by their index in the store of all points.
struct Kept<'a> {
    verdicts: &'a [u8],
}

impl<'a> Kept<'a> {
    fn new(verdicts: &'a [u8]) -> Self {
        Kept { verdicts }
    }

    /// Whether point `i` is kept.
    fn holds(&self, i: u64) -> bool {
        self.verdicts.get(i as usize) == Some(&0)
    }
}

/// The kept points of a store, part by part.
struct KeptParts<'a> {
    store: &'a TileStore,
    kept: &'a Kept<'a>,
    monitor: &'a Monitor<'a>,
}

impl KeptParts<'_> {
    /// `visit(index, position)` over the kept points of part `part`, in the file's order.
    fn each_of(&self, part: usize, visit: &mut dyn FnMut(u64, DVec3)) -> Result<(), String> {
        let points = (self.store)
            .part_where(part, &|_| true)
            .map_err(|e| e.to_string())?;
        for (i, p) in points {
            if self.kept.holds(i) {
                visit(i, p.p);
            }
        }
        Ok(())
    }

    /// `visit` over every kept point, part after part (progress: stage `"clumps"`).
    fn each(&self, visit: &mut dyn FnMut(u64, DVec3)) -> Result<(), String> {
        let parts = self.store.part_count();
        for part in 0..parts {
            self.monitor.report("clumps", part as u64, parts as u64);
            self.monitor
                .check()
                .map_err(|_| "interrupted".to_string())?;
            self.each_of(part, visit)?;
        }
        Ok(())
    }

    /// Per part of the store, `visit(state, index, position)` over its kept points in the
    /// file's order, from `start()`; the parts' states in part order, whatever the threads.
    /// Two parts at a time ([`two_at_a_time`], as the tiles are taken); the first error in
    /// part order. Progress: stage `"clumps"`, parts done of parts.
    fn fold<T: Send>(
        &self,
        start: &(dyn Fn() -> T + Sync),
        visit: &(dyn Fn(&mut T, u64, DVec3) + Sync),
    ) -> Result<Vec<T>, String> {
        let parts = self.store.part_count();
        let one = |part: usize| -> Result<T, String> {
            let mut state = start();
            self.each_of(part, &mut |i, p| visit(&mut state, i, p))?;
            Ok(state)
        };
        let mut states = Vec::with_capacity(parts);
        self.monitor.report("clumps", 0, parts as u64);
        two_at_a_time(
            parts,
            &one,
            &|| self.monitor.stopped(),
            &mut |part, state| {
                self.monitor.report("clumps", part as u64 + 1, parts as u64);
                states.push(state);
                Ok(())
            },
        )?;
        self.monitor
            .check()
            .map_err(|_| "interrupted".to_string())?;
        Ok(states)
    }
}

/// The marks (a bit a point of the store, by index; shape ⌈N / 64⌉) of the points `verdicts`
/// keeps whose rank among them is a multiple of `stride`.
fn sample_marks(verdicts: &[u8], stride: u64) -> Vec<u64> {
    let mut marks = vec![0u64; verdicts.len().div_ceil(64)];
    let kept = verdicts.iter().enumerate().filter(|(_, v)| **v == 0);
    for (rank, (i, _)) in kept.enumerate() {
        if (rank as u64).is_multiple_of(stride) {
            marks[i / 64] |= 1 << (i % 64);
        }
    }
    marks
}

/// The sampled spacing of the kept point at `x` (world units) among the kept points of
/// `store` (by `kept`), read from the cube of half-edge `reach` around it, doubled until it
/// certainly holds the point's 16 nearest, or every kept point (a half-edge past their bounding
/// box's `diagonal`).
fn spacing_at(
    store: &TileStore,
    kept: &Kept<'_>,
    x: DVec3,
    mut reach: f64,
    diagonal: f64,
) -> Result<f64, String> {
    let frame = store.manifest().frame;
    loop {
        let found = store
            .gather_box_indexed(x - frame.origin, reach, 0.0, &|_| true)
            .map_err(|e| e.to_string())?;
        let cube: Vec<DVec3> = (found.into_iter())
            .filter(|(i, _)| kept.holds(*i))
            .map(|(_, p)| p.p)
            .collect();
        // (The store tests the cube in its local frame: a rounding's margin inside is certain.)
        let size = frame.origin.abs().max_element() + x.abs().max_element() + reach;
        let certain = reach - (1e-9 * frame.root_half + 16.0 * f64::EPSILON * size);
        if let Some(s) = clump_spacing_in_cube(x, &cube, certain, certain > diagonal) {
            return Ok(s);
        }
        reach *= 2.0;
    }
}

/// The stray clumps among the points of `store` (all points) that `verdicts` keeps (shape: the
/// store's population; 0: kept): their indices in the store, ascending, and the clump points
/// withheld by the 1 % rule. Bitwise [`psi_preprocess::find_clumps`] of the kept points in
/// index order.
///
/// # Errors
///
/// Why the store could not be read (a file named), or `"interrupted"`.
pub(crate) fn stray_clumps(
    store: &TileStore,
    verdicts: &[u8],
    monitor: &Monitor<'_>,
) -> Result<(Vec<u64>, u64), String> {
    let kept = Kept::new(verdicts);
    let n = verdicts.iter().filter(|&&v| v == 0).count() as u64;
    let keep = |i: u64| Ok::<bool, String>(kept.holds(i));
    let fail = |e: psi_tiles::TileError| e.to_string();
    let tiles = store.part_count();
    let kept_parts = KeptParts {
        store,
        kept: &kept,
        monitor,
    };
    let bounds = match store.bounds_where(&keep).map_err(fail)? {
        Some(b) => Some(b),
        None => {
            let mut b: Option<Aabb> = None;
            kept_parts.each(&mut |_, p| {
                b = Some(b.map_or(Aabb { min: p, max: p }, |b| Aabb {
                    min: b.min.min(p),
                    max: b.max.max(p),
                }));
            })?;
            b
        }
    };
    // As in core: no clumps among fewer than two distinct points or 2^32 − 1 and more.
    let Some(bounds) = bounds.filter(|b| b.diagonal() > 0.0 && b.diagonal().is_finite()) else {
        return Ok((Vec::new(), 0));
    };
    if n < 2 || n >= u64::from(u32::MAX) {
        return Ok((Vec::new(), 0));
    }
    // The spacings sampled every stride-th kept point by rank, as in core: the samples found
    // in the tile files, then each measured among the kept points of a cube around it.
    let marks = sample_marks(verdicts, ClumpScale::spacing_stride(n));
    let by_part = kept_parts.fold(&Vec::new, &|found: &mut Vec<DVec3>, i, p| {
        if marks[(i / 64) as usize] >> (i % 64) & 1 == 1 {
            found.push(p);
        }
    })?;
    let tiles_of = &store.manifest().tiles;
    let samples: Vec<(DVec3, f64)> = by_part
        .iter()
        .zip(tiles_of)
        .flat_map(|(found, tile)| {
            // (Half a first halo, three spacings of the tile's: its 16 nearest lie within
            // about 2.3 on a surface.)
            let reach = 0.5 * first_halo(store, tile.key);
            found.iter().map(move |&x| (x, reach))
        })
        .collect();
    let spacings = samples
        .par_iter()
        .map(|&(x, reach)| spacing_at(store, &kept, x, reach, bounds.diagonal()))
        .collect::<Result<Vec<f64>, String>>()?;
    if spacings.is_empty() {
        return Ok((Vec::new(), 0));
    }
    let scale = ClumpScale::of_spacings(spacings, bounds.diagonal());
    // The passes over every kept point by parts, two at a time, each part's result in part
    // order: the sequential pass's counts, and its candidates in its order.
    let cubes = kept_parts
        .fold(&|| ClumpCubes::new(bounds.min, &scale), &|c, _, p| c.add(p))?
        .into_iter()
        .fold(ClumpCubes::new(bounds.min, &scale), ClumpCubes::merge);
    let candidates = cubes.candidates(&scale);
    if candidates.is_empty() {
        return Ok((Vec::new(), 0));
    }
    let chosen: Vec<(u64, DVec3)> = kept_parts
        .fold(&Vec::new, &|chosen, i, p| {
            if candidates.holds(&cubes, p) {
                chosen.push((i, p));
            }
        })?
        .concat();
    // (Indices in the store of all points order the kept points as their kept do.) The
    // cube around the box, a rounding's margin wider: the search needs every point of the box
    // and takes more.
    let frame = store.manifest().frame;
    let mut gather = |lo: DVec3, hi: DVec3| -> Result<Vec<(u64, DVec3)>, String> {
        let centre = 0.5 * (lo + hi);
        let half = 0.5 * (hi - lo).max_element();
        // (The rounding of the local centre grows with the coordinates' size.)
        let size = frame.origin.abs().max_element() + centre.abs().max_element() + half;
        let margin = 1e-9 * frame.root_half + 16.0 * f64::EPSILON * size;
        let found = store
            .gather_box_indexed(centre - frame.origin, half, margin, &|_| true)
            .map_err(fail)?;
        Ok(found
            .into_iter()
            .filter(|(i, _)| kept.holds(*i))
            .map(|(i, p)| (i, p.p))
            .collect())
    };
    let (groups, withheld) = clumps_of_candidates(n, &cubes, &scale, chosen, &mut gather)?;
    let mut clumped: Vec<u64> = groups.into_iter().flatten().collect();
    clumped.sort_unstable();
    monitor.report("clumps", tiles as u64, tiles as u64);
    Ok((clumped, withheld))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The samples' marks are the kept points whose rank among the kept ones is a multiple of
    /// the stride, by brute force (the in-core search samples every stride-th point it searches).
    #[test]
    fn the_marks_are_every_stride_th_kept_point() {
        let verdicts: Vec<u8> = (0..3000u64)
            .map(|i| [0, 0, 0, 2, 0, 3, 0, 4][((i * 2_654_435_761) >> 9) as usize % 8])
            .collect();
        let kept: Vec<usize> = (0..verdicts.len()).filter(|&i| verdicts[i] == 0).collect();
        assert!(kept.len() > 1000 && kept.len() < 3000);
        for stride in [1, 7, 64, 5000] {
            let marks = sample_marks(&verdicts, stride);
            let marked: Vec<usize> = (0..verdicts.len())
                .filter(|&i| marks[i / 64] >> (i % 64) & 1 == 1)
                .collect();
            let expected: Vec<usize> = kept.iter().copied().step_by(stride as usize).collect();
            assert_eq!(marked, expected, "stride {stride}");
        }
    }
}
