//! The data's footprint: where on the surface there are input points. Per input point, what its
//! 9 nearest points say about the data around it (its spacing, whether its neighbours surround
//! it, their centroid), cached on first use; and the test whether a position lies within the
//! data rather than on a part of the implicit that no data backs (a hole, a scan's border).

use std::sync::Arc;

use glam::DVec3;
use psi_octree::all_k_nearest;

use crate::input_local::{InputData, InputLocal, InputLocalSlot, LocalTable, tangential_length};
use crate::point_footprint::{BAND_EDGE_OFFSET, DEEP, PointFootprint, SUBSET_SLACK};
use crate::surrounded::{SURROUND_REACH, surrounded};

/// An input point a particle was near, with what [`crate::Mpu::near_data_from`] reads of it:
/// kept by the particle between moves.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DataAnchor {
    point: u32,
    /// The point's position, local frame.
    position: DVec3,
    /// Within this distance of `position` (world units) a position is on the data without a
    /// search: half the point's spacing when it is interior, else −1 (never).
    fast_radius: f64,
}

impl DataAnchor {
    /// The input point's index.
    pub fn point(&self) -> u32 {
        self.point
    }
}

/// The answer of the footprint test ([`crate::Mpu::near_data_from`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FootprintTest {
    /// Whether the position lies inside the data's footprint.
    pub inside: bool,
    /// The input point nearest the position, to pass to the next test of a nearby position
    /// (`None` for an empty input).
    pub anchor: Option<DataAnchor>,
}

/// The per-point table of [`InputLocal`]s, filled lazily and shared by the clones of an MPU.
#[derive(Clone, Debug, Default)]
pub(crate) struct DataFootprint {
    table: Arc<LocalTable>,
    /// The whole input's footprint at each point, when the points are a thinned subset of it
    /// (shape: N).
    whole: Option<Arc<[PointFootprint]>>,
}

impl DataFootprint {
    /// An empty table for `n` input points, in `memory`'s allocation (emptied first).
    pub(crate) fn new_in(memory: Vec<InputLocalSlot>, n: usize) -> Self {
        Self {
            table: Arc::new(LocalTable::new_in(memory, n)),
            whole: None,
        }
    }

    /// This footprint reading `whole` (shape: N, one per point) for the spacing and edges of
    /// the points, a thinned subset of an input `whole` describes (see `near_data_from`).
    pub(crate) fn thinned(self, whole: &[PointFootprint]) -> Self {
        Self {
            whole: Some(whole.into()),
            ..self
        }
    }

    /// What this footprint says of each of points `qs` (its own points' spacing and edges,
    /// not a carried whole input's), with their hops from the data's edge: 0 for a point at
    /// the edge, 1 for one of whose 8 nearest is, 2 for one with such a neighbour, else
    /// [`DEEP`], edges as [`DataFootprint::near_edge`] tells; a point whose 9 nearest may lie
    /// beyond the points given (`complete`(its local position, the distance to its 9th
    /// nearest) false) counts as interior there. Reads the table, lazily filled (see
    /// `fill_all`).
    /// Shape: as `qs`.
    pub(crate) fn point_footprints(
        &self,
        data: InputData<'_>,
        qs: &[u32],
        complete: &dyn Fn(DVec3, f64) -> bool,
    ) -> Vec<PointFootprint> {
        // A point whose 9 nearest may lie beyond the points given counts as interior.
        let interior = |q: u32| {
            !self.near_edge(data, q)
                || !complete(data.positions[q as usize], self.local(data, q).last)
        };
        // Per point: 0 not known, 1 not touching an edge, 2 touching one (itself or a
        // neighbour not interior).
        let mut touches = vec![0u8; data.positions.len()];
        let mut touches_edge = |q: u32| {
            let t = &mut touches[q as usize];
            if *t == 0 {
                let local = self.local(data, q);
                let edge = !interior(q)
                    || local.near[..usize::from(local.near_len)]
                        .iter()
                        .any(|&j| !interior(j));
                *t = 1 + u8::from(edge);
            }
            *t == 2
        };
        qs.iter()
            .map(|&q| {
                let local = self.local(data, q);
                let hops = if !interior(q) {
                    0
                } else if touches_edge(q) {
                    1
                } else if local.near[..usize::from(local.near_len)]
                    .iter()
                    .any(|&j| touches_edge(j))
                {
                    2
                } else {
                    DEEP
                };
                PointFootprint::from_measure(
                    local.centroid_offset,
                    local.spacing() as f32,
                    local.interior,
                    hops,
                )
            })
            .collect()
    }

