//! Triangle primitives, written once: the barycentric grid (the fit's dense and clustering
//! points and its sparse sample patches lay it), the covering samples of a triangle (the voxel
//! solid's surface cells), the choice between the two on slivers (the fit's descent, seam and
//! band points) and the closest point on a triangle (the albedo's coverage test and the geom
//! and bake tests).

use glam::DVec3;

/// The barycentric grid of `m` divisions per edge on triangle (`a`, `b`, `c`): the
/// (m + 1)(m + 2) / 2 points `a + (b − a)·(i/m) + (c − a)·(j/m)` for `i` in `0..=m` and `j` in
/// `0..=m − i`, in that order (`i` outer), each with its `(i, j)`. The corners are `(0, 0)` = a,
/// `(m, 0)` = b and `(0, m)` = c; neighbouring points are the edges' lengths / m apart. `m = 0`
/// gives the one point a. Each point is computed from `a` alone (no accumulation), so the same
/// triangle and `m` give the same bits wherever the grid is laid.
pub fn triangle_grid(a: DVec3, b: DVec3, c: DVec3, m: usize) -> impl Iterator<Item = (usize, usize, DVec3)> {
    let (ab, ac) = (b - a, c - a);
    let mf = m as f64;
    (0..=m).flat_map(move |i| {
        (0..=m - i).map(
            move |j| {
                if m == 0 {
                    (0, 0, a)
                } else {
                    (i, j, a + ab * (i as f64 / mf) + ac * (j as f64 / mf))
                }
            },
        )
    })
}

/// Calls `f` on points of triangle (a, b, c) such that every point of the triangle lies within
/// `spacing` of one: rows from the vertex opposite the shortest edge towards that edge, each row
/// sampled in proportion to its own length. A sliver costs about length / spacing points, not
/// (length / spacing)² as a barycentric grid over its long edges would (issue 17: a fan of 30 000
/// slivers spent 21 s in such a grid). At most 4096 rows and 4096 points per row; non-finite
/// input or spacing gives the apex alone.
pub fn cover_samples(a: DVec3, b: DVec3, c: DVec3, spacing: f64, mut f: impl FnMut(DVec3)) {
    match Rows::new(a, b, c, spacing) {
        Some(rows) => rows.for_each(|p, _| f(p)),
        None => f(Rows::apex(a, b, c).0),
    }
}

/// The rows of [`cover_samples`]: the apex (the corner opposite the shortest edge), the two
/// other corners `p` and `q`, the base |pq|, and `rows` + 1 rows from the apex (row 0) to the
/// base (row `rows`).
struct Rows {
    apex: DVec3,
    p: DVec3,
    q: DVec3,
    base: f64,
    spacing: f64,
    rows: usize,
}

impl Rows {
    /// The apex and the other two corners, and the base's length.
    fn apex(a: DVec3, b: DVec3, c: DVec3) -> (DVec3, DVec3, DVec3, f64) {
        let (ab, bc, ca) = ((b - a).length(), (c - b).length(), (a - c).length());
        if bc <= ab && bc <= ca {
            (a, b, c, bc)
        } else if ca <= ab {
            (b, c, a, ca)
        } else {
            (c, a, b, ab)
        }
    }

    /// `None` for non-finite corners or spacing.
    fn new(a: DVec3, b: DVec3, c: DVec3, spacing: f64) -> Option<Self> {
        let (apex, p, q, base) = Self::apex(a, b, c);
        let long = (p - apex).length().max((q - apex).length());
        if !(long.is_finite() && base.is_finite() && spacing > 0.0) {
            return None;
        }
        let rows = (long / spacing).ceil().clamp(1.0, 4096.0) as usize;
        Some(Self { apex, p, q, base, spacing, rows })
    }

    /// Divisions of row `r` (it holds one point more).
    fn divisions(&self, r: usize) -> usize {
        let s = r as f64 / self.rows as f64;
        (s * self.base / self.spacing).ceil().clamp(1.0, 4096.0) as usize
    }

    /// Points in all rows.
    fn count(&self) -> usize {
        (0..=self.rows).map(|r| self.divisions(r) + 1).sum()
    }

