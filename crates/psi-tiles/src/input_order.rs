//! Gathered records put in increasing input index order (every reader of a store sees the
//! points as the whole input orders them): the indices' order by a least-significant-digit
//! radix sort of their offsets from the least (8 bytes an entry and as many again for the
//! passes, against 16 for a comparison sort of index and place), then the records moved into
//! that order in place, cycle by cycle (the places, in the sort's own room, beside them).

use psi_octree::OrientedPoint;

/// Bits of one radix digit (a 2 048-entry count).
const DIGIT_BITS: u32 = 11;

/// `found` in increasing input index, ties in the order given (a stable sort).
pub(crate) fn in_input_order(mut found: Vec<(u64, OrientedPoint)>) -> Vec<(u64, OrientedPoint)> {
    if found.is_sorted_by_key(|(i, _)| *i) {
        return found;
    }
    // Slot j takes the record now at from[j]; a slot done is marked u32::MAX.
    let mut from = order_of(&found);
    for start in 0..found.len() {
        if from[start] == u32::MAX {
            continue;
        }
        let first = found[start];
        let mut j = start;
        loop {
            let k = from[j] as usize;
            from[j] = u32::MAX;
            if k == start {
                found[j] = first;
                break;
            }
            found[j] = found[k];
            j = k;
        }
    }
    found
}

/// The places of `found`'s records in increasing index order, ties in place order (shape: as
/// `found`, fewer than 2³² records).
fn order_of(found: &[(u64, OrientedPoint)]) -> Vec<u32> {
    let least = found.iter().map(|r| r.0).min().unwrap_or(0);
    let span = found.iter().map(|r| r.0 - least).max().unwrap_or(0);
    let Ok(span) = u32::try_from(span) else {
        let mut order: Vec<(u64, u32)> = (0..found.len() as u32)
            .map(|k| (found[k as usize].0, k))
            .collect();
        order.sort_unstable();
        return order.into_iter().map(|(_, k)| k).collect();
    };
    let mut keyed: Vec<(u32, u32)> = (0..found.len() as u32)
        .map(|k| ((found[k as usize].0 - least) as u32, k))
        .collect();
    radix_sort(&mut keyed, u32::BITS - span.leading_zeros());
    keyed.into_iter().map(|(_, k)| k).collect()
}

/// Sorts `items` by their first member, stably, reading its low `bits` bits (the higher ones
/// are zero): one counting pass per [`DIGIT_BITS`] digit, least significant first.
fn radix_sort(items: &mut Vec<(u32, u32)>, bits: u32) {
    let mut spare = vec![(0u32, 0u32); items.len()];
    let mask = (1u32 << DIGIT_BITS) - 1;
    let mut shift = 0;
    while shift < bits {
        let mut starts = vec![0usize; 1 << DIGIT_BITS];
        for &(key, _) in items.iter() {
            starts[((key >> shift) & mask) as usize] += 1;
        }
        let mut sum = 0;
        for s in &mut starts {
            (*s, sum) = (sum, sum + *s);
        }
        for &item in items.iter() {
            let d = ((item.0 >> shift) & mask) as usize;
            spare[starts[d]] = item;
            starts[d] += 1;
        }
        std::mem::swap(items, &mut spare);
        shift += DIGIT_BITS;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use glam::DVec3;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64Mcg;

    /// `n` ids in runs of ascending ids, as the tiles' sub-cells give them, interleaved;
    /// `stride` spaces the ids (a span of more than 32 bits takes the comparison sort).
    fn runs_of(n: u64, stride: u64, seed: u64) -> Vec<(u64, OrientedPoint)> {
        let mut rng = Pcg64Mcg::seed_from_u64(seed);
        let mut ids: Vec<u64> = (0..n).map(|i| i * stride + 7).collect();
        for i in (1..ids.len()).rev() {
            ids.swap(i, rng.random_range(0..=i));
        }
        let mut found = Vec::new();
        for run in ids.chunks(97) {
            let mut run = run.to_vec();
            run.sort_unstable();
            found.extend(run.iter().map(|&i| {
                let p = OrientedPoint {
                    p: DVec3::splat(i as f64),
                    n: DVec3::Z,
                };
                (i, p)
            }));
        }
        found
    }

    #[test]
    fn records_come_out_in_input_order_as_a_stable_sort_gives_them() {
        // Oracle: the standard library's stable sort by index. Spans of 1 to 3 digits and
        // one beyond 32 bits; ties (an index twice) in the order given.
        for (n, stride, seed) in [
            (1500, 1, 1),
            (5000, 3, 2),
            (5000, 1 << 14, 3),
            (5000, 1 << 20, 4),
        ] {
            let mut found = runs_of(n, stride, seed);
            found.push((found[10].0, found[3].1));
            let mut expected = found.clone();
            expected.sort_by_key(|(i, _)| *i);
            assert_ne!(found, expected);
            assert_eq!(in_input_order(found), expected, "stride {stride}");
            assert_eq!(in_input_order(expected.clone()), expected);
        }
    }
}