    /// The table's memory, when no other MPU shares it.
    pub(crate) fn into_memory(self) -> Vec<InputLocalSlot> {
        Arc::try_unwrap(self.table)
            .map(LocalTable::into_memory)
            .unwrap_or_default()
    }

    /// The table, to be carried to a later MPU, when no other MPU shares it and it has `n`
    /// entries; this footprint is left empty.
    pub(crate) fn take_table(&mut self, n: usize) -> Option<Vec<InputLocalSlot>> {
        Arc::get_mut(&mut self.table)?.take_dense(n)
    }

    /// The table's entries (shape: one per input point) when the table is dense.
    pub(crate) fn table(&self) -> Option<&[InputLocalSlot]> {
        self.table.dense()
    }

    /// A footprint over a carried table.
    pub(crate) fn from_table(table: Vec<InputLocalSlot>) -> Self {
        Self {
            table: Arc::new(LocalTable::Dense(table)),
            whole: None,
        }
    }

    /// Number of entries.
    pub(crate) fn len(&self) -> usize {
        self.table.len()
    }

    /// The input spacing at input point `q`: d₈·√(π/8), d₈ the distance to its 8th nearest
    /// neighbour (world units).
    pub(crate) fn spacing(&self, data: InputData<'_>, q: u32) -> f64 {
        self.local(data, q).spacing()
    }

    /// Whether input point `q` lies well inside the data: its own 8 nearest points (itself
    /// included) have their centroid within half a spacing of it in its tangent plane (an edge
    /// point's is about 0.95 spacing away for a dense random sampling; a point on the straight
    /// border of a regular grid's is only about 0.45 away and passes, corners fail).
    pub(crate) fn is_interior(&self, data: InputData<'_>, q: u32) -> bool {
        self.local(data, q).interior
    }

    /// The cached [`InputLocal`] of input point `q`, computed on first use from one query of
    /// its 9 nearest points (itself and 8 neighbours; the centroid is of the first 8).
    fn local(&self, data: InputData<'_>, q: u32) -> InputLocal {
        self.table.get_or_init(q, || {
            let y = data.positions[q as usize];
            InputLocal::from_nearest(data, q, &data.index.nearest_of_entry(q, y, 9))
        })
    }

    /// Whether input point `q` lies at or near the data's edge, as the thinned test's band
    /// counts it: not interior, or the centroid of its 8 nearest more than
    /// [`BAND_EDGE_OFFSET`] of a spacing from it in its tangent plane (a point on the straight
    /// border of a regular sampling, about 0.45, passes the interior test).
    pub(crate) fn near_edge(&self, data: InputData<'_>, q: u32) -> bool {
        let local = self.local(data, q);
        if !local.interior {
            return true;
        }
        let n = data.points[q as usize].n;
        tangential_length(local.centroid_offset(), n) > BAND_EDGE_OFFSET * local.spacing()
    }

    /// Fills every entry of the table at once ([`psi_octree::all_k_nearest`]: a grid instead
    /// of a kd-tree query per point), for a caller that reads them all. A sparse table not
    /// shared with another MPU becomes a dense one first (all its entries will be held).
    pub(crate) fn fill_all(&mut self, data: InputData<'_>) {
        if let Some(table) = Arc::get_mut(&mut self.table)
            && table.dense().is_none()
        {
            *table = LocalTable::dense_for(table.len());
        }
        all_k_nearest(data.positions, data.index, 9, |q, around| {
            self.table
                .get_or_init(q, || InputLocal::from_nearest(data, q, around));
        });
    }

