//! Fits to a small neighbourhood of points: the least-squares plane (principal component
//! analysis) and a quadratic height field over it, with their residuals.

use glam::DVec3;
use nalgebra::{Matrix3, SMatrix, SVector};

use crate::symmetric_eigen3::Eigen3;

/// A set is flat enough to have a plane when its middle covariance eigenvalue exceeds this
/// share of the total variance: a spread across the main direction of at least about 3 % of
/// the spread along it. Coincident points, a scan line, or any neighbourhood thinner than that
/// has no plane (its least-variance direction is arbitrary in the plane across the line).
const FLAT_SPREAD: f64 = 1e-3;

/// A point is left out of a trimmed quadric fit when it lies more than this many robust
/// standard deviations off the fit ([`QuadricFit::of_trimmed`]).
const TRIM_MADS: f64 = 3.0;

/// The least-squares plane of a point set: its centroid, unit normal (the direction of least
/// variance; sign arbitrary) and the covariance's eigenvalues, ascending (world units²: the
/// mean squared distance to the plane is `eigenvalues[0]`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct PlaneFit {
    pub(crate) centroid: DVec3,
    pub(crate) normal: DVec3,
    pub(crate) eigenvalues: [f64; 3],
}

impl PlaneFit {
    /// Surface variation λ0 / (λ0 + λ1 + λ2) (Pauly et al. 2002): 0 on a plane, 1/3 for an
    /// isotropic cloud (the closed-form twin [`Moments::variation`] is checked against it).
    #[cfg(test)]
    pub(crate) fn variation(&self) -> f64 {
        let sum: f64 = self.eigenvalues.iter().sum();
        if sum > 0.0 {
            self.eigenvalues[0] / sum
        } else {
            0.0
        }
    }
}

/// Running sums of a point set, for plane fits of growing prefixes of a neighbour list.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Moments {
    count: usize,
    /// The points are summed relative to this origin (the query point), for precision.
    origin: DVec3,
    sum: DVec3,
    /// Σ y yᵀ, upper triangle: xx, xy, xz, yy, yz, zz.
    outer: [f64; 6],
}

impl Moments {
    /// Empty sums relative to `origin`.
    pub(crate) fn around(origin: DVec3) -> Self {
        Self {
            origin,
            ..Self::default()
        }
    }

    /// Adds a point.
    pub(crate) fn add(&mut self, p: DVec3) {
        let y = p - self.origin;
        self.count += 1;
        self.sum += y;
        self.outer[0] += y.x * y.x;
        self.outer[1] += y.x * y.y;
        self.outer[2] += y.x * y.z;
        self.outer[3] += y.y * y.y;
        self.outer[4] += y.y * y.z;
        self.outer[5] += y.z * y.z;
    }

    /// Adds the points `other` added (summed around the same origin).
    pub(crate) fn merge(&mut self, other: &Moments) {
        debug_assert_eq!(self.origin, other.origin);
        self.count += other.count;
        self.sum += other.sum;
        for (a, b) in self.outer.iter_mut().zip(other.outer) {
            *a += b;
        }
    }

    /// The covariance of the points added (at least one).
    pub(crate) fn covariance(&self) -> Matrix3<f64> {
        let n = self.count as f64;
        let m = self.sum / n;
        let [xx, xy, xz, yy, yz, zz] = self.outer.map(|v| v / n);
        Matrix3::new(
            xx - m.x * m.x,
            xy - m.x * m.y,
            xz - m.x * m.z,
            xy - m.x * m.y,
            yy - m.y * m.y,
            yz - m.y * m.z,
            xz - m.x * m.z,
            yz - m.y * m.z,
            zz - m.z * m.z,
        )
    }

    /// The surface variation λ0/(λ0+λ1+λ2) of the points added, from the covariance's
    /// eigenvalues in closed form ([`Eigen3`]), without eigenvectors: what choosing among
    /// neighbourhoods needs. `None` where [`Moments::plane`] has no plane (fewer than 3 points,
    /// no spread in two directions, non-finite).
    pub(crate) fn variation(&self) -> Option<f64> {
        if self.count < 3 {
            return None;
        }
        let e = Eigen3::of(&self.covariance())?.shape();
        let total: f64 = e.iter().sum();
        let spread = e[1] > FLAT_SPREAD * total;
        (spread && e.iter().all(|v| v.is_finite())).then(|| e[0] / total)
    }

    /// Number of points added.
    pub(crate) fn count(&self) -> usize {
        self.count
    }

