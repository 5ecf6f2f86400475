//! The maximum spanning forest of a weighted neighbour graph (Kruskal: edges in decreasing
//! weight, each kept when it joins two trees), for normal orientation (Hoppe et al. 1992 grow
//! it with Prim from a seed; without ties both give the one maximum spanning tree, and
//! Kruskal's edge order, sorted in parallel, replaces Prim's serial priority queue; notes:
//! 2026-11-26-throughput). Ties between equal weights go to the
//! edge whose endpoints' original indices are smaller (lower, then higher), so the forest is a
//! function of the points alone, whatever their order or the thread count.

use rayon::prelude::*;

use crate::disjoint_sets::Sets;
use crate::neighbour_graph::Graph;

/// An edge to be sorted: the weight's bits (a non-negative f64 orders as its bits), the
/// endpoints' original indices (lower, higher), and the endpoints.
type Keyed = (u64, u64, u32, u32);

/// The maximum spanning forest of the undirected graph over `n` points whose edges `edges(i)`
/// appends for each point i as `(j, weight)` (symmetric: listed from both ends with the same
/// weight, ≥ 0 and finite; no repeats), `ids` (shape: n) the points' original indices: the
/// forest as a graph (row i: point i's tree neighbours, in the order their edges were kept).
pub(crate) fn maximum_spanning_forest(
    n: usize,
    ids: &[u32],
    edges: impl Fn(usize, &mut Vec<(u32, f64)>) + Sync,
) -> Graph {
    // Each edge once (from its lower slot), keyed for a descending sort.
    let mut keyed: Vec<Keyed> = (0..n)
        .into_par_iter()
        .fold(
            || (Vec::new(), Vec::new()),
            |(mut out, mut buf): (Vec<Keyed>, Vec<(u32, f64)>), i| {
                buf.clear();
                edges(i, &mut buf);
                for &(j, w) in &buf {
                    let (a, b) = (i as u32, j);
                    if a >= b {
                        continue;
                    }
                    let (lo, hi) = (
                        ids[a as usize].min(ids[b as usize]),
                        ids[a as usize].max(ids[b as usize]),
                    );
                    out.push((!w.to_bits(), u64::from(lo) << 32 | u64::from(hi), a, b));
                }
                (out, buf)
            },
        )
        .map(|(out, _)| out)
        .reduce(Vec::new, |mut a, mut b| {
            a.append(&mut b);
            a
        });
    keyed.par_sort_unstable();
    let chunk = (keyed.len() / 64).max(1 << 16);
    Graph::from_edges(n, &kruskal(n, &keyed, chunk))
}

/// Kruskal's loop over `keyed` (sorted, heaviest first) in chunks of `chunk` edges: in each,
/// the edges whose ends are already one tree are dropped in parallel (trees only grow, so the
/// serial loop would drop them too), then the rest are joined in order. The edges kept, as
/// the plain loop keeps them (docs/results/2026-11-27-orientation-forest/).
fn kruskal(n: usize, keyed: &[Keyed], chunk: usize) -> Vec<(u32, u32)> {
    let mut sets = Sets::new(n);
    let mut kept = Vec::with_capacity(n);
    for part in keyed.chunks(chunk.max(1)) {
        let apart: Vec<(u32, u32)> = part
            .par_iter()
            .filter(|e| sets.root_of(e.2) != sets.root_of(e.3))
            .map(|e| (e.2, e.3))
            .collect();
        for (a, b) in apart {
            if sets.join(a, b) {
                kept.push((a, b));
            }
        }
    }
    kept
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against brute force: the total weight of the forest equals the best over all spanning
    /// forests found by exhaustive search on small graphs, and the forest spans each component.
    #[test]
    fn the_forest_is_maximum_and_spanning() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(3);
        let mut rnd = move || rng.random::<u64>();
        for _ in 0..40 {
            let n = 2 + (rnd() % 6) as usize;
            let mut all: Vec<(usize, usize, f64)> = Vec::new();
            for a in 0..n {
                for b in a + 1..n {
                    if rnd() % 3 != 0 {
                        all.push((a, b, (rnd() % 5) as f64 / 4.0));
                    }
                }
            }
            let ids: Vec<u32> = (0..n as u32).rev().collect();
            let forest = maximum_spanning_forest(n, &ids, |i, out| {
                for &(a, b, w) in &all {
                    if a == i {
                        out.push((b as u32, w));
                    } else if b == i {
                        out.push((a as u32, w));
                    }
                }
            });
            let mut tree: Vec<(usize, usize)> = Vec::new();
            for a in 0..n {
                for &b in forest.row(a) {
                    if a < b as usize {
                        tree.push((a, b as usize));
                    }
                }
            }
            let weight = |set: &[(usize, usize)]| -> f64 {
                set.iter()
                    .map(|&(a, b)| all.iter().find(|e| (e.0, e.1) == (a, b)).unwrap().2)
                    .sum()
            };
            // Brute force: the heaviest acyclic subset of the largest size.
            let mut best = (0usize, f64::NEG_INFINITY);
            for mask in 0u32..1 << all.len() {
                let pick: Vec<(usize, usize)> = (0..all.len())
                    .filter(|k| mask >> k & 1 == 1)
                    .map(|k| (all[k].0, all[k].1))
                    .collect();
                let mut sets = Sets::new(n);
                let acyclic = pick.iter().all(|&(a, b)| sets.join(a as u32, b as u32));
                if acyclic {
                    let cand = (pick.len(), weight(&pick));
                    if cand.0 > best.0 || (cand.0 == best.0 && cand.1 > best.1) {
                        best = cand;
                    }
                }
            }
            assert_eq!(tree.len(), best.0, "spanning");
            assert!((weight(&tree) - best.1).abs() < 1e-12, "maximum");
        }
    }

    /// The chunked loop keeps exactly the edges of the plain one, in its order, for any chunk
    /// size, on a random graph with many ties (weights of a few values).
    #[test]
    fn chunks_keep_the_plain_loops_edges() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(11);
        let n = 3000usize;
        let mut keyed: Vec<Keyed> = (0..20_000)
            .map(|_| {
                let a = rng.random_range(0..n as u32);
                let b = rng.random_range(0..n as u32);
                let w = f64::from(rng.random_range(0..8u32)) / 8.0;
                (
                    !w.to_bits(),
                    u64::from(a.min(b)) << 32 | u64::from(a.max(b)),
                    a,
                    b,
                )
            })
            .filter(|e| e.2 != e.3)
            .collect();
        keyed.sort_unstable();
        let mut sets = Sets::new(n);
        let plain: Vec<(u32, u32)> = keyed
            .iter()
            .filter(|e| sets.join(e.2, e.3))
            .map(|e| (e.2, e.3))
            .collect();
        assert!(plain.len() > n / 2 && plain.len() < keyed.len() / 2);
        for chunk in [1, 7, 100, 4096, keyed.len()] {
            assert_eq!(kruskal(n, &keyed, chunk), plain, "chunk {chunk}");
        }
        // The graph of the kept edges: each edge in both rows, in the edges' order.
        let forest = Graph::from_edges(n, &plain);
        for i in 0..n {
            let row: Vec<u32> = plain
                .iter()
                .filter_map(|&(a, b)| {
                    (a as usize == i)
                        .then_some(b)
                        .or((b as usize == i).then_some(a))
                })
                .collect();
            assert_eq!(forest.row(i), row.as_slice());
        }
    }
}
