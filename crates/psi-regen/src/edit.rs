//! Shape edits of the control points, each a value, and how they change the point set.

use glam::{DMat3, DVec3};
use psi_octree::OrientedPoint;
use serde::{Deserialize, Serialize};

use crate::RegenError;

/// One edit of the control points (world units).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Edit {
    /// Moves the points within `radius` of `center` by `displacement` × (1 − t²)², t = r/radius;
    /// normals follow the inverse transpose of the deformation's Jacobian.
    Brush {
        /// Brush centre.
        center: DVec3,
        /// Brush radius (> 0).
        radius: f64,
        /// Displacement at the centre.
        displacement: DVec3,
    },
    /// Removes the points within `radius` of `center`.
    Remove {
        /// Ball centre.
        center: DVec3,
        /// Ball radius.
        radius: f64,
    },
    /// Replaces the points within `radius` of `center` by `points` (an over-sketched stroke).
    Replace {
        /// Ball centre.
        center: DVec3,
        /// Ball radius.
        radius: f64,
        /// The new oriented points.
        points: Vec<OrientedPoint>,
    },
    /// Inserts points.
    Insert {
        /// The new oriented points.
        points: Vec<OrientedPoint>,
    },
}

/// The brush weight (1 − t²)² and its gradient at offset `y` = p − centre.
fn falloff(y: DVec3, radius: f64) -> (f64, DVec3) {
    let s = y.length_squared() / (radius * radius);
    if s >= 1.0 {
        return (0.0, DVec3::ZERO);
    }
    let a = 1.0 - s;
    (a * a, (-4.0 * a / (radius * radius)) * y)
}

/// An edit's result with what it changed: the new points, the changed positions (old and new)
/// and the indices of the points a brush moved.
pub(crate) type Tracked = (Vec<OrientedPoint>, Vec<DVec3>, Vec<u32>);

/// A brush's effect on one point: its new state, `None` where the brush does not reach it.
/// Errors when the deformation folds the surface there.
fn brushed(
    p: &OrientedPoint,
    center: DVec3,
    radius: f64,
    displacement: DVec3,
) -> Result<Option<OrientedPoint>, RegenError> {
    let (w, gw) = falloff(p.p - center, radius);
    if w == 0.0 {
        return Ok(None);
    }
    // J = I + d ⊗ ∇w; normals transform by J^{-T}.
    let j = DMat3::IDENTITY
        + DMat3::from_cols(
            displacement * gw.x,
            displacement * gw.y,
            displacement * gw.z,
        );
    if j.determinant() <= 1e-6 {
        return Err(RegenError::BadEdit(format!(
            "the brush folds the surface (displacement {} too large for radius {radius})",
            displacement.length()
        )));
    }
    let n = j.inverse().transpose() * p.n;
    Ok(Some(OrientedPoint {
        p: p.p + w * displacement,
        n: n.normalize(),
    }))
}

impl Edit {
    /// A brush's moves: of `points`, those among `candidates` (ascending indices, every point
    /// the brush reaches among them) that it moves, with their new states, as
    /// [`Edit::apply`] moves them. `None` for the other edits.
    pub(crate) fn brush_moves(
        &self,
        points: &[OrientedPoint],
        candidates: &[u32],
    ) -> Option<Result<Vec<(u32, OrientedPoint)>, RegenError>> {
        let Edit::Brush {
            center,
            radius,
            displacement,
        } = self
        else {
            return None;
        };
        let moves = || {
            self.validate()?;
            let mut out = Vec::new();
            for &i in candidates {
                if let Some(q) = brushed(&points[i as usize], *center, *radius, *displacement)? {
                    out.push((i, q));
                }
            }
            Ok(out)
        };
        Some(moves())
    }

    /// Whether the points the edit leaves unchanged keep their indices (a brush moves points
    /// in place, an insertion appends; a removal or replacement renumbers).
    pub fn keeps_indices(&self) -> bool {
        matches!(self, Edit::Brush { .. } | Edit::Insert { .. })
    }

    /// The indices of `points` that survive the edit, in the order the new points list them
    /// first (every point for a brush or an insertion; those outside the ball for a removal or
    /// a replacement); the edit's own points, if any, follow them. Attributes of the points
    /// follow the edit by it ([`psi_octree::PointAttributes::select`]).
    pub fn survivors(&self, points: &[OrientedPoint]) -> Vec<u32> {
        match self {
            Edit::Remove { center, radius } | Edit::Replace { center, radius, .. } => {
                let r2 = radius * radius;
                (0..points.len() as u32)
                    .filter(|&i| (points[i as usize].p - *center).length_squared() > r2)
                    .collect()
            }
            Edit::Brush { .. } | Edit::Insert { .. } => (0..points.len() as u32).collect(),
        }
    }

    /// The points the edit adds after the survivors (a replacement's or an insertion's).
    pub fn added(&self) -> usize {
        match self {
            Edit::Replace { points, .. } | Edit::Insert { points } => points.len(),
            Edit::Brush { .. } | Edit::Remove { .. } => 0,
        }
    }

    /// Applies the edit to `points`, returning the new points and every changed position (old
    /// and new positions of moved points, removed and added points).
    pub fn apply(
        &self,
        points: &[OrientedPoint],
    ) -> Result<(Vec<OrientedPoint>, Vec<DVec3>), RegenError> {
        self.apply_into(points, Vec::with_capacity(points.len()))
    }

