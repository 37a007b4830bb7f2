//! f64 sphere geometry for sphere sets (math reference §6): ball, cap and lens volumes, the
//! smallest sphere around two spheres, minimal enclosing balls of points (Welzl, move-to-front)
//! and of balls (support-set iteration).
//!
//! Radii and lengths are in the caller's units (model space); volumes in units³.
//! Nothing here panics; non-finite input gives non-finite output.

use glam::DVec3;
use std::f64::consts::PI;

/// Volume of a ball of radius `r`: 4/3 π r³.
pub fn ball_volume(r: f64) -> f64 {
    4.0 / 3.0 * PI * r * r * r
}

/// Volume of a spherical cap of height `h` cut from a ball of radius `r`: π h² (3r − h) / 3.
/// `h` is clamped to `[0, 2r]` (0 → empty, 2r → the whole ball).
pub fn cap_volume(r: f64, h: f64) -> f64 {
    let h = h.clamp(0.0, 2.0 * r.max(0.0));
    PI * h * h * (3.0 * r - h) / 3.0
}

/// Volume of the intersection of two balls with radii `r1`, `r2` and centre distance `d`.
/// Disjoint (d ≥ r1 + r2) → 0; nested (d ≤ |r1 − r2|) → the smaller ball.
pub fn lens_volume(r1: f64, r2: f64, d: f64) -> f64 {
    let d = d.abs();
    if d >= r1 + r2 {
        return 0.0;
    }
    if d <= (r1 - r2).abs() {
        return ball_volume(r1.min(r2));
    }
    let s = r1 + r2 - d;
    PI * s * s * (d * d + 2.0 * d * (r1 + r2) - 3.0 * (r1 - r2) * (r1 - r2)) / (12.0 * d)
}

/// Smallest sphere containing the spheres (c1, r1) and (c2, r2); returns (centre, radius).
pub fn sphere_pair_bound(c1: DVec3, r1: f64, c2: DVec3, r2: f64) -> (DVec3, f64) {
    let d = c1.distance(c2);
    if d + r2 <= r1 {
        return (c1, r1);
    }
    if d + r1 <= r2 {
        return (c2, r2);
    }
    let r = (d + r1 + r2) / 2.0;
    (c1 + (c2 - c1) * ((r - r1) / d), r)
}

/// Centre of the smallest sphere through the points `support` with its centre in their affine
/// hull (1 point: itself; 2: midpoint; 3: circumcentre in their plane; 4: circumsphere).
/// `None` if the points are (numerically) affinely dependent. At most 4 points (panics on
/// more); no allocation (the move-to-front recursion calls it at every support change).
fn circumsphere(support: &[DVec3]) -> Option<(DVec3, f64)> {
    let p0 = *support.first()?;
    let k = support.len() - 1;
    if k == 0 {
        return Some((p0, 0.0));
    }
    let mut v = [DVec3::ZERO; 3];
    for (vj, p) in v.iter_mut().zip(&support[1..=k]) {
        *vj = *p - p0;
    }
    // Solve G λ = b with G_jl = 2 v_j·v_l, b_j = |v_j|²; centre = p0 + Σ λ_l v_l.
    let mut g = [[0.0f64; 4]; 3];
    for j in 0..k {
        for l in 0..k {
            g[j][l] = 2.0 * v[j].dot(v[l]);
        }
        g[j][3] = v[j].length_squared();
    }
    let lambda = solve_small(&mut g, k)?;
    let mut c = p0;
    for l in 0..k {
        c += v[l] * lambda[l];
    }
    Some((c, support.iter().map(|p| p.distance(c)).fold(0.0, f64::max)))
}

