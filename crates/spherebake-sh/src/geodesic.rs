//! The 92 geodesic sample directions (math reference §5): icosahedron, frequency 3, class I.

/// Number of geodesic directions, 10·3² + 2 = 92.
pub const GEODESIC_DIRECTION_COUNT: usize = 92;

const PHI: f64 = 1.618_033_988_749_895; // (1 + √5) / 2

/// Base icosahedron vertices in the §5 order (unnormalised, edge length 2).
const BASE: [[f64; 3]; 12] = [
    [-1.0, PHI, 0.0],
    [1.0, PHI, 0.0],
    [-1.0, -PHI, 0.0],
    [1.0, -PHI, 0.0],
    [0.0, -1.0, PHI],
    [0.0, 1.0, PHI],
    [0.0, -1.0, -PHI],
    [0.0, 1.0, -PHI],
    [PHI, 0.0, -1.0],
    [PHI, 0.0, 1.0],
    [-PHI, 0.0, -1.0],
    [-PHI, 0.0, 1.0],
];

fn normalize(v: [f64; 3]) -> [f64; 3] {
    let n = libm::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    [v[0] / n, v[1] / n, v[2] / n]
}

fn combo(a: [f64; 3], wa: f64, b: [f64; 3], wb: f64) -> [f64; 3] {
    [wa * a[0] + wb * b[0], wa * a[1] + wb * b[1], wa * a[2] + wb * b[2]]
}

/// True when base vertices `i`, `j` share an icosahedron edge (|v_i − v_j| = 2; non-edges are ≥ 2φ apart).
fn is_edge(i: usize, j: usize) -> bool {
    let (a, b) = (BASE[i], BASE[j]);
    let d2 = (a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]);
    libm::fabs(d2 - 4.0) < 1e-9
}

/// The 92 geodesic unit directions in f64, in the §5 order: 0–11 icosahedron vertices, 12+2e / 13+2e
/// the points normalize(2v_i + v_j) / normalize(v_i + 2v_j) of edge e = (i, j) (edges i < j lexicographic),
/// 72+f the centre normalize(v_i + v_j + v_k) of face f (triples lexicographic).
///
/// [`GEODESIC_DIRECTIONS`] is the same table rounded to f32.
pub fn geodesic_directions_f64() -> [[f64; 3]; GEODESIC_DIRECTION_COUNT] {
    let mut out = [[0.0; 3]; GEODESIC_DIRECTION_COUNT];
    for (o, v) in out.iter_mut().zip(BASE) {
        *o = normalize(v);
    }
    let mut next = 12;
    for i in 0..12 {
        for j in (i + 1)..12 {
            if is_edge(i, j) {
                out[next] = normalize(combo(BASE[i], 2.0, BASE[j], 1.0));
                out[next + 1] = normalize(combo(BASE[i], 1.0, BASE[j], 2.0));
                next += 2;
            }
        }
    }
    for i in 0..12 {
        for j in (i + 1)..12 {
            if !is_edge(i, j) {
                continue;
            }
            for k in (j + 1)..12 {
                if is_edge(i, k) && is_edge(j, k) {
                    let s = combo(combo(BASE[i], 1.0, BASE[j], 1.0), 1.0, BASE[k], 1.0);
                    out[next] = normalize(s);
                    next += 1;
                }
            }
        }
    }
    out
}

