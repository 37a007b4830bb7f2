//! Solid voxelization of closed meshes and of meshes damaged on purpose.

mod voxel_support;

use glam::{DVec3, Vec3};
use spherebake_geom::voxel::{voxelize, VoxelGrid, VoxelSettings};
use spherebake_geom::winding::WindingNumber;
use std::collections::HashMap;
use voxel_support::{cuboid, icosphere, merge, signed_volume, signed_volume_f64};

fn vox(v: &[Vec3], f: &[[u32; 3]], res: u32) -> VoxelGrid {
    voxelize(v, f, &VoxelSettings { resolution: res, ..Default::default() })
}

fn surface_count(g: &VoxelGrid) -> usize {
    g.surface.iter().filter(|&&s| s).count()
}

/// Volume of solid cells that are not surface cells (a lower bound of the true volume).
fn interior_volume(g: &VoxelGrid) -> f64 {
    (g.solid_count() - surface_count(g)) as f64 * g.cell_size.powi(3)
}

/// interior cells ≤ `volume` ≤ all solid cells.
fn assert_brackets(g: &VoxelGrid, volume: f64, what: &str) {
    assert!(
        interior_volume(g) <= volume && volume <= g.volume(),
        "{what}: {} ≤ {volume} ≤ {}",
        interior_volume(g),
        g.volume()
    );
}

fn sphere_mesh() -> (Vec<Vec3>, Vec<[u32; 3]>) {
    icosphere(3, Vec3::new(0.05, -0.1, 0.2), 1.0)
}

#[test]
fn closed_icosphere_and_cube() {
    let (v, f) = sphere_mesh();
    let mesh_volume = signed_volume(&v, &f);
    let ball = 4.0 / 3.0 * std::f64::consts::PI;
    assert!(mesh_volume > 0.97 * ball && mesh_volume < ball); // 1280 faces: ~1% below the ball
    let g = vox(&v, &f, 32);
    assert_eq!(g.dims.iter().copied().max(), Some(32));
    assert_brackets(&g, mesh_volume, "icosphere");
    // Every solid cell centre is inside or the cell touches the surface, by the exact winding number.
    let w = WindingNumber::new(&v, &f);
    for k in 0..g.dims[2] {
        for j in 0..g.dims[1] {
            for i in 0..g.dims[0] {
                let idx = g.index(i, j, k);
                if !g.surface[idx] {
                    let inside = w.eval_exact(g.cell_center(i, j, k)) >= 0.5;
                    assert_eq!(g.solid[idx], inside, "cell {i} {j} {k}");
                }
            }
        }
    }
    // A box that does not align with the grid: brackets its exact volume.
    let (cv, cf) = cuboid(Vec3::new(-0.3, 0.1, 0.2), Vec3::new(0.8, 0.7, 1.25));
    let g = vox(&cv, &cf, 40);
    assert_brackets(&g, 1.1 * 0.6 * 1.05, "box");
}

#[test]
fn hole_punched_sphere_keeps_its_solid() {
    let (v, f) = sphere_mesh();
    let closed = vox(&v, &f, 48);
    // Remove a cap of triangles (a hole of radius ~0.3) and, separately, a single triangle.
    // The cap is centred on a diagonal, so the bounding box and hence the grid do not change.
    let top = Vec3::new(0.05, -0.1, 0.2) + Vec3::ONE.normalize();
    let holed: Vec<[u32; 3]> = f
        .iter()
        .copied()
        .filter(|t| t.iter().map(|&i| v[i as usize]).sum::<Vec3>().distance(top * 3.0) > 0.9)
        .collect();
    assert!(f.len() - holed.len() >= 20, "removed {}", f.len() - holed.len());
    let g = vox(&v, &holed, 48);
    assert_eq!((g.origin, g.dims), (closed.origin, closed.dims));
    let rel = (g.volume() - closed.volume()).abs() / closed.volume();
    println!(
        "cap hole: {} triangles removed, solid volume {} vs closed {} ({rel:.2e})",
        f.len() - holed.len(),
        g.volume(),
        closed.volume()
    );
    assert!(rel < 0.01, "{rel}");
    assert_brackets(&g, signed_volume(&v, &f), "icosphere with a hole");
    // Cells away from the hole are unchanged.
    for k in 0..g.dims[2] {
        for j in 0..g.dims[1] {
            for i in 0..g.dims[0] {
                let idx = g.index(i, j, k);
                if g.cell_center(i, j, k).distance(top.as_dvec3()) > 0.6 {
                    assert_eq!(g.solid[idx], closed.solid[idx], "cell {i} {j} {k}");
                }
            }
        }
    }
    let mut one = f.clone();
    one.remove(100);
    let g = vox(&v, &one, 48);
    let diff = g.solid.iter().zip(&closed.solid).filter(|(a, b)| a != b).count();
    assert!(diff <= 4, "{diff} cells changed by one missing triangle");
}

