//! What the whole input says about one of its points, carried with it into an MPU over a
//! thinned subset of the input (`BuildOptions::whole_footprint`): its spacing, its neighbours'
//! centroid and its hops from the data's edge.

use glam::DVec3;

/// What the whole input says about one of its points ([`crate::Mpu::point_footprints`]): carried
/// with the point into an MPU over a thinned subset of the input, so that the subset's
/// footprint test reads the whole input's spacing and edges ([`crate::BuildOptions`]'s
/// `whole_footprint`). 24 bytes.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PointFootprint {
    /// Centroid of the point's 8 nearest input points (itself included) minus the point, local
    /// frame axes (world units, f32).
    centroid_offset: [f32; 3],
    /// The input spacing at the point, d₈·√(π/8) (world units, f32).
    spacing: f32,
    /// Whether the point lies well inside the data ([`crate::Mpu::input_is_interior`]).
    interior: bool,
    /// Its hops from the data's edge, at most [`DEEP`] ([`crate::Mpu::point_footprints`]).
    hops: u8,
    /// The fraction of the input's points around it that the subset holds (1 for the input
    /// itself; [`PointFootprint::thinned_to`]).
    rate: f32,
    /// Points fewer hops than this from the data's edge take the whole test in a subset, the
    /// others the lenient one ([`PointFootprint::thinned_to`]).
    exact_hops: u8,
    /// Whether it was measured at the point, and if not, which test a subset point takes.
    origin: Origin,
}

/// How a [`PointFootprint`] was obtained, and for an unmeasured one the test its subset point
/// takes (`DataFootprint::near_data_from`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
enum Origin {
    /// Measured on the whole input.
    Measured,
    /// Not measured (its region's spacing estimate, or 0): the lenient test.
    Unmeasured,
    /// Not measured, in a subset dense enough for its own test
    /// ([`PointFootprint::with_own_test`]): the whole test on the subset's own points.
    UnmeasuredOwnTest,
}

/// A point whose 8 nearest have their centroid farther than this fraction of a spacing from it
/// (tangentially) counts as an edge point for the thinned test's band
/// (`DataFootprint::near_edge`): an interior point of a jittered grid's is about 0.1 away, a
/// straight border's 0.45, a half disc's 0.95.
pub const BAND_EDGE_OFFSET: f64 = 0.4;

/// At a point of an unmeasured region, the subset's own d₈ (the lenient test) or its own
/// spacing (the whole test on the subset, [`PointFootprint::with_own_test`]) counts up to this
/// many times the one the rate implies from the region's spacing (an irregular subset's slack,
/// and the region's spread of spacings). Beyond it the point stands nearly alone in the
/// subset, as along a thin feature whose nearest points lie far along it; reading its own there
/// let particles cross the gaps beside such features (docs/notes/2026-11-27-thin-features.md).
pub(crate) const SUBSET_SLACK: f64 = 2.0;

/// [`PointFootprint::hops`] of a point three or more hops from the data's edge.
pub const DEEP: u8 = 3;

impl PointFootprint {
    /// Whether the point lies well inside the data (its neighbours surround it).
    pub fn interior(&self) -> bool {
        self.interior
    }

    /// Its hops from the data's edge: 0 for a point at the edge (not interior, or its
    /// neighbours' centroid [`BAND_EDGE_OFFSET`] of a spacing away), 1 for one of whose 8
    /// nearest is, 2 for one with such a neighbour, else [`DEEP`].
    pub fn hops(&self) -> u8 {
        self.hops
    }

    /// This footprint in a subset that holds the fraction `rate` (in (0, 1]) of the input
    /// points deeper in the data and every point fewer than `exact_hops + 1` hops from its edge
    /// (or none, for `exact_hops` 0): the footprint test at a point fewer than `exact_hops`
    /// hops from the edge is the whole test, at the others the lenient one (`thinned_test`).
    /// The subset keeps one hop more than it tests exactly, so that a position beside the
    /// band's inner side finds a lenient point nearer than the exact ones.
    pub fn thinned_to(self, rate: f64, exact_hops: u8) -> PointFootprint {
        PointFootprint {
            rate: rate as f32,
            exact_hops,
            ..self
        }
    }

    /// The footprint of a point not measured on the whole input (a region of a random
    /// sampling): interior, deep, with `spacing` (world units) the input spacing around it as
    /// its region estimates it, or 0 when unknown (the thinned test then reads the subset's own
    /// spacing alone). It takes the lenient test unless [`PointFootprint::with_own_test`].
    pub fn unmeasured(spacing: f64) -> PointFootprint {
        PointFootprint {
            centroid_offset: [0.0; 3],
            spacing: spacing as f32,
            interior: true,
            hops: DEEP,
            rate: 1.0,
            exact_hops: 0,
            origin: Origin::Unmeasured,
        }
    }

    /// The hops tested exactly ([`PointFootprint::thinned_to`]).
    pub fn exact_hops(&self) -> u8 {
        self.exact_hops
    }

    /// The input spacing at the point, world units.
    pub fn spacing(&self) -> f64 {
        f64::from(self.spacing)
    }

    /// The centroid of its 8 nearest input points minus the point, local frame, world units.
    pub(crate) fn centroid_offset(&self) -> DVec3 {
        vector_of(self.centroid_offset)
    }

    /// Whether the footprint was measured at the point ([`PointFootprint::unmeasured`]: not).
    pub(crate) fn measured(&self) -> bool {
        self.origin == Origin::Measured
    }

    /// Whether the point, unmeasured, takes the whole test on the subset's own points.
    pub(crate) fn own_test(&self) -> bool {
        self.origin == Origin::UnmeasuredOwnTest
    }

    /// This footprint, when unmeasured, with the whole test on the subset's own points instead
    /// of the lenient one (a measured footprint is returned as it is). For a subset dense
    /// enough that its own gaps lie far below the particles' spacing: a hashed subset of a
    /// random sampling is as random as the input, so its own test rejects there as the whole
    /// test does on the input, and at holes, where the lenient test accepts nearly everything
    /// (docs/notes/2026-11-28-unmeasured-own-test.md). On a subset of a few points a particle
    /// its gaps are the particles' own size, and the relaxation's spacing gets less even.
    pub fn with_own_test(self) -> PointFootprint {
        let origin = match self.origin {
            Origin::Unmeasured => Origin::UnmeasuredOwnTest,
            o => o,
        };
        PointFootprint { origin, ..self }
    }

    /// [`PointFootprint::thinned_to`]'s rate.
    pub(crate) fn rate(&self) -> f64 {
        f64::from(self.rate)
    }

    /// What the whole input measured at a point (`DataFootprint::point_footprints`): untested
    /// in a subset yet (rate 1, `exact_hops` [`DEEP`] − 1).
    pub(crate) fn from_measure(
        centroid_offset: [f32; 3],
        spacing: f32,
        interior: bool,
        hops: u8,
    ) -> PointFootprint {
        PointFootprint {
            centroid_offset,
            spacing,
            interior,
            hops,
            rate: 1.0,
            exact_hops: DEEP - 1,
            origin: Origin::Measured,
        }
    }
}

/// A stored f32 vector as a `DVec3` (the same frame and units).
#[inline]
pub(crate) fn vector_of(v: [f32; 3]) -> DVec3 {
    let [x, y, z] = v.map(f64::from);
    DVec3::new(x, y, z)
}
