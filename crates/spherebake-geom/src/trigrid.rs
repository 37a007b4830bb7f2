//! The barycentric grid on a triangle, written once: the fit's dense, descent and seam points and
//! its sparse sample patches all lay the same grid.

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

#[cfg(test)]
mod tests {
    use super::*;

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
}
