//! Sorting lists whose order starts with a small integer key (a vertex or corner id): a
//! counting sort on the key, then each bucket sorted on its own. With a handful of items per
//! key this is O(n + buckets) where a comparison sort of the whole list is O(n log n) (the
//! orientation's edges and the duplicate-triangle check's keys on the bunny were a third and a
//! tenth of their stages).

/// The items `items()` yields, in ascending order (what `sort_unstable` on them gives), when
/// `bucket(x)` is below `buckets` and never decreases along that order (the order's leading
/// key, clamped). `items` is called twice (counting, then placing), so no unsorted copy is
/// held. Cost O(n + buckets) plus the buckets' own sorts.
pub(crate) fn bucket_sorted<T, I>(items: impl Fn() -> I, buckets: usize, bucket: impl Fn(&T) -> usize) -> Vec<T>
where
    T: Ord + Copy + Default,
    I: Iterator<Item = T>,
{
    // `start[b]..start[b + 1]` will hold bucket b.
    let mut start = vec![0usize; buckets + 1];
    // `for_each`, not a `for` loop: the callers' iterators are flat maps over filtered
    // triangles, whose internal iteration (`fold`) compiles to plain loops where `next` does
    // not (the orientation's edges: half the cost of this sort).
    items().for_each(|x| start[bucket(&x) + 1] += 1);
    for b in 0..buckets {
        start[b + 1] += start[b];
    }
    let mut fill = start.clone();
    let mut out = vec![T::default(); start[buckets]];
    items().for_each(|x| {
        let b = bucket(&x);
        out[fill[b]] = x;
        fill[b] += 1;
    });
    for b in 0..buckets {
        out[start[b]..start[b + 1]].sort_unstable();
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bucket_sorted_is_the_sorted_list() {
        // Random pairs whose first field is the bucket (many equal, some buckets empty, the
        // last one full), against a comparison sort; fails when a bucket is left unsorted or
        // an item lands in the wrong bucket.
        let mut rng = spherebake_testkit::rng::SplitMix64::new(11);
        for round in 0..40usize {
            let buckets = 1 + round * 3;
            let n = round * 17;
            let items: Vec<(u32, u32)> =
                (0..n).map(|_| ((rng.next_u64() % buckets as u64) as u32, (rng.next_u64() % 50) as u32)).collect();
            let got = bucket_sorted(|| items.iter().copied(), buckets, |x| x.0 as usize);
            let mut want = items.clone();
            want.sort_unstable();
            assert_eq!(got, want, "round {round}");
        }
        assert!(bucket_sorted(std::iter::empty::<(u32, u32)>, 0, |x| x.0 as usize).is_empty());
    }
}