#[test]
fn hole_punched_cube() {
    // Unit cube made of 2×2 quads per face (48 triangles) so a missing triangle is a real hole.
    let mut mesh = (Vec::new(), Vec::new());
    for z in 0..2 {
        for y in 0..2 {
            for x in 0..2 {
                let lo = Vec3::new(x as f32, y as f32, z as f32) * 0.5;
                merge(&mut mesh, &cuboid(lo, lo + 0.5));
            }
        }
    }
    // Keep only the outer faces of the eight small boxes: drop faces that appear twice (inner).
    let key = |t: &[u32; 3]| {
        let c = t.iter().map(|&i| mesh.0[i as usize]).sum::<Vec3>() / 3.0;
        [(c.x * 1e4).round() as i64, (c.y * 1e4).round() as i64, (c.z * 1e4).round() as i64]
    };
    let mut count: HashMap<[i64; 3], usize> = HashMap::new();
    for t in &mesh.1 {
        *count.entry(key(t)).or_default() += 1;
    }
    let outer: Vec<[u32; 3]> = mesh.1.iter().copied().filter(|t| count[&key(t)] == 1).collect();
    assert_eq!(outer.len(), 48);
    assert!((signed_volume(&mesh.0, &outer) - 1.0).abs() < 1e-6);
    let closed = vox(&mesh.0, &outer, 32);
    assert_eq!(closed.solid_count(), 32 * 32 * 32);
    for remove in [0usize, 5, 17, 30, 47] {
        let mut f = outer.clone();
        f.remove(remove);
        let g = vox(&mesh.0, &f, 32);
        let missing = closed.solid_count() - g.solid_count();
        println!("cube without triangle {remove}: {missing} cells lost");
        assert!(missing <= 32, "{missing}");
    }
    // A whole quarter face (2 triangles) missing.
    let z_top: Vec<[u32; 3]> = outer
        .iter()
        .copied()
        .filter(|t| {
            !(t.iter().all(|&i| mesh.0[i as usize].z == 1.0)
                && t.iter().all(|&i| mesh.0[i as usize].x <= 0.5 && mesh.0[i as usize].y <= 0.5))
        })
        .collect();
    assert_eq!(z_top.len(), 46);
    let g = vox(&mesh.0, &z_top, 32);
    assert!(closed.solid_count() - g.solid_count() <= 64, "{}", closed.solid_count() - g.solid_count());
}

#[test]
fn duplicates_overlaps_and_flips() {
    let (v, f) = sphere_mesh();
    let closed = vox(&v, &f, 40);
    // Every triangle twice, or every third triangle twice.
    let mut dup = f.clone();
    dup.extend_from_slice(&f);
    assert_eq!(vox(&v, &dup, 40).solid, closed.solid);
    let mut some: Vec<[u32; 3]> = f.clone();
    some.extend(f.iter().step_by(3));
    assert_eq!(vox(&v, &some, 40).solid, closed.solid);
    // Fully flipped: w = −1 inside, |w| decides, same solid.
    let flipped: Vec<[u32; 3]> = f.iter().map(|t| [t[0], t[2], t[1]]).collect();
    assert_eq!(vox(&v, &flipped, 40).solid, closed.solid);
    // Two overlapping boxes (a self-intersecting union): union volume bracketed, overlap solid.
    let mut two = cuboid(Vec3::ZERO, Vec3::ONE);
    merge(&mut two, &cuboid(Vec3::new(0.6, 0.2, 0.3), Vec3::new(1.7, 0.8, 1.3)));
    let g = vox(&two.0, &two.1, 48);
    let union = 1.0 + 1.1 * 0.6 * 1.0 - 0.4 * 0.6 * 0.7;
    assert_brackets(&g, union, "two boxes");
    let w = WindingNumber::new(&two.0, &two.1);
    assert!((w.eval_exact(DVec3::new(0.8, 0.5, 0.6)) - 2.0).abs() < 1e-9);
    // Overlapping spheres: union of two icospheres.
    let mut spheres = icosphere(3, Vec3::ZERO, 1.0);
    merge(&mut spheres, &icosphere(3, Vec3::new(0.8, 0.0, 0.0), 1.0));
    let g = vox(&spheres.0, &spheres.1, 48);
    let vi = signed_volume(&icosphere(3, Vec3::ZERO, 1.0).0, &icosphere(3, Vec3::ZERO, 1.0).1);
    // Union ≈ 2 V − lens; the icosphere is ~1% smaller than the ball, use generous bounds.
    let lens = spherebake_geom::sphere::lens_volume(1.0, 1.0, 0.8);
    let union = 2.0 * vi - lens * vi / (4.0 / 3.0 * std::f64::consts::PI);
    assert!(
        interior_volume(&g) < union * 1.01 && g.volume() > union * 0.99,
        "{} {} {union}",
        interior_volume(&g),
        g.volume()
    );
}