    /// Calls `f` on every row's points, in order, with whether the point is a corner's (row 0
    /// holds the apex twice; the last row's ends are `p` and `q`, given exactly).
    fn for_each(&self, mut f: impl FnMut(DVec3, bool)) {
        let (apex, p, q) = (self.apex, self.p, self.q);
        for r in 0..=self.rows {
            let s = r as f64 / self.rows as f64;
            let (u, v) = (apex + (p - apex) * s, apex + (q - apex) * s);
            let n = self.divisions(r);
            for k in 0..=n {
                let corner = r == 0 || r == self.rows && (k == 0 || k == n);
                f(u + (v - u) * (k as f64 / n as f64), corner);
            }
        }
    }
}

/// How many times the points of [`cover_samples`] a triangle's barycentric grid may hold
/// before [`grid_or_rows`] lays the rows instead.
pub const SLIVER_FACTOR: usize = 2;

/// Points on triangle (a, b, c) at `m` divisions of its longest edge, each with whether it is
/// one of the corners: the barycentric grid ([`triangle_grid`], corners at `(0, 0)`, `(m, 0)`
/// and `(0, m)`) unless it holds more than [`SLIVER_FACTOR`] times the points of
/// [`cover_samples`] at the grid's spacing (longest edge / m); then those rows. Both leave
/// every point of the triangle within about the spacing of one. On a well-shaped triangle the
/// two sets are of a size (a right isosceles triangle at m = 64: the grid's 2145 points against
/// the rows' 1569, so it keeps the grid), but a sliver's grid crowds (m + 1)(m + 2) / 2 points
/// across its short edge where the rows need a few: a cylinder's 20 : 1 side triangle at
/// m = 43 gets 114 points instead of 990. The rows' corners are given exactly (`p`, `q` and
/// the apex as the triangle's own corners). `m` ≤ 1 gives the grid.
pub fn grid_or_rows(a: DVec3, b: DVec3, c: DVec3, m: usize, mut f: impl FnMut(DVec3, bool)) {
    let grid = (m + 1) * (m + 2) / 2;
    if m > 1 {
        let spacing = (b - a).length().max((c - b).length()).max((a - c).length()) / m as f64;
        if let Some(rows) = Rows::new(a, b, c, spacing) {
            if grid > SLIVER_FACTOR * rows.count() {
                let corners = [rows.apex, rows.p, rows.q];
                rows.for_each(|x, corner| if corner { f(snap(x, corners), true) } else { f(x, false) });
                return;
            }
        }
    }
    let corner = |i: usize, j: usize| (i == 0 || i == m) && j == 0 || i == 0 && j == m;
    for (i, j, x) in triangle_grid(a, b, c, m) {
        f(x, corner(i, j));
    }
}

/// The corner of `corners` nearest `x` (the rows' end points, computed as apex + (p − apex)·1,
/// can miss the corner's bits).
fn snap(x: DVec3, corners: [DVec3; 3]) -> DVec3 {
    corners.into_iter().fold(corners[0], |m, y| if x.distance_squared(y) < x.distance_squared(m) { y } else { m })
}

/// Closest point of triangle `t` to `p` (Ericson, Real-Time Collision Detection §5.1.5): the
/// point of the closed triangle nearest to `p`, found by the Voronoi region of `p` (a corner, an
/// edge, or the face by barycentrics). A triangle with two equal corners gives the closest
/// point of its segment; one with three (or collinear corners off every edge region) its
/// corner nearest to `p`.
#[must_use]
pub fn closest_point_on_triangle(p: DVec3, t: &[DVec3; 3]) -> DVec3 {
    closest_point_and_weights(p, t).0
}