    /// Whether local position `y` lies inside the data's footprint, and the new anchor (see
    /// `Mpu::near_data_from`, which states the test).
    pub(crate) fn near_data_from(
        &self,
        data: InputData<'_>,
        y: DVec3,
        reach: f64,
        floor: f64,
        anchor: Option<DataAnchor>,
    ) -> FootprintTest {
        let answer = |inside, anchor| FootprintTest { inside, anchor };
        if let Some(a) = anchor
            && (a.position - y).length() <= a.fast_radius
        {
            return answer(true, Some(a));
        }
        let found = anchor
            .and_then(|a| self.nearest_among_neighbours_of(data, y, a.point))
            .or_else(|| data.index.nearest_one(y));
        let Some((q, d2)) = found else {
            return answer(false, None);
        };
        let local = self.local(data, q);
        let at_q = Nearest {
            q,
            position: data.positions[q as usize],
            normal: data.points[q as usize].n,
            d2,
        };
        // A point of a thinned subset carries the whole input's footprint when its region's was
        // measured; in a region it was not (a random sampling's, whose seeming edges are too
        // many for a band) and a subset dense enough (`PointFootprint::with_own_test`), the
        // whole test on the subset's own points, its spacing capped where a point stands nearly
        // alone in the subset (`SUBSET_SLACK`).
        let limit = Reach { reach, floor };
        let Some(whole) = &self.whole else {
            return self.whole_test(data, &local, at_q, y, local.spacing(), limit);
        };
        let at = whole[q as usize];
        if !at.own_test() {
            return thinned_test(at, local.last, at_q, y, limit);
        }
        let spacing = if at.spacing() > 0.0 {
            local
                .spacing()
                .min(SUBSET_SLACK * at.spacing() / at.rate().sqrt())
        } else {
            local.spacing()
        };
        self.whole_test(data, &local, at_q, y, spacing, limit)
    }

    /// The whole test of local position `y` at its nearest input point (`at_q`, whose cached
    /// entry is `local`), for input spacing `spacing` there (world units) and `limit` (see
    /// `Mpu::near_data_from`).
    fn whole_test(
        &self,
        data: InputData<'_>,
        local: &InputLocal,
        at_q: Nearest,
        y: DVec3,
        spacing: f64,
        limit: Reach,
    ) -> FootprintTest {
        let answer = |inside, anchor| FootprintTest { inside, anchor };
        let Nearest {
            q,
            position: q_position,
            normal: n,
            d2,
        } = at_q;
        let new_anchor = Some(DataAnchor {
            point: q,
            position: q_position,
            fast_radius: if local.interior { 0.5 * spacing } else { -1.0 },
        });
        let d = d2.sqrt();
        if d > limit.distance(spacing) {
            return answer(false, new_anchor);
        }
        // Fast path: q lies well inside the data and y is within half a spacing of it.
        if d <= 0.5 * spacing && local.interior {
            return answer(true, new_anchor);
        }
        // The edge rule: the input points within a couple of spacings of y surround it in q's
        // tangent plane. The spacing is read as at least the floor, up to
        // [`FLOOR_SURROUND_SPACINGS`] spacings: a gap of the sampling that the floor lets pass
        // is surrounded by its rim at that reach, while an edge's points lie to one side of y at
        // any reach. Points that surround y surround it with more points added, so q and its
        // cached 8 nearest, where they lie within that reach (a hair inside it, so that they are
        // among the query's), decide most positions without the kd-tree query.
        let floor = limit.floor.min(FLOOR_SURROUND_SPACINGS * spacing);
        let around = SURROUND_REACH * spacing.max(floor);
        let inner2 = (around * around) * (1.0 - 1e-9);
        let cached = std::iter::once(q)
            .chain(local.near[..usize::from(local.near_len)].iter().copied())
            .map(|j| data.positions[j as usize])
            .filter(|p| (*p - y).length_squared() <= inner2);
        if surrounded(y, n, cached) {
            return answer(true, new_anchor);
        }
        // The same monotony: the points within half the reach first (a quarter of the
        // query's points), the whole reach only when they do not surround y.
        let mut near = Vec::with_capacity(64);
        for reach in [0.5 * around, around] {
            near.clear();
            data.index.within(y, reach, &mut near);
            if surrounded(y, n, near.iter().map(|&j| data.positions[j as usize])) {
                return answer(true, new_anchor);
            }
        }
        answer(false, new_anchor)
    }

    /// The input point nearest to local `y` and its squared distance, when the cached 9 nearest
    /// of input point `a` prove it: the closest of them is nearer to `y` than any other input
    /// point can be (those are at least `beyond` from `a`, so at least `beyond − |y − a|` from
    /// `y`). `None` when the proof fails; ties go to the lower index.
    fn nearest_among_neighbours_of(
        &self,
        data: InputData<'_>,
        y: DVec3,
        a: u32,
    ) -> Option<(u32, f64)> {
        let local = self.local(data, a);
        let positions = data.positions;
        let bound = local.beyond() - (positions[a as usize] - y).length();
        if bound <= 0.0 {
            return None;
        }
        let mut best = (u32::MAX, f64::INFINITY);
        for &j in std::iter::once(&a).chain(&local.near[..usize::from(local.near_len)]) {
            let d2 = (positions[j as usize] - y).length_squared();
            if d2 < best.1 || (d2 == best.1 && j < best.0) {
                best = (j, d2);
            }
        }
        (best.1 < bound * bound).then_some(best)
    }
}

