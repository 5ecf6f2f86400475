//! Byte-level mutations of valid files for the no-panic properties: the edits that reach a
//! reader's corner cases (bytes set, inserted, deleted, truncated, spans duplicated), plus
//! blown-up digit runs for text formats and extreme 8-byte words for binary headers.

use proptest::prelude::*;

/// One edit of a file's bytes; positions are taken modulo the length.
#[derive(Clone, Debug)]
pub enum Mutation {
    Set(usize, u8),
    Insert(usize, u8),
    Delete(usize),
    Truncate(usize),
    /// Replace the byte at the position with a run of digits (blows up counts in headers).
    Digits(usize, String),
    /// Overwrite 8 bytes with an extreme little-endian value (counts, offsets, sizes).
    Word(usize, u64),
    /// Copy a span elsewhere (duplicated lines and records).
    Duplicate(usize, usize, usize),
}

/// The edits common to every format.
fn common() -> Vec<BoxedStrategy<Mutation>> {
    let pos = any::<usize>();
    vec![
        (pos, any::<u8>())
            .prop_map(|(p, b)| Mutation::Set(p, b))
            .boxed(),
        (pos, any::<u8>())
            .prop_map(|(p, b)| Mutation::Insert(p, b))
            .boxed(),
        pos.prop_map(Mutation::Delete).boxed(),
        pos.prop_map(Mutation::Truncate).boxed(),
        (pos, 0usize..64, pos)
            .prop_map(|(a, n, b)| Mutation::Duplicate(a, n, b))
            .boxed(),
    ]
}

/// Edits for text formats: the common ones and digit runs.
pub fn text_mutation() -> impl Strategy<Value = Mutation> {
    let mut all = common();
    all.push(
        (any::<usize>(), "[0-9]{1,22}")
            .prop_map(|(p, d)| Mutation::Digits(p, d))
            .boxed(),
    );
    proptest::strategy::Union::new(all)
}

/// Edits for binary formats: the common ones and extreme words.
pub fn binary_mutation() -> impl Strategy<Value = Mutation> {
    let extreme = prop_oneof![
        Just(0u64),
        Just(u64::MAX),
        Just(u64::from(u32::MAX)),
        Just(1u64 << 31),
        any::<u64>(),
        0u64..100_000,
    ];
    let mut all = common();
    all.push(
        (any::<usize>(), extreme)
            .prop_map(|(p, w)| Mutation::Word(p, w))
            .boxed(),
    );
    proptest::strategy::Union::new(all)
}

/// Applies `m` to `bytes` (nothing for an empty file).
pub fn apply(bytes: &mut Vec<u8>, m: &Mutation) {
    if bytes.is_empty() {
        return;
    }
    let len = bytes.len();
    match *m {
        Mutation::Set(p, b) => bytes[p % len] = b,
        Mutation::Insert(p, b) => bytes.insert(p % (len + 1), b),
        Mutation::Delete(p) => {
            bytes.remove(p % len);
        }
        Mutation::Truncate(p) => bytes.truncate(p % len),
        Mutation::Digits(p, ref digits) => {
            // Prefer positions that already hold a digit, so counts and indices change.
            let i = p % len;
            let i = (i..len).find(|&k| bytes[k].is_ascii_digit()).unwrap_or(i);
            bytes.splice(i..=i, digits.bytes());
        }
        Mutation::Word(p, w) => {
            // Header fields lie mostly in the first few hundred bytes.
            let at = (p % len.min(400)).min(len.saturating_sub(8));
            let end = (at + 8).min(len);
            bytes[at..end].copy_from_slice(&w.to_le_bytes()[..end - at]);
        }
        Mutation::Duplicate(a, n, b) => {
            let start = a % len;
            let span = bytes[start..(start + n).min(len)].to_vec();
            let to = b % (len + 1);
            bytes.splice(to..to, span);
        }
    }
}