    /// The plane of the points added so far; `None` for fewer than 3 points, a set without
    /// spread in two directions (coincident or on a line: the middle eigenvalue at most
    /// [`FLAT_SPREAD`] of the total variance) or a non-finite fit.
    pub(crate) fn plane(&self) -> Option<PlaneFit> {
        if self.count < 3 {
            return None;
        }
        let (eigenvalues, normal) = Eigen3::of(&self.covariance())?.decomposed();
        let spread = eigenvalues[1] > FLAT_SPREAD * eigenvalues.iter().sum::<f64>();
        let finite = eigenvalues.iter().all(|e| e.is_finite());
        // (The normal is a unit vector: `Eigen3` has refused a non-finite matrix.)
        (spread && finite).then_some(PlaneFit {
            centroid: self.origin + self.sum / self.count as f64,
            normal,
            eigenvalues,
        })
    }
}

/// The least-squares plane of `points`; `None` for fewer than 3 points or a set without spread
/// in two directions (see [`Moments::plane`]).
pub(crate) fn fit_plane(points: impl IntoIterator<Item = DVec3>) -> Option<PlaneFit> {
    let mut points = points.into_iter().peekable();
    let mut m = Moments::around(*points.peek()?);
    for p in points {
        m.add(p);
    }
    m.plane()
}

/// A least-squares quadratic height field h(u, v) = a + b·u + c·v + d·u² + e·uv + f·v² over a
/// plane: heights along the plane's normal, u and v along two directions in it, lengths in
/// units of `scale` for conditioning.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct QuadricFit {
    plane: PlaneFit,
    tangent: DVec3,
    bitangent: DVec3,
    scale: f64,
    coef: [f64; 6],
    /// Residual sum of squares over the fitted points, world units².
    pub(crate) rss: f64,
    /// Points fitted.
    pub(crate) count: usize,
}

impl QuadricFit {
    /// The quadric height field of `points` over their least-squares plane, with lengths in
    /// units of `scale` (world units; about the neighbourhood's radius). `None` for fewer than
    /// 7 points, a degenerate plane or a singular system.
    pub(crate) fn of(points: &[DVec3], scale: f64) -> Option<Self> {
        let mut fit = Self::solved(points, scale)?;
        // The residual summed directly (the normal equations' identity loses digits).
        fit.rss = points.iter().map(|p| fit.height(*p).powi(2)).sum();
        fit.finite()
    }

    /// The fit of [`QuadricFit::of`] before its residual: `None` where `of` gives none for
    /// want of points, plane or a solvable system.
    fn solved(points: &[DVec3], scale: f64) -> Option<Self> {
        if points.len() < 7 || scale.is_nan() || scale <= 0.0 {
            return None;
        }
        let plane = fit_plane(points.iter().copied())?;
        let tangent = plane.normal.any_orthonormal_vector();
        let mut fit = QuadricFit {
            plane,
            tangent,
            bitangent: plane.normal.cross(tangent),
            scale,
            coef: [0.0; 6],
            rss: 0.0,
            count: points.len(),
        };
        // The normal equations of the height field: the upper triangle summed, the lower one
        // mirrored (a product is the same either way round, so the matrix is the full loop's
        // to the bit).
        // (Summed in plain arrays, each entry over the points in their order: the loops unroll.)
        let mut upper = [0.0f64; 21];
        let mut rhs = [0.0f64; 6];
        for p in points {
            let (row, h) = fit.row(*p);
            let mut k = 0;
            for i in 0..6 {
                rhs[i] += row[i] * h;
                for j in i..6 {
                    upper[k] += row[i] * row[j];
                    k += 1;
                }
            }
        }
        let mut ata = SMatrix::<f64, 6, 6>::zeros();
        let mut k = 0;
        for i in 0..6 {
            for j in i..6 {
                (ata[(i, j)], ata[(j, i)]) = (upper[k], upper[k]);
                k += 1;
            }
        }
        let atb = SVector::<f64, 6>::from(rhs);
        let coef = ata.cholesky()?.solve(&atb);
        fit.coef = [coef[0], coef[1], coef[2], coef[3], coef[4], coef[5]];
        Some(fit)
    }

    /// This fit when its residual and coefficients are finite.
    fn finite(self) -> Option<Self> {
        (self.rss.is_finite() && self.coef.iter().all(|c| c.is_finite())).then_some(self)
    }