/// Gaussian elimination with partial pivoting on an augmented k×(k+1) system (k ≤ 3, the
/// right-hand side in column 3). `None` when the matrix is numerically singular.
#[allow(clippy::needless_range_loop)]
fn solve_small(m: &mut [[f64; 4]; 3], k: usize) -> Option<[f64; 3]> {
    let scale = (0..k).flat_map(|i| (0..k).map(move |j| (i, j))).map(|(i, j)| m[i][j].abs()).fold(0.0, f64::max);
    if scale.is_nan() || scale <= 0.0 || !scale.is_finite() {
        return None;
    }
    for col in 0..k {
        let piv = (col..k).max_by(|&a, &b| m[a][col].abs().total_cmp(&m[b][col].abs()))?;
        if m[piv][col].abs() <= 1e-12 * scale {
            return None;
        }
        m.swap(col, piv);
        for row in col + 1..k {
            let f = m[row][col] / m[col][col];
            for c in col..k {
                m[row][c] -= f * m[col][c];
            }
            m[row][3] -= f * m[col][3];
        }
    }
    let mut x = [0.0; 3];
    for row in (0..k).rev() {
        let mut s = m[row][3];
        for c in row + 1..k {
            s -= m[row][c] * x[c];
        }
        x[row] = s / m[row][row];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

fn normalize(v: [f32; 3]) -> [f32; 3] {
    let inv = 1.0 / (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    [v[0] * inv, v[1] * inv, v[2] * inv]
}

/// Unit icosphere (radius 1, centre 0), written once (the glTF export's sphere shape and the
/// geom and bake tests' meshes): the icosahedron subdivided `levels` times, each edge
/// midpoint pushed to the sphere; 10·4^levels + 2 vertices, 20·4^levels outward counter-clockwise
/// triangles. Each triangle (a, b, c) with midpoints (m_ab, m_bc, m_ca) becomes
/// (a, m_ab, m_ca), (b, m_bc, m_ab), (c, m_ca, m_bc), (m_ab, m_bc, m_ca); midpoints are numbered
/// in order of first use.
#[must_use]
pub fn icosphere(levels: usize) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let mut v: Vec<[f32; 3]> = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ]
    .into_iter()
    .map(normalize)
    .collect();
    let mut f: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..levels {
        let mut mid = std::collections::BTreeMap::new();
        let mut next = Vec::with_capacity(f.len() * 4);
        for tri in &f {
            let mut m = [0u32; 3];
            for e in 0..3 {
                let (a, b) = (tri[e], tri[(e + 1) % 3]);
                m[e] = *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                    let (pa, pb) = (v[a as usize], v[b as usize]);
                    v.push(normalize([(pa[0] + pb[0]) * 0.5, (pa[1] + pb[1]) * 0.5, (pa[2] + pb[2]) * 0.5]));
                    (v.len() - 1) as u32
                });
            }
            next.extend([[tri[0], m[0], m[2]], [tri[1], m[1], m[0]], [tri[2], m[2], m[1]], m]);
        }
        f = next;
    }
    (v, f)
}

/// The principal axes of points: the unit eigenvectors of their covariance matrix, largest
/// eigenvalue (the direction of largest spread) first, by cyclic Jacobi rotations on the
/// 3 × 3 matrix (at most 32 sweeps; quadratic convergence, so 4–6 in practice); orthonormal.
/// Deterministic; each axis's sign is fixed so that its largest-magnitude component is
/// positive. `None` for fewer than two finite points or when they all coincide (no spread).
/// Covariance terms off the diagonal below 1e-12 of its trace count as zero, so a box's
/// points (along x, y, z) give x, y and z; where eigenvalues are equal otherwise (a sphere's
/// points) any basis of that eigenspace may come back.
pub fn principal_axes(points: &[DVec3]) -> Option<[DVec3; 3]> {
    let (mut n, mut sum) = (0usize, DVec3::ZERO);
    for p in points.iter().filter(|p| p.is_finite()) {
        n += 1;
        sum += *p;
    }
    let first = points.iter().find(|p| p.is_finite());
    if n < 2 || points.iter().filter(|p| p.is_finite()).all(|p| Some(p) == first) {
        return None;
    }
    let mean = sum / n as f64;
    let (mut sq, mut cross) = (DVec3::ZERO, DVec3::ZERO);
    for p in points.iter().filter(|p| p.is_finite()) {
        let d = *p - mean;
        sq += d * d;
        cross += DVec3::new(d.x * d.y, d.x * d.z, d.y * d.z);
    }
    let mut a = [[sq.x, cross.x, cross.y], [cross.x, sq.y, cross.z], [cross.y, cross.z, sq.z]];
    let trace = sq.x + sq.y + sq.z;
    if !trace.is_finite() || trace <= 0.0 {
        return None;
    }
    // Columns of v: the eigenvectors.
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    // Off-diagonal terms below 1e-12 of the trace count as zero: a box's or a symmetric
    // cell's covariance is diagonal up to rounding, and rotating on rounding between equal
    // eigenvalues would turn its axes by 45° at random.
    let tiny = 1e-12 * trace;
    for _sweep in 0..32 {
        let off = a[0][1].abs() + a[0][2].abs() + a[1][2].abs();
        if off <= tiny {
            break;
        }
        for (p, q) in [(0usize, 1usize), (0, 2), (1, 2)] {
            if a[p][q].abs() <= tiny {
                continue;
            }
            // The rotation that zeroes a[p][q] (Golub & Van Loan, the symmetric Schur step).
            let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
            let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
            let c = 1.0 / (t * t + 1.0).sqrt();
            let s = t * c;
            for row in &mut a {
                let (akp, akq) = (row[p], row[q]);
                row[p] = c * akp - s * akq;
                row[q] = s * akp + c * akq;
            }
            let (row_p, row_q) = (a[p], a[q]);
            for (k, (apk, aqk)) in row_p.into_iter().zip(row_q).enumerate() {
                a[p][k] = c * apk - s * aqk;
                a[q][k] = s * apk + c * aqk;
            }
            for row in &mut v {
                let (vp, vq) = (row[p], row[q]);
                row[p] = c * vp - s * vq;
                row[q] = s * vp + c * vq;
            }
        }
    }
    // Largest eigenvalue first (the earliest column on a tie).
    let mut order = [0usize, 1, 2];
    order.sort_by(|&i, &j| a[j][j].total_cmp(&a[i][i]));
    let mut axes = [DVec3::ZERO; 3];
    for (axis, &col) in axes.iter_mut().zip(&order) {
        let e = DVec3::new(v[0][col], v[1][col], v[2][col]).normalize_or_zero();
        if e == DVec3::ZERO {
            return None;
        }
        let arr = e.to_array();
        let big = (0..3).fold(0, |b, i| if arr[i].abs() > arr[b].abs() { i } else { b });
        *axis = if arr[big] < 0.0 { -e } else { e };
    }
    Some(axes)
}