/// The 92 geodesic unit directions (f32), in the §5 order of [`geodesic_directions_f64`]; the one shared table for bake and runtime.
#[rustfmt::skip]
pub const GEODESIC_DIRECTIONS: [[f32; 3]; GEODESIC_DIRECTION_COUNT] = [
    [-0.5257311, 0.8506508, 0.0],
    [0.5257311, 0.8506508, 0.0],
    [-0.5257311, -0.8506508, 0.0],
    [0.5257311, -0.8506508, 0.0],
    [0.0, -0.5257311, 0.8506508],
    [0.0, 0.5257311, 0.8506508],
    [0.0, -0.5257311, -0.8506508],
    [0.0, 0.5257311, -0.8506508],
    [0.8506508, 0.0, -0.5257311],
    [0.8506508, 0.0, 0.5257311],
    [-0.8506508, 0.0, -0.5257311],
    [-0.8506508, 0.0, 0.5257311],
    [-0.2017741, 0.9794321, 0.0],
    [0.2017741, 0.9794321, 0.0],
    [-0.4035482, 0.8547288, 0.32647735],
    [-0.2017741, 0.7300256, 0.6529547],
    [-0.4035482, 0.8547288, -0.32647735],
    [-0.2017741, 0.7300256, -0.6529547],
    [-0.7300256, 0.6529547, -0.2017741],
    [-0.8547288, 0.32647735, -0.4035482],
    [-0.7300256, 0.6529547, 0.2017741],
    [-0.8547288, 0.32647735, 0.4035482],
    [0.4035482, 0.8547288, 0.32647735],
    [0.2017741, 0.7300256, 0.6529547],
    [0.4035482, 0.8547288, -0.32647735],
    [0.2017741, 0.7300256, -0.6529547],
    [0.7300256, 0.6529547, -0.2017741],
    [0.8547288, 0.32647735, -0.4035482],
    [0.7300256, 0.6529547, 0.2017741],
    [0.8547288, 0.32647735, 0.4035482],
    [-0.2017741, -0.9794321, 0.0],
    [0.2017741, -0.9794321, 0.0],
    [-0.4035482, -0.8547288, 0.32647735],
    [-0.2017741, -0.7300256, 0.6529547],
    [-0.4035482, -0.8547288, -0.32647735],
    [-0.2017741, -0.7300256, -0.6529547],
    [-0.7300256, -0.6529547, -0.2017741],
    [-0.8547288, -0.32647735, -0.4035482],
    [-0.7300256, -0.6529547, 0.2017741],
    [-0.8547288, -0.32647735, 0.4035482],
    [0.4035482, -0.8547288, 0.32647735],
    [0.2017741, -0.7300256, 0.6529547],
    [0.4035482, -0.8547288, -0.32647735],
    [0.2017741, -0.7300256, -0.6529547],
    [0.7300256, -0.6529547, -0.2017741],
    [0.8547288, -0.32647735, -0.4035482],
    [0.7300256, -0.6529547, 0.2017741],
    [0.8547288, -0.32647735, 0.4035482],
    [0.0, -0.2017741, 0.9794321],
    [0.0, 0.2017741, 0.9794321],
    [0.32647735, -0.4035482, 0.8547288],
    [0.6529547, -0.2017741, 0.7300256],
    [-0.32647735, -0.4035482, 0.8547288],
    [-0.6529547, -0.2017741, 0.7300256],
    [0.32647735, 0.4035482, 0.8547288],
    [0.6529547, 0.2017741, 0.7300256],
    [-0.32647735, 0.4035482, 0.8547288],
    [-0.6529547, 0.2017741, 0.7300256],
    [0.0, -0.2017741, -0.9794321],
    [0.0, 0.2017741, -0.9794321],
    [0.32647735, -0.4035482, -0.8547288],
    [0.6529547, -0.2017741, -0.7300256],
    [-0.32647735, -0.4035482, -0.8547288],
    [-0.6529547, -0.2017741, -0.7300256],
    [0.32647735, 0.4035482, -0.8547288],
    [0.6529547, 0.2017741, -0.7300256],
    [-0.32647735, 0.4035482, -0.8547288],
    [-0.6529547, 0.2017741, -0.7300256],
    [0.9794321, 0.0, -0.2017741],
    [0.9794321, 0.0, 0.2017741],
    [-0.9794321, 0.0, -0.2017741],
    [-0.9794321, 0.0, 0.2017741],
    [0.0, 0.93417233, 0.3568221],
    [0.0, 0.93417233, -0.3568221],
    [-0.57735026, 0.57735026, 0.57735026],
    [-0.57735026, 0.57735026, -0.57735026],
    [-0.93417233, 0.3568221, 0.0],
    [0.57735026, 0.57735026, 0.57735026],
    [0.57735026, 0.57735026, -0.57735026],
    [0.93417233, 0.3568221, 0.0],
    [0.0, -0.93417233, 0.3568221],
    [0.0, -0.93417233, -0.3568221],
    [-0.57735026, -0.57735026, 0.57735026],
    [-0.57735026, -0.57735026, -0.57735026],
    [-0.93417233, -0.3568221, 0.0],
    [0.57735026, -0.57735026, 0.57735026],
    [0.57735026, -0.57735026, -0.57735026],
    [0.93417233, -0.3568221, 0.0],
    [0.3568221, 0.0, 0.93417233],
    [-0.3568221, 0.0, 0.93417233],
    [0.3568221, 0.0, -0.93417233],
    [-0.3568221, 0.0, -0.93417233],
];

