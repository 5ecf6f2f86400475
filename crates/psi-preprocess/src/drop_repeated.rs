//! Repeated points left out: every point whose position equals an earlier point's, coordinate
//! by coordinate (merged or re-exported scans repeat points). A repeat adds nothing to a
//! surface, and 16 or more copies of one position put all of its nearest neighbours at
//! distance 0, which the outlier search would read as no surface around it.

use psi_octree::{MortonIndex, OrientedPoint};

use crate::drop_strays::retain_kept;

/// Leaves out of `points` (shape: N) and `source` (shape: N, their input indices) every point
/// whose position repeats that of a point with a smaller index (the first copy stays, with its
/// normal), given `index`, the Morton index of their positions. Returns how many were left out
/// and the index of the points kept (no second sort: [`MortonIndex::retained`]).
pub(crate) fn drop_repeated(
    points: &mut Vec<OrientedPoint>,
    source: &mut Vec<u32>,
    index: MortonIndex,
) -> (usize, MortonIndex) {
    let copies = index.repeated_positions();
    if copies.is_empty() {
        return (0, index);
    }
    let mut keep = vec![true; points.len()];
    for &c in &copies {
        keep[c as usize] = false;
    }
    retain_kept(points, source, &keep);
    (copies.len(), index.retained(&keep))
}
