//! The median of a sample, the statistic the preprocessing steps use for typical spacings,
//! residuals and areas (robust to the stray values they look for), held or streamed.

/// Samples up to this size are ordered by their keys on the stack (a neighbourhood's few
/// dozen values: the keys computed once, not at every comparison).
const SMALL: usize = 32;

/// A streamed median holds the values left once this few agree with the bits found so far
/// (as many as its bins).
const HELD: u64 = 1 << 16;

/// The median of `v` (the upper one of an even count, in the order of `f64::total_cmp`; `v`
/// may be reordered); 0 for an empty slice.
pub(crate) fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    let mid = v.len() / 2;
    if v.len() <= SMALL {
        let mut keys = [0i64; SMALL];
        let keys = &mut keys[..v.len()];
        for (k, &x) in keys.iter_mut().zip(v.iter()) {
            *k = total_order_key(x);
        }
        // (The key is its own inverse: equal keys are equal bits.)
        let key = *keys.select_nth_unstable(mid).1;
        return f64::from_bits(total_order_key_inverse(key) as u64);
    }
    *v.select_nth_unstable_by_key(mid, |&x| total_order_key(x)).1
}

/// The median of values that are streamed rather than held (the upper middle one of an even
/// count, as the held median takes it; 0 for none): `pass(visit)` calls `visit` with every
/// value, in any order, each time it is called (at most four times: the 64 bits of the value's
/// key, which orders as `f64::total_cmp`, are found 16 at a time, each pass counting the values
/// that agree with the bits found so far in 65 536 bins; once at most 65 536 values agree, one
/// last pass holds them and selects among them). Memory: the bins, or as many values; bitwise
/// the held median of the values, or `None` when the passes did not see the same values (their
/// count or their bits changed between them).
///
/// # Errors
///
/// The first error of `pass`, which stops the search.
///
/// ```
/// let values = [3.0, -1.0, 7.5, 2.0];
/// let median = psi_preprocess::median_of_passes(|visit: &mut dyn FnMut(f64)| {
///     values.iter().for_each(|&v| visit(v));
///     Ok::<(), ()>(())
/// });
/// assert_eq!(median, Ok(Some(3.0)));
/// ```
pub fn median_of_passes<E>(
    mut pass: impl FnMut(&mut dyn FnMut(f64)) -> Result<(), E>,
) -> Result<Option<f64>, E> {
    // Keys as unsigned integers, ordered as the floats by `total_cmp`.
    let key = |x: f64| (total_order_key(x) as u64) ^ (1 << 63);
    let (mut prefix, mut rank, mut count) = (0u64, None::<u64>, 0u64);
    for round in 0..4u32 {
        let shift = 48 - 16 * round;
        let mut bins = vec![0u64; 1 << 16];
        pass(&mut |x| {
            let k = key(x);
            // Only the values whose higher bits are those found so far.
            if round == 0 || k >> (shift + 16) == prefix >> (shift + 16) {
                bins[((k >> shift) & 0xffff) as usize] += 1;
            }
        })?;
        let mut left = match rank {
            Some(r) => r,
            None => {
                count = bins.iter().sum();
                if count == 0 {
                    return Ok(Some(0.0));
                }
                count / 2
            }
        };
        let Some(bin) = bins.iter().position(|&b| {
            if left < b {
                true
            } else {
                left -= b;
                false
            }
        }) else {
            return Ok(None);
        };
        prefix |= (bin as u64) << shift;
        rank = Some(left);
        let agree = bins[bin];
        if shift > 0 && agree <= HELD {
            // Few enough agree: held in one more pass, and the rank selected among them.
            let mut held = Vec::with_capacity(agree as usize);
            pass(&mut |x| {
                let k = key(x);
                if k >> shift == prefix >> shift {
                    held.push(k);
                }
            })?;
            if held.len() as u64 != agree {
                return Ok(None);
            }
            prefix = *held.select_nth_unstable(left as usize).1;
            break;
        }
    }
    debug_assert!(count > 0);
    // Back from the key to the float (the key's map is its own inverse on the signed bits).
    let bits = (prefix ^ (1 << 63)) as i64;
    let value = f64::from_bits(total_order_key(f64::from_bits(bits as u64)) as u64);
    Ok(Some(value))
}