/// Texels per side of each cube face in [`NearestDirection`]'s table (6 × 32² = 6144 texels,
/// 3.6 candidates on average over random directions).
const NEAREST_FACE_TEXELS: usize = 32;

/// The range of a vector's largest |component| that [`NearestDirection`] answers from its
/// table; outside it (zero included) or with a component that is not finite it scans all 92
/// directions, so the dot products never overflow or lose the table's margin to underflow.
const NEAREST_TABLE_RANGE: [f64; 2] = [1e-100, 1e100];

/// The first index of the largest `dirs[q] · d` (x·x' + y·y' + z·z'), 0 when there is none.
fn scan_nearest(dirs: &[[f64; 3]; GEODESIC_DIRECTION_COUNT], d: [f64; 3]) -> usize {
    let mut best = (f64::NEG_INFINITY, 0usize);
    for (q, w) in dirs.iter().enumerate() {
        let v = w[0] * d[0] + w[1] * d[1] + w[2] * d[2];
        if v > best.0 {
            best = (v, q);
        }
    }
    best.1
}

/// Which of the 92 geodesic directions a vector points along: the index q of the largest
/// `GEODESIC_DIRECTIONS[q] · d` (the f32 table read as f64; ties to the lowest index), the
/// sample direction whose Voronoi cell holds d. A cube-map table lists, per texel, the
/// directions that can win anywhere in that texel, so a query tests about 4 of them instead
/// of 92 and returns the index a scan of all 92 returns, bit for bit: a direction left out of
/// a texel's list has a dot product below the texel's best by at least 2 × 10⁻⁹ |d| everywhere
/// in the texel (a texel reaches at most δ in chord length from its centre x₀, so with p the
/// best direction at x₀, (q − p)·x moves by at most |q − p| δ within it: q is listed when
/// (q − p)·x₀ ≥ −|q − p| δ − 4 × 10⁻⁹), far above the dot products' rounding (≈ 10⁻¹⁵ |d|).
/// Built in O(6144 × 92), about 2 ms on one core; a query is O(1).
#[derive(Clone, Debug)]
pub struct NearestDirection {
    /// Texel t (face-major, row t = j·n + i) lists `cand[start[t]..start[t + 1]]`.
    start: alloc::vec::Vec<u16>,
    /// Candidate direction indices, ascending within a texel; the last 92 are 0..92 (the scan).
    cand: alloc::vec::Vec<u8>,
}

impl Default for NearestDirection {
    fn default() -> Self {
        Self::new()
    }
}