/// Minimal enclosing ball of points (Welzl 1991, Gärtner's move-to-front form: recursion depth
/// ≤ 4 whatever the number of points). Deterministic: one shuffle with a fixed seed.
/// Returns (centre, radius); empty input → (0, 0). The radius is finally raised to the largest
/// point distance, so every point is inside. Duplicates and cospherical sets are fine: a point
/// within 1e-12 · scale of the current ball counts as inside.
pub fn min_enclosing_ball(points: &[DVec3]) -> (DVec3, f64) {
    min_enclosing_ball_of(points.iter().copied())
}

/// [`min_enclosing_ball`] of the points `points` yields, without a slice of them made first
/// (the split starts ask for the balls of many subsets of one point set). The same ball, bit
/// for bit: the finite points are shuffled in place by the same swaps the index shuffle made
/// (so the same list), and the scale and the final radius are maxima, whatever the order.
pub fn min_enclosing_ball_of(points: impl Iterator<Item = DVec3>) -> (DVec3, f64) {
    let mut list: Vec<DVec3> = Vec::with_capacity(points.size_hint().0);
    list.extend(points.filter(|p| p.is_finite()));
    if list.is_empty() {
        return (DVec3::ZERO, 0.0);
    }
    // Fixed seed: the one shuffle Welzl's expected-linear bound needs.
    let mut rng = crate::rng::SplitMix64::new(0x5EED_5BE2_E0B1_BA11);
    for i in (1..list.len()).rev() {
        let j = (rng.next_u64() % (i as u64 + 1)) as usize;
        list.swap(i, j);
    }
    let scale = list.iter().map(|p| p.abs().max_element()).fold(0.0, f64::max).max(f64::MIN_POSITIVE);
    let tol = 1e-12 * scale;
    let mut support: Vec<DVec3> = Vec::with_capacity(4);
    let (start, n) = ((list[0], -1.0), list.len());
    let (c, _) = mtf_mb(&mut list, n, &mut support, start, tol);
    let r = list.iter().map(|p| p.distance(c)).fold(0.0, f64::max);
    (c, r)
}

