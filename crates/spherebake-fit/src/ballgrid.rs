//! Uniform grid over balls, for the fit's "which spheres can contain or reach this point"
//! queries. Without it those queries scanned every sphere for every point (power assignment,
//! coverage checks, the pocket search), so a fit cost O(points × spheres) per pass and
//! `--spheres 4096` on a 12-triangle cube ran for over ten minutes (issue 17).
//!
//! Each ball (centre c, reach R) is listed in every cell its box [c − R, c + R] overlaps, so a
//! point p with |p − c| ≤ R is always found in the list of p's cell: queries return a superset
//! of the balls that can contain p, in increasing index order, and callers apply their exact
//! test to those only. Results are therefore identical to the full scan (same candidates in the
//! same order, ties broken the same way).
//!
//! Cost: building is O(n + entries); the cell edge is about twice the median reach (at least
//! the box extent over ∛(8n)), enlarged until the lists hold at most 32 entries per ball on
//! average and the grid at most [`MAX_CELLS`] cells, so memory is O(n) whatever the radii.

use glam::DVec3;

/// Cells of a grid at most (4 bytes each for the list offsets).
const MAX_CELLS: usize = 1 << 21;

pub(crate) struct BallGrid {
    origin: DVec3,
    cell: f64,
    dims: [usize; 3],
    /// CSR: the balls of cell `i` are `items[start[i]..start[i + 1]]`, increasing.
    start: Vec<u32>,
    items: Vec<u32>,
    /// Balls with a non-finite centre or reach: listed nowhere, returned by every query.
    everywhere: Vec<u32>,
}

impl BallGrid {
    /// Grid over `balls` (centre, reach radius ≥ 0; a negative reach lists the ball nowhere).
    pub(crate) fn new(balls: &[(DVec3, f64)]) -> Self {
        let finite = |b: &(DVec3, f64)| b.0.is_finite() && b.1.is_finite();
        // Boxes padded by 1e-9 of the reach (and 1e-12 of the coordinates) so a point the
        // caller's rounded distance test puts inside a ball is inside its box too.
        let reach_of = |b: &(DVec3, f64)| b.1 * (1.0 + 1e-9) + 1e-12 * b.0.abs().max_element();
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        let mut reach: Vec<f64> = Vec::with_capacity(balls.len());
        for b in balls.iter().filter(|b| finite(b) && b.1 >= 0.0) {
            lo = lo.min(b.0 - reach_of(b));
            hi = hi.max(b.0 + reach_of(b));
            reach.push(b.1);
        }
        let everywhere: Vec<u32> =
            balls.iter().enumerate().filter(|(_, b)| !finite(b)).map(|(i, _)| i as u32).collect();
        if reach.is_empty() {
            return Self {
                origin: DVec3::ZERO,
                cell: 1.0,
                dims: [1, 1, 1],
                start: vec![0, 0],
                items: Vec::new(),
                everywhere,
            };
        }
        let ext = (hi - lo).max(DVec3::splat(f64::MIN_POSITIVE));
        let n = reach.len();
        let mid = n / 2;
        let median = *reach.select_nth_unstable_by(mid, |a, b| a.total_cmp(b)).1;
        let floor = ext.max_element() / (8.0 * n as f64).cbrt();
        let mut cell = (2.0 * median).max(floor).max(f64::MIN_POSITIVE);
        loop {
            let d = (ext / cell).floor() + 1.0;
            let cells = d.x * d.y * d.z;
            let entries: f64 = balls
                .iter()
                .filter(|b| finite(b) && b.1 >= 0.0)
                .map(|b| {
                    let a = ((b.0 - reach_of(b) - lo) / cell).floor();
                    let z = ((b.0 + reach_of(b) - lo) / cell).floor();
                    let s = (z - a + 1.0).min(d);
                    s.x * s.y * s.z
                })
                .sum();
            if (cells <= MAX_CELLS as f64 && entries <= 32.0 * n as f64) || cells <= 1.0 {
                break;
            }
            cell *= 1.5;
        }
        let dims = [
            ((ext.x / cell).floor() as usize + 1).max(1),
            ((ext.y / cell).floor() as usize + 1).max(1),
            ((ext.z / cell).floor() as usize + 1).max(1),
        ];
        let mut g = Self { origin: lo, cell, dims, start: Vec::new(), items: Vec::new(), everywhere };
        let n_cells = dims[0] * dims[1] * dims[2];
        let mut count = vec![0u32; n_cells + 1];
        let ranges: Vec<Option<([usize; 3], [usize; 3])>> = balls
            .iter()
            .map(|b| (finite(b) && b.1 >= 0.0).then(|| (g.coords(b.0 - reach_of(b)), g.coords(b.0 + reach_of(b)))))
            .collect();
        for r in ranges.iter().flatten() {
            g.for_cells(r.0, r.1, |c| count[c + 1] += 1);
        }
        for i in 0..n_cells {
            count[i + 1] += count[i];
        }
        let mut fill = count.clone();
        let mut items = vec![0u32; count[n_cells] as usize];
        for (i, r) in ranges.iter().enumerate() {
            if let Some(r) = r {
                g.for_cells(r.0, r.1, |c| {
                    items[fill[c] as usize] = i as u32;
                    fill[c] += 1;
                });
            }
        }
        g.start = count;
        g.items = items;
        g
    }

