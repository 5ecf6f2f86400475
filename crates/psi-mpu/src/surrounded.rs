//! Whether input points surround a position on the surface: the edge rule of the data's
//! footprint test (`data_footprint.rs`). A position beyond the data's edge (a hole, a scan's
//! border) sees every nearby input point on one side; a position inside sees them all around.
//! Measured on the position's own nearest points, so that the rule does not depend on how the
//! data is sampled: range-scan rows (a point's nearest neighbours all on its own row) and
//! seams between views of different density made the earlier rule, on the centroid of the
//! nearest input point's 8 neighbours, take the data's inside for an edge
//! (docs/notes/2026-11-27-multiview-level-cv.md).

use glam::DVec3;

/// The rule reads the input points within this many local input spacings of the position
/// (about 12 on an even sampling): enough to surround a position between two range-scan rows,
/// few enough that the rim of a small hole does not wrap around a position inside it.
pub(crate) const SURROUND_REACH: f64 = 2.0;

/// A direction counts for a quadrant of the plane only when it lies at least this far (the
/// sine of its angle) inside it: then the quadrants' answer is the angles' answer whatever
/// their rounding (a few ulps of a turn), see [`surrounded`].
const QUADRANT_MARGIN_SQUARED: f64 = 1e-10;

/// Whether the points `near` (world units, any frame shared with `y`) surround `y` in the plane
/// normal to unit `n`: projected into it, the directions from `y` to them leave no gap of half
/// a turn or more between consecutive ones. Points within 1e-12 of `y` in the plane have no
/// direction and are skipped; fewer than 3 directions never surround.
///
/// ```text
/// y inside:  ·  ·  ·        y past an edge:  ·  ·  ·
///            ·  y  ·                         ·  ·  ·
///            ·  ·  ·                               y
/// ```
///
/// The points are read until a direction lies well inside each quadrant of the plane (around
/// `u`, `w`): then no gap reaches half a turn (two neighbouring quadrants make half a turn,
/// and each direction lies 1e-5 rad inside its own), and the answer is the angles' own
/// ([`surrounded_by_angles`]; a test holds the two to the same answer). Dense inputs surround
/// most positions this way after a few of the hundreds of points a query finds; the angles
/// (an `atan2` and a sort) decide the rest.
pub(crate) fn surrounded(y: DVec3, n: DVec3, near: impl IntoIterator<Item = DVec3>) -> bool {
    let u = n.any_orthonormal_vector();
    let w = n.cross(u);
    let mut seen = [false; 4];
    let mut planar: Vec<(f64, f64)> = Vec::with_capacity(32);
    for p in near {
        let v = p - y;
        let (a, b) = (v.dot(u), v.dot(w));
        let r2 = a * a + b * b;
        // (As the angles skip them: no direction, or not a number.)
        if r2.partial_cmp(&1e-24) != Some(std::cmp::Ordering::Greater) {
            continue;
        }
        planar.push((a, b));
        let margin = QUADRANT_MARGIN_SQUARED * r2;
        if a * a > margin && b * b > margin {
            seen[usize::from(a < 0.0) * 2 + usize::from(b < 0.0)] = true;
            if seen == [true; 4] {
                return true;
            }
        }
    }
    gap_below_half_turn(planar.iter().map(|&(a, b)| b.atan2(a)).collect())
}

/// [`surrounded`] by the angles alone: the directions' angles in the plane, sorted, and
/// their largest gap (the wrap included) below half a turn.
#[cfg(test)]
fn surrounded_by_angles(y: DVec3, n: DVec3, near: impl IntoIterator<Item = DVec3>) -> bool {
    let u = n.any_orthonormal_vector();
    let w = n.cross(u);
    let angles: Vec<f64> = near
        .into_iter()
        .filter_map(|p| {
            let v = p - y;
            let (a, b) = (v.dot(u), v.dot(w));
            (a * a + b * b > 1e-24).then(|| b.atan2(a))
        })
        .collect();
    gap_below_half_turn(angles)
}

