//! Whether given normals point inward as a whole: judged at the input's extreme points along
//! many directions, which lie on its convex hull, where a closed surface's outward normal
//! points away from the rest (n·d > 0 for the extreme point along d).

use glam::DVec3;
use psi_octree::OrientedPoint;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Directions probed: a Fibonacci sphere of this many.
const DIRECTIONS: usize = 64;
/// An extreme point votes only when its normal is this clearly along or against the direction
/// (|n·d| ≥ 0.5); on an open sheet's rim the normal lies across the direction and says nothing.
const DECISIVE: f64 = 0.5;
/// Normals are judged only when the input looks closed: at least this many of the directions
/// vote. A closed surface's extreme point along d has its normal near d (a smooth surface) or
/// within a corner's angle of it (a cube's 0.577); an open one (a bowl seen from inside, a
/// hemisphere, one range view) has directions whose extreme point lies on its rim, with the
/// normal across d, and is never judged.
const MIN_VOTES: usize = 62;
/// Inward when at least this share of the votes says inward.
const INWARD_SHARE: f64 = 0.9;

/// The votes of the extreme points ([`inward_votes`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct InwardVotes {
    /// Directions whose extreme point's normal is clearly along or against them.
    pub decisive: usize,
    /// Of those, the ones whose normal points against them (inward).
    pub inward: usize,
}

impl InwardVotes {
    /// Whether the normals point inward as a whole: enough decisive votes, nearly all inward.
    pub fn inward(&self) -> bool {
        self.decisive >= MIN_VOTES && self.inward as f64 >= INWARD_SHARE * self.decisive as f64
    }
}

/// The `i`-th of `n` directions spread evenly over the unit sphere (golden-angle spiral).
fn fibonacci_direction(i: usize, n: usize) -> DVec3 {
    let z = 1.0 - (2.0 * i as f64 + 1.0) / n as f64;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = i as f64 * std::f64::consts::PI * (3.0 - 5f64.sqrt());
    DVec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// For each of 64 directions d, the point of `points` (shape N, world units, unit normals)
/// farthest along d (ties: the lowest index) votes with its normal: along d (outward) or
/// against it (inward), when |n·d| ≥ 0.5. Deterministic for any thread count.
///
/// ```
/// use glam::DVec3;
/// use psi_octree::OrientedPoint;
/// use psi_preprocess::inward_votes;
///
/// let mut sphere = psi_shapes::AnalyticShape::Sphere { radius: 1.0 }.sample(2000, 1);
/// assert!(!inward_votes(&sphere).inward());
/// for p in &mut sphere {
///     p.n = -p.n;
/// }
/// assert!(inward_votes(&sphere).inward());
/// ```
pub fn inward_votes(points: &[OrientedPoint]) -> InwardVotes {
    let dirs: Vec<DVec3> = (0..DIRECTIONS)
        .map(|i| fibonacci_direction(i, DIRECTIONS))
        .collect();
    let none = || vec![(f64::NEG_INFINITY, usize::MAX); DIRECTIONS];
    let better = |a: (f64, usize), b: (f64, usize)| {
        if b.0 > a.0 || (b.0 == a.0 && b.1 < a.1) {
            b
        } else {
            a
        }
    };
    let extremes = points
        .par_iter()
        .enumerate()
        .fold(none, |mut best, (i, p)| {
            if p.p.is_finite() {
                for (b, d) in best.iter_mut().zip(&dirs) {
                    *b = better(*b, (p.p.dot(*d), i));
                }
            }
            best
        })
        .reduce(none, |a, b| {
            a.into_iter().zip(b).map(|(a, b)| better(a, b)).collect()
        });
    let mut votes = InwardVotes::default();
    for ((_, i), d) in extremes.into_iter().zip(&dirs) {
        let Some(p) = points.get(i) else { continue };
        let s = p.n.normalize_or_zero().dot(*d);
        if s.abs() >= DECISIVE {
            votes.decisive += 1;
            votes.inward += usize::from(s < 0.0);
        }
    }
    votes
}

#[cfg(test)]
mod tests {
    use super::*;
    use psi_shapes::AnalyticShape;

    fn flipped(mut points: Vec<OrientedPoint>) -> Vec<OrientedPoint> {
        for p in &mut points {
            p.n = -p.n;
        }
        points
    }

    #[test]
    fn closed_shapes_are_judged_by_their_hull() {
        for shape in [
            AnalyticShape::Sphere { radius: 2.0 },
            AnalyticShape::Torus {
                major: 1.0,
                minor: 0.3,
            },
        ] {
            let points = shape.sample(5000, 3);
            let out = inward_votes(&points);
            assert!(out.decisive >= MIN_VOTES && out.inward == 0, "{out:?}");
            let inw = inward_votes(&flipped(points));
            assert!(inw.inward() && inw.inward == inw.decisive, "{inw:?}");
        }
    }

    /// A cube's faces sampled on a grid, with the faces' outward normals: its extreme points
    /// along most directions are at corners, where the normal makes 55° with the direction.
    fn cube(per_edge: usize) -> Vec<OrientedPoint> {
        let mut points = Vec::new();
        for axis in 0..3 {
            for side in [-1.0, 1.0] {
                for i in 0..per_edge {
                    for j in 0..per_edge {
                        let u = -1.0 + 2.0 * (i as f64 + 0.5) / per_edge as f64;
                        let v = -1.0 + 2.0 * (j as f64 + 0.5) / per_edge as f64;
                        let mut p = [0.0; 3];
                        p[axis] = side;
                        p[(axis + 1) % 3] = u;
                        p[(axis + 2) % 3] = v;
                        let mut n = [0.0; 3];
                        n[axis] = side;
                        points.push(OrientedPoint {
                            p: DVec3::from_array(p),
                            n: DVec3::from_array(n),
                        });
                    }
                }
            }
        }
        points
    }

    #[test]
    fn a_cube_is_judged_at_its_corners() {
        assert!(!inward_votes(&cube(20)).inward());
        assert!(inward_votes(&flipped(cube(20))).inward());
    }

    #[test]
    fn open_sheets_are_never_judged_inward() {
        // A flat square with normals +z, and the same with -z: both directions vote alike.
        let plane: Vec<OrientedPoint> = (0..900)
            .map(|i| OrientedPoint {
                p: DVec3::new((i % 30) as f64, (i / 30) as f64, 0.0),
                n: DVec3::Z,
            })
            .collect();
        assert!(!inward_votes(&plane).inward());
        assert!(!inward_votes(&flipped(plane)).inward());
        // A hemisphere (one range view) with outward normals is not inward.
        let cap: Vec<OrientedPoint> = AnalyticShape::Sphere { radius: 1.0 }
            .sample(4000, 2)
            .into_iter()
            .filter(|p| p.p.z > 0.0)
            .collect();
        assert!(!inward_votes(&cap).inward());
        // The same cap with inward normals is a bowl seen from inside: not flipped either.
        assert!(!inward_votes(&flipped(cap)).inward());
    }
}
