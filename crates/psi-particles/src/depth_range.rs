//! The depth range [d_min, d_max] of paper eq. 1 ([`crate::DensityField`]), robust to stray
//! leaves: the run of consecutive depths around the most common surface-leaf depth, stopping
//! at the first depth on either side that holds no surface leaf.
//!
//! Paper eq. 1 maps the range of leaf depths onto the range of target radii, so the range
//! decides σ̂ for every particle. A clean surface's leaf depths form one run (every shared
//! model's do, `docs/results/2026-11-27-outlier-sweep/`), and its extreme depths may hold only
//! a few leaves, which must count. A stray leaf several depths below the rest (a few stray
//! points beside the surface split a cell down to the maximum depth) lies past empty depths
//! and is left out. Leaves outside the range get the nearest end's σ̂ (the density clamps
//! their depth).

/// The range `(d_min, d_max)` of `depths` (one per surface leaf): from the most common depth
/// (the shallower on a tie), outward while each next depth holds a leaf. `(0, 0)` when
/// `depths` is empty.
pub fn depth_range(depths: impl IntoIterator<Item = u8>) -> (u8, u8) {
    let mut count = [0usize; 256];
    for d in depths {
        count[usize::from(d)] += 1;
    }
    let Some(mode) = (0..256).max_by_key(|&d| (count[d], std::cmp::Reverse(d))) else {
        return (0, 0);
    };
    if count[mode] == 0 {
        return (0, 0);
    }
    let mut lo = mode;
    while lo > 0 && count[lo - 1] > 0 {
        lo -= 1;
    }
    let mut hi = mode;
    while hi < 255 && count[hi + 1] > 0 {
        hi += 1;
    }
    (lo as u8, hi as u8)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Depths from counts per depth, starting at depth 0.
    fn leaves(counts: &[usize]) -> Vec<u8> {
        counts
            .iter()
            .enumerate()
            .flat_map(|(d, &n)| std::iter::repeat_n(d as u8, n))
            .collect()
    }

    /// The plain range of the depths present.
    fn min_max(depths: &[u8]) -> (u8, u8) {
        (
            depths.iter().copied().min().unwrap_or(0),
            depths.iter().copied().max().unwrap_or(0),
        )
    }

    #[test]
    fn a_contiguous_range_is_the_plain_one() {
        // The shared models' surface leaves (docs/results/2026-11-27-outlier-sweep/), whose
        // extreme depths hold as few as 2 leaves.
        for counts in [
            vec![0, 0, 0, 0, 0, 747, 5701, 1633, 4],
            vec![0, 0, 0, 0, 2, 332, 1753, 2738, 1172],
            vec![0, 0, 0, 0, 9, 345, 1656, 2287, 1011, 7],
            vec![0, 0, 0, 0, 0, 5, 3520, 12814, 6800, 96],
            vec![0, 0, 0, 0, 10, 1230, 4295, 1703, 12],
            vec![0, 0, 3],
            vec![1],
        ] {
            let d = leaves(&counts);
            assert_eq!(depth_range(d.iter().copied()), min_max(&d), "{counts:?}");
        }
    }

    #[test]
    fn leaves_past_an_empty_depth_are_left_out() {
        // The 1 % outlier sweep's bunny at seeds 2 and 17.
        let d = leaves(&[0, 0, 0, 0, 1, 745, 5686, 1684, 12, 1, 0, 0, 1]);
        assert_eq!(min_max(&d), (4, 12));
        assert_eq!(depth_range(d), (4, 9));
        let d = leaves(&[0, 0, 0, 0, 0, 741, 5711, 1682, 17, 1, 1, 0, 2]);
        assert_eq!(depth_range(d), (5, 10));
        // Shallow strays alike, and the order of the leaves does not matter.
        let mut d = leaves(&[1, 0, 0, 40, 900, 30, 0, 0, 0, 2]);
        d.reverse();
        assert_eq!(depth_range(d), (3, 5));
    }

    #[test]
    fn the_most_common_depth_anchors_the_range() {
        // Two runs: the one holding the most common depth wins; a tie goes to the shallower.
        assert_eq!(depth_range(leaves(&[0, 5, 5, 0, 9, 1])), (4, 5));
        assert_eq!(depth_range(leaves(&[0, 7, 0, 7])), (1, 1));
        assert_eq!(depth_range(std::iter::empty()), (0, 0));
    }
}
