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

/// The notice for the normals of input `name` flipped outward ([`inward_votes`]).
pub fn inward_flip_notice(name: &str) -> String {
    format!("{name}: the normals pointed inward (judged on the convex hull); flipped them outward")
}

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

/// Input indices between the dipoles' samples among `n` points (points 0, stride, 2·stride, …).
fn winding_stride(n: u64) -> u64 {
    n.div_ceil(WINDING_SAMPLES as u64).max(1)
}

impl Dipoles {
    /// The dipoles of `sample` (the points at every [`winding_stride`]-th index, in index
    /// order): those with a finite position and a normal, the normal made unit.
    fn new(sample: &[OrientedPoint]) -> Self {
        let sample: Vec<OrientedPoint> = sample
            .iter()
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

/// What the inward check reads of N oriented points, gathered part by part in any order
/// ([`InwardEvidence::add`], [`InwardEvidence::merge`]): per direction the extreme point (ties:
/// the lowest index), and the points at every stride-th index for the winding number. Its
/// [`InwardEvidence::votes`] are [`inward_votes`] of the N points, bit for bit.
#[derive(Clone, Debug)]
pub struct InwardEvidence {
    n: u64,
    /// Per direction: how far along it, the index, the point.
    extremes: Vec<(f64, u64, OrientedPoint)>,
    /// The winding number's samples (index, point), in the order added.
    sample: Vec<(u64, OrientedPoint)>,
}

impl InwardEvidence {
    /// No points yet, of `n` in all (indices 0..n).
    pub fn new(n: u64) -> Self {
        let nowhere = OrientedPoint {
            p: DVec3::ZERO,
            n: DVec3::ZERO,
        };
        let none = (f64::NEG_INFINITY, u64::MAX, nowhere);
        InwardEvidence {
            n,
            extremes: vec![none; DIRECTIONS],
            sample: Vec::new(),
        }
    }

    /// Adds point `p` (world units) of input index `index` (< n; each index once).
    pub fn add(&mut self, index: u64, p: OrientedPoint) {
        self.add_along(index, p, &ALL_DIRECTIONS);
    }

    /// [`InwardEvidence::add`] where only the directions `along` (of
    /// [`InwardEvidence::directions_reaching`] a box holding `p`) may find a new extreme.
    pub fn add_along(&mut self, index: u64, p: OrientedPoint, along: &[usize]) {
        if index.is_multiple_of(winding_stride(self.n)) {
            self.sample.push((index, p));
        }
        if !p.p.is_finite() {
            return;
        }
        let table = &*DIRECTION_TABLE;
        for &i in along {
            let e = &mut self.extremes[i];
            let x = p.p.dot(table[i]);
            if x > e.0 || (x == e.0 && index < e.1) {
                *e = (x, index, p);
            }
        }
    }

    /// The directions along which a point in the closed box `lo..=hi` (world units) could be
    /// or tie the extreme found so far (the box's farthest corner, with a rounding's slack, as
    /// far as it); along the others, its points cannot change the votes.
    pub fn directions_reaching(&self, lo: DVec3, hi: DVec3) -> Vec<usize> {
        let slack = 1e-9 * (lo.abs().max(hi.abs()).max_element() + (hi - lo).max_element());
        (0..DIRECTIONS)
            .filter(|&i| {
                let d = direction(i);
                let corner = DVec3::select(d.cmpge(DVec3::ZERO), hi, lo);
                corner.dot(d) + slack >= self.extremes[i].0
            })
            .collect()
    }

    /// The evidence of both parts' points (disjoint indices of the same N).
    pub fn merge(mut self, other: InwardEvidence) -> InwardEvidence {
        for (e, o) in self.extremes.iter_mut().zip(other.extremes) {
            if o.0 > e.0 || (o.0 == e.0 && o.1 < e.1) {
                *e = o;
            }
        }
        self.sample.extend(other.sample);
        self
    }

    /// The votes of the extreme points ([`inward_votes`]).
    pub fn votes(mut self) -> InwardVotes {
        let dirs: Vec<DVec3> = (0..DIRECTIONS).map(direction).collect();
        let mut votes = InwardVotes::default();
        let extremes: Vec<(OrientedPoint, DVec3)> = self
            .extremes
            .iter()
            .zip(&dirs)
            .filter(|(e, _)| e.1 < self.n)
            .map(|(e, d)| (e.2, *d))
            .collect();
        for (p, d) in &extremes {
            let s = p.n.normalize_or_zero().dot(*d);
            if s.abs() >= DECISIVE {
                votes.decisive += 1;
                votes.inward += usize::from(s < 0.0);
            }
        }
        // The winding number just inside each extreme point (a few area radii along −d).
        self.sample.sort_unstable_by_key(|s| s.0);
        let sample: Vec<OrientedPoint> = self.sample.iter().map(|s| s.1).collect();
        let dipoles = Dipoles::new(&sample);
        let w: Vec<f64> = extremes
            .par_iter()
            .map(|(p, d)| dipoles.winding_number(p.p - INSIDE_RADII * dipoles.radius * *d))
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
}

/// Every direction's number.
const ALL_DIRECTIONS: [usize; DIRECTIONS] = {
    let mut all = [0; DIRECTIONS];
    let mut i = 0;
    while i < DIRECTIONS {
        all[i] = i;
        i += 1;
    }
    all
};

/// The [`DIRECTIONS`] directions probed, computed once: every point is tested along each,
/// and a direction's sine, cosine and root cost far more than the test
/// (docs/notes/2026-12-04-inward-directions.md).
static DIRECTION_TABLE: std::sync::LazyLock<[DVec3; DIRECTIONS]> =
    std::sync::LazyLock::new(|| std::array::from_fn(|i| fibonacci_direction(i, DIRECTIONS)));

/// The `i`-th of the [`DIRECTIONS`] directions probed.
fn direction(i: usize) -> DVec3 {
    DIRECTION_TABLE[i]
}

/// For each of 64 directions d, the point of `points` (shape N, world units, unit normals)
/// farthest along d (ties: the lowest index) votes with its normal: along d (outward) or
/// against it (inward), when |n·d| ≥ 0.5; and the winding number of the points just inside
/// each extreme point (two area radii along −d) says whether the surface is closed there
/// (±1, or 0 past a thin part) or open (a fraction). Deterministic for any thread count; by
/// parts: [`InwardEvidence`].
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
    let n = points.len() as u64;
    points
        .par_iter()
        .enumerate()
        .fold(
            || InwardEvidence::new(n),
            |mut e, (i, p)| {
                e.add(i as u64, *p);
                e
            },
        )
        .reduce(|| InwardEvidence::new(n), InwardEvidence::merge)
        .votes()
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

    /// The evidence gathered in parts, in a shuffled order, votes as the whole: the torus's
    /// points (and the flipped torus's) dealt to 7 parts by a hash of their index.
    #[test]
    fn parts_vote_as_the_whole() {
        let torus = AnalyticShape::Torus {
            major: 1.0,
            minor: 0.3,
        };
        for points in [torus.sample(30_000, 5), flipped(torus.sample(30_000, 5))] {
            let n = points.len() as u64;
            let mut parts: Vec<InwardEvidence> = (0..7).map(|_| InwardEvidence::new(n)).collect();
            for (i, p) in points.iter().enumerate().rev() {
                let part = (i.wrapping_mul(2_654_435_761) >> 7) % 7;
                parts[part].add(i as u64, *p);
            }
            let votes = parts
                .into_iter()
                .rev()
                .reduce(InwardEvidence::merge)
                .unwrap()
                .votes();
            let whole = inward_votes(&points);
            assert_eq!(votes, whole);
            // Parts of a grid, each adding along the directions its box may reach: the same.
            let mut pruned = InwardEvidence::new(n);
            let (mut skipped, cells) = (0, 4);
            let lo = points.iter().fold(DVec3::INFINITY, |m, p| m.min(p.p));
            let hi = points.iter().fold(DVec3::NEG_INFINITY, |m, p| m.max(p.p));
            let edge = (hi - lo) / cells as f64;
            for c in 0..cells * cells * cells {
                let at = DVec3::new((c % 4) as f64, (c / 4 % 4) as f64, (c / 16) as f64);
                let (a, b) = (lo + at * edge, lo + (at + 1.0) * edge);
                let along = pruned.directions_reaching(a, b);
                skipped += DIRECTIONS - along.len();
                for (i, p) in points.iter().enumerate() {
                    let cell = ((p.p - lo) / edge)
                        .floor()
                        .clamp(DVec3::ZERO, DVec3::splat(3.0));
                    if cell == at {
                        pruned.add_along(i as u64, *p, &along);
                    }
                }
            }
            assert_eq!(pruned.votes(), whole);
            assert!(skipped > 32 * DIRECTIONS, "{skipped}");
            assert!(
                whole.probes == DIRECTIONS && whole.decisive >= MIN_VOTES,
                "{whole:?}"
            );
        }
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