#[test]
fn open_sheets_and_degenerate_input() {
    // A single square sheet encloses nothing: solid = surface.
    let v = vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
    let f = vec![[0, 1, 2], [0, 2, 3]];
    let g = vox(&v, &f, 16);
    assert_eq!(g.dims, [16, 16, 1]);
    assert_eq!(g.solid, g.surface);
    assert_eq!(g.solid_count(), 256);
    // An open sheet next to a closed box does not change the box.
    let mut m = cuboid(Vec3::ZERO, Vec3::ONE);
    let only_box = vox(&m.0, &m.1, 20);
    merge(
        &mut m,
        &(vec![Vec3::new(0.2, 0.2, 0.5), Vec3::new(0.8, 0.2, 0.5), Vec3::new(0.5, 0.8, 0.5)], vec![[0, 1, 2]]),
    );
    assert_eq!(vox(&m.0, &m.1, 20).solid, only_box.solid);
    // Empty, invalid and NaN input never panics.
    assert_eq!(vox(&[], &[], 32).dims, [0, 0, 0]);
    let g = vox(&[Vec3::ZERO, Vec3::X], &[[0, 1, 7]], 32);
    assert_eq!((g.dims, g.volume()), ([0, 0, 0], 0.0));
    let g = vox(&[Vec3::ZERO, Vec3::ZERO, Vec3::ZERO], &[[0, 1, 2]], 8);
    assert_eq!(g.dims, [1, 1, 1]);
    let g = vox(&[Vec3::splat(f32::NAN), Vec3::X, Vec3::Y, Vec3::Z], &[[0, 1, 2], [1, 2, 3]], 8);
    assert!(g.solid_count() > 0 && g.solid == g.surface);
    let _ = vox(&v, &f, 0); // resolution clamped to 1
}

#[test]
fn same_result_for_any_thread_count() {
    let (v, f) = sphere_mesh();
    let mut holed = f.clone();
    holed.truncate(f.len() - 40);
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap().install(|| vox(&v, &holed, 40))
    };
    let a = run(1);
    let b = run(4);
    assert_eq!(a, b);
}

#[test]
fn boundary_mesh_is_closed_and_encloses_the_solid() {
    let (v, f) = sphere_mesh();
    let mut two = (v, f);
    merge(&mut two, &cuboid(Vec3::new(0.9, 0.9, 0.9), Vec3::new(1.6, 1.3, 1.5)));
    let g = vox(&two.0, &two.1, 24);
    let (bv, bf) = g.boundary_mesh();
    // Watertight: each directed edge is matched by its reverse.
    let mut edges: HashMap<(u32, u32), i32> = HashMap::new();
    for t in &bf {
        for e in 0..3 {
            let (a, b) = (t[e], t[(e + 1) % 3]);
            *edges.entry((a.min(b), a.max(b))).or_default() += if a < b { 1 } else { -1 };
        }
    }
    assert!(edges.values().all(|&c| c == 0));
    // Shared lattice vertices: no duplicates.
    let mut seen: Vec<[i64; 3]> = bv.iter().map(|p| [p.x, p.y, p.z].map(|c| (c * 1e6).round() as i64)).collect();
    seen.sort();
    seen.dedup();
    assert_eq!(seen.len(), bv.len());
    // Encloses exactly the solid volume, outward.
    let vol = signed_volume_f64(&bv, &bf);
    assert!((vol - g.volume()).abs() < 1e-9 * g.volume(), "{vol} vs {}", g.volume());
    // Its winding number is 1 at solid cell centres and 0 at empty ones.
    let bv32: Vec<Vec3> = bv.iter().map(|p| p.as_vec3()).collect();
    let w = WindingNumber::new(&bv32, &bf);
    for k in (0..g.dims[2]).step_by(3) {
        for j in (0..g.dims[1]).step_by(2) {
            for i in 0..g.dims[0] {
                let want = if g.solid[g.index(i, j, k)] { 1.0 } else { 0.0 };
                assert!((w.eval_exact(g.cell_center(i, j, k)) - want).abs() < 1e-6);
            }
        }
    }
}