impl NearestDirection {
    /// Builds the table.
    pub fn new() -> Self {
        let n = NEAREST_FACE_TEXELS;
        let dirs = GEODESIC_DIRECTIONS.map(|d| d.map(f64::from));
        let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        let mut start = alloc::vec::Vec::with_capacity(6 * n * n + 1);
        let mut cand = alloc::vec::Vec::new();
        start.push(0u16);
        for face in crate::CubeFace::ALL {
            for j in 0..n {
                for i in 0..n {
                    let x0 = crate::cube_texel_direction(face, i, j, n);
                    // δ: the largest chord from the centre to the texel's corners (the texel is
                    // a geodesically convex quadrilateral within a hemisphere of x0, so its
                    // farthest point from x0 is a corner), padded for rounding.
                    let mut delta: f64 = 0.0;
                    for (a, b) in [(i, j), (i + 1, j), (i, j + 1), (i + 1, j + 1)] {
                        let u = 2.0 * a as f64 / n as f64 - 1.0;
                        let v = 2.0 * b as f64 / n as f64 - 1.0;
                        let c = crate::cube_face_uv_direction(face, u, v);
                        let e = [c[0] - x0[0], c[1] - x0[1], c[2] - x0[2]];
                        delta = delta.max(libm::sqrt(dot(e, e)));
                    }
                    let delta = delta * (1.0 + 1e-6) + 1e-12;
                    // q can win at a point x of the texel only if it beats p, the best at x0,
                    // there: (q − p)·x ≥ 0, and (q − p)·x ≥ (q − p)·x0 − |q − p| δ.
                    let p = dirs[scan_nearest(&dirs, x0)];
                    cand.extend((0..GEODESIC_DIRECTION_COUNT as u8).filter(|&q| {
                        let e = [0, 1, 2].map(|c| dirs[q as usize][c] - p[c]);
                        dot(e, x0) >= -libm::sqrt(dot(e, e)) * delta - 4e-9
                    }));
                    start.push(cand.len() as u16);
                }
            }
        }
        cand.extend(0..GEODESIC_DIRECTION_COUNT as u8);
        Self { start, cand }
    }

    /// The directions that can have the largest dot product with `d`, ascending: its texel's
    /// list (see [`NearestDirection`]), or all 92 when d is not finite or its largest
    /// |component| is outside [10⁻¹⁰⁰, 10¹⁰⁰] (zero included).
    pub fn candidates(&self, d: [f64; 3]) -> &[u8] {
        let m = libm::fabs(d[0]).max(libm::fabs(d[1])).max(libm::fabs(d[2]));
        let all = &self.cand[self.cand.len() - GEODESIC_DIRECTION_COUNT..];
        if !(NEAREST_TABLE_RANGE[0]..=NEAREST_TABLE_RANGE[1]).contains(&m) || d.iter().any(|c| !c.is_finite()) {
            return all;
        }
        let n = NEAREST_FACE_TEXELS;
        let (face, s, t) = crate::cube_dir_to_face_uv(d);
        let texel = |x: f64| ((x * n as f64) as usize).min(n - 1);
        let k = face.index() * n * n + texel(t) * n + texel(s);
        &self.cand[self.start[k] as usize..self.start[k + 1] as usize]
    }

    /// The index q of the largest `GEODESIC_DIRECTIONS[q] · d` computed in f64 as
    /// x·x' + y·y' + z·z' (ties, and a `d` that is zero or NaN, to the lowest index): the index a
    /// scan of all 92 returns.
    pub fn nearest(&self, d: [f64; 3]) -> usize {
        let mut best = (f64::NEG_INFINITY, 0usize);
        for &q in self.candidates(d) {
            let w = GEODESIC_DIRECTIONS[q as usize].map(f64::from);
            let v = w[0] * d[0] + w[1] * d[1] + w[2] * d[2];
            if v > best.0 {
                best = (v, q as usize);
            }
        }
        best.1
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::basis::{eval_sh8, sh_index, MAX_COEFFS};
    use core::f64::consts::PI;

    fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
        a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
    }

    #[test]
    fn f32_table_matches_construction() {
        let d = geodesic_directions_f64();
        for (k, (a, b)) in d.iter().zip(GEODESIC_DIRECTIONS.iter()).enumerate() {
            for c in 0..3 {
                assert!((a[c] - b[c] as f64).abs() < 1e-7, "direction {k}");
            }
        }
    }