/// The minimal ball of `list[..end]` with the points of `support` on its boundary, starting
/// from `ball`: the circumsphere of `support` (the caller computed it to know the support is
/// affinely independent, so it is not solved twice), or (list[0], −1) with no support.
fn mtf_mb(list: &mut [DVec3], end: usize, support: &mut Vec<DVec3>, mut ball: (DVec3, f64), tol: f64) -> (DVec3, f64) {
    if support.len() == 4 {
        return ball;
    }
    let mut i = 0;
    while i < end {
        let p = list[i];
        if ball.1 < 0.0 || p.distance(ball.0) > ball.1 + tol {
            support.push(p);
            let candidate = circumsphere(support).map(|b| mtf_mb(list, i, support, b, tol));
            support.pop();
            if let Some(b) = candidate {
                ball = b;
                // Move p to the front.
                list[..=i].rotate_right(1);
            }
        }
        i += 1;
    }
    if ball.1 < 0.0 {
        ball.1 = 0.0;
    }
    ball
}

/// Minimal ball enclosing balls `(centre, radius)` (radii ≥ 0; negative radii count as 0).
///
/// Support-set iteration: keep the ≤ 4 balls that define the current minimal ball, add the most
/// violating input ball, recompute the minimal ball of that ≤ 5-set exactly (every subset's
/// internally tangent ball, solved in closed form: a linear system plus one quadratic), repeat
/// until no ball sticks out by more than 1e-12 · scale. The radius only grows, so it terminates.
/// Finally the radius is raised to max(|c − cᵢ| + rᵢ) · (1 + 1e-14), so every input ball is inside.
/// Empty input → (0, 0).
pub fn min_enclosing_ball_of_balls(balls: &[(DVec3, f64)]) -> (DVec3, f64) {
    let balls: Vec<(DVec3, f64)> =
        balls.iter().filter(|(c, r)| c.is_finite() && r.is_finite()).map(|&(c, r)| (c, r.max(0.0))).collect();
    if balls.is_empty() {
        return (DVec3::ZERO, 0.0);
    }
    let scale = balls.iter().map(|(c, r)| c.abs().max_element() + r).fold(0.0, f64::max).max(f64::MIN_POSITIVE);
    let tol = 1e-12 * scale;
    // Start with the largest ball (lowest index on ties).
    let first = (0..balls.len()).fold(0, |b, i| if balls[i].1 > balls[b].1 { i } else { b });
    let mut support = vec![first];
    let mut cur = balls[first];
    for _ in 0..10_000 {
        // Most violating ball (lowest index on ties).
        let mut worst = None;
        let mut worst_excess = tol;
        for (i, &(c, r)) in balls.iter().enumerate() {
            let excess = c.distance(cur.0) + r - cur.1;
            if excess > worst_excess {
                worst_excess = excess;
                worst = Some(i);
            }
        }
        let Some(w) = worst else { break };
        if support.contains(&w) {
            break; // numerical stall
        }
        let mut set = support.clone();
        set.push(w);
        match min_ball_of_small_set(&balls, &set, tol) {
            Some((ball, sup)) if ball.1 >= cur.1 - tol => {
                cur = ball;
                support = sup;
            }
            _ => break,
        }
    }
    let r = balls.iter().map(|(c, r)| c.distance(cur.0) + r).fold(0.0, f64::max);
    (cur.0, r * (1.0 + 1e-14))
}

/// Exact minimal enclosing ball of at most 5 balls `set` (indices into `balls`) by enumerating
/// the subsets' tangent balls; returns the ball and its defining subset.
fn min_ball_of_small_set(balls: &[(DVec3, f64)], set: &[usize], tol: f64) -> Option<((DVec3, f64), Vec<usize>)> {
    let n = set.len();
    let mut best: Option<((DVec3, f64), Vec<usize>)> = None;
    for mask in 1u32..(1 << n) {
        let sub: Vec<usize> = (0..n).filter(|&k| mask & (1 << k) != 0).map(|k| set[k]).collect();
        if sub.len() > 4 {
            continue;
        }
        for cand in tangent_balls(balls, &sub) {
            let encloses = set.iter().all(|&j| balls[j].0.distance(cand.0) + balls[j].1 <= cand.1 + tol);
            let smaller = match &best {
                None => true,
                Some((b, bs)) => cand.1 < b.1 - tol || (cand.1 <= b.1 + tol && sub.len() < bs.len()),
            };
            if encloses && smaller {
                best = Some((cand, sub.clone()));
            }
        }
    }
    best
}