    fn coords(&self, p: DVec3) -> [usize; 3] {
        let u = (p - self.origin) / self.cell;
        // ⌊x⌋ clamped to the grid: a cast floors a non-negative value and sends a negative one
        // or NaN to 0 (no library call for the floor). Cast to u32, which a dimension (at most
        // MAX_CELLS cells) fits: the same index as a cast to usize (both saturate beyond the
        // grid) in about half the instructions (a usize cast handles values ≥ 2⁶³ apart).
        let c = |x: f64, n: usize| (x as u32 as usize).min(n - 1);
        [c(u.x, self.dims[0]), c(u.y, self.dims[1]), c(u.z, self.dims[2])]
    }

    fn for_cells(&self, a: [usize; 3], b: [usize; 3], mut f: impl FnMut(usize)) {
        for k in a[2]..=b[2] {
            for j in a[1]..=b[1] {
                let row = self.dims[0] * (j + self.dims[1] * k);
                for i in a[0]..=b[0] {
                    f(row + i);
                }
            }
        }
    }

    /// From now on ball `i` is returned by every query (it outgrew the reach it is listed with).
    pub(crate) fn list_everywhere(&mut self, i: u32) {
        if let Err(at) = self.everywhere.binary_search(&i) {
            self.everywhere.insert(at, i);
        }
    }

    /// Balls that can contain `p` (|p − c| ≤ R), a superset, in increasing index order (balls
    /// with non-finite values, if any, last).
    pub(crate) fn at(&self, p: DVec3, out: &mut Vec<u32>) {
        out.clear();
        if p.is_finite() {
            let [i, j, k] = self.coords(p);
            let c = i + self.dims[0] * (j + self.dims[1] * k);
            out.extend_from_slice(&self.items[self.start[c] as usize..self.start[c + 1] as usize]);
        } else {
            // A non-finite point: every ball (the caller's exact test decides).
            out.extend(self.items.iter().copied());
            out.sort_unstable();
            out.dedup();
        }
        out.extend_from_slice(&self.everywhere);
    }

    /// Balls whose box meets the box [c − r, c + r] (a superset of those with
    /// |c − c_j| ≤ r + R_j), in increasing index order.
    pub(crate) fn near(&self, c: DVec3, r: f64, out: &mut Vec<u32>) {
        out.clear();
        if c.is_finite() && r.is_finite() {
            let r = r.max(0.0) * (1.0 + 1e-9);
            let (a, b) = (self.coords(c - r), self.coords(c + r));
            self.for_cells(a, b, |cell| {
                out.extend_from_slice(&self.items[self.start[cell] as usize..self.start[cell + 1] as usize])
            });
        } else {
            out.extend(self.items.iter().copied());
        }
        out.extend_from_slice(&self.everywhere);
        sort_dedup(out);
    }
}