/// `x` as an integer that orders as [`f64::total_cmp`] orders the floats (its own definition:
/// the bits as a signed integer, the magnitude bits flipped for negative values). Selecting by
/// it makes the comparisons `total_cmp` makes, with the same outcomes, compared inline.
#[inline]
pub(crate) fn total_order_key(x: f64) -> i64 {
    let bits = x.to_bits() as i64;
    bits ^ ((((bits >> 63) as u64) >> 1) as i64)
}

/// The bits whose [`total_order_key`] is `key` (the map keeps the sign bit and flips the others
/// of a negative value: it is its own inverse).
fn total_order_key_inverse(key: i64) -> i64 {
    key ^ ((((key >> 63) as u64) >> 1) as i64)
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

    /// The median of random samples of any length, on the stack (up to 32) or in place, is
    /// bitwise the middle value of the sample selected by `total_cmp`.
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
        }
    }

    /// Streamed in passes, the median is bitwise the held one, for any count, signs, zeros of
    /// either sign, repeated values and values sharing their higher bits.
    #[test]
    fn the_streamed_median_is_the_median() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(9);
        for n in [0usize, 1, 2, 3, 10, 101, 4000] {
            for spread in [1e-9, 1.0, 1e300] {
                let v: Vec<f64> = (0..n)
                    .map(|i| match i % 11 {
                        0 => 0.0,
                        1 => -0.0,
                        2 => 1.0,
                        _ => spread * (rng.random::<f64>() - 0.4),
                    })
                    .collect();
                let mut passes = 0;
                let streamed = super::median_of_passes(|visit: &mut dyn FnMut(f64)| {
                    passes += 1;
                    v.iter().rev().for_each(|&x| visit(x));
                    Ok::<(), ()>(())
                });
                let held = median(&mut v.clone());
                assert_eq!(streamed, Ok(Some(held)), "n {n}");
                assert_eq!(streamed.unwrap().unwrap().to_bits(), held.to_bits());
                // (One pass to count, one to hold the few values left.)
                assert_eq!(passes, if n == 0 { 1 } else { 2 }, "n {n}");
            }
        }
        // More values than it holds sharing their 16 and their 32 highest bits: the bits are
        // found in three rounds before the rest is held.
        for (n, spread) in [(200_000usize, 0.06), (200_000, 1e-9)] {
            let v: Vec<f64> = (0..n).map(|_| 1.0 + spread * rng.random::<f64>()).collect();
            let mut passes = 0;
            let streamed = super::median_of_passes(|visit: &mut dyn FnMut(f64)| {
                passes += 1;
                v.iter().for_each(|&x| visit(x));
                Ok::<(), ()>(())
            });
            let held = median(&mut v.clone());
            assert_eq!(
                streamed.unwrap().unwrap().to_bits(),
                held.to_bits(),
                "n {n}"
            );
            assert!((3..=4).contains(&passes), "{passes} passes");
        }
        let failing = super::median_of_passes(|_: &mut dyn FnMut(f64)| Err("unreadable"));
        assert_eq!(failing, Err("unreadable"));
        // Values that change between the passes: no median rather than a wrong one.
        let mut pass = 0;
        let changing = super::median_of_passes(|visit: &mut dyn FnMut(f64)| {
            pass += 1;
            let v = if pass == 1 { 1.0 } else { 2.0 };
            (0..5).for_each(|_| visit(v));
            Ok::<(), ()>(())
        });
        assert_eq!(changing, Ok(None));
    }

    #[test]
    fn the_median_is_the_middle_value_of_the_sorted_sample() {
        assert_eq!(median(&mut []), 0.0);
        assert_eq!(median(&mut [3.0]), 3.0);
        assert_eq!(median(&mut [5.0, -1.0, 2.0]), 2.0);
        assert_eq!(median(&mut [4.0, 1.0, 3.0, 2.0]), 3.0);
    }
}
