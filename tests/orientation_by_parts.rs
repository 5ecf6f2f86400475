//! Preprocessing by parts on the real multi-view scan (`../shared/scans/dragon_stand_scan.xyz`,
//! skipped without): the level-0 estimate and the orientation computed from 8 tiles with a halo
//! are bitwise those of the whole cloud, and so are the outlier step's verdicts.

use std::path::Path;

use psi::preprocess::{
    IncompletePart, OutlierStats, PartEdges, StrayVerdict, estimate_normals, find_outliers,
    median_of_passes, orient_by_parts, orient_normals, part_normals, part_orientation_edges,
    part_outliers, part_standings,
};
use psi::{DVec3, OrientedPoint};

/// A tile: its points' indices (ascending), which are its own, and the box it holds (a ball
/// inside it holds every point of the ball).
type Tile = (Vec<u32>, Vec<bool>, (DVec3, DVec3));

/// The 2 × 2 × 2 tiles of `positions`' bounding box, each with the points within ∞-distance
/// `halo` of it.
fn tiles(positions: &[DVec3], halo: f64) -> Vec<Tile> {
    let (lo, hi) = positions
        .iter()
        .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(l, h), &p| {
            (l.min(p), h.max(p))
        });
    let mid = 0.5 * (lo + hi);
    let tile_of = |p: DVec3| p.cmpge(mid).bitmask();
    (0..8u32)
        .map(|t| {
            let bit = |axis: u32| t >> axis & 1 == 1;
            let pick = |axis: u32, a: f64, b: f64| if bit(axis) { b } else { a };
            let low = DVec3::new(
                pick(0, lo.x, mid.x),
                pick(1, lo.y, mid.y),
                pick(2, lo.z, mid.z),
            );
            let high = DVec3::new(
                pick(0, mid.x, hi.x),
                pick(1, mid.y, hi.y),
                pick(2, mid.z, hi.z),
            );
            let (box_lo, box_hi) = (low - halo, high + halo);
            let ids: Vec<u32> = (0..positions.len() as u32)
                .filter(|&i| {
                    let p = positions[i as usize];
                    p.cmpge(box_lo).all() && p.cmple(box_hi).all()
                })
                .collect();
            let own = ids
                .iter()
                .map(|&i| tile_of(positions[i as usize]) == t)
                .collect();
            (ids, own, (box_lo, box_hi))
        })
        .collect()
}

#[test]
fn the_real_scan_by_tiles_is_the_whole_scan_bitwise() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/scans/dragon_stand_scan.xyz");
    if !path.is_file() {
        eprintln!("skipped: {} is absent", path.display());
        return;
    }
    let cloud = psi::load_points(&path, &psi::ReadOptions::paper()).unwrap();
    let positions: Vec<DVec3> = cloud.points.iter().map(|p| p.p).collect();
    let diagonal = positions
        .iter()
        .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(l, h), &p| {
            (l.min(p), h.max(p))
        });
    // Stray points of the scan (left in: the outlier step is not run here) have their 47
    // nearest up to a quarter of the diagonal away.
    let halo = 0.3 * (diagonal.1 - diagonal.0).length();
    let whole = estimate_normals(&positions);
    let inside = |(box_lo, box_hi): (DVec3, DVec3)| {
        move |x: DVec3, r: f64| (x - r).cmpge(box_lo).all() && (x + r).cmple(box_hi).all()
    };
    let mut by_tiles = vec![DVec3::NAN; positions.len()];
    for (ids, own, bounds) in tiles(&positions, halo) {
        let held: Vec<DVec3> = ids.iter().map(|&i| positions[i as usize]).collect();
        let normals = part_normals(&held, &ids, &own, &inside(bounds)).unwrap();
        let mine = ids.iter().zip(&own).filter(|p| *p.1).map(|p| *p.0);
        for (i, n) in mine.zip(normals) {
            by_tiles[i as usize] = n;
        }
    }
    assert!(
        by_tiles == whole,
        "the tiles' normals differ from the whole estimate's"
    );
    // Oriented as the preprocessing orients them: the points with a plane.
    let points: Vec<OrientedPoint> = positions
        .iter()
        .zip(&whole)
        .filter(|p| *p.1 != DVec3::ZERO)
        .map(|(&p, &n)| OrientedPoint { p, n })
        .collect();
    let mut oriented = points.clone();
    let flips = orient_normals(&mut oriented);
    let kept: Vec<DVec3> = points.iter().map(|p| p.p).collect();
    let parts: Vec<PartEdges> = tiles(&kept, halo)
        .into_iter()
        .map(|(ids, own, bounds)| {
            let held: Vec<OrientedPoint> = ids.iter().map(|&i| points[i as usize]).collect();
            part_orientation_edges(&held, &ids, &own, &inside(bounds)).unwrap()
        })
        .collect();
    let across: usize = parts.iter().map(|p| p.across.len()).sum();
    let mut by_parts = points.clone();
    assert_eq!(orient_by_parts(&mut by_parts, &parts), flips);
    assert!(
        by_parts == oriented,
        "the tiles' sides differ from the whole orientation's"
    );
    eprintln!(
        "{} points, {} with a plane, {flips} flipped, {across} edges across the tiles",
        positions.len(),
        points.len()
    );
    assert!(across > 1000);
}

