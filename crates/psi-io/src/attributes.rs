//! Per-point attributes a scan carries beside positions: colour, intensity, classification,
//! in the shared [`PointAttributes`] columns of `psi-octree`, and how each reader fills them.
//!
//! Conventions, the same for every reader:
//!
//! * **Colour** is 8 bits per channel, `[red, green, blue]`. LAS stores 16 bits per channel,
//!   "normalized to 16 bit values" (ASPRS LAS 1.4 R15, point data record format 2: an 8-bit
//!   value is multiplied by 256), so psi keeps the high byte, `v >> 8`; PLY `ushort` colours
//!   likewise. E57 colours are scaled from the scan's `colorLimits` to 0–255 and rounded; PLY
//!   `float`/`double` colours from 0–1. PCD's packed `rgb`/`rgba` are 8-bit already.
//! * **Intensity** is the file's own value as `f32`, not rescaled (LAS: 0–65535; E57: within
//!   its `intensityLimits`; PCD and PLY: as written). A point whose intensity the file leaves
//!   undefined (a non-finite value, an E57 point flagged invalid or a scan without intensity
//!   in a file where another has it) gets 0, as `PointAttributes::extend` fills a missing
//!   column; likewise a missing colour is black.
//! * **Classification** is the LAS class code (ASPRS LAS 1.4 R15 Table 17; the low 5 bits in
//!   point formats 0–5, the whole byte in 6–10).
//!
//! A column is present (`Some`) when the file declares it, and then has exactly one entry per
//! point, in the points' order.

pub use psi_octree::PointAttributes;

/// Which attribute columns a file (or a [`PointAttributes`]) has.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct AttributeKinds {
    /// Colour (`red green blue`).
    pub colors: bool,
    /// Intensity.
    pub intensity: bool,
    /// LAS classification.
    pub classification: bool,
}

impl AttributeKinds {
    /// The names of the present columns, in a fixed order: `colors`, `intensity`,
    /// `classification`.
    ///
    /// ```
    /// let kinds = psi_io::AttributeKinds { colors: true, classification: true, ..Default::default() };
    /// assert_eq!(kinds.names(), vec!["colors", "classification"]);
    /// ```
    pub fn names(&self) -> Vec<&'static str> {
        [
            ("colors", self.colors),
            ("intensity", self.intensity),
            ("classification", self.classification),
        ]
        .into_iter()
        .filter_map(|(name, present)| present.then_some(name))
        .collect()
    }
}

/// Empty columns for the attributes named in `kinds` (no column for the others).
pub(crate) fn with_kinds(kinds: AttributeKinds, capacity: usize) -> PointAttributes {
    PointAttributes {
        colors: kinds.colors.then(|| Vec::with_capacity(capacity)),
        intensity: kinds.intensity.then(|| Vec::with_capacity(capacity)),
        classification: kinds.classification.then(|| Vec::with_capacity(capacity)),
    }
}

impl AttributeKinds {
    /// The columns `attributes` has.
    ///
    /// ```
    /// let a = psi_io::PointAttributes { intensity: Some(vec![1.0]), ..Default::default() };
    /// assert_eq!(psi_io::AttributeKinds::of(&a).names(), vec!["intensity"]);
    /// ```
    pub fn of(attributes: &PointAttributes) -> Self {
        AttributeKinds {
            colors: attributes.colors.is_some(),
            intensity: attributes.intensity.is_some(),
            classification: attributes.classification.is_some(),
        }
    }
}

/// Appends `other`'s entries to the columns both have (the caller keeps the same kinds).
pub(crate) fn append(to: &mut PointAttributes, other: PointAttributes) {
    fn join<T>(to: &mut Option<Vec<T>>, from: Option<Vec<T>>) {
        if let (Some(to), Some(mut from)) = (to.as_mut(), from) {
            if to.is_empty() {
                std::mem::swap(to, &mut from);
            } else {
                to.append(&mut from);
            }
        }
    }
    join(&mut to.colors, other.colors);
    join(&mut to.intensity, other.intensity);
    join(&mut to.classification, other.classification);
}

