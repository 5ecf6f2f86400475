//! The median of a sample, the statistic the preprocessing steps use for typical spacings,
//! residuals and areas (robust to the stray values they look for).

/// The median of `v` (the upper one of an even count; `v` reordered); 0 for an empty slice.
pub(crate) fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    let mid = v.len() / 2;
    *v.select_nth_unstable_by_key(mid, |&x| total_order_key(x)).1
}

/// `x` as an integer that orders as [`f64::total_cmp`] orders the floats (its own definition:
/// the bits as a signed integer, the magnitude bits flipped for negative values). Selecting by
/// it makes the comparisons `total_cmp` makes, with the same outcomes, compared inline.
#[inline]
pub(crate) fn total_order_key(x: f64) -> i64 {
    let bits = x.to_bits() as i64;
    bits ^ ((((bits >> 63) as u64) >> 1) as i64)
}

#[cfg(test)]
mod tests {
    use super::median;

    /// The integer keys order every float as `total_cmp` does: signed zeros, infinities,
    /// subnormals and NaNs of either sign included.
    #[test]
    fn keys_order_as_total_cmp() {
        let values = [
            f64::NEG_INFINITY,
            -1e300,
            -1.0,
            -f64::MIN_POSITIVE / 4.0,
            -0.0,
            0.0,
            f64::MIN_POSITIVE / 4.0,
            1.0,
            1e300,
            f64::INFINITY,
            f64::NAN,
            -f64::NAN,
        ];
        for a in values {
            for b in values {
                let keys = super::total_order_key(a).cmp(&super::total_order_key(b));
                assert_eq!(keys, a.total_cmp(&b), "{a} {b}");
            }
        }
    }

    /// The median of random samples of any length is the sorted sample's middle value, and
    /// the slice is left as selecting by `total_cmp` leaves it.
    #[test]
    fn the_median_selects_as_total_cmp_selects() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(4);
        for n in 1..60 {
            let v: Vec<f64> = (0..n)
                .map(|i| match i % 7 {
                    0 => 0.0,
                    1 => -0.0,
                    _ => rng.random::<f64>() - 0.3,
                })
                .collect();
            let (mut a, mut b) = (v.clone(), v.clone());
            let m = median(&mut a);
            b.select_nth_unstable_by(n / 2, f64::total_cmp);
            assert_eq!(m.to_bits(), b[n / 2].to_bits());
            assert_eq!(
                a.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
                b.iter().map(|x| x.to_bits()).collect::<Vec<_>>()
            );
        }
    }

    #[test]
    fn the_median_is_the_middle_value_of_the_sorted_sample() {
        assert_eq!(median(&mut []), 0.0);
        assert_eq!(median(&mut [3.0]), 3.0);
        assert_eq!(median(&mut [5.0, -1.0, 2.0]), 2.0);
        assert_eq!(median(&mut [4.0, 1.0, 3.0, 2.0]), 3.0);
    }
}
