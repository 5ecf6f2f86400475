//! The leaves' local functions, stored in append-only chunks that a rebuilt MPU shares with the
//! one it replaces: a local regeneration appends the refitted leaves' functions in a new chunk
//! and names every reused leaf's function by its old id, so nothing is copied (copying them
//! wrote megabytes of fresh memory per edit: notes, local regeneration).
//!
//! A fit id is `chunk << CHUNK_SHIFT | index`. Replaced functions stay in their chunk until the
//! chunks are compacted: a build that finds [`MAX_CHUNKS`] chunks copies the live functions into
//! one.

use std::sync::Arc;

use glam::DVec3;

use crate::local_function::StoredFunction;
use crate::{FitKind, LocalFunction, Quadric};

/// Bits of a fit id that index within its chunk.
const CHUNK_SHIFT: u32 = 28;
const INDEX_MASK: u32 = (1 << CHUNK_SHIFT) - 1;

/// A build that finds this many chunks compacts them.
pub(crate) const MAX_CHUNKS: usize = 8;

/// One chunk: functions with their kinds and fallback flags, and the sharp functions' pieces.
#[derive(Debug, Default)]
struct FitChunk {
    functions: Vec<StoredFunction>,
    kinds: Vec<FitKind>,
    fallback: Vec<bool>,
    pieces: Vec<Quadric>,
}

/// The functions of an MPU's leaves (cheap to clone: chunks are shared).
#[derive(Clone, Debug, Default)]
pub(crate) struct FitStore {
    chunks: Vec<Arc<FitChunk>>,
}

impl FitStore {
    /// The number of chunks.
    pub(crate) fn chunk_count(&self) -> usize {
        self.chunks.len()
    }

    #[inline]
    fn chunk(&self, id: u32) -> (&FitChunk, usize) {
        (
            &self.chunks[(id >> CHUNK_SHIFT) as usize],
            (id & INDEX_MASK) as usize,
        )
    }

    /// (Q(y), ∇Q(y)) of function `id` at local position `y`.
    #[inline]
    pub(crate) fn value_and_gradient(&self, id: u32, y: DVec3) -> (f64, DVec3) {
        let (c, i) = self.chunk(id);
        c.functions[i].value_and_gradient(&c.pieces, y)
    }

    /// Q(y) of function `id` at local position `y`.
    #[inline]
    pub(crate) fn value(&self, id: u32, y: DVec3) -> f64 {
        let (c, i) = self.chunk(id);
        c.functions[i].value(&c.pieces, y)
    }

    /// Function `id` as a value.
    pub(crate) fn load(&self, id: u32) -> LocalFunction {
        let (c, i) = self.chunk(id);
        c.functions[i].load(&c.pieces)
    }

    /// The fit kind of function `id`.
    pub(crate) fn kind(&self, id: u32) -> FitKind {
        let (c, i) = self.chunk(id);
        c.kinds[i]
    }

    /// Whether function `id` came from a fallback.
    pub(crate) fn fallback(&self, id: u32) -> bool {
        let (c, i) = self.chunk(id);
        c.fallback[i]
    }
}

/// Collects a build's functions: new ones in a fresh chunk, reused ones by their old id.
pub(crate) struct FitStoreBuilder<'a> {
    old: Option<&'a FitStore>,
    /// Whether the old chunks are shared (else reused functions are copied: compaction).
    share: bool,
    fresh: FitChunk,
}

impl<'a> FitStoreBuilder<'a> {
    /// A builder taking reused functions from `old`, sharing its chunks when `share` and it has
    /// fewer than [`MAX_CHUNKS`] (else copying them); `capacity` is the expected number of
    /// functions added to the new chunk.
    pub(crate) fn new(old: Option<&'a FitStore>, share: bool, capacity: usize) -> Self {
        let share = share && old.is_some_and(|o| o.chunks.len() < MAX_CHUNKS);
        Self {
            old,
            share,
            fresh: FitChunk {
                functions: Vec::with_capacity(capacity),
                kinds: Vec::with_capacity(capacity),
                fallback: Vec::with_capacity(capacity),
                pieces: Vec::new(),
            },
        }
    }

    fn fresh_id(&self) -> u32 {
        // 2^28 functions per chunk: more leaves than any octree that fits in memory.
        debug_assert!(self.fresh.functions.len() < 1 << CHUNK_SHIFT);
        let chunk = if self.share {
            self.old.map_or(0, |o| o.chunks.len())
        } else {
            0
        };
        ((chunk as u32) << CHUNK_SHIFT) | self.fresh.functions.len() as u32
    }

    /// Adds a new function; returns its id.
    pub(crate) fn push(&mut self, f: LocalFunction, kind: FitKind, fallback: bool) -> u32 {
        let id = self.fresh_id();
        let stored = StoredFunction::store(f, &mut self.fresh.pieces);
        self.fresh.functions.push(stored);
        self.fresh.kinds.push(kind);
        self.fresh.fallback.push(fallback);
        id
    }

    /// Adds function `id` of the old store; returns its id in the new one.
    pub(crate) fn reuse(&mut self, id: u32) -> u32 {
        let old = self.old.expect("reused functions come from an old store");
        if self.share {
            return id;
        }
        let new = self.fresh_id();
        let (c, i) = old.chunk(id);
        let stored = c.functions[i].copy(&c.pieces, &mut self.fresh.pieces);
        self.fresh.functions.push(stored);
        self.fresh.kinds.push(c.kinds[i]);
        self.fresh.fallback.push(c.fallback[i]);
        new
    }

    /// The store: the old chunks (when shared) and the new one.
    pub(crate) fn finish(self) -> FitStore {
        let mut chunks = match (self.share, self.old) {
            (true, Some(o)) => o.chunks.clone(),
            _ => Vec::new(),
        };
        chunks.push(Arc::new(self.fresh));
        FitStore { chunks }
    }
}