/// The entries at `indices`, in that order.
pub(crate) fn select(from: &PointAttributes, indices: &[usize]) -> PointAttributes {
    fn pick<T: Copy>(column: &Option<Vec<T>>, indices: &[usize]) -> Option<Vec<T>> {
        column
            .as_ref()
            .map(|c| indices.iter().map(|&i| c[i]).collect())
    }
    PointAttributes {
        colors: pick(&from.colors, indices),
        intensity: pick(&from.intensity, indices),
        classification: pick(&from.classification, indices),
    }
}

/// One entry per triangle of `faces` (indices into the per-vertex columns of `from`): colour
/// and intensity the mean of the three vertices' (colour rounded), classification the first
/// vertex's.
pub(crate) fn per_face(from: &PointAttributes, faces: &[[u32; 3]]) -> PointAttributes {
    let colors = from.colors.as_ref().map(|c| {
        faces
            .iter()
            .map(|f| {
                let mut rgb = [0u8; 3];
                for (k, channel) in rgb.iter_mut().enumerate() {
                    let sum: u32 = f.iter().map(|&i| u32::from(c[i as usize][k])).sum();
                    // Rounded mean of three values in 0..=255 stays in 0..=255.
                    *channel = ((sum + 1) / 3) as u8;
                }
                rgb
            })
            .collect()
    });
    let intensity = from.intensity.as_ref().map(|v| {
        faces
            .iter()
            .map(|f| f.iter().map(|&i| v[i as usize]).sum::<f32>() / 3.0)
            .collect()
    });
    let classification = from
        .classification
        .as_ref()
        .map(|v| faces.iter().map(|f| v[f[0] as usize]).collect());
    PointAttributes {
        colors,
        intensity,
        classification,
    }
}

/// A 16-bit colour channel as 8 bits: the high byte (LAS 1.4 R15 stores 8-bit colour × 256).
pub(crate) fn channel_from_u16(v: u16) -> u8 {
    (v >> 8) as u8
}

/// A colour channel in 0–1 as 8 bits, rounded; out-of-range values are clamped, NaN is 0.
pub(crate) fn channel_from_unit(v: f64) -> u8 {
    if v.is_nan() {
        return 0;
    }
    (v.clamp(0.0, 1.0) * 255.0).round() as u8
}

/// An intensity value as stored: the value, or 0 when it is not finite (or beyond f32).
pub(crate) fn intensity_value(v: f64) -> f32 {
    let v = v as f32;
    if v.is_finite() { v } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn channels_convert_as_documented() {
        assert_eq!(channel_from_u16(255 * 256), 255);
        assert_eq!(channel_from_u16(65535), 255);
        assert_eq!(channel_from_u16(200 * 257), 200);
        assert_eq!(channel_from_unit(1.0), 255);
        assert_eq!(channel_from_unit(0.5), 128);
        assert_eq!(channel_from_unit(-3.0), 0);
        assert_eq!(channel_from_unit(f64::NAN), 0);
        assert_eq!(intensity_value(f64::INFINITY), 0.0);
        assert_eq!(intensity_value(1e300), 0.0);
    }

    #[test]
    fn per_face_means_round() {
        let a = PointAttributes {
            colors: Some(vec![[0, 0, 255], [1, 0, 255], [1, 3, 254]]),
            intensity: Some(vec![1.0, 2.0, 6.0]),
            classification: Some(vec![2, 5, 6]),
        };
        let f = per_face(&a, &[[0, 1, 2]]);
        assert_eq!(f.colors, Some(vec![[1, 1, 255]]));
        assert_eq!(f.intensity, Some(vec![3.0]));
        assert_eq!(f.classification, Some(vec![2]));
    }
}
