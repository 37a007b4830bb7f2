//! Pairing directed triangle edges: the one place that groups a triangle soup's directed edges
//! by their undirected edge and reads each group's uses.
//!
//! The caller supplies the key of each directed edge's undirected edge (welded vertex ids for
//! [`crate::topology`], vertex indices for the fit's closed check, exact corner positions for
//! the open-soup blocks of [`crate::voxel`]) and whether the edge runs forward, from its lower
//! end to its higher ([`directed`], [`directed_ids`]). [`group_edges`] sorts them by key and
//! yields one [`EdgeGroup`] per undirected edge, in ascending key order, with how many directed
//! edges run each way; [`EdgeGroup::class`] names its class (boundary, paired, inconsistently
//! oriented, non-manifold) and [`EdgeClasses`] counts them. Cost: one sort (in parallel for many
//! edges; the sorted list is the same whatever the thread count) and a linear scan.

use rayon::slice::ParallelSliceMut;

/// The directed edge a → b as (its undirected key (lower end, higher end), whether it runs
/// forward, from the lower end to the higher). An edge from a vertex to itself runs forward.
pub fn directed<V: Ord>(a: V, b: V) -> ((V, V), bool) {
    if a <= b {
        ((a, b), true)
    } else {
        ((b, a), false)
    }
}

/// [`directed`] on u32 ids, the key packed into one u64 (lower << 32 | higher, which sorts as
/// the pair does).
pub fn directed_ids(a: u32, b: u32) -> (u64, bool) {
    ((u64::from(a.min(b)) << 32) | u64::from(a.max(b)), a <= b)
}

/// The two ends of a key made by [`directed_ids`]: (lower, higher).
pub fn id_ends(key: u64) -> (u32, u32) {
    ((key >> 32) as u32, key as u32)
}

/// One undirected edge: its key and how many of the directed edges run each way along it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EdgeGroup<K> {
    pub key: K,
    /// Directed edges from the lower end to the higher.
    pub forward: usize,
    /// Directed edges from the higher end to the lower.
    pub backward: usize,
}

/// What an undirected edge is by its uses (the number of directed edges along it).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EdgeClass {
    /// Used once.
    Boundary,
    /// Used twice, once each way.
    Paired,
    /// Used twice in the same direction (its two triangles wind opposite ways).
    Inconsistent,
    /// Used three or more times.
    NonManifold,
}

impl<K> EdgeGroup<K> {
    /// Directed edges along this edge, either way.
    pub fn uses(&self) -> usize {
        self.forward + self.backward
    }

    pub fn class(&self) -> EdgeClass {
        match self.uses() {
            1 => EdgeClass::Boundary,
            2 if self.forward == 1 => EdgeClass::Paired,
            2 => EdgeClass::Inconsistent,
            _ => EdgeClass::NonManifold,
        }
    }

    /// Forward uses minus backward ones: what no reverse edge cancels, signed.
    pub fn net(&self) -> i64 {
        self.forward as i64 - self.backward as i64
    }
}

/// Below this many edges, or on one thread, [`group_edges`] sorts on the calling thread: std's
/// sort is faster than rayon's on one thread (the topology report of the 69 k-triangle bunny took
/// 1 ms more with rayon's).
const PARALLEL_SORT_MIN: usize = 1 << 16;

/// Sorts `edges` (undirected key, runs forward) and yields one group per key, in ascending key
/// order.
pub fn group_edges<K: Ord + Copy + Send>(edges: &mut [(K, bool)]) -> impl Iterator<Item = EdgeGroup<K>> + '_ {
    // Either sort gives the one sorted list (equal elements are indistinguishable).
    if edges.len() < PARALLEL_SORT_MIN || rayon::current_num_threads() == 1 {
        edges.sort_unstable();
    } else {
        edges.par_sort_unstable();
    }
    sorted_groups(edges)
}