/// The tangent-ball solver, written once (the minimal enclosing ball here and the hierarchy's
/// brute-force reference use it): the balls (c, R) to which every ball of `sub` (1..=4 indices
/// into `balls`, radii ≥ 0) is internally tangent, |c − cⱼ| + rⱼ = R, with c in the affine hull of
/// the centres and R ≥ max rⱼ (less 1e-12 relative). With x = c − c₀ = Σ λₗ vₗ (vₗ = cₗ − c₀) the
/// tangency conditions are linear in λ for fixed R (a Gram system solved for two right-hand
/// sides) plus one quadratic in R, so there are at most two solutions; none when the centres are
/// affinely dependent. One ball gives itself.
pub fn tangent_balls(balls: &[(DVec3, f64)], sub: &[usize]) -> Vec<(DVec3, f64)> {
    let (c0, r0) = balls[sub[0]];
    let k = sub.len() - 1;
    if k == 0 {
        return vec![(c0, r0)];
    }
    // x = c − c0 = Σ λ_l v_l; x·v_j = a_j + R b_j with a_j = (|v_j|² − r_j² + r0²)/2, b_j = r_j − r0.
    let v: Vec<DVec3> = sub[1..].iter().map(|&j| balls[j].0 - c0).collect();
    let mut ga = [[0.0f64; 4]; 3];
    let mut gb = [[0.0f64; 4]; 3];
    for j in 0..k {
        let rj = balls[sub[j + 1]].1;
        for l in 0..k {
            ga[j][l] = v[j].dot(v[l]);
            gb[j][l] = ga[j][l];
        }
        ga[j][3] = (v[j].length_squared() - rj * rj + r0 * r0) / 2.0;
        gb[j][3] = rj - r0;
    }
    let (Some(la), Some(lb)) = (solve_small(&mut ga, k), solve_small(&mut gb, k)) else {
        return Vec::new();
    };
    let mut xa = DVec3::ZERO;
    let mut xb = DVec3::ZERO;
    for l in 0..k {
        xa += v[l] * la[l];
        xb += v[l] * lb[l];
    }
    // |xa + R xb|² = (R − r0)²  →  qa R² + qb R + qc = 0.
    let qa = xb.length_squared() - 1.0;
    let qb = 2.0 * (xa.dot(xb) + r0);
    let qc = xa.length_squared() - r0 * r0;
    let rmax = sub.iter().map(|&j| balls[j].1).fold(0.0, f64::max);
    let mut roots = Vec::with_capacity(2);
    if qa.abs() < 1e-14 {
        if qb != 0.0 {
            roots.push(-qc / qb);
        }
    } else {
        let disc = qb * qb - 4.0 * qa * qc;
        if disc >= 0.0 {
            let s = disc.sqrt();
            // Numerically stable pair of roots.
            let q = -0.5 * (qb + qb.signum() * s);
            if q != 0.0 {
                roots.push(qc / q);
            }
            roots.push(q / qa);
        }
    }
    roots
        .into_iter()
        .filter(|r| r.is_finite() && *r >= rmax - 1e-12 * (1.0 + rmax))
        .map(|r| (c0 + xa + xb * r, r))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The minimal ball as it was before it shuffled the points in place: the finite points
    /// copied, their indices shuffled and gathered, the scale and the radius over the copy.
    fn min_enclosing_ball_by_indices(points: &[DVec3]) -> (DVec3, f64) {
        let pts: Vec<DVec3> = points.iter().copied().filter(|p| p.is_finite()).collect();
        if pts.is_empty() {
            return (DVec3::ZERO, 0.0);
        }
        let mut order: Vec<usize> = (0..pts.len()).collect();
        let mut rng = crate::rng::SplitMix64::new(0x5EED_5BE2_E0B1_BA11);
        for i in (1..order.len()).rev() {
            let j = (rng.next_u64() % (i as u64 + 1)) as usize;
            order.swap(i, j);
        }
        let scale = pts.iter().map(|p| p.abs().max_element()).fold(0.0, f64::max).max(f64::MIN_POSITIVE);
        let tol = 1e-12 * scale;
        let mut list: Vec<DVec3> = order.iter().map(|&i| pts[i]).collect();
        let mut support: Vec<DVec3> = Vec::with_capacity(4);
        let start = (list[0], -1.0);
        let (c, _) = mtf_mb(&mut list, pts.len(), &mut support, start, tol);
        (c, pts.iter().map(|p| p.distance(c)).fold(0.0, f64::max))
    }

    /// The in-place shuffle gives the index shuffle's ball bit for bit: random clouds, flat and
    /// collinear ones, duplicates, non-finite points mixed in, one point and none; from a
    /// slice and from an iterator.
    #[test]
    fn the_ball_of_the_points_shuffled_in_place_is_the_ball_of_the_shuffled_indices() {
        let mut rng = crate::rng::SplitMix64::new(77);
        for round in 0..300 {
            let n = (rng.next_u64() % 300) as usize;
            let mut pts: Vec<DVec3> = (0..n)
                .map(|_| {
                    let p = DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64()) * 10.0 - 3.0;
                    match round % 5 {
                        0 => DVec3::new(p.x, p.y, 1.5),
                        1 => DVec3::new(p.x, 2.0 * p.x, -p.x),
                        _ => p,
                    }
                })
                .collect();
            if round % 7 == 0 && n > 3 {
                pts[1] = pts[0];
                pts[n - 1] = DVec3::new(f64::NAN, 0.0, 0.0);
                pts[n / 2] = DVec3::INFINITY;
            }
            let want = min_enclosing_ball_by_indices(&pts);
            let bits = |b: (DVec3, f64)| (b.0.to_array().map(f64::to_bits), b.1.to_bits());
            assert_eq!(bits(min_enclosing_ball(&pts)), bits(want), "round {round}, {n} points");
            let by_index: Vec<u32> = (0..n as u32).collect();
            let of = min_enclosing_ball_of(by_index.iter().map(|&i| pts[i as usize]));
            assert_eq!(bits(of), bits(want), "round {round}, {n} points");
        }
    }

    /// The move-to-front recursion as it was before it passed each support's circumsphere
    /// down (solving it twice, once to test the support and once to start from).
    fn mtf_mb_reference(list: &mut [DVec3], end: usize, support: &mut Vec<DVec3>, tol: f64) -> (DVec3, f64) {
        // The circumsphere itself is shared: keeping its differences on the stack changed no
        // arithmetic.
        let circ = circumsphere;
        let mut ball = if support.is_empty() { (list[0], -1.0) } else { circ(support).unwrap_or((support[0], 0.0)) };
        if support.len() == 4 {
            return ball;
        }
        let mut i = 0;
        while i < end {
            let p = list[i];
            if ball.1 < 0.0 || p.distance(ball.0) > ball.1 + tol {
                support.push(p);
                let candidate =
                    if circ(support).is_some() { Some(mtf_mb_reference(list, i, support, tol)) } else { None };
                support.pop();
                if let Some(b) = candidate {
                    ball = b;
                    list[..=i].rotate_right(1);
                }
            }
            i += 1;
        }
        if ball.1 < 0.0 {
            ball.1 = 0.0;
        }
        ball
    }

    /// The same bits as the reference recursion, and the same list order after it, on random
    /// clouds, cospherical and coplanar sets and duplicates (degenerate supports).
    #[test]
    fn min_enclosing_ball_matches_the_reference_recursion_bit_for_bit() {
        let mut rng = crate::rng::SplitMix64::new(17);
        for case in 0..300 {
            let n = 1 + (rng.next_u64() % 200) as usize;
            let pts: Vec<DVec3> = (0..n)
                .map(|_| {
                    let p = DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64()) * 2.0 - DVec3::ONE;
                    match case % 4 {
                        0 => p * 10.0 + DVec3::splat(3.0),
                        1 => p.normalize_or_zero(),
                        2 => DVec3::new(p.x, p.y, 0.25),
                        _ => (p * 4.0).round() * 0.5,
                    }
                })
                .collect();
            let tol = 1e-12 * pts.iter().map(|p| p.abs().max_element()).fold(0.0, f64::max).max(f64::MIN_POSITIVE);
            let (mut a, mut b) = (pts.clone(), pts.clone());
            let mut support = Vec::with_capacity(4);
            let start = (a[0], -1.0);
            let got = mtf_mb(&mut a, n, &mut support, start, tol);
            let want = mtf_mb_reference(&mut b, n, &mut Vec::new(), tol);
            assert_eq!(
                (got.0.to_array().map(f64::to_bits), got.1.to_bits()),
                (want.0.to_array().map(f64::to_bits), want.1.to_bits()),
                "case {case}"
            );
            assert_eq!(a, b, "case {case}");
        }
    }

    #[test]
    fn the_principal_axes_are_eigenvectors_largest_spread_first() {
        let mut rng = crate::rng::SplitMix64::new(3);
        // A box of half-sides 5, 2, 1 rotated to an oblique frame: its covariance's top
        // eigenvector is the rotated long side (the half-sides' variances a²/3 differ).
        let u = DVec3::new(1.0, 2.0, -2.0).normalize();
        let w0 = DVec3::new(2.0, -1.0, 0.0).normalize();
        let w = (w0 - u * u.dot(w0)).normalize();
        let z = u.cross(w);
        let pts: Vec<DVec3> = (0..4000)
            .map(|_| {
                let f = |h: f64, r: &mut crate::rng::SplitMix64| (2.0 * r.next_f64() - 1.0) * h;
                DVec3::new(7.0, -3.0, 1.5) + u * f(5.0, &mut rng) + w * f(2.0, &mut rng) + z * f(1.0, &mut rng)
            })
            .collect();
        let axes = principal_axes(&pts).expect("spread");
        let a = axes[0];
        assert!((a.length() - 1.0).abs() < 1e-12);
        assert!(a.dot(u).abs() > 0.999, "axis {a} against {u}");
        assert!(axes[1].dot(w).abs() > 0.99 && axes[2].dot(z).abs() > 0.999, "{axes:?}");
        for i in 0..3 {
            for j in 0..3 {
                let want = if i == j { 1.0 } else { 0.0 };
                assert!((axes[i].dot(axes[j]) - want).abs() < 1e-12, "not orthonormal: {axes:?}");
            }
        }
        // Sign convention: the largest component positive.
        let big = a.to_array().into_iter().fold(0.0f64, |m, x| if x.abs() > m.abs() { x } else { m });
        assert!(big > 0.0);
        // Against the covariance by brute force: an eigenvector, and no direction spreads more.
        let mean = pts.iter().copied().sum::<DVec3>() / pts.len() as f64;
        let spread = |d: DVec3| pts.iter().map(|p| (*p - mean).dot(d).powi(2)).sum::<f64>();
        let cov_times = |d: DVec3| pts.iter().map(|p| (*p - mean) * (*p - mean).dot(d)).sum::<DVec3>();
        let lambda = spread(a);
        for (i, e) in axes.iter().enumerate() {
            let l = spread(*e);
            assert!((cov_times(*e) - *e * l).length() < 1e-9 * lambda, "axis {i} not an eigenvector");
            assert!(i == 0 || l <= spread(axes[i - 1]), "axis {i} spreads more than axis {}", i - 1);
        }
        for _ in 0..2000 {
            let d = DVec3::new(rng.next_f64() - 0.5, rng.next_f64() - 0.5, rng.next_f64() - 0.5).normalize();
            assert!(spread(d) <= lambda * (1.0 + 1e-12), "{d} spreads more");
        }
        // Points on a line: the line; degenerate inputs: none.
        let line: Vec<DVec3> =
            (0..10).map(|i| DVec3::new(1.0, 1.0, 1.0) + DVec3::new(0.0, 3.0, -4.0) * i as f64).collect();
        let l = principal_axes(&line).unwrap()[0];
        assert!((l - DVec3::new(0.0, -0.6, 0.8)).length() < 1e-12, "{l}");
        // A cube's lattice, moved off the origin (its covariance diagonal up to rounding, its
        // eigenvalues equal): x, y and z, not a rotation decided by rounding.
        let cube: Vec<DVec3> = (0..1000)
            .map(|i| {
                DVec3::new((i % 10) as f64, (i / 10 % 10) as f64, (i / 100) as f64) * 0.37 + DVec3::splat(1e3 / 7.0)
            })
            .collect();
        let axes = principal_axes(&cube).unwrap();
        assert!(axes.iter().all(|e| e.abs().max_element() == 1.0), "{axes:?}");
        assert_eq!(principal_axes(&[]), None);
        assert_eq!(principal_axes(&[DVec3::ONE]), None);
        assert_eq!(principal_axes(&[DVec3::ONE; 7]), None);
        // Coincident points whose mean rounds off them (0.1 + 0.1 + 0.1 ≠ 0.3): still none.
        assert_eq!(principal_axes(&[DVec3::splat(0.1); 3]), None);
        assert_eq!(principal_axes(&[DVec3::NAN, DVec3::ONE]), None);
    }

    /// Enclosed volume of a closed mesh by the divergence theorem (f64).
    fn mesh_volume(v: &[[f32; 3]], f: &[[u32; 3]]) -> f64 {
        f.iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| DVec3::from(v[i as usize].map(f64::from)));
                a.dot(b.cross(c)) / 6.0
            })
            .sum()
    }

    #[test]
    fn icosphere_counts_radius_and_orientation() {
        for levels in 0..4 {
            let (v, f) = icosphere(levels);
            assert_eq!(v.len(), 10 * 4usize.pow(levels as u32) + 2);
            assert_eq!(f.len(), 20 * 4usize.pow(levels as u32));
            assert!(v.iter().all(|p| ((p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt() - 1.0).abs() < 1e-6));
            let vol = mesh_volume(&v, &f);
            // Inscribed polyhedron: positive (outward) and below 4π/3.
            assert!(vol > 0.0 && vol < 4.0 / 3.0 * std::f64::consts::PI, "{levels}: {vol}");
        }
        // The icosahedron's volume with unit circumradius: (5/12)(3 + √5) a³, a = 4 / √(10 + 2√5).
        let a = 4.0 / (10.0 + 2.0 * 5f64.sqrt()).sqrt();
        let (v, f) = icosphere(0);
        assert!((mesh_volume(&v, &f) - 5.0 / 12.0 * (3.0 + 5f64.sqrt()) * a * a * a).abs() < 1e-6);
    }

    #[test]
    fn tangent_balls_of_known_configurations() {
        let has = |got: &[(DVec3, f64)], c: DVec3, r: f64| {
            got.iter().any(|&(gc, gr)| (gc - c).length() < 1e-10 && (gr - r).abs() < 1e-10)
        };
        // One ball: itself.
        let b = [(DVec3::new(1.0, 2.0, 3.0), 0.5)];
        assert_eq!(tangent_balls(&b, &[0]), vec![b[0]]);
        // Radii 1 and 2, centres 3 apart: R = (3 + 1 + 2) / 2 = 3, centre R − 1 = 2 from the first.
        let b = [(DVec3::ZERO, 1.0), (DVec3::new(3.0, 0.0, 0.0), 2.0)];
        assert!(has(&tangent_balls(&b, &[0, 1]), DVec3::new(2.0, 0.0, 0.0), 3.0));
        // Three points: their circumcircle (centre 0, radius 1).
        let b = [(DVec3::X, 0.0), (-DVec3::X, 0.0), (DVec3::Y, 0.0)];
        assert!(has(&tangent_balls(&b, &[0, 1, 2]), DVec3::ZERO, 1.0));
        // Four unit balls on a regular tetrahedron of circumradius √3: R = √3 + 1 about the origin.
        let b = [
            (DVec3::new(1.0, 1.0, 1.0), 1.0),
            (DVec3::new(1.0, -1.0, -1.0), 1.0),
            (DVec3::new(-1.0, 1.0, -1.0), 1.0),
            (DVec3::new(-1.0, -1.0, 1.0), 1.0),
        ];
        assert!(has(&tangent_balls(&b, &[0, 1, 2, 3]), DVec3::ZERO, 3f64.sqrt() + 1.0));
        // Collinear centres have no three-ball solution.
        let b = [(DVec3::ZERO, 0.0), (DVec3::X, 0.0), (2.0 * DVec3::X, 0.0)];
        assert!(tangent_balls(&b, &[0, 1, 2]).is_empty());
    }

    fn check(points: &[DVec3], center: DVec3, radius: f64) {
        let (c, r) = min_enclosing_ball(points);
        assert!((c - center).length() < 1e-9, "{c} vs {center}");
        assert!((r - radius).abs() < 1e-9, "{r} vs {radius}");
    }

    #[test]
    fn small_cases() {
        check(&[DVec3::ONE], DVec3::ONE, 0.0);
        check(&[DVec3::ZERO, DVec3::X * 2.0], DVec3::X, 1.0);
        check(&[DVec3::ZERO, DVec3::ZERO, DVec3::ZERO], DVec3::ZERO, 0.0);
        // Collinear: the two extremes decide.
        check(&[DVec3::ZERO, DVec3::X, DVec3::X * 4.0, DVec3::X * 2.0], DVec3::X * 2.0, 2.0);
    }
}