    /// Checks the edit's own numbers, before any point is touched: a brush needs a finite
    /// centre and displacement and a positive radius, a removal (or a replacement) a finite
    /// centre and a non-negative radius, every inserted point a finite position and a normal
    /// that normalises. (Whether a brush folds the surface depends on the points; only
    /// [`Edit::apply`] can tell.)
    ///
    /// ```
    /// use psi_regen::Edit;
    /// use glam::DVec3;
    /// assert!(Edit::Remove { center: DVec3::ZERO, radius: 0.0 }.validate().is_ok());
    /// assert!(Edit::Remove { center: DVec3::ZERO, radius: -1.0 }.validate().is_err());
    /// // The message names what is wrong.
    /// let nan = DVec3::new(0.0, f64::NAN, 0.0);
    /// let brush = |center, radius, displacement| Edit::Brush { center, radius, displacement };
    /// let say = |e: Edit| e.validate().unwrap_err().to_string();
    /// assert!(say(brush(nan, 0.1, DVec3::Z)).ends_with("its centre is [0, NaN, 0]"));
    /// assert!(say(brush(DVec3::ZERO, 0.1, nan)).ends_with("its displacement is [0, NaN, 0]"));
    /// assert!(say(brush(DVec3::ZERO, -2.0, DVec3::Z)).ends_with("not -2"));
    /// ```
    ///
    /// # Errors
    ///
    /// [`RegenError::BadEdit`] naming what is wrong.
    pub fn validate(&self) -> Result<(), RegenError> {
        let bad = |m: String| Err(RegenError::BadEdit(m));
        match self {
            Edit::Brush {
                center,
                radius,
                displacement,
            } => {
                let rule = "a brush needs a finite centre and displacement and a positive radius";
                if !center.is_finite() {
                    return bad(format!("{rule}; its centre is {center}"));
                }
                if !displacement.is_finite() {
                    return bad(format!("{rule}; its displacement is {displacement}"));
                }
                if !(*radius > 0.0 && radius.is_finite()) {
                    return bad(format!("{rule}, not {radius}"));
                }
            }
            Edit::Remove { center, radius } | Edit::Replace { center, radius, .. } => {
                let rule = "a removal needs a finite centre and a non-negative radius";
                if !center.is_finite() {
                    return bad(format!("{rule}; its centre is {center}"));
                }
                if !(radius.is_finite() && *radius >= 0.0) {
                    return bad(format!("{rule}, not {radius}"));
                }
            }
            Edit::Insert { .. } => {}
        }
        if let Edit::Insert { points } | Edit::Replace { points, .. } = self
            && let Some(i) = points
                .iter()
                .position(|p| OrientedPoint::new_normalized(p.p, p.n).is_none())
        {
            return bad(format!(
                "inserted point {i} is not finite or has a zero normal"
            ));
        }
        Ok(())
    }

    /// [`Edit::apply`] writing the new points into `out` (emptied first; a buffer to reuse).
    pub fn apply_into(
        &self,
        points: &[OrientedPoint],
        out: Vec<OrientedPoint>,
    ) -> Result<(Vec<OrientedPoint>, Vec<DVec3>), RegenError> {
        self.apply_tracked(points, out).map(|(p, c, _)| (p, c))
    }

    /// [`Edit::apply_into`], also returning the indices of the points a brush moved (empty for
    /// the other edits).
    pub(crate) fn apply_tracked(
        &self,
        points: &[OrientedPoint],
        mut out: Vec<OrientedPoint>,
    ) -> Result<Tracked, RegenError> {
        self.validate()?;
        out.clear();
        let mut changed = Vec::new();
        let mut moved = Vec::new();
        match self {
            Edit::Brush {
                center,
                radius,
                displacement,
            } => {
                for (i, p) in points.iter().enumerate() {
                    let Some(q) = brushed(p, *center, *radius, *displacement)? else {
                        out.push(*p);
                        continue;
                    };
                    changed.push(p.p);
                    changed.push(q.p);
                    moved.push(i as u32);
                    out.push(q);
                }
                Ok((out, changed, moved))
            }
            Edit::Remove { center, radius } => {
                let r2 = radius * radius;
                for p in points {
                    if (p.p - *center).length_squared() <= r2 {
                        changed.push(p.p);
                    } else {
                        out.push(*p);
                    }
                }
                Ok((out, changed, moved))
            }
            Edit::Replace {
                center,
                radius,
                points: new,
            } => {
                let (mut out, mut changed) = Edit::Remove {
                    center: *center,
                    radius: *radius,
                }
                .apply_into(points, out)?;
                let (_, added) = Edit::Insert {
                    points: new.clone(),
                }
                .apply(&[])?;
                out.extend(
                    new.iter()
                        .map(|p| OrientedPoint::new_normalized(p.p, p.n).expect("checked")),
                );
                changed.extend(added);
                Ok((out, changed, moved))
            }
            Edit::Insert { points: new } => {
                out.extend_from_slice(points);
                out.extend(
                    new.iter()
                        .map(|p| OrientedPoint::new_normalized(p.p, p.n).expect("checked")),
                );
                Ok((out, new.iter().map(|p| p.p).collect(), moved))
            }
        }
    }
}