/// The groups of `edges` already in ascending order (what [`group_edges`] yields after its
/// sort): one per run of equal keys, in the runs' order. Cost: a linear scan.
pub fn sorted_groups<K: PartialEq + Copy>(edges: &[(K, bool)]) -> impl Iterator<Item = EdgeGroup<K>> + '_ {
    edges.chunk_by(|x, y| x.0 == y.0).map(|g| {
        let forward = g.iter().filter(|e| e.1).count();
        EdgeGroup { key: g[0].0, forward, backward: g.len() - forward }
    })
}

/// `edges` (keys made by [`directed_ids`]) in ascending order, the list `group_edges` sorts them
/// to, by a counting sort on the keys' lower ends ([`crate::bucket::bucket_sorted`]; a lower end
/// of `ids` or more shares the last bucket, still in order), each vertex's few edges then
/// sorted on their own: O(n + ids) where the comparison sort is O(n log n) (on the bunny's
/// topology report, 208 k directed edges over 35 k welded ids, the sort was most of its
/// 96 M instructions). One thread; the same list whatever the thread count.
pub fn sort_id_edges(edges: &[(u64, bool)], ids: usize) -> Vec<(u64, bool)> {
    crate::bucket::bucket_sorted(|| edges.iter().copied(), ids + 1, |e| (id_ends(e.0).0 as usize).min(ids))
}

/// Undirected edges counted by class, so `bake` and `inspect` name the same numbers: used once
/// (boundary), twice in the same direction (inconsistently oriented), three or more times
/// (non-manifold).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct EdgeClasses {
    pub boundary: usize,
    pub inconsistent: usize,
    pub non_manifold: usize,
}

impl EdgeClasses {
    pub fn add(&mut self, class: EdgeClass) {
        match class {
            EdgeClass::Boundary => self.boundary += 1,
            EdgeClass::Inconsistent => self.inconsistent += 1,
            EdgeClass::NonManifold => self.non_manifold += 1,
            EdgeClass::Paired => {}
        }
    }

