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
