//! Test meshes shared by the `bvh_*`, `voxel_*` and `sphere_*` integration tests.
#![allow(dead_code)]

use glam::{DVec3, Vec3};
use std::collections::HashMap;

/// Unit-radius icosphere centred at `center` with `radius`, outward counter-clockwise faces.
pub fn icosphere(subdivisions: u32, center: Vec3, radius: f32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let mut v: Vec<Vec3> = [
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
    .iter()
    .map(|p| Vec3::from(*p).normalize())
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
    for _ in 0..subdivisions {
        let mut mid: HashMap<(u32, u32), u32> = HashMap::new();
        let mut nf = Vec::with_capacity(f.len() * 4);
        for tri in &f {
            let mut m = [0u32; 3];
            for e in 0..3 {
                let (a, b) = (tri[e], tri[(e + 1) % 3]);
                let key = (a.min(b), a.max(b));
                m[e] = *mid.entry(key).or_insert_with(|| {
                    v.push(((v[a as usize] + v[b as usize]) * 0.5).normalize());
                    (v.len() - 1) as u32
                });
            }
            nf.push([tri[0], m[0], m[2]]);
            nf.push([tri[1], m[1], m[0]]);
            nf.push([tri[2], m[2], m[1]]);
            nf.push(m);
        }
        f = nf;
    }
    (v.into_iter().map(|p| center + p * radius).collect(), f)
}

/// Axis-aligned box [min, max] as 12 outward triangles.
pub fn cuboid(min: Vec3, max: Vec3) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let p = |x: bool, y: bool, z: bool| {
        Vec3::new(if x { max.x } else { min.x }, if y { max.y } else { min.y }, if z { max.z } else { min.z })
    };
    let v = vec![
        p(false, false, false),
        p(true, false, false),
        p(true, true, false),
        p(false, true, false),
        p(false, false, true),
        p(true, false, true),
        p(true, true, true),
        p(false, true, true),
    ];
    let f = vec![
        [0, 2, 1],
        [0, 3, 2], // z = min, normal -z
        [4, 5, 6],
        [4, 6, 7], // z = max
        [0, 1, 5],
        [0, 5, 4], // y = min
        [3, 7, 6],
        [3, 6, 2], // y = max
        [0, 4, 7],
        [0, 7, 3], // x = min
        [1, 2, 6],
        [1, 6, 5], // x = max
    ];
    (v, f)
}

/// Appends mesh b to mesh a.
pub fn merge(a: &mut (Vec<Vec3>, Vec<[u32; 3]>), b: &(Vec<Vec3>, Vec<[u32; 3]>)) {
    let off = a.0.len() as u32;
    a.0.extend_from_slice(&b.0);
    a.1.extend(b.1.iter().map(|t| t.map(|i| i + off)));
}

/// Signed volume Σ a·(b×c)/6 in f64.
pub fn signed_volume(v: &[Vec3], f: &[[u32; 3]]) -> f64 {
    f.iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| v[i as usize].as_dvec3());
            a.dot(b.cross(c)) / 6.0
        })
        .sum()
}

pub fn signed_volume_f64(v: &[DVec3], f: &[[u32; 3]]) -> f64 {
    f.iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| v[i as usize]);
            a.dot(b.cross(c)) / 6.0
        })
        .sum()
}

/// Minimal OBJ reader: `v x y z` and triangular/polygonal `f` (fan-triangulated; `v/vt/vn`,
/// negative indices).
pub fn load_obj(path: &std::path::Path) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let text = std::fs::read_to_string(path).expect("read obj");
    let mut v = Vec::new();
    let mut f = Vec::new();
    for line in text.lines() {
        let mut it = line.split_whitespace();
        match it.next() {
            Some("v") => {
                let c: Vec<f32> = it.take(3).map(|s| s.parse().expect("float")).collect();
                v.push(Vec3::new(c[0], c[1], c[2]));
            }
            Some("f") => {
                let idx: Vec<u32> = it
                    .map(|s| {
                        let i: i64 = s.split('/').next().unwrap().parse().expect("index");
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

/// Deterministic test RNG (the crate's SplitMix64).
pub struct Rng(spherebake_geom::rng::SplitMix64);
impl Rng {
    pub fn new(seed: u64) -> Self {
        Self(spherebake_geom::rng::SplitMix64::new(seed))
    }
    pub fn next_u64(&mut self) -> u64 {
        self.0.next_u64()
    }
    /// Uniform in [0, 1).
    pub fn f64(&mut self) -> f64 {
        self.0.next_f64()
    }
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.f64()
    }
    pub fn dvec3(&mut self, lo: f64, hi: f64) -> DVec3 {
        DVec3::new(self.range(lo, hi), self.range(lo, hi), self.range(lo, hi))
    }
}