    /// "296 boundary edges, 47 non-manifold, 3 inconsistently oriented" (classes of 0 left out;
    /// boundary edges always named).
    pub fn describe(&self) -> String {
        let mut s = format!("{} boundary edges", self.boundary);
        if self.non_manifold > 0 {
            s += &format!(", {} non-manifold", self.non_manifold);
        }
        if self.inconsistent > 0 {
            s += &format!(", {} inconsistently oriented", self.inconsistent);
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use std::collections::HashMap;

    use super::*;
    use crate::rng::SplitMix64;

    /// Random directed id edges (ids below and at or above the bucket count, duplicates, edges
    /// from a vertex to itself): [`sort_id_edges`] gives the list `group_edges` sorts them to,
    /// so the same groups; fails if an edge lands in the wrong bucket or a bucket is unsorted.
    #[test]
    fn sort_id_edges_is_group_edges_sort() {
        let mut rng = SplitMix64::new(5);
        for case in 0..300usize {
            let nv = 1 + (rng.next_u64() % 40) as u32;
            let ids = (rng.next_u64() % (u64::from(nv) + 2)) as usize;
            let n = (rng.next_u64() % 200) as usize;
            let edges: Vec<(u64, bool)> = (0..n)
                .map(|_| directed_ids((rng.next_u64() % u64::from(nv)) as u32, (rng.next_u64() % u64::from(nv)) as u32))
                .collect();
            let got = sort_id_edges(&edges, ids);
            let mut want = edges.clone();
            let want_groups: Vec<_> = group_edges(&mut want).collect();
            assert_eq!(got, want, "case {case}");
            assert_eq!(sorted_groups(&got).collect::<Vec<_>>(), want_groups, "case {case}");
        }
        assert!(sort_id_edges(&[], 0).is_empty());
    }

    /// Random soups over few vertices (duplicates, fans of three and more, edges from a vertex
    /// to itself, holes, turned triangles), against a count of each undirected edge's uses in a
    /// hash map, edge by edge: the groups, their order, their classes and net counts, for ids
    /// and for a tuple key of the same ids.
    #[test]
    fn groups_match_a_count_of_each_edges_uses() {
        let mut rng = SplitMix64::new(11);
        let mut seen = [0usize; 4];
        for case in 0..500 {
            let nv = 2 + (rng.next_u64() % 7) as u32;
            let nt = (rng.next_u64() % 14) as usize;
            // Large ids too, so the packed key's halves are both exercised.
            let id = |v: u64| if v % 3 == 0 { u32::MAX - v as u32 } else { v as u32 };
            let tris: Vec<[u32; 3]> =
                (0..nt).map(|_| std::array::from_fn(|_| id(rng.next_u64() % u64::from(nv)))).collect();
            // Brute force: per unordered pair {a, b} (a ≤ b), uses from a to b and from b to a.
            let mut uses: HashMap<(u32, u32), (usize, usize)> = HashMap::new();
            for t in &tris {
                for k in 0..3 {
                    let (a, b) = (t[k], t[(k + 1) % 3]);
                    let e = uses.entry((a.min(b), a.max(b))).or_default();
                    if a <= b {
                        e.0 += 1;
                    } else {
                        e.1 += 1;
                    }
                }
            }
            let mut want: Vec<((u32, u32), (usize, usize))> = uses.into_iter().collect();
            want.sort_unstable();
            let mut ids: Vec<(u64, bool)> = tris
                .iter()
                .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
                .map(|(a, b)| directed_ids(a, b))
                .collect();
            let got: Vec<EdgeGroup<u64>> = group_edges(&mut ids).collect();
            let mut pairs: Vec<((u32, u32), bool)> = tris
                .iter()
                .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
                .map(|(a, b)| directed(a, b))
                .collect();
            let got_pairs: Vec<EdgeGroup<(u32, u32)>> = group_edges(&mut pairs).collect();
            assert_eq!(got.len(), want.len(), "case {case}: {tris:?}");
            assert_eq!(got_pairs.len(), want.len(), "case {case}: {tris:?}");
            let mut classes = EdgeClasses::default();
            let mut want_classes = EdgeClasses::default();
            for ((g, gp), &((a, b), (f, r))) in got.iter().zip(&got_pairs).zip(&want) {
                assert_eq!(id_ends(g.key), (a, b), "case {case}");
                assert_eq!((g.forward, g.backward), (f, r), "case {case}: {a}-{b}");
                assert_eq!(*gp, EdgeGroup { key: (a, b), forward: f, backward: r }, "case {case}");
                assert_eq!(g.uses(), f + r);
                assert_eq!(g.net(), f as i64 - r as i64);
                let want_class = if f + r == 1 {
                    EdgeClass::Boundary
                } else if f + r >= 3 {
                    EdgeClass::NonManifold
                } else if f == r {
                    EdgeClass::Paired
                } else {
                    EdgeClass::Inconsistent
                };
                assert_eq!(g.class(), want_class, "case {case}: {a}-{b} used ({f}, {r})");
                seen[want_class as usize] += 1;
                classes.add(g.class());
                match (f + r, f == r) {
                    (1, _) => want_classes.boundary += 1,
                    (2, true) => {}
                    (2, false) => want_classes.inconsistent += 1,
                    _ => want_classes.non_manifold += 1,
                }
            }
            assert_eq!(classes, want_classes, "case {case}");
        }
        assert!(seen.iter().all(|&n| n > 20), "every class exercised: {seen:?}");
    }

    #[test]
    fn describe_names_the_classes_present() {
        let open = EdgeClasses { boundary: 3, ..Default::default() };
        assert_eq!(open.describe(), "3 boundary edges");
        let all = EdgeClasses { boundary: 296, non_manifold: 47, inconsistent: 3 };
        assert_eq!(all.describe(), "296 boundary edges, 47 non-manifold, 3 inconsistently oriented");
        assert_eq!(group_edges::<u64>(&mut []).count(), 0);
    }
}