    /// [`QuadricFit::of`] made robust to one stray point among `points`: when the point
    /// farthest from the fit lies more than `floor` (world units) and more than
    /// [`TRIM_MADS`] robust standard deviations (1.4826 × the median absolute height of the
    /// points) off it, it is left out and the others are fitted again. (A least-squares fit
    /// bends towards a stray neighbour, and a second stray point beside it then seems to lie on
    /// the surface.)
    pub(crate) fn of_trimmed(points: &[DVec3], scale: f64, floor: f64) -> Option<Self> {
        // [`QuadricFit::of`], each point's height computed once for the residual and the trim.
        let mut fit = Self::solved(points, scale)?;
        // (On the stack for a neighbourhood's few dozen points: no allocation per fit.)
        let (mut on_stack, mut on_heap) = ([0.0f64; 32], Vec::new());
        let heights: &mut [f64] = if points.len() <= on_stack.len() {
            &mut on_stack[..points.len()]
        } else {
            on_heap.resize(points.len(), 0.0);
            &mut on_heap
        };
        for (h, p) in heights.iter_mut().zip(points) {
            *h = fit.height(*p);
        }
        fit.rss = heights.iter().map(|h| h.powi(2)).sum();
        let fit = fit.finite()?;
        for h in heights.iter_mut() {
            *h = h.abs();
        }
        let (worst, largest) =
            heights
                .iter()
                .copied()
                .enumerate()
                .fold((0, f64::NEG_INFINITY), |best, (k, h)| {
                    if h > best.1 { (k, h) } else { best }
                });
        let mad = crate::median::median(heights);
        if largest <= floor.max(TRIM_MADS * 1.4826 * mad) {
            return Some(fit);
        }
        let rest: Vec<DVec3> = points
            .iter()
            .enumerate()
            .filter(|&(k, _)| k != worst)
            .map(|(_, p)| *p)
            .collect();
        Self::of(&rest, scale).or(Some(fit))
    }

    /// The monomials (1, u, v, u², uv, v²) of `p` and its height over the plane, in units of
    /// the scale.
    fn row(&self, p: DVec3) -> ([f64; 6], f64) {
        let d = (p - self.plane.centroid) / self.scale;
        let (u, v, h) = (
            d.dot(self.tangent),
            d.dot(self.bitangent),
            d.dot(self.plane.normal),
        );
        ([1.0, u, v, u * u, u * v, v * v], h)
    }

    /// The signed distance of `p` from the height field along the plane's normal, world units.
    pub(crate) fn height(&self, p: DVec3) -> f64 {
        let (row, h) = self.row(p);
        let fit: f64 = row.iter().zip(&self.coef).map(|(m, c)| m * c).sum();
        (h - fit) * self.scale
    }

    /// This fit corrected near `near` (points around a place, world units): the residuals of
    /// `near` are fitted by a plane over (u, v) and added to the fit's offset and slopes. The
    /// curvature comes from this fit (of more points), the offset and tilt there from `near`:
    /// its offset varies as σ²/|near| rather than a full quadric's several times that. Unchanged
    /// for fewer than 3 points or a singular system.
    pub(crate) fn refined(&self, near: &[DVec3]) -> QuadricFit {
        if near.len() < 3 {
            return *self;
        }
        let mut ata = nalgebra::Matrix3::<f64>::zeros();
        let mut atb = nalgebra::Vector3::<f64>::zeros();
        for q in near {
            let (row, _) = self.row(*q);
            let r = self.height(*q) / self.scale;
            let m = [1.0, row[1], row[2]];
            for i in 0..3 {
                atb[i] += m[i] * r;
                for j in 0..3 {
                    ata[(i, j)] += m[i] * m[j];
                }
            }
        }
        let Some(c) = ata.cholesky().map(|ch| ch.solve(&atb)) else {
            return *self;
        };
        if !c.iter().all(|v| v.is_finite()) {
            return *self;
        }
        let mut refined = *self;
        for i in 0..3 {
            refined.coef[i] += c[i];
        }
        refined
    }

    /// The plane's unit normal (the direction of heights).
    pub(crate) fn normal(&self) -> DVec3 {
        self.plane.normal
    }

    /// The height field's unit normal at `p`'s place over the plane, on the side of the plane's
    /// normal.
    pub(crate) fn normal_at(&self, p: DVec3) -> DVec3 {
        let (row, _) = self.row(p);
        let (u, v) = (row[1], row[2]);
        let c = &self.coef;
        let du = c[1] + 2.0 * c[3] * u + c[4] * v;
        let dv = c[2] + c[4] * u + 2.0 * c[5] * v;
        (self.plane.normal - du * self.tangent - dv * self.bitangent).normalize_or_zero()
    }

