//! Normals of a point cloud that has none: a least-squares plane per point over an adaptive
//! neighbourhood. Among its 12, 16, 24, 32 and 48 nearest points, the neighbourhood with the
//! smallest surface variation λ0/(λ0+λ1+λ2) is taken (after Pauly et al. 2002 and Mitra and
//! Nguyen 2003): noise favours larger neighbourhoods (its share of the variance falls with the
//! radius), curvature and a nearby second sheet (a thin part) smaller ones, and counting
//! neighbours rather than a fixed radius follows changes of density. The normals come out
//! unoriented; `orient_normals` or `orient_toward` give them a side.

use glam::DVec3;
use psi_octree::{Monitor, MortonIndex};

use crate::local_fit::Moments;

/// The neighbourhood sizes tried, ascending.
const SIZES: [usize; 5] = [12, 16, 24, 32, 48];

/// Unit normals of `positions` (shape: N, world units) from plane fits over adaptive
/// neighbourhoods (shape of the result: N; each sign arbitrary). A point whose neighbourhood
/// is degenerate (all neighbours on a line, or fewer than 3 points in all) gets the zero vector.
/// Deterministic and independent of the thread count.
///
/// ```
/// use glam::DVec3;
/// use psi_preprocess::estimate_normals;
///
/// // A grid in the plane z = x: normals ±(−1, 0, 1)/√2.
/// let grid: Vec<DVec3> = (0..400)
///     .map(|i| DVec3::new((i % 20) as f64, (i / 20) as f64, (i % 20) as f64))
///     .collect();
/// for n in estimate_normals(&grid) {
///     assert!((n.dot(DVec3::new(-1.0, 0.0, 1.0)).abs() - 2f64.sqrt()).abs() < 1e-9);
/// }
/// ```
pub fn estimate_normals(positions: &[DVec3]) -> Vec<DVec3> {
    estimate_normals_with(positions, &Monitor::silent())
}

/// [`estimate_normals`], stopping early once `monitor`'s flag is set (checked per cell of a
/// few dozen points, before their searches; the caller then discards the result).
pub fn estimate_normals_with(positions: &[DVec3], monitor: &Monitor<'_>) -> Vec<DVec3> {
    // The points in Morton order (slots), each with its nearest others in one sweep.
    estimate_normals_in(positions.len(), &MortonIndex::new(positions), monitor)
}