/// The footprint test of local position `y` on a thinned subset of the input whose points
/// carry the whole input's footprint (`whole`, of q, the subset point nearest y, unless it
/// takes the subset's own test; world units).
/// The subset holds every point within a band along the data's edge (`psi_tiles`' thinned
/// data: two hops wide, or less for a small input with long edges), so near an edge the subset
/// point nearest y is the input's nearest:
/// - q in the band but its innermost hop ([`PointFootprint::thinned_to`]): the whole test at q
///   as it was before the surround rule, on what q carries (within `reach` × its spacing; then
///   within half a spacing of an interior q, or the centroid of its 8 nearest within a spacing
///   of y in q's tangent plane; docs/notes/2026-11-27-multiview-level-cv.md);
/// - q farther inside: y is inside when it lies within `reach` × the distance at which a
///   point of the subset has its 8th nearest: the larger of q's own (`subset_d8`) and the
///   one its rate implies, d₈ = spacing/√(rate·π/8); at a point of an unmeasured region, q's
///   own, at most [`SUBSET_SLACK`] × the one its region's spacing implies (when known).
///   The edge test on the subset's own neighbours would reject where the subset is
///   irregular (a hashed subset of a regular input most of all), which made the thinned
///   relaxation's spacing less even (docs/notes/2026-11-27-carried-footprint.md).
///
/// The distance rules read the spacing and d₈ as at least `floor` (world units), as in the whole
/// test. The anchor's fast radius is half the whole spacing at an interior point, as in the
/// whole test.
fn thinned_test(
    whole: PointFootprint,
    subset_d8: f64,
    q: Nearest,
    y: DVec3,
    limit: Reach,
) -> FootprintTest {
    let spacing = whole.spacing();
    let anchor = Some(DataAnchor {
        point: q.q,
        position: q.position,
        fast_radius: if whole.interior() {
            0.5 * spacing
        } else {
            -1.0
        },
    });
    let d = q.d2.sqrt();
    let inside = if whole.hops() >= whole.exact_hops() {
        let rate_d8 = spacing / (whole.rate() * std::f64::consts::PI / 8.0).sqrt();
        let d8 = if whole.measured() {
            rate_d8.max(subset_d8)
        } else if spacing > 0.0 {
            subset_d8.min(SUBSET_SLACK * rate_d8)
        } else {
            subset_d8
        };
        d <= limit.distance(d8)
    } else {
        let offset = q.position + whole.centroid_offset() - y;
        d <= limit.distance(spacing)
            && ((whole.interior() && d <= 0.5 * spacing)
                || tangential_length(offset, q.normal) <= spacing)
    };
    FootprintTest { inside, anchor }
}

/// The distance rule of the footprint test: within `reach` spacings, the spacing read as at
/// least `floor` (world units; `Mpu::near_data_from`).
#[derive(Clone, Copy)]
struct Reach {
    reach: f64,
    floor: f64,
}

impl Reach {
    /// The largest distance (world units) from the nearest input point at input spacing
    /// `spacing` (world units).
    fn distance(self, spacing: f64) -> f64 {
        self.reach * spacing.max(self.floor)
    }
}

/// The edge rule reads a floor on the spacing up to this many input spacings: far beyond the
/// gaps of a random sampling (a gap wider than two spacings is about e^−4π of its positions),
/// and a query of a few hundred points, where the whole floor (a coarse particle's σ on a dense
/// input, tens of spacings) would gather thousands for each position off its nearest point.
const FLOOR_SURROUND_SPACINGS: f64 = 4.0;

/// The subset point nearest a tested position.
#[derive(Clone, Copy)]
struct Nearest {
    q: u32,
    /// Its position, local frame.
    position: DVec3,
    /// Its unit normal.
    normal: DVec3,
    /// Its squared distance to the position, world units².
    d2: f64,
}

#[cfg(test)]
mod tests {
    use super::*;
    use psi_octree::{OrientedPoint, PointIndex};
    use psi_shapes::AnalyticShape;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64Mcg;

    /// `n` points sampled on a torus with `seed`, their positions and a kd-tree of them.
    fn torus(n: usize, seed: u64) -> (Vec<OrientedPoint>, Vec<DVec3>, PointIndex) {
        let points = AnalyticShape::Torus {
            major: 1.0,
            minor: 0.3,
        }
        .sample(n, seed);
        let positions: Vec<DVec3> = points.iter().map(|p| p.p).collect();
        let index = PointIndex::new(&positions);
        (points, positions, index)
    }

