//! Whether given normals point inward as a whole: judged at the input's extreme points along
//! many directions, which lie on its convex hull, where a closed surface's outward normal
//! points away from the rest (n·d > 0 for the extreme point along d) — and judged only where
//! the input is closed. Closedness is read from the generalized winding number of the oriented
//! points (Barill et al., *Fast Winding Numbers for Soups and Clouds*, 2018: a sum of dipoles
//! a_i n_i·(p_i − q)/(4π|p_i − q|³), a_i each point's area): just inside an extreme point it
//! is ±1 for a closed surface (+1 outward, −1 inward) or 0 where a thin part was crossed, and
//! a fraction between for an open one (a bowl seen from inside, one range view), whose
//! orientation is then left alone.

use glam::DVec3;
use psi_octree::{OrientedPoint, PointIndex};
use rayon::prelude::*;

use serde::{Deserialize, Serialize};

/// Directions probed: a Fibonacci sphere of this many.
const DIRECTIONS: usize = 64;
/// An extreme point votes only when its normal is this clearly along or against the direction
/// (|n·d| ≥ 0.5); on an open sheet's rim the normal lies across the direction and says nothing.
const DECISIVE: f64 = 0.5;
/// Normals are judged only when at least this many of the directions vote. A closed surface's
/// extreme point along d has its normal near d (a smooth surface) or within a corner's angle of
/// it (a cube's 0.577); a sharp or sparse spot may leave a few directions undecided.
const MIN_VOTES: usize = 48;
/// Inward when at least this share of the decisive votes says inward.
const INWARD_SHARE: f64 = 0.9;
/// The winding number is summed over at most this many of the points (an even stride).
const WINDING_SAMPLES: usize = 20_000;
/// Each sampled point's area is that of the disk out to its 8th nearest neighbour over 8.
const AREA_NEIGHBOURS: usize = 8;
/// The winding number is read this many of those radii (median) inside each extreme point:
/// far enough for the sum over the samples to be accurate, near enough to stay inside most
/// thin parts (four, on the paper's models).
const INSIDE_RADII: f64 = 4.0;
/// A winding number within this of 0 or ±1 is whole (a closed surface, read with the sum's
/// error); between, fractional.
const WHOLE: f64 = 0.25;
/// At least this many extreme points must read a whole, non-zero winding number.
const MIN_INSIDE: usize = 8;

/// The votes of the extreme points ([`inward_votes`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct InwardVotes {
    /// Directions whose extreme point's normal is clearly along or against them.
    pub decisive: usize,
    /// Of those, the ones whose normal points against them (inward).
    pub inward: usize,
    /// Extreme points just inside which the winding number is −1 (inward) or +1 (outward).
    pub wound_inward: usize,
    /// (The same, +1.)
    pub wound_outward: usize,
    /// Extreme points just inside which it is a fraction: the surface is open there.
    pub open: usize,
    /// Extreme points probed.
    pub probes: usize,
}

impl InwardVotes {
    /// Whether the normals point inward as a whole: the surface closed (at most one probe in
    /// ten reads a fractional winding number: a sharp or thin spot may), enough whole non-zero
    /// readings, nearly all −1, and enough decisive votes, nearly all inward.
    pub fn inward(&self) -> bool {
        let wound = (self.wound_inward + self.wound_outward) as f64;
        10 * self.open <= self.probes
            && self.wound_inward >= MIN_INSIDE
            && self.wound_inward as f64 >= INWARD_SHARE * wound
            && self.decisive >= MIN_VOTES
            && self.inward as f64 >= INWARD_SHARE * self.decisive as f64
    }
}

/// The oriented points as area-weighted dipoles: an even subsample of at most
/// [`WINDING_SAMPLES`] points, each with its area, and the median area radius.
struct Dipoles {
    sample: Vec<OrientedPoint>,
    area: Vec<f64>,
    radius: f64,
}

impl Dipoles {
    fn new(points: &[OrientedPoint]) -> Self {
        let stride = points.len().div_ceil(WINDING_SAMPLES).max(1);
        let sample: Vec<OrientedPoint> = points
            .iter()
            .step_by(stride)
            .filter_map(|p| {
                let n = p.n.normalize_or_zero();
                (p.p.is_finite() && n != DVec3::ZERO).then_some(OrientedPoint { p: p.p, n })
            })
            .collect();
        if sample.len() <= AREA_NEIGHBOURS {
            return Dipoles {
                sample: Vec::new(),
                area: Vec::new(),
                radius: 0.0,
            };
        }
        let positions: Vec<DVec3> = sample.iter().map(|p| p.p).collect();
        let index = PointIndex::new(&positions);
        let radii: Vec<f64> = positions
            .par_iter()
            .map(|&p| {
                let near = index.nearest(p, AREA_NEIGHBOURS + 1);
                near.last().map_or(0.0, |n| n.1.sqrt())
            })
            .collect();
        let mut sorted = radii.clone();
        sorted.sort_by(f64::total_cmp);
        let area = radii
            .iter()
            .map(|r| std::f64::consts::PI * r * r / AREA_NEIGHBOURS as f64)
            .collect();
        Dipoles {
            sample,
            area,
            radius: sorted[sorted.len() / 2],
        }
    }

    /// The generalized winding number at `q` (world units), summed in index order.
    fn winding_number(&self, q: DVec3) -> f64 {
        let sum: f64 = self
            .sample
            .iter()
            .zip(&self.area)
            .map(|(p, a)| {
                let v = p.p - q;
                let d2 = v.length_squared();
                if d2 == 0.0 {
                    0.0
                } else {
                    a * v.dot(p.n) / (d2 * d2.sqrt())
                }
            })
            .sum();
        sum / (4.0 * std::f64::consts::PI)
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
/// against it (inward), when |n·d| ≥ 0.5; and the winding number of the points just inside
/// each extreme point (two area radii along −d) says whether the surface is closed there
/// (±1, or 0 past a thin part) or open (a fraction). Deterministic for any thread count.
///
/// ```
/// use glam::DVec3;
/// use psi_octree::{OrientedPoint, PointIndex};
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
    for (&(_, i), d) in extremes.iter().zip(&dirs) {
        let Some(p) = points.get(i) else { continue };
        let s = p.n.normalize_or_zero().dot(*d);
        if s.abs() >= DECISIVE {
            votes.decisive += 1;
            votes.inward += usize::from(s < 0.0);
        }
    }
    // The winding number just inside each extreme point (a few area radii along −d).
    let probes: Vec<(usize, DVec3)> = extremes
        .iter()
        .zip(&dirs)
        .filter(|(e, _)| e.1 < points.len())
        .map(|(e, d)| (e.1, *d))
        .collect();
    let dipoles = Dipoles::new(points);
    let w: Vec<f64> = probes
        .par_iter()
        .map(|&(i, d)| dipoles.winding_number(points[i].p - INSIDE_RADII * dipoles.radius * d))
        .collect();
    votes.probes = w.len();
    for w in w {
        if (w.abs() - 1.0).abs() <= WHOLE {
            if w < 0.0 {
                votes.wound_inward += 1;
            } else {
                votes.wound_outward += 1;
            }
        } else if w.abs() > WHOLE {
            votes.open += 1;
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
        // Nor a dome, most of a sphere open at the bottom, seen from inside.
        let dome: Vec<OrientedPoint> = AnalyticShape::Sphere { radius: 1.0 }
            .sample(8000, 4)
            .into_iter()
            .filter(|p| p.p.z > -0.3)
            .collect();
        let votes = inward_votes(&flipped(dome));
        assert!(votes.open > 0 && !votes.inward(), "{votes:?}");
    }
}