/// [`estimate_normals_with`] of the `n` points that `index` indexes (ids 0..n; a point left
/// out of it gets no normal).
pub(crate) fn estimate_normals_in(
    n: usize,
    index: &MortonIndex,
    monitor: &Monitor<'_>,
) -> Vec<DVec3> {
    let by_slot = index.points();
    let largest = SIZES[SIZES.len() - 1];
    let Ok(normals) = index.map_nearest_with(largest - 1, monitor, |s, near| {
        let p = by_slot[s];
        let mut moments = Moments::around(p);
        // The neighbourhoods by variation (eigenvalues only), then the plane of the least
        // varied one that has a plane (the closed form and the decomposition can disagree
        // at the flatness limit).
        // (A fixed array: no allocation per point.)
        let mut tried = [(f64::INFINITY, Moments::default()); SIZES.len()];
        let mut count = 0;
        let mut sizes = SIZES.iter().peekable();
        // The point itself, then its neighbours nearest first.
        let points = std::iter::once(p).chain(near.iter().map(|&(t, _)| by_slot[t as usize]));
        for q in points {
            moments.add(q);
            if sizes.peek() == Some(&&moments.count()) {
                sizes.next();
                if let Some(v) = moments.variation() {
                    tried[count] = (v, moments);
                    count += 1;
                }
            }
        }
        // Stable: equal variations keep the smaller neighbourhood first.
        let tried = &mut tried[..count];
        tried.sort_by(|a, b| a.0.total_cmp(&b.0));
        // None of the sizes (fewer points than the smallest): the plane of all of them.
        tried
            .iter()
            .find_map(|(_, m)| m.plane())
            .or_else(|| moments.plane())
            .map_or(DVec3::ZERO, |fit| fit.normal)
    }) else {
        return vec![DVec3::ZERO; n];
    };
    // Back to the caller's order (a point with a non-finite coordinate has no normal).
    let mut out = vec![DVec3::ZERO; n];
    for (&i, n) in index.ids().iter().zip(normals) {
        out[i as usize] = n;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use psi_shapes::AnalyticShape;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64Mcg;

    /// A sphere's estimated normals against the analytic ones, clean and with noise of a
    /// third of the sample spacing along the normal.
    #[test]
    fn sphere_normals_match_the_analytic_ones() {
        let sphere = AnalyticShape::Sphere { radius: 1.0 };
        let points = sphere.sample(20_000, 3);
        let spacing = (4.0 * std::f64::consts::PI / 20_000.0).sqrt();
        let mut rng = Pcg64Mcg::seed_from_u64(9);
        for noise in [0.0, spacing / 3.0] {
            let positions: Vec<DVec3> = points
                .iter()
                .map(|p| p.p + noise * (rng.random::<f64>() * 2.0 - 1.0) * p.n)
                .collect();
            let normals = estimate_normals(&positions);
            let mut worst = 0.0f64;
            let mut mean = 0.0;
            for (n, p) in normals.iter().zip(&points) {
                let angle = n.dot(p.n).abs().min(1.0).acos().to_degrees();
                worst = worst.max(angle);
                mean += angle / points.len() as f64;
            }
            let (mean_limit, worst_limit) = if noise == 0.0 {
                (1.0, 6.0)
            } else {
                (3.0, 15.0)
            };
            assert!(
                mean < mean_limit && worst < worst_limit,
                "noise {noise}: mean {mean:.2}°, worst {worst:.2}°"
            );
        }
    }

    /// Two parallel sheets closer than the largest neighbourhood: the adaptive choice keeps
    /// each point's normal across the sheets (a fixed 48-neighbourhood would mix them).
    #[test]
    fn thin_slabs_keep_their_normals() {
        let slab = AnalyticShape::Box {
            half: DVec3::new(0.5, 0.5, 0.02),
        }
        .sample(20_000, 4);
        let positions: Vec<DVec3> = slab.iter().map(|p| p.p).collect();
        let normals = estimate_normals(&positions);
        let faces: Vec<usize> = (0..slab.len())
            .filter(|&i| {
                slab[i].n.z.abs() > 0.99 && slab[i].p.x.abs() < 0.45 && slab[i].p.y.abs() < 0.45
            })
            .collect();
        let bad = faces.iter().filter(|&&i| normals[i].z.abs() < 0.95).count();
        assert!(bad * 200 < faces.len(), "{bad} of {} tilted", faces.len());
    }

    #[test]
    fn tiny_and_degenerate_inputs_do_not_panic() {
        assert!(estimate_normals(&[]).is_empty());
        assert_eq!(estimate_normals(&[DVec3::ZERO; 2]), vec![DVec3::ZERO; 2]);
        // Coincident points and a (slightly noisy) line have no plane: zero normals, not an
        // arbitrary direction.
        assert_eq!(estimate_normals(&[DVec3::ONE; 5]), vec![DVec3::ZERO; 5]);
        let line: Vec<DVec3> = (0..20)
            .map(|i| DVec3::new(i as f64, 1e-4 * (i % 3) as f64, 0.0))
            .collect();
        assert_eq!(estimate_normals(&line), vec![DVec3::ZERO; 20]);
        // A plane sampled along rows far apart still gets its normal once the neighbourhood
        // reaches across rows.
        let rows: Vec<DVec3> = (0..400)
            .map(|i| DVec3::new(0.01 * (i % 100) as f64, (i / 100) as f64 * 0.2, 0.0))
            .collect();
        for n in estimate_normals(&rows) {
            assert!(n.z.abs() > 0.999_999, "{n}");
        }
    }
}
