//! Colour maps: octree depth from green (shallow) to deep red (deep), as in the paper's
//! Fig. 5; a sequential map for σ; normals as RGB.

use glam::DVec3;

/// Colour of a value that is NaN (no colour can be derived).
pub const MISSING: [u8; 3] = [128, 128, 128];

/// A colour ramp over t ∈ [0, 1], piecewise linear in sRGB between fixed stops.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Ramp {
    /// Green → yellow → orange → deep red: octree depth, shallow to deep (paper Fig. 5).
    #[default]
    Depth,
    /// Dark violet → blue → teal → green → yellow, increasing lightness: any magnitude (σ).
    Sequential,
}

const DEPTH_STOPS: [(f64, [u8; 3]); 4] = [
    (0.0, [26, 150, 65]),
    (0.33, [238, 200, 40]),
    (0.66, [240, 115, 35]),
    (1.0, [170, 20, 30]),
];

const SEQUENTIAL_STOPS: [(f64, [u8; 3]); 5] = [
    (0.0, [68, 1, 84]),
    (0.25, [59, 82, 139]),
    (0.5, [33, 145, 140]),
    (0.75, [94, 201, 98]),
    (1.0, [253, 231, 37]),
];

impl Ramp {
    /// The colour at `t` (clamped to [0, 1]); [`MISSING`] grey for NaN.
    ///
    /// ```
    /// use psi_render::Ramp;
    /// let (shallow, deep) = (Ramp::Depth.color(0.0), Ramp::Depth.color(1.0));
    /// assert!(shallow[1] > shallow[0] && deep[0] > deep[1]); // green, then red
    /// ```
    pub fn color(self, t: f64) -> [u8; 3] {
        if t.is_nan() {
            return MISSING;
        }
        let stops: &[(f64, [u8; 3])] = match self {
            Ramp::Depth => &DEPTH_STOPS,
            Ramp::Sequential => &SEQUENTIAL_STOPS,
        };
        let t = t.clamp(0.0, 1.0);
        let k = stops.iter().rposition(|s| s.0 <= t).unwrap_or(0);
        if k + 1 == stops.len() {
            return stops[k].1;
        }
        let ((t0, a), (t1, b)) = (stops[k], stops[k + 1]);
        let w = (t - t0) / (t1 - t0);
        let mix =
            |i: usize| (f64::from(a[i]) + w * (f64::from(b[i]) - f64::from(a[i]))).round() as u8;
        [mix(0), mix(1), mix(2)]
    }
}

/// The smallest and largest finite value, `None` when there is none.
pub(crate) fn finite_range(values: &[f64]) -> Option<(f64, f64)> {
    values
        .iter()
        .filter(|v| v.is_finite())
        .fold(None, |r, &v| match r {
            None => Some((v, v)),
            Some((lo, hi)) => Some((lo.min(v), hi.max(v))),
        })
}

/// Where `v` lies in `[min, max]` as t ∈ [0, 1]; 0.5 when the range is empty (all equal);
/// NaN for a non-finite `v`.
pub(crate) fn unit(v: f64, min: f64, max: f64) -> f64 {
    if !v.is_finite() {
        f64::NAN
    } else if max > min {
        ((v - min) / (max - min)).clamp(0.0, 1.0)
    } else {
        0.5
    }
}

/// Colours for `values` (shape: N) on `ramp`, `min` ↦ t = 0 and `max` ↦ t = 1 (values
/// outside are clamped; all the middle colour when `min == max`; NaN or infinite values are
/// [`MISSING`] grey).
pub fn scalar_colors(values: &[f64], ramp: Ramp, min: f64, max: f64) -> Vec<[u8; 3]> {
    values
        .iter()
        .map(|&v| ramp.color(unit(v, min, max)))
        .collect()
}

/// Colours for octree depths (shape: N, any units, usually whole numbers): the smallest
/// finite depth green, the largest deep red ([`Ramp::Depth`]), as in the paper's Fig. 5.
/// [`crate::Legend::depth`] of the same slice labels them.
///
/// ```
/// let c = psi_render::depth_colors(&[5.0, 9.0, 7.0]);
/// assert_eq!(c[0], psi_render::Ramp::Depth.color(0.0));
/// assert_eq!(c[1], psi_render::Ramp::Depth.color(1.0));
/// assert_eq!(c[2], psi_render::Ramp::Depth.color(0.5));
/// ```
pub fn depth_colors(depth: &[f64]) -> Vec<[u8; 3]> {
    let (min, max) = finite_range(depth).unwrap_or((0.0, 0.0));
    scalar_colors(depth, Ramp::Depth, min, max)
}

/// Colours for repulsion radii σ (shape: N, world units): smallest dark violet, largest
/// yellow ([`Ramp::Sequential`]). [`crate::Legend::sigma`] of the same slice labels them.
pub fn sigma_colors(sigma: &[f64]) -> Vec<[u8; 3]> {
    let (min, max) = finite_range(sigma).unwrap_or((0.0, 0.0));
    scalar_colors(sigma, Ramp::Sequential, min, max)
}

/// Colours for normals (shape: N, any length): the unit normal's components mapped from
/// [−1, 1] to [0, 255] as red, green, blue; zero or non-finite normals are [`MISSING`].
///
/// ```
/// use glam::DVec3;
/// assert_eq!(psi_render::normal_colors(&[DVec3::X * 3.0])[0], [255, 128, 128]);
/// ```
pub fn normal_colors(normals: &[DVec3]) -> Vec<[u8; 3]> {
    normals
        .iter()
        .map(|n| match n.try_normalize() {
            Some(u) => {
                let c = |v: f64| (127.5 * (v + 1.0)).round().clamp(0.0, 255.0) as u8;
                [c(u.x), c(u.y), c(u.z)]
            }
            None => MISSING,
        })
        .collect()
}
