//! Test meshes and a minimal OBJ reader, as plain arrays (this crate has no dependencies; callers
//! convert to their vector types): the unit cube, the icosphere, `v`/`f` OBJ text.

use std::path::Path;
use std::str::FromStr;

/// Unit cube [0, 1]³: vertex k at (k & 1, (k >> 1) & 1, (k >> 2) & 1), 12 outward
/// counter-clockwise triangles (two per face, each face's triangles sharing its lowest vertex).
#[must_use]
pub fn unit_cube() -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
    let p: Vec<[f64; 3]> = (0..8).map(|i| [(i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64]).collect();
    let quads = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
    let t = quads.iter().flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]).collect();
    (p, t)
}

fn normalize(v: [f32; 3]) -> [f32; 3] {
    let inv = 1.0 / (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    [v[0] * inv, v[1] * inv, v[2] * inv]
}

/// Unit icosphere (radius 1, centre 0): the icosahedron subdivided `levels` times, each edge
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

/// Minimal OBJ reader: `v x y z` lines (parsed as `T`, `f32` or `f64`) and polygonal `f` lines
/// (fan-triangulated; `v/vt/vn` forms; negative indices count back from the last vertex);
/// everything else is ignored. Unreferenced vertices are kept, nothing is welded.
///
/// # Panics
/// On a malformed number or index: test input, not the product's importer.
#[must_use]
pub fn parse_obj<T: FromStr + Copy>(text: &str) -> (Vec<[T; 3]>, Vec<[u32; 3]>)
where
    T::Err: std::fmt::Debug,
{
    let mut v = Vec::new();
    let mut f = Vec::new();
    for line in text.lines() {
        let mut it = line.split_whitespace();
        match it.next() {
            Some("v") => {
                let c: Vec<T> = it.take(3).map(|s| s.parse().expect("OBJ vertex coordinate")).collect();
                v.push([c[0], c[1], c[2]]);
            }
            Some("f") => {
                let idx: Vec<u32> = it
                    .map(|s| {
                        let i: i64 = s.split('/').next().unwrap_or("").parse().expect("OBJ face index");
                        if i < 0 {
                            (v.len() as i64 + i) as u32
                        } else {
                            (i - 1) as u32
                        }
                    })
                    .collect();
                for k in 1..idx.len().saturating_sub(1) {
                    f.push([idx[0], idx[k], idx[k + 1]]);
                }
            }
            _ => {}
        }
    }
    (v, f)
}

/// [`parse_obj`] of a file.
///
/// # Panics
/// When the file cannot be read, or as [`parse_obj`].
#[must_use]
pub fn load_obj<T: FromStr + Copy>(path: &Path) -> (Vec<[T; 3]>, Vec<[u32; 3]>)
where
    T::Err: std::fmt::Debug,
{
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    parse_obj(&text)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::oracle::closed_mesh_volume;

    #[test]
    fn cube_is_closed_and_outward() {
        let (p, t) = unit_cube();
        assert_eq!((p.len(), t.len()), (8, 12));
        assert!((closed_mesh_volume(&p, &t) - 1.0).abs() < 1e-15);
    }

    #[test]
    fn icosphere_counts_radius_and_orientation() {
        for levels in 0..4 {
            let (v, f) = icosphere(levels);
            assert_eq!(v.len(), 10 * 4usize.pow(levels as u32) + 2);
            assert_eq!(f.len(), 20 * 4usize.pow(levels as u32));
            assert!(v.iter().all(|p| ((p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt() - 1.0).abs() < 1e-6));
            let p64: Vec<[f64; 3]> = v.iter().map(|p| p.map(f64::from)).collect();
            let vol = closed_mesh_volume(&p64, &f);
            // Inscribed polyhedron: positive (outward) and below 4π/3, approaching it.
            assert!(vol > 0.0 && vol < 4.0 / 3.0 * std::f64::consts::PI, "{levels}: {vol}");
        }
        // The icosahedron's volume with unit circumradius: (5/12)(3 + √5) a³, a = 4 / √(10 + 2√5).
        let a = 4.0 / (10.0 + 2.0 * 5f64.sqrt()).sqrt();
        let (v, f) = icosphere(0);
        let p64: Vec<[f64; 3]> = v.iter().map(|p| p.map(f64::from)).collect();
        assert!((closed_mesh_volume(&p64, &f) - 5.0 / 12.0 * (3.0 + 5f64.sqrt()) * a * a * a).abs() < 1e-6);
    }

    #[test]
    fn obj_faces_are_fanned_and_indices_resolved() {
        let text = "# a quad and a triangle\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0.5\nvn 0 0 1\nf 1/1/1 2/2/1 3 4\nf -4 -2 -1\ng x\n";
        let (v, f) = parse_obj::<f64>(text);
        assert_eq!(v, [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.5]]);
        assert_eq!(f, [[0, 1, 2], [0, 2, 3], [0, 2, 3]]);
        let (v32, _) = parse_obj::<f32>("v 0.1 2 3\n");
        assert_eq!(v32, [[0.1f32, 2.0, 3.0]]);
    }
}