/// The scan's positions, or `None` (skipped, with a message) without the file.
fn scan_positions() -> Option<Vec<DVec3>> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/scans/dragon_stand_scan.xyz");
    if !path.is_file() {
        eprintln!("skipped: {} is absent", path.display());
        return None;
    }
    let cloud = psi::load_points(&path, &psi::ReadOptions::paper()).unwrap();
    Some(cloud.points.iter().map(|p| p.p).collect())
}

/// `f` on each of the 8 tiles of `positions`, the tile's halo grown from `halo` (world units)
/// while `f` refuses it; the results in tile order and how many tiles grew.
fn by_tiles<T>(
    positions: &[DVec3],
    halo: f64,
    f: impl Fn(
        &[DVec3],
        &[u32],
        &[bool],
        &(dyn Fn(DVec3, f64) -> bool + Sync),
    ) -> Result<T, IncompletePart>,
) -> (Vec<T>, usize) {
    let mut grown = 0;
    let out = (0..8)
        .map(|t| {
            let mut h = halo;
            loop {
                let (ids, own, (lo, hi)) = tiles(positions, h).swap_remove(t);
                let held: Vec<DVec3> = ids.iter().map(|&i| positions[i as usize]).collect();
                let inside = |x: DVec3, r: f64| (x - r).cmpge(lo).all() && (x + r).cmple(hi).all();
                match f(&held, &ids, &own, &inside) {
                    Ok(found) => return found,
                    Err(e) => {
                        grown += usize::from(h == halo);
                        h = if e.reach.is_finite() {
                            (1.01 * e.reach).max(1.5 * h)
                        } else {
                            2.0 * h
                        };
                    }
                }
            }
        })
        .collect();
    (out, grown)
}

/// The outlier step on the scan by 8 tiles (its halos grown where its stray points reach far):
/// the statistic it reads and every verdict are the whole step's (`find_outliers`; the scan
/// has no repeated points).
#[test]
fn the_real_scan_loses_the_same_outliers_by_tiles() {
    let Some(positions) = scan_positions() else {
        return;
    };
    let whole = find_outliers(&positions, None);
    let (standings, _) = by_tiles(&positions, 0.005, |held, ids, own, inside| {
        let found = part_standings(held, ids, own, None, inside)?;
        let mine = ids.iter().zip(own).filter(|p| *p.1).map(|p| *p.0);
        Ok(mine.zip(found).collect::<Vec<_>>())
    });
    let mut standing_of = vec![None; positions.len()];
    for (i, st) in standings.into_iter().flatten() {
        standing_of[i as usize] = Some(st);
    }
    let reaches: Vec<f64> = standing_of
        .iter()
        .filter_map(|st| st.and_then(|st| st.searched_reach()))
        .collect();
    assert_eq!(reaches.len(), positions.len());
    let typical = median_of_passes(|visit: &mut dyn FnMut(f64)| {
        reaches.iter().for_each(|&r| visit(r));
        Ok::<(), ()>(())
    })
    .unwrap()
    .unwrap();
    let stats = OutlierStats {
        typical,
        points: reaches.len() as u64,
    };
    let (found, grown) = by_tiles(&positions, 0.005, |held, ids, own, inside| {
        let mine: Vec<u32> = ids.iter().zip(own).filter(|p| *p.1).map(|p| *p.0).collect();
        let own_standings: Vec<_> = mine
            .iter()
            .map(|&i| standing_of[i as usize].expect("a standing"))
            .collect();
        let verdicts = part_outliers(held, ids, own, None, inside, (stats, &own_standings))?;
        Ok(mine.into_iter().zip(verdicts).collect::<Vec<_>>())
    });
    let mut by_parts = vec![None; positions.len()];
    for (i, v) in found.into_iter().flatten() {
        by_parts[i as usize] = Some(v);
    }
    let count = |k| by_parts.iter().filter(|v| **v == Some(k)).count();
    assert_eq!(count(StrayVerdict::Far), whole.far);
    assert_eq!(count(StrayVerdict::OffSurface), whole.off_surface);
    for (i, (v, &m)) in by_parts.iter().zip(&whole.mask).enumerate() {
        assert_eq!(*v != Some(StrayVerdict::Kept), m, "point {i}: {v:?}");
    }
    eprintln!("{} outliers, {grown} tiles grew their halos", whole.count());
    assert!(whole.count() > 50 && grown > 0);
}