    /// The distance from `p`'s projection onto the plane to the fitted points' centroid, world
    /// units: how far `p` lies beside the patch rather than over it.
    pub(crate) fn tangential_offset(&self, p: DVec3) -> f64 {
        let d = p - self.plane.centroid;
        (d - self.plane.normal * d.dot(self.plane.normal)).length()
    }

    /// √(RSS/(k − 6)): the residual's standard deviation with the six coefficients' degrees of
    /// freedom removed (world units).
    pub(crate) fn sigma(&self) -> f64 {
        (self.rss / self.count.saturating_sub(6).max(1) as f64).sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use psi_shapes::assert_near;

    /// The closed-form variation and plane against nalgebra's iterative eigen-decomposition
    /// (the brute-force twin), on flat, curved, isotropic and degenerate sets.
    #[test]
    fn closed_form_variation_and_plane_equal_the_iterative_decompositions() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(7);
        let mut rnd = move || rng.random::<f64>() - 0.5;
        for (scale, count) in [
            (DVec3::new(1.0, 1.0, 1e-3), 48),
            (DVec3::new(1.0, 0.3, 0.1), 12),
            (DVec3::ONE, 30),
            (DVec3::new(1.0, 1e-9, 1e-9), 20),
            (DVec3::new(2.0, 1.0, 0.0), 3),
            (DVec3::new(1e-4, 2e-4, 1e-8), 16),
        ] {
            let mut m = Moments::around(DVec3::new(10.0, -4.0, 2.0));
            for _ in 0..count {
                m.add(DVec3::new(10.0, -4.0, 2.0) + scale * DVec3::new(rnd(), rnd(), rnd()));
            }
            let eig = m.covariance().symmetric_eigen();
            let mut order = [0usize, 1, 2];
            order.sort_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]));
            let e = order.map(|k| eig.eigenvalues[k].max(0.0));
            let total: f64 = e.iter().sum();
            let has_plane = e[1] > FLAT_SPREAD * total;
            match (m.variation(), m.plane()) {
                (Some(v), Some(fit)) if has_plane => {
                    assert_near!(v, e[0] / total, 1e-12);
                    for k in 0..3 {
                        assert_near!(fit.eigenvalues[k], e[k], 1e-12 * total);
                    }
                    let least = eig.eigenvectors.column(order[0]);
                    let n = DVec3::new(least[0], least[1], least[2]);
                    if e[1] - e[0] > 1e-3 * total {
                        assert_near!(fit.normal.dot(n).abs(), 1.0, 1e-10);
                    }
                }
                (None, None) => assert!(!has_plane, "{scale}"),
                other => panic!("{scale}: {other:?}"),
            }
        }
    }

    #[test]
    fn a_tilted_plane_is_found_exactly() {
        let n = DVec3::new(1.0, 2.0, 2.0) / 3.0;
        let t = n.any_orthonormal_vector();
        let b = n.cross(t);
        let pts: Vec<DVec3> = (0..50)
            .map(|i| {
                let (u, v) = ((i % 7) as f64 - 3.0, (i / 7) as f64 - 3.0);
                DVec3::new(5.0, -1.0, 2.0) + u * t + v * b
            })
            .collect();
        let fit = fit_plane(pts.iter().copied()).unwrap();
        assert_near!(fit.normal.dot(n).abs(), 1.0, 1e-12);
        assert_near!(fit.eigenvalues[0], 0.0, 1e-12);
        assert_near!(fit.variation(), 0.0, 1e-12);
        // A gentle paraboloid is nearly a quadratic height field over its least-squares plane
        // (tilted slightly from its own tangent plane, so not exactly: a small residual).
        let bowl: Vec<DVec3> = pts
            .iter()
            .map(|p| {
                let (u, v) = ((*p - pts[24]).dot(t), (*p - pts[24]).dot(b));
                *p + 0.01 * (u * u - 0.5 * u * v) * n
            })
            .collect();
        let fit = QuadricFit::of(&bowl, 3.0).unwrap();
        assert!(fit.sigma() < 1e-4, "{}", fit.sigma());
        // A point off the bowl is at its height.
        let off = bowl[20] + 0.5 * n;
        assert_near!(fit.height(off).abs(), 0.5, 1e-3);
    }
}
