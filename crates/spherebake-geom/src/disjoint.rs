//! Disjoint sets over `0..n` as a parent array (`parent[i] = i` to start): [`find`] with path
//! halving and [`union`] keeping the lower root, so the root of a set is its least member
//! and the result does not depend on the order of the unions' arguments.

/// The root of `x`'s set (its least member), halving the path on the way.
pub fn find(parent: &mut [usize], mut x: usize) -> usize {
    while parent[x] != x {
        parent[x] = parent[parent[x]];
        x = parent[x];
    }
    x
}

/// Joins the sets of `a` and `b` under the lower root; false when they were one set already.
pub fn union(parent: &mut [usize], a: usize, b: usize) -> bool {
    let (ra, rb) = (find(parent, a), find(parent, b));
    if ra == rb {
        return false;
    }
    let (lo, hi) = if ra < rb { (ra, rb) } else { (rb, ra) };
    parent[hi] = lo;
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Random unions against a brute-force relabelling: the same sets, each rooted at its
    /// least member.
    #[test]
    fn sets_are_those_of_the_unions_rooted_at_their_least_member() {
        let mut rng = crate::rng::SplitMix64::new(9);
        for _ in 0..50 {
            let n = 1 + rng.below(30) as usize;
            let mut parent: Vec<usize> = (0..n).collect();
            let mut label: Vec<usize> = (0..n).collect();
            for _ in 0..rng.below(40) {
                let (a, b) = (rng.below(n as u64) as usize, rng.below(n as u64) as usize);
                let (la, lb) = (label[a], label[b]);
                assert_eq!(union(&mut parent, a, b), la != lb);
                let keep = la.min(lb);
                for l in &mut label {
                    if *l == la || *l == lb {
                        *l = keep;
                    }
                }
            }
            for (i, &l) in label.iter().enumerate() {
                assert_eq!(find(&mut parent, i), l);
            }
        }
    }
}