/// Whether `angles` (radians in [−π, π], any order), at least 3 of them, leave no gap of half
/// a turn or more between consecutive ones around the circle.
fn gap_below_half_turn(mut angles: Vec<f64>) -> bool {
    if angles.len() < 3 {
        return false;
    }
    angles.sort_by(f64::total_cmp);
    let wrap = angles[0] + std::f64::consts::TAU - angles[angles.len() - 1];
    let gap = angles.windows(2).map(|w| w[1] - w[0]).fold(wrap, f64::max);
    gap < std::f64::consts::PI
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64Mcg;

    /// The brute-force twin: `y` is surrounded when no line through it in the plane has every
    /// point strictly on one side or on it, tried over many directions (a gap of half a turn
    /// or more is a direction with every point on one closed side).
    fn surrounded_by_halfplanes(y: DVec3, n: DVec3, near: &[DVec3]) -> bool {
        let u = n.any_orthonormal_vector();
        let w = n.cross(u);
        let dirs: Vec<(f64, f64)> = near
            .iter()
            .map(|p| ((*p - y).dot(u), (*p - y).dot(w)))
            .filter(|(a, b)| a * a + b * b > 1e-24)
            .collect();
        if dirs.len() < 3 {
            return false;
        }
        // Every point on one closed side of the line with normal m: a gap ≥ π. Candidate
        // normals: perpendicular to each point's direction (the extreme ones), both signs.
        for &(a, b) in &dirs {
            for m in [(-b, a), (b, -a)] {
                if dirs
                    .iter()
                    .all(|&(c, d)| m.0 * c + m.1 * d >= -1e-12 * (c.hypot(d)))
                {
                    return false;
                }
            }
        }
        true
    }

    #[test]
    fn a_grid_surrounds_its_inside_and_not_its_outside() {
        let n = DVec3::Z;
        let grid: Vec<DVec3> = (0..25)
            .map(|i| DVec3::new((i % 5) as f64, (i / 5) as f64, 0.1 * (i % 3) as f64))
            .collect();
        assert!(surrounded(
            DVec3::new(2.3, 1.6, 0.0),
            n,
            grid.iter().copied()
        ));
        // On a grid point: the point itself has no direction, the others surround it.
        assert!(surrounded(
            DVec3::new(2.0, 2.0, 0.0),
            n,
            grid.iter().copied()
        ));
        // Beyond an edge, and beyond a corner.
        assert!(!surrounded(
            DVec3::new(4.3, 2.0, 0.0),
            n,
            grid.iter().copied()
        ));
        assert!(!surrounded(
            DVec3::new(-0.2, -0.2, 0.0),
            n,
            grid.iter().copied()
        ));
        // Exactly on the straight border: the two border neighbours are half a turn apart.
        assert!(!surrounded(
            DVec3::new(4.0, 2.5, 0.0),
            n,
            grid.iter().copied()
        ));
        // Too few points.
        assert!(!surrounded(DVec3::ZERO, n, [DVec3::X, DVec3::Y]));
    }

    /// A random unit normal and two unit directions completing it to an orthonormal frame.
    fn random_frame(rng: &mut Pcg64Mcg) -> (DVec3, DVec3, DVec3) {
        let n = DVec3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        )
        .normalize_or(DVec3::Z);
        let u = n.any_orthonormal_vector();
        (n, u, n.cross(u))
    }

    #[test]
    fn agrees_with_the_half_plane_test_on_random_sets() {
        let mut rng = Pcg64Mcg::seed_from_u64(7);
        let mut both = [0usize; 2];
        for _ in 0..2000 {
            let (n, u, w) = random_frame(&mut rng);
            let y = DVec3::new(rng.random_range(-1.0..1.0), 0.0, 0.0);
            let count = rng.random_range(0..12);
            // Points in a random half-disc or the whole disc around the origin.
            let half = rng.random_bool(0.5);
            let near: Vec<DVec3> = (0..count)
                .map(|_| {
                    let t = rng.random_range(0.0..std::f64::consts::TAU);
                    let t = if half { t / 2.0 } else { t };
                    let r = rng.random_range(0.1..2.0);
                    r * (t.cos() * u + t.sin() * w) + rng.random_range(-0.2..0.2) * n
                })
                .collect();
            let fast = surrounded(y, n, near.iter().copied());
            assert_eq!(
                fast,
                surrounded_by_halfplanes(y, n, &near),
                "{y} {n} {near:?}"
            );
            both[usize::from(fast)] += 1;
        }
        // Both answers occur.
        assert!(both[0] > 100 && both[1] > 100, "{both:?}");
    }

    /// The quadrants' shortcut gives the angles' answer: dense discs and half-discs (where the
    /// shortcut is taken or not), directions within a hair of the quadrants' borders (the
    /// axes) or of half a turn apart, and points that are not numbers.
    #[test]
    fn the_quadrants_give_the_angles_answer() {
        let mut rng = Pcg64Mcg::seed_from_u64(11);
        let mut both = [0usize; 2];
        for case in 0..3000 {
            let (n, u, w) = random_frame(&mut rng);
            let count = rng.random_range(0..300);
            let span = match case % 3 {
                0 => std::f64::consts::TAU,
                1 => std::f64::consts::PI,
                _ => std::f64::consts::PI * (1.0 - 1e-9),
            };
            let mut near: Vec<DVec3> = (0..count)
                .map(|_| {
                    let t = match rng.random_range(0..4) {
                        // Near an axis (a quadrant's border) by a hair either way.
                        0 => {
                            let k = f64::from(rng.random_range(0..4u8));
                            let t = k * std::f64::consts::FRAC_PI_2 + rng.random_range(-1e-5..1e-5);
                            t.clamp(0.0, span)
                        }
                        _ => rng.random_range(0.0..span),
                    };
                    let r = rng.random_range(1e-3..2.0);
                    r * (t.cos() * u + t.sin() * w) + rng.random_range(-0.2..0.2) * n
                })
                .collect();
            // Points that are not numbers, which both skip.
            if case % 7 == 0 && !near.is_empty() {
                let at = rng.random_range(0..near.len());
                near.insert(at, DVec3::new(f64::NAN, 0.0, 1.0));
            }
            let fast = surrounded(DVec3::ZERO, n, near.iter().copied());
            assert_eq!(
                fast,
                surrounded_by_angles(DVec3::ZERO, n, near.iter().copied()),
                "case {case}: {near:?}"
            );
            both[usize::from(fast)] += 1;
        }
        assert!(both[0] > 500 && both[1] > 500, "{both:?}");
    }
}