/// Sorts `ids` increasing and removes repeats: by a sort when the list is short next to the
/// largest id, else by marking the ids in a bit set and reading it back in order (O(len +
/// max id / 64); a query near a large piece lists each ball once per cell it shares with the
/// query's box, and sorting those lists was 6 % of a bake of the open RiggedSimple). The same
/// list either way.
fn sort_dedup(ids: &mut Vec<u32>) {
    let Some(&max) = ids.iter().max() else { return };
    let words = max as usize / 64 + 1;
    if ids.len() < 32 || words > 4 * ids.len() {
        ids.sort_unstable();
        ids.dedup();
        return;
    }
    thread_local! {
        static MARKS: std::cell::RefCell<Vec<u64>> = const { std::cell::RefCell::new(Vec::new()) };
    }
    MARKS.with_borrow_mut(|marks| {
        marks.clear();
        marks.resize(words, 0);
        for &i in ids.iter() {
            marks[i as usize / 64] |= 1 << (i % 64);
        }
        ids.clear();
        for (w, &word) in marks.iter().enumerate() {
            let mut x = word;
            while x != 0 {
                ids.push((w * 64) as u32 + x.trailing_zeros());
                x &= x - 1;
            }
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::SplitMix64;

    /// A point's cell against the cast to usize (the cell ⌊x⌋ clamped to the grid) written
    /// apart, for points inside, around and far beyond the grid (past 2³² and 2⁶³ cells),
    /// on cell faces, and not finite.
    #[test]
    fn coords_are_the_clamped_floor() {
        let mut rng = SplitMix64::new(41);
        let balls: Vec<(DVec3, f64)> = (0..300)
            .map(|_| (DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64()) * 10.0, 0.3 * rng.next_f64()))
            .collect();
        let g = BallGrid::new(&balls);
        let want = |p: DVec3| {
            let u = (p - g.origin) / g.cell;
            let c = |x: f64, n: usize| (x as usize).min(n - 1);
            [c(u.x, g.dims[0]), c(u.y, g.dims[1]), c(u.z, g.dims[2])]
        };
        let mut ps: Vec<DVec3> = (0..3000)
            .map(|i| {
                let s = [1.0, 2.0, 1e9, 1e20][i % 4];
                DVec3::new(rng.next_f64() - 0.3, rng.next_f64() - 0.3, rng.next_f64() - 0.3) * 12.0 * s
            })
            .collect();
        ps.extend((0..8).map(|i| g.origin + DVec3::splat(i as f64 * g.cell)));
        ps.extend([DVec3::NAN, DVec3::INFINITY, DVec3::NEG_INFINITY, DVec3::new(f64::NAN, 1.0, -1e300)]);
        for p in ps {
            assert_eq!(g.coords(p), want(p), "{p}");
        }
    }

    #[test]
    fn sort_dedup_gives_the_ordered_set_of_the_ids() {
        // Lists short and long, ids dense and sparse, against a BTreeSet: both branches (sort
        // and bit set) are taken.
        let mut rng = SplitMix64::new(17);
        let mut by_marks = 0;
        for round in 0..400 {
            let len = (rng.next_f64() * 300.0) as usize;
            let max = [8u32, 64, 500, 5000, 100_000][round % 5];
            let ids: Vec<u32> = (0..len).map(|_| (rng.next_f64() * max as f64) as u32).collect();
            let want: Vec<u32> = ids.iter().copied().collect::<std::collections::BTreeSet<_>>().into_iter().collect();
            let mut got = ids.clone();
            sort_dedup(&mut got);
            assert_eq!(got, want, "{len} ids below {max}");
            let top = ids.iter().max().map_or(0, |&m| m as usize / 64 + 1);
            by_marks += usize::from(len >= 32 && top <= 4 * len);
        }
        assert!(by_marks > 100, "{by_marks} lists took the bit set");
    }

    #[test]
    fn queries_find_every_ball_the_full_scan_finds() {
        // Random balls of very different sizes (one huge, several of radius 0), random points
        // in and around them: the grid's candidates contain every ball a brute-force scan
        // finds, for both queries.
        let mut rng = SplitMix64::new(3);
        let mut u = || rng.next_f64();
        let mut balls: Vec<(DVec3, f64)> = (0..500)
            .map(|i| {
                let c = DVec3::new(u(), u(), u()) * 10.0;
                let r = if i % 50 == 0 { 0.0 } else { 0.05 + 0.6 * u() * u() };
                (c, r)
            })
            .collect();
        balls.push((DVec3::splat(5.0), 4.0));
        balls.push((DVec3::new(f64::NAN, 0.0, 0.0), 1.0));
        let g = BallGrid::new(&balls);
        let mut out = Vec::new();
        let mut total = 0;
        for _ in 0..4000 {
            let p = DVec3::new(u(), u(), u()) * 12.0 - 1.0;
            g.at(p, &mut out);
            for (i, b) in balls.iter().enumerate() {
                if p.distance(b.0) <= b.1 {
                    assert!(out.contains(&(i as u32)), "ball {i} contains {p} but is not a candidate");
                    total += 1;
                }
            }
            assert!(out.contains(&501), "the non-finite ball is always a candidate");
            let r = 0.3 * u();
            g.near(p, r, &mut out);
            assert!(out.windows(2).all(|w| w[0] < w[1]), "increasing, no duplicates");
            for (i, b) in balls.iter().enumerate() {
                if p.distance(b.0) <= r + b.1 {
                    assert!(out.contains(&(i as u32)), "ball {i} reaches within {r} of {p}");
                }
            }
        }
        assert!(total > 300, "the points do fall in balls ({total})");
        // The lists stay small: a typical point sees far fewer than all balls.
        g.at(DVec3::splat(1.0), &mut out);
        assert!(out.len() < 100, "{}", out.len());
    }

    #[test]
    fn degenerate_inputs_give_a_valid_grid() {
        let mut out = Vec::new();
        let empty = BallGrid::new(&[]);
        empty.at(DVec3::ZERO, &mut out);
        assert!(out.is_empty());
        // All balls at one point with radius 0.
        let same = BallGrid::new(&[(DVec3::ONE, 0.0); 5]);
        same.at(DVec3::ONE, &mut out);
        assert_eq!(out, vec![0, 1, 2, 3, 4]);
        same.near(DVec3::ZERO, 0.1, &mut out);
        assert_eq!(out, vec![0, 1, 2, 3, 4], "clamped to the one cell: a superset");
    }
}
