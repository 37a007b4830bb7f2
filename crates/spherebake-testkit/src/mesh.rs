//! Test meshes and a minimal OBJ reader, as plain arrays (this crate has no dependencies; callers
//! convert to their vector types): the unit cube and `v`/`f` OBJ text. (The icosphere is
//! `spherebake_geom::sphere::icosphere`, which the glTF export draws spheres with.)

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

/// A closed, outward-oriented UV sphere of `radius` about the origin: single-vertex poles at
/// ±radius on z, `n − 1` rings of `2n` vertices at polar angles θ = πi/n and azimuths φ = πj/n;
/// 4n(n − 1) counter-clockwise triangles (fans at the poles, two per quad between rings).
/// `n ≥ 2`.
#[must_use]
pub fn uv_sphere(n: u32, radius: f64) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
    use std::f64::consts::PI;
    let mut p = vec![[0.0, 0.0, radius]];
    for i in 1..n {
        let th = PI * f64::from(i) / f64::from(n);
        for j in 0..2 * n {
            let ph = PI * f64::from(j) / f64::from(n);
            p.push([radius * (th.sin() * ph.cos()), radius * (th.sin() * ph.sin()), radius * th.cos()]);
        }
    }
    p.push([0.0, 0.0, -radius]);
    let ring = |i: u32, j: u32| 1 + (i - 1) * 2 * n + (j % (2 * n));
    let last = p.len() as u32 - 1;
    let mut t = Vec::new();
    for j in 0..2 * n {
        t.push([0, ring(1, j), ring(1, j + 1)]);
        t.push([last, ring(n - 1, j + 1), ring(n - 1, j)]);
    }
    for i in 1..n - 1 {
        for j in 0..2 * n {
            t.push([ring(i, j), ring(i + 1, j), ring(i + 1, j + 1)]);
            t.push([ring(i, j), ring(i + 1, j + 1), ring(i, j + 1)]);
        }
    }
    (p, t)
}

/// Closed outward boundary of a union of unit voxels `cells` (cell c spans [c, c + 1]³): every
/// face not shared with another cell of the list, split into `n`×`n` quads of two
/// counter-clockwise triangles each. Vertices are welded and given as integer lattice points in
/// units of 1/n (scale them to taste), numbered in order of first use; faces go cell by cell,
/// axis x, y, z, the − side before the +. Derived from the cell list alone (no library code).
#[must_use]
pub fn voxel_union(cells: &[[i32; 3]], n: u32) -> (Vec<[i64; 3]>, Vec<[u32; 3]>) {
    let n = i64::from(n);
    let mut pos: Vec<[i64; 3]> = Vec::new();
    let mut tris = Vec::new();
    let mut index = std::collections::BTreeMap::new();
    let mut vid = |p: [i64; 3], pos: &mut Vec<[i64; 3]>| -> u32 {
        *index.entry(p).or_insert_with(|| {
            pos.push(p);
            pos.len() as u32 - 1
        })
    };
    let has = |c: [i32; 3]| cells.contains(&c);
    for &c in cells {
        for axis in 0..3 {
            for dir in [-1i32, 1] {
                let mut nb = c;
                nb[axis] += dir;
                if has(nb) {
                    continue;
                }
                let u = (axis + 1) % 3;
                let v = (axis + 2) % 3;
                for a in 0..n {
                    for b in 0..n {
                        let mut q = [[0i64; 3]; 4];
                        for (qi, (du, dv)) in [(0, 0), (1, 0), (1, 1), (0, 1)].into_iter().enumerate() {
                            let mut x = c.map(|k| i64::from(k) * n);
                            if dir > 0 {
                                x[axis] += n;
                            }
                            x[u] += a + du;
                            x[v] += b + dv;
                            q[qi] = x;
                        }
                        let ids = q.map(|x| vid(x, &mut pos));
                        // (u, v, axis) is right-handed, so u×v = +axis: CCW in (u, v) faces +axis.
                        if dir > 0 {
                            tris.push([ids[0], ids[1], ids[2]]);
                            tris.push([ids[0], ids[2], ids[3]]);
                        } else {
                            tris.push([ids[0], ids[2], ids[1]]);
                            tris.push([ids[0], ids[3], ids[2]]);
                        }
                    }
                }
            }
        }
    }
    (pos, tris)
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
    fn uv_sphere_is_closed_outward_and_inscribed() {
        for n in [2u32, 3, 12] {
            let (p, t) = uv_sphere(n, 2.0);
            assert_eq!(p.len() as u32, 2 + (n - 1) * 2 * n);
            assert_eq!(t.len() as u32, 4 * n * (n - 1));
            assert!(p.iter().all(|q| ((q[0] * q[0] + q[1] * q[1] + q[2] * q[2]).sqrt() - 2.0).abs() < 1e-12));
            // Every edge used once in each direction: closed and consistently oriented.
            let mut edges = std::collections::BTreeMap::new();
            for tri in &t {
                for e in 0..3 {
                    *edges.entry((tri[e], tri[(e + 1) % 3])).or_insert(0) += 1;
                }
            }
            assert!(edges.iter().all(|(&(a, b), &c)| c == 1 && edges.get(&(b, a)) == Some(&1)));
            let vol = closed_mesh_volume(&p, &t);
            assert!(vol > 0.0 && vol < 4.0 / 3.0 * std::f64::consts::PI * 8.0, "{n}: {vol}");
        }
    }

    #[test]
    fn voxel_union_volume_and_faces() {
        // An L of three cells: volume 3, 14 exposed faces.
        let cells = [[0, 0, 0], [1, 0, 0], [0, 1, 0]];
        for n in [1u32, 3] {
            let (p, t) = voxel_union(&cells, n);
            assert_eq!(t.len() as u32, 14 * 2 * n * n);
            let pf: Vec<[f64; 3]> = p.iter().map(|q| q.map(|x| x as f64 / f64::from(n))).collect();
            assert!((closed_mesh_volume(&pf, &t) - 3.0).abs() < 1e-12, "n = {n}");
        }
        // Welded: a single cell at n = 1 has its 8 corners.
        assert_eq!(voxel_union(&[[5, -2, 7]], 1).0.len(), 8);
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