    /// A sparse table (what inputs above `FOOTPRINT_SPARSE_ABOVE` points get) answers as a
    /// dense one: the footprint test at positions on, beside and off the data, and every
    /// point's spacing, interior flag and footprint, the entries filled from two threads at
    /// once; and it holds only the entries asked for.
    #[test]
    fn a_sparse_table_answers_as_a_dense_one() {
        use rayon::prelude::*;
        let (points, positions, index) = torus(3000, 7);
        let data = InputData {
            positions: &positions,
            points: &points,
            index: &index,
        };
        let dense = DataFootprint::new_in(Vec::new(), points.len());
        let sparse = DataFootprint {
            table: Arc::new(LocalTable::sparse(points.len())),
            whole: None,
        };
        let mut rng = Pcg64Mcg::seed_from_u64(8);
        let probes: Vec<(DVec3, f64)> = (0..600)
            .map(|t| {
                let p = points[t * 5 % points.len()];
                let lift = [0.0, 0.01, 0.1][t % 3] * (rng.random::<f64>() - 0.5);
                let side = DVec3::new(rng.random(), rng.random(), rng.random()) * 0.02;
                (p.p + lift * p.n + side, [1.0, 1.5][t % 2])
            })
            .collect();
        let answers = |f: &DataFootprint| -> Vec<FootprintTest> {
            probes
                .par_iter()
                .map(|&(y, reach)| f.near_data_from(data, y, reach, 0.0, None))
                .collect()
        };
        assert_eq!(answers(&sparse), answers(&dense));
        let asked = sparse.table.filled();
        assert!(0 < asked && asked < points.len() / 2, "{asked} entries");
        assert_eq!(asked, dense.table.filled());
        let every: Vec<u32> = (0..points.len() as u32).collect();
        let complete = |_: DVec3, _: f64| true;
        assert_eq!(
            sparse.point_footprints(data, &every, &complete),
            dense.point_footprints(data, &every, &complete)
        );
        // Filling every entry makes an unshared table dense first.
        let mut filled = DataFootprint {
            table: Arc::new(LocalTable::sparse(points.len())),
            whole: None,
        };
        filled.fill_all(data);
        assert!(filled.table().is_some());
        assert_eq!(filled.table.filled(), points.len());
        for q in every {
            assert_eq!(sparse.spacing(data, q), dense.spacing(data, q));
            assert_eq!(filled.spacing(data, q), dense.spacing(data, q));
            assert_eq!(sparse.is_interior(data, q), dense.is_interior(data, q));
        }
    }

    #[test]
    fn a_footprint_entry_is_one_cache_line() {
        assert_eq!(std::mem::size_of::<InputLocalSlot>(), 64);
        assert_eq!(std::mem::align_of::<InputLocalSlot>(), 64);
    }

    /// The certificate from an input point's cached neighbours against a brute-force nearest
    /// point: whenever it answers, the answer is the nearest; and it answers for most positions
    /// within a spacing of the point (else it would save nothing). Positions up to two
    /// spacings away are tried too, for the answers' sake.
    #[test]
    fn nearest_among_neighbours_is_the_brute_force_nearest() {
        let (points, positions, index) = torus(4000, 5);
        let data = InputData {
            positions: &positions,
            points: &points,
            index: &index,
        };
        let footprint = DataFootprint::new_in(Vec::new(), points.len());
        let mut rng = Pcg64Mcg::seed_from_u64(3);
        let (mut answered, trials) = (0, 2000);
        for t in 0..2 * trials {
            let a = (t * 7 % positions.len()) as u32;
            let s = footprint.spacing(data, a);
            let dir = DVec3::new(
                rng.random::<f64>() - 0.5,
                rng.random::<f64>() - 0.5,
                rng.random::<f64>() - 0.5,
            );
            let reach = if t < trials { 1.0 } else { 2.0 };
            let y = positions[a as usize] + reach * s * rng.random::<f64>() * dir.normalize();
            let brute = positions
                .iter()
                .map(|p| (p - y).length_squared())
                .fold(f64::INFINITY, f64::min);
            if let Some((q, d2)) = footprint.nearest_among_neighbours_of(data, y, a) {
                assert_eq!(d2, brute, "trial {t}");
                assert_eq!((positions[q as usize] - y).length_squared(), d2);
                answered += usize::from(t < trials);
            }
        }
        assert!(answered > trials / 2, "answered {answered} of {trials}");
    }
}
