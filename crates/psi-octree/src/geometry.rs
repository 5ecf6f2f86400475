//! Oriented points and axis-aligned boxes: the geometric vocabulary every psi crate shares.

use glam::DVec3;
use serde::{Deserialize, Serialize};

/// A surface sample: a position and its outward unit normal, both in the input's world frame
/// (the units of the input file).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct OrientedPoint {
    /// Position, world units.
    pub p: DVec3,
    /// Outward unit normal (|n| = 1 up to rounding).
    pub n: DVec3,
}

impl OrientedPoint {
    /// A point with its normal normalised; `None` when the normal has zero or non-finite length
    /// or the position is not finite.
    pub fn new_normalized(p: DVec3, n: DVec3) -> Option<Self> {
        let len = n.length();
        if !p.is_finite() || !len.is_finite() || len <= f64::MIN_POSITIVE {
            return None;
        }
        Some(Self { p, n: n / len })
    }
}

/// An axis-aligned bounding box in world units. `min <= max` componentwise for a non-empty box.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Aabb {
    /// Smallest corner.
    pub min: DVec3,
    /// Largest corner.
    pub max: DVec3,
}

impl Aabb {
    /// The tightest box around `points` (shape: N positions); `None` for an empty slice.
    pub fn from_points(points: impl IntoIterator<Item = DVec3>) -> Option<Self> {
        let mut it = points.into_iter();
        let first = it.next()?;
        let (min, max) = it.fold((first, first), |(lo, hi), p| (lo.min(p), hi.max(p)));
        Some(Self { min, max })
    }

    /// [`Aabb::from_points`] of the `n` positions `at(0..n)` (shape: N, world units; no copy
    /// of them), in parallel: fixed chunks of 65 536 positions each folded from its own first,
    /// the chunks' boxes folded in order from the first position, so the box (the ties of
    /// signed zeros included) is the serial fold's for any thread count. `None` for `n = 0`.
    ///
    /// ```
    /// use glam::DVec3;
    /// let p = [DVec3::new(1.0, -2.0, 0.5), DVec3::new(-1.0, 3.0, 0.0)];
    /// let b = psi_octree::Aabb::from_positions_at(p.len(), &|i| p[i]).unwrap();
    /// assert_eq!((b.min, b.max), (DVec3::new(-1.0, -2.0, 0.0), DVec3::new(1.0, 3.0, 0.5)));
    /// ```
    pub fn from_positions_at(n: usize, at: &(dyn Fn(usize) -> DVec3 + Sync)) -> Option<Self> {
        use rayon::prelude::*;
        const CHUNK: usize = 1 << 16;
        let fold = |(lo, hi): (DVec3, DVec3), (l, h): (DVec3, DVec3)| (lo.min(l), hi.max(h));
        let first = (n > 0).then(|| at(0))?;
        let chunks: Vec<(DVec3, DVec3)> = (0..n.div_ceil(CHUNK))
            .into_par_iter()
            .map(|c| {
                let start = at(c * CHUNK);
                (c * CHUNK..n.min((c + 1) * CHUNK))
                    .map(at)
                    .fold((start, start), |b, p| fold(b, (p, p)))
            })
            .collect();
        let (min, max) = chunks.into_iter().fold((first, first), fold);
        Some(Self { min, max })
    }

    /// Centre of the box.
    pub fn center(&self) -> DVec3 {
        0.5 * (self.min + self.max)
    }

    /// Edge lengths along x, y, z.
    pub fn extent(&self) -> DVec3 {
        self.max - self.min
    }

    /// Length of the main diagonal (plain, not squared): the `D` that all relative tolerances use.
    pub fn diagonal(&self) -> f64 {
        self.extent().length()
    }

    /// Whether `x` lies in the closed box.
    pub fn contains(&self, x: DVec3) -> bool {
        x.cmpge(self.min).all() && x.cmple(self.max).all()
    }
}
