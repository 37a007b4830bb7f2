//! Test meshes shared by the `bvh_*`, `voxel_*` and `sphere_*` integration tests.
#![allow(dead_code)]

use glam::{DVec3, Vec3};

/// Icosphere centred at `center` with `radius` (`spherebake_geom::sphere::icosphere`),
/// outward counter-clockwise faces.
pub fn icosphere(subdivisions: u32, center: Vec3, radius: f32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let (v, f) = spherebake_geom::sphere::icosphere(subdivisions as usize);
    (v.into_iter().map(|p| center + Vec3::from(p) * radius).collect(), f)
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

/// `spherebake_testkit::mesh::load_obj` with glam positions.
pub fn load_obj(path: &std::path::Path) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let (v, f) = spherebake_testkit::mesh::load_obj::<f32>(path);
    (v.into_iter().map(Vec3::from).collect(), f)
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

/// The cells the surface passes through, on `g`'s layout (`voxel::surface_cells`).
pub fn surface(v: &[Vec3], f: &[[u32; 3]], g: &spherebake_geom::voxel::VoxelGrid) -> spherebake_geom::voxel::Bits {
    spherebake_geom::voxel::surface_cells(&spherebake_geom::bvh::TriangleBvh::new(v, f), g)
}

/// Volume bounds of the solid from its grid: cells the surface does not meet lie wholly inside
/// or wholly outside and are classified by their centre, so (solid, not surface) cells ≤ V ≤
/// (solid or surface) cells, in units³.
pub fn volume_bounds(g: &spherebake_geom::voxel::VoxelGrid, surf: &spherebake_geom::voxel::Bits) -> (f64, f64) {
    let h3 = g.cell_size.powi(3);
    let certain = g.solid.count_and_not(surf);
    let possible = g.solid_count() + surf.count_and_not(&g.solid);
    (certain as f64 * h3, possible as f64 * h3)
}