/// [`closest_point_on_triangle`] and its barycentric weights (λ_a, λ_b, λ_c), Σ λ = 1, each in
/// [0, 1]: the weights of the Voronoi region that gave the point (one-hot at a corner).
#[must_use]
pub fn closest_point_and_weights(p: DVec3, t: &[DVec3; 3]) -> (DVec3, [f64; 3]) {
    let [a, b, c] = *t;
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = ab.dot(ap);
    let d2 = ac.dot(ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return (a, [1.0, 0.0, 0.0]);
    }
    let bp = p - b;
    let d3 = ab.dot(bp);
    let d4 = ac.dot(bp);
    if d3 >= 0.0 && d4 <= d3 {
        return (b, [0.0, 1.0, 0.0]);
    }
    let vc = d1 * d4 - d3 * d2;
    // Each edge's denominator is its length squared: an edge of length 0 (two equal corners)
    // is left to the other regions, which hold the triangle's segment (0 / 0 gave NaN).
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 && d1 - d3 > 0.0 {
        let v = d1 / (d1 - d3);
        return (a + ab * v, [1.0 - v, v, 0.0]);
    }
    let cp = p - c;
    let d5 = ab.dot(cp);
    let d6 = ac.dot(cp);
    if d6 >= 0.0 && d5 <= d6 {
        return (c, [0.0, 0.0, 1.0]);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 && d2 - d6 > 0.0 {
        let w = d2 / (d2 - d6);
        return (a + ac * w, [1.0 - w, 0.0, w]);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 && (d4 - d3) + (d5 - d6) > 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (b + (c - b) * w, [0.0, 1.0 - w, w]);
    }
    let denom = va + vb + vc;
    if denom == 0.0 || !denom.is_finite() {
        // Degenerate triangle: the nearest corner is as good as any point.
        let i = (0..3).fold(0, |m, i| if (t[i] - p).length_squared() < (t[m] - p).length_squared() { i } else { m });
        let mut l = [0.0; 3];
        l[i] = 1.0;
        return (t[i], l);
    }
    let v = vb / denom;
    let w = vc / denom;
    // Inside the face v, w ≥ 0 and v + w ≤ 1 up to rounding: held there for the weights.
    let (lv, lw) = (v.clamp(0.0, 1.0), w.clamp(0.0, 1.0 - v.clamp(0.0, 1.0)));
    (a + ab * v + ac * w, [1.0 - lv - lw, lv, lw])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A triangle with two equal corners (in each position) is the segment between its two
    /// distinct corners: the closest point is the segment's, against its analytic clamp, and
    /// finite (0 / 0 gave NaN off the zero-length edge); the weights reproduce it.
    #[test]
    fn a_triangle_with_two_equal_corners_gives_the_closest_point_of_its_segment() {
        let mut rng = crate::rng::SplitMix64::new(21);
        for n in 0..300 {
            let mut r = || DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64()) * 4.0 - 2.0;
            let (a, c, p) = (r(), r(), r());
            let s = ((p - a).dot(c - a) / (c - a).length_squared()).clamp(0.0, 1.0);
            let want = a + (c - a) * s;
            for t in [[a, a, c], [a, c, a], [c, a, a]] {
                let (q, l) = closest_point_and_weights(p, &t);
                assert!((q - want).length() < 1e-12, "{n}: {t:?} from {p}: {q}, segment {want}");
                assert_eq!(q, closest_point_on_triangle(p, &t));
                let back = t[0] * l[0] + t[1] * l[1] + t[2] * l[2];
                assert!((back - q).length() < 1e-12 && (l.iter().sum::<f64>() - 1.0).abs() < 1e-12, "{n}");
            }
        }
    }

    #[test]
    fn grid_counts_corners_and_spacing() {
        let (a, b, c) = (DVec3::new(1.0, 2.0, 3.0), DVec3::new(5.0, 2.0, 3.0), DVec3::new(1.0, 2.0, 7.0));
        for m in 0..6 {
            let pts: Vec<(usize, usize, DVec3)> = triangle_grid(a, b, c, m).collect();
            assert_eq!(pts.len(), (m + 1) * (m + 2) / 2, "m = {m}");
            assert_eq!(pts[0], (0, 0, a));
            if m > 0 {
                assert!(pts.contains(&(m, 0, b)) && pts.contains(&(0, m, c)), "m = {m}");
            }
            for &(i, j, p) in &pts {
                assert!(i + j <= m);
                // A right triangle with legs 4 along x and z: the point is (1 + 4i/m, 2, 3 + 4j/m).
                if m > 0 {
                    let want = DVec3::new(1.0 + 4.0 * i as f64 / m as f64, 2.0, 3.0 + 4.0 * j as f64 / m as f64);
                    assert!((p - want).length() < 1e-14, "{p} vs {want}");
                }
            }
        }
        // Order: i outer, j inner.
        let ij: Vec<(usize, usize)> = triangle_grid(a, b, c, 2).map(|(i, j, _)| (i, j)).collect();
        assert_eq!(ij, [(0, 0), (0, 1), (0, 2), (1, 0), (1, 1), (2, 0)]);
    }

    #[test]
    fn closest_point_matches_dense_sampling() {
        let t = [DVec3::new(0.0, 0.0, 0.0), DVec3::new(2.0, 0.1, 0.0), DVec3::new(0.3, 1.5, 0.4)];
        for p in [
            DVec3::new(1.0, 0.5, 2.0),
            DVec3::new(-1.0, -1.0, 0.0),
            DVec3::new(3.0, 0.0, 0.0),
            DVec3::new(1.5, 1.5, -0.5),
        ] {
            let q = closest_point_on_triangle(p, &t);
            let mut best = f64::INFINITY;
            let m = 400;
            for (_, _, x) in triangle_grid(t[0], t[1], t[2], m) {
                best = best.min((x - p).length());
            }
            assert!((q - p).length() <= best + 1e-12 && (q - p).length() > best - 5e-3, "{p}");
        }
    }

    #[test]
    fn cover_samples_cover_the_triangle_and_a_sliver_costs_its_length() {
        let tris = [
            [DVec3::ZERO, DVec3::X, DVec3::Y],
            [DVec3::ZERO, DVec3::new(2.0, 0.0, 0.0), DVec3::new(2.0, 0.002, 0.0)],
            [DVec3::new(0.3, -1.0, 0.5), DVec3::new(-0.7, 0.4, 1.0), DVec3::new(1.1, 0.9, -0.2)],
        ];
        let spacing = 0.05;
        for [a, b, c] in tris {
            let mut pts = Vec::new();
            cover_samples(a, b, c, spacing, |p| pts.push(p));
            let m = 200;
            for (_, _, x) in triangle_grid(a, b, c, m) {
                let d = pts.iter().map(|p| p.distance(x)).fold(f64::INFINITY, f64::min);
                assert!(d <= spacing, "{x} is {d} from the nearest sample");
            }
        }
        let mut n = 0;
        cover_samples(tris[1][0], tris[1][1], tris[1][2], spacing, |_| n += 1);
        assert!(n <= 2 * (2.0 / spacing) as usize + 4, "a sliver of length 2: {n} samples");
    }

    #[test]
    fn grid_or_rows_keeps_the_grid_on_well_shaped_triangles_and_lays_rows_on_slivers() {
        let corner_of = |m: usize, i: usize, j: usize| (i == 0 || i == m) && j == 0 || i == 0 && j == m;
        let collect = |t: [DVec3; 3], m: usize| {
            let mut v = Vec::new();
            grid_or_rows(t[0], t[1], t[2], m, |p, k| v.push((p, k)));
            v
        };
        // Well-shaped triangles: the grid itself, point for point, corners flagged as (i, j) says.
        let shapely = [
            [DVec3::new(0.3, -1.0, 0.5), DVec3::new(-0.7, 0.4, 1.0), DVec3::new(1.1, 0.9, -0.2)],
            [DVec3::ZERO, DVec3::X, DVec3::Y],
        ];
        for t in shapely {
            for m in [0, 1, 2, 7, 64] {
                let want: Vec<(DVec3, bool)> =
                    triangle_grid(t[0], t[1], t[2], m).map(|(i, j, p)| (p, corner_of(m, i, j))).collect();
                assert_eq!(collect(t, m), want, "m = {m}");
            }
        }
        // A cylinder's side triangle: 2 long, 0.098 across (32 sides of radius 0.5).
        // (Corners where apex + (p − apex)·1 misses p's bits: 2.021 + 0.47 ≠ 2.491.)
        let t = [DVec3::new(0.47, 0.34, -0.38), DVec3::new(2.491, 0.342, -0.38), DVec3::new(2.491, 0.44, -0.38)];
        let m = 43;
        let spacing = t[0].distance(t[2]) / m as f64;
        let pts = collect(t, m);
        let grid = (m + 1) * (m + 2) / 2;
        assert!(pts.len() * SLIVER_FACTOR < grid, "{} points against the grid's {grid}", pts.len());
        // Rows about `spacing` apart along the length, a few points each.
        assert!(pts.len() <= 3 * (2.0 / spacing).ceil() as usize + 6, "{} points", pts.len());
        for &(p, _) in &pts {
            assert!(closest_point_on_triangle(p, &t).distance(p) < 1e-12, "{p} is off the triangle");
        }
        for (_, _, x) in triangle_grid(t[0], t[1], t[2], 400) {
            let d = pts.iter().map(|(p, _)| p.distance(x)).fold(f64::INFINITY, f64::min);
            assert!(d <= spacing, "{x} is {d} from the nearest point");
        }
        // The corners: each given exactly and flagged, and nothing else flagged.
        for c in t {
            assert!(pts.contains(&(c, true)), "corner {c} missing");
        }
        for &(p, k) in &pts {
            assert_eq!(k, t.contains(&p), "{p} flagged {k}");
        }
    }
}
