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
