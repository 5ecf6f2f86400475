//! Test support: points split by a g × g × g grid over their bounding box into parts, each with
//! the points within ∞-distance `halo` of its cell, as the by-parts functions take them.

use glam::DVec3;

/// A part: its points' indices (ascending), which are its own, and the box it holds.
pub(crate) struct GridPart {
    pub(crate) ids: Vec<u32>,
    pub(crate) own: Vec<bool>,
    lo: DVec3,
    hi: DVec3,
}

impl GridPart {
    /// Whether every point within `r` of `x` is held (the ball lies in the held box).
    pub(crate) fn holds_ball(&self, x: DVec3, r: f64) -> bool {
        (x - r).cmpge(self.lo).all() && (x + r).cmple(self.hi).all()
    }
}

/// The `g`³ parts of `positions` (shape: N, world units) with halo `halo` (world units).
pub(crate) fn grid_parts(positions: &[DVec3], g: usize, halo: f64) -> Vec<GridPart> {
    let (lo, hi) = positions
        .iter()
        .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(l, h), &p| {
            (l.min(p), h.max(p))
        });
    let edge = (hi - lo) / g as f64;
    let top = (g - 1) as f64;
    let cell = |p: DVec3| {
        ((p - lo) / edge)
            .floor()
            .clamp(DVec3::ZERO, DVec3::splat(top))
    };
    (0..g * g * g)
        .map(|c| {
            let at = DVec3::new((c % g) as f64, (c / g % g) as f64, (c / g / g) as f64);
            let (box_lo, box_hi) = (lo + at * edge - halo, lo + (at + 1.0) * edge + halo);
            let ids: Vec<u32> = (0..positions.len() as u32)
                .filter(|&i| {
                    let p = positions[i as usize];
                    p.cmpge(box_lo).all() && p.cmple(box_hi).all()
                })
                .collect();
            let own = ids
                .iter()
                .map(|&i| cell(positions[i as usize]) == at)
                .collect();
            GridPart {
                ids,
                own,
                lo: box_lo,
                hi: box_hi,
            }
        })
        .collect()
}