    /// The brute-force answer [`NearestDirection::nearest`] must give: a scan of all 92.
    fn scan(d: [f64; 3]) -> usize {
        scan_nearest(&GEODESIC_DIRECTIONS.map(|w| w.map(f64::from)), d)
    }

    #[test]
    fn the_nearest_direction_table_agrees_with_a_scan_of_all_92() {
        let table = NearestDirection::new();
        let mut rng = spherebake_testkit::rng::SplitMix64::new(92);
        let mut queries: std::vec::Vec<[f64; 3]> = std::vec::Vec::new();
        // Random directions at several lengths.
        for _ in 0..200_000 {
            let d = [rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)];
            let s = [1.0, 1e-3, 7e5][queries.len() % 3];
            queries.push(d.map(|c| c * s));
        }
        // The hardest places: near the Voronoi boundaries (midpoints of neighbouring
        // directions and centroids of triples, nudged by ±1e-9..1e-4), texel corners and face
        // edges, where a list that is too short first shows.
        let dirs = geodesic_directions_f64();
        for a in 0..92 {
            for b in 0..92 {
                let m = [0, 1, 2].map(|c| dirs[a][c] + dirs[b][c]);
                for e in [0.0, 1e-9, -1e-9, 1e-6, -1e-4] {
                    queries.push([m[0] + e, m[1] - e, m[2] + 0.5 * e]);
                }
                let c = (a * 7 + b * 13) % 92;
                queries.push([0, 1, 2].map(|k| dirs[a][k] + dirs[b][k] + dirs[c][k]));
            }
        }
        let n = NEAREST_FACE_TEXELS;
        for face in crate::CubeFace::ALL {
            for j in 0..=n {
                for i in 0..=n {
                    for (du, dv) in [(0.0, 0.0), (1e-12, -1e-12), (0.3, 0.7)] {
                        let u = (2.0 * (i as f64 + du) / n as f64 - 1.0).clamp(-1.0, 1.0);
                        let v = (2.0 * (j as f64 + dv) / n as f64 - 1.0).clamp(-1.0, 1.0);
                        queries.push(crate::cube_face_uv_direction(face, u, v));
                    }
                }
            }
        }
        // Degenerate input: zero, NaN, infinite, tiny and huge components.
        queries.extend([
            [0.0; 3],
            [f64::NAN, 1.0, 0.0],
            [f64::INFINITY, 1.0, 0.0],
            [-f64::INFINITY, f64::INFINITY, 0.0],
            [1e-300, -2e-300, 0.0],
            [1e300, 1e300, -1e300],
            [1.0, 1.0, 0.0],
            [-1.0, -1.0, -1.0],
        ]);
        let mut short = 0;
        for d in &queries {
            assert_eq!(table.nearest(*d), scan(*d), "d {d:?}");
            short += usize::from(table.candidates(*d).len() < 92);
        }
        // The table does cut the work: most queries test a short list.
        let mean = queries.iter().map(|d| table.candidates(*d).len()).sum::<usize>() as f64 / queries.len() as f64;
        assert!(short > queries.len() * 9 / 10 && mean < 5.0, "short {short} of {}, mean {mean}", queries.len());
    }

    #[test]
    fn a_direction_left_out_of_a_texel_loses_there_by_the_documented_margin() {
        // At random points of every texel, each direction not in the texel's list has a dot
        // product at least 2e-9 below the best (the margin the module docs promise).
        let table = NearestDirection::new();
        let dirs = GEODESIC_DIRECTIONS.map(|d| d.map(f64::from));
        let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        let mut rng = spherebake_testkit::rng::SplitMix64::new(7);
        let n = NEAREST_FACE_TEXELS;
        for face in crate::CubeFace::ALL {
            for j in 0..n {
                for i in 0..n {
                    for corner in 0..12 {
                        // The four corners first, then random points.
                        let (a, b) = if corner < 4 {
                            ((corner & 1) as f64, (corner >> 1) as f64)
                        } else {
                            (rng.next_f64(), rng.next_f64())
                        };
                        let u = 2.0 * (i as f64 + a) / n as f64 - 1.0;
                        let v = 2.0 * (j as f64 + b) / n as f64 - 1.0;
                        let x = crate::cube_face_uv_direction(face, u, v);
                        let centre = crate::cube_texel_direction(face, i, j, n);
                        let list = table.candidates(centre);
                        let best = dirs.iter().map(|&q| dot(q, x)).fold(f64::NEG_INFINITY, f64::max);
                        for q in 0..92u8 {
                            if !list.contains(&q) {
                                let gap = best - dot(dirs[q as usize], x);
                                assert!(gap >= 2e-9, "face {face:?} texel ({i}, {j}) point {corner}: q {q} gap {gap}");
                            }
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn listed_vectors() {
        let d = geodesic_directions_f64();
        assert_eq!(d.len(), 92);
        let listed: [(usize, [f64; 3]); 6] = [
            (0, [-0.5257311121, 0.8506508084, 0.0]),
            (12, [-0.2017741062, 0.9794320855, 0.0]),
            (13, [0.2017741062, 0.9794320855, 0.0]),
            (71, [-0.9794320855, 0.0, 0.2017741062]),
            (72, [0.0, 0.934172359, 0.3568220898]),
            (91, [-0.3568220898, 0.0, -0.934172359]),
        ];
        for (k, v) in listed {
            for c in 0..3 {
                // 10 quoted significant digits.
                assert!((d[k][c] - v[c]).abs() < 1e-12 + 1e-10, "v{k}[{c}] = {}", d[k][c]);
            }
        }
        for v in d {
            assert!((dot(v, v) - 1.0).abs() < 1e-15);
        }
    }

    #[test]
    fn moments_and_design() {
        let d = geodesic_directions_f64();
        let mut sum = [0.0; 3];
        let mut second = [[0.0; 3]; 3];
        let mut ysum = [0.0; MAX_COEFFS];
        for v in d {
            for a in 0..3 {
                sum[a] += v[a];
                for b in 0..3 {
                    second[a][b] += v[a] * v[b];
                }
            }
            let y = eval_sh8(v);
            for i in 0..MAX_COEFFS {
                ysum[i] += y[i];
            }
        }
        for a in 0..3 {
            assert!(sum[a].abs() < 1e-13);
            for b in 0..3 {
                let e = if a == b { 92.0 / 3.0 } else { 0.0 };
                assert!((second[a][b] - e).abs() < 1e-12);
            }
        }
        // Spherical 5-design: Σ y_lm = 0 for 1 ≤ l ≤ 5.
        for i in 1..36 {
            assert!(ysum[i].abs() < 1e-12, "sum y[{i}] = {}", ysum[i]);
        }
        assert!((ysum[0] - 92.0 / libm::sqrt(4.0 * PI)).abs() < 1e-12);
        assert!((ysum[0] - 25.95272084).abs() < 1e-8);
        assert!((ysum[sh_index(6, 0)] - -0.7861189261).abs() < 1e-9);
        // Central symmetry: −d is in the set for every d.
        for v in d {
            assert!(d.iter().any(|w| (w[0] + v[0]).abs() + (w[1] + v[1]).abs() + (w[2] + v[2]).abs() < 1e-14));
        }
    }

    /// Hull edges: the 270 pairs with dot ≥ the quoted nearest-neighbour minimum, clearly separated from the rest.
    #[test]
    fn neighbour_spacing() {
        let d = geodesic_directions_f64();
        let lo = 0.9149583817;
        let mut edges = 0;
        let mut valence = [0usize; 92];
        let (mut dmin, mut dmax) = (f64::MAX, f64::MIN);
        let mut next_below = f64::MIN;
        for i in 0..92 {
            for j in (i + 1)..92 {
                let c = dot(d[i], d[j]);
                if c >= lo - 1e-9 {
                    edges += 1;
                    valence[i] += 1;
                    valence[j] += 1;
                    dmin = dmin.min(c);
                    dmax = dmax.max(c);
                } else {
                    next_below = next_below.max(c);
                }
            }
        }
        assert_eq!(edges, 270);
        for (k, &v) in valence.iter().enumerate() {
            assert_eq!(v, if k < 12 { 5 } else { 6 }, "valence of {k}");
        }
        assert!((dmin - 0.9149583817).abs() < 1e-9);
        assert!((dmax - 0.9392336205).abs() < 1e-9);
        assert!(next_below < dmin - 0.05, "no clean gap: {next_below}");
        assert!((libm::acos(dmax) - 0.3504054128).abs() < 1e-9);
        assert!((libm::acos(dmin) - 0.415391549).abs() < 1e-9);
        assert!((libm::acos(dmax).to_degrees() - 20.07675127).abs() < 1e-7);
        assert!((libm::acos(dmin).to_degrees() - 23.8001826).abs() < 1e-7);
        // Euler: V − E + F = 2 with F = 180.
        assert_eq!(92 - edges + 180, 2);
    }

    fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
        [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    }

    /// Voronoi cells from the hull triangles (triples of mutual nearest neighbours): 12 pentagons and two hexagon classes.
    #[test]
    fn voronoi_cells() {
        let d = geodesic_directions_f64();
        let near = |i: usize, j: usize| i != j && dot(d[i], d[j]) > 0.9;
        let mut tris = std::vec::Vec::new();
        for i in 0..92 {
            for j in (i + 1)..92 {
                for k in (j + 1)..92 {
                    if near(i, j) && near(j, k) && near(i, k) {
                        tris.push([i, j, k]);
                    }
                }
            }
        }
        assert_eq!(tris.len(), 180);
        let mut total = 0.0;
        for p in 0..92 {
            let pc = d[p];
            // Circumcentres of the triangles around p, sorted by angle in p's tangent plane.
            let t1 = {
                let a = if pc[0].abs() < 0.9 { [1.0, 0.0, 0.0] } else { [0.0, 1.0, 0.0] };
                let c = cross(pc, a);
                let n = dot(c, c).sqrt();
                [c[0] / n, c[1] / n, c[2] / n]
            };
            let t2 = cross(pc, t1);
            let mut centres: std::vec::Vec<(f64, [f64; 3])> = tris
                .iter()
                .filter(|t| t.contains(&p))
                .map(|t| {
                    let (a, b, c) = (d[t[0]], d[t[1]], d[t[2]]);
                    let mut n = cross([b[0] - a[0], b[1] - a[1], b[2] - a[2]], [c[0] - a[0], c[1] - a[1], c[2] - a[2]]);
                    if dot(n, a) < 0.0 {
                        n = [-n[0], -n[1], -n[2]];
                    }
                    let l = dot(n, n).sqrt();
                    let n = [n[0] / l, n[1] / l, n[2] / l];
                    (libm::atan2(dot(n, t2), dot(n, t1)), n)
                })
                .collect();
            centres.sort_by(|a, b| a.0.total_cmp(&b.0));
            assert_eq!(centres.len(), if p < 12 { 5 } else { 6 });
            let mut area = 0.0;
            for k in 0..centres.len() {
                let (a, b) = (centres[k].1, centres[(k + 1) % centres.len()].1);
                let num = dot(pc, cross(a, b));
                let den = 1.0 + dot(pc, a) + dot(a, b) + dot(b, pc);
                area += 2.0 * libm::atan2(num, den);
            }
            let want = if p < 12 {
                0.1107812016
            } else if p < 72 {
                0.1378263993
            } else {
                0.1483706118
            };
            assert!((area - want).abs() < 1e-9, "cell {p}: {area}");
            total += area;
        }
        assert!((total - 4.0 * PI).abs() < 1e-12);
    }
}
