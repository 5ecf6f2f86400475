//! Hash maps keyed by cell or point indices (or other keys of our own), with a multiplicative
//! hash (Knuth's Fibonacci hashing, TAOCP vol. 3 §6.4) instead of the standard library's
//! SipHash: the keys are not adversarial input, and a rebuild after an edit looks one up for
//! every cell it copies.

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

/// A hasher of one `u32` or `u64` key of our own (other writes are folded in byte by byte):
/// for `HashMap`s keyed by indices or packed grid coordinates (`BuildHasherDefault<IdHasher>`).
#[derive(Default)]
pub struct IdHasher(u64);

impl Hasher for IdHasher {
    fn finish(&self) -> u64 {
        // The high bits of the product mix every bit of the key; folded down so that the
        // table's low bits see them too.
        let h = self.0.wrapping_mul(0x9e37_79b9_7f4a_7c15);
        h ^ (h >> 29)
    }

    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = self.0.rotate_left(8) ^ u64::from(b);
        }
    }

    fn write_u32(&mut self, i: u32) {
        self.0 = self.0.rotate_left(32) ^ u64::from(i);
    }

    fn write_u64(&mut self, i: u64) {
        self.0 = self.0.rotate_left(32) ^ i;
    }
}

/// A map from indices.
pub(crate) type IdMap<V> = HashMap<u32, V, BuildHasherDefault<IdHasher>>;

#[cfg(test)]
mod tests {
    use super::*;
    use std::hash::BuildHasher;

    #[test]
    fn consecutive_indices_spread_over_the_low_and_high_bits() {
        let build = BuildHasherDefault::<IdHasher>::default();
        // 4096 consecutive keys into 256 buckets by the low byte and by the high byte.
        for shift in [0, 56] {
            let mut buckets = [0u32; 256];
            for k in 0..4096u32 {
                buckets[((build.hash_one(k) >> shift) & 0xff) as usize] += 1;
            }
            let most = buckets.iter().max().copied().unwrap_or(0);
            assert!(
                most <= 40,
                "a bucket of {most} (16 expected), shift {shift}"
            );
        }
        let mut map: IdMap<i64> = IdMap::default();
        for k in (0..10_000u32).step_by(7) {
            *map.entry(k).or_default() += i64::from(k);
        }
        assert_eq!(map.get(&7007), Some(&7007));
        assert_eq!(map.get(&7008), None);
    }
}
