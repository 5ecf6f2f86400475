//! What a scan carries besides positions and normals: colour, return intensity and a LiDAR
//! classification per point, each column present or not, aligned index by index with the
//! points it describes.

use serde::{Deserialize, Serialize};

/// Per-point attributes (shape: each present column N, aligned with the points). A column is
/// `None` when the input has no such attribute; an empty set has every column `None`.
///
/// ```
/// use psi_octree::PointAttributes;
/// let a = PointAttributes {
///     colors: Some(vec![[255, 0, 0], [0, 0, 255], [0, 255, 0]]),
///     intensity: None,
///     classification: Some(vec![2, 6, 2]),
/// };
/// let b = a.select(&[2, 0]);
/// assert_eq!(b.colors, Some(vec![[0, 255, 0], [255, 0, 0]]));
/// assert_eq!(b.classification, Some(vec![2, 2]));
/// assert_eq!(b.len(), Some(2));
/// assert!(PointAttributes::default().is_empty());
/// ```
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PointAttributes {
    /// Colour, 8 bits per channel (red, green, blue).
    pub colors: Option<Vec<[u8; 3]>>,
    /// Return intensity, in the input's units (LAS: 0–65535 as read).
    pub intensity: Option<Vec<f32>>,
    /// LAS classification code (ASPRS LAS 1.4 R15, table 17: 2 ground, 6 building, ...).
    pub classification: Option<Vec<u8>>,
}

impl PointAttributes {
    /// Whether no column is present.
    pub fn is_empty(&self) -> bool {
        self.colors.is_none() && self.intensity.is_none() && self.classification.is_none()
    }

    /// The length of the present columns (`None` when none is present). Columns of different
    /// lengths are a caller's bug; the first present one's length is returned.
    pub fn len(&self) -> Option<usize> {
        self.colors
            .as_ref()
            .map(Vec::len)
            .or(self.intensity.as_ref().map(Vec::len))
            .or(self.classification.as_ref().map(Vec::len))
    }

    /// Whether every present column has `n` entries.
    pub fn fits(&self, n: usize) -> bool {
        self.colors.as_ref().is_none_or(|c| c.len() == n)
            && self.intensity.as_ref().is_none_or(|c| c.len() == n)
            && self.classification.as_ref().is_none_or(|c| c.len() == n)
    }

    /// The rows `indices` (each `< len`), in that order: what points that were reordered, left
    /// out or repeated carry along.
    pub fn select(&self, indices: &[u32]) -> PointAttributes {
        fn pick<T: Copy>(column: &Option<Vec<T>>, indices: &[u32]) -> Option<Vec<T>> {
            column
                .as_ref()
                .map(|c| indices.iter().map(|&i| c[i as usize]).collect())
        }
        PointAttributes {
            colors: pick(&self.colors, indices),
            intensity: pick(&self.intensity, indices),
            classification: pick(&self.classification, indices),
        }
    }

    /// Appends `other`'s rows (`n` of them): a column present on one side only gets defaults
    /// for the other side's rows (black, zero intensity, class 0 "never classified") so that
    /// the columns stay aligned. `self` has `len` rows.
    pub fn extend(&mut self, len: usize, other: &PointAttributes, n: usize) {
        fn join<T: Copy>(a: &mut Option<Vec<T>>, len: usize, b: &Option<Vec<T>>, n: usize, d: T) {
            match (a.as_mut(), b) {
                (Some(a), Some(b)) => a.extend_from_slice(b),
                (Some(a), None) => a.extend(std::iter::repeat_n(d, n)),
                (None, Some(b)) => {
                    let mut v = vec![d; len];
                    v.extend_from_slice(b);
                    *a = Some(v);
                }
                (None, None) => {}
            }
        }
        join(&mut self.colors, len, &other.colors, n, [0; 3]);
        join(&mut self.intensity, len, &other.intensity, n, 0.0);
        join(&mut self.classification, len, &other.classification, n, 0);
    }
}
