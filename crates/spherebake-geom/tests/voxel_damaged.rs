//! Solid voxelization of closed meshes and of meshes damaged on purpose.

mod voxel_support;

use glam::{DVec3, Vec3};
use spherebake_geom::voxel::{voxelize, VoxelGrid, VoxelSettings};
use spherebake_geom::winding::WindingNumber;
use std::collections::HashMap;
use voxel_support::{cuboid, icosphere, merge, signed_volume, signed_volume_f64, surface, volume_bounds};

fn vox(v: &[Vec3], f: &[[u32; 3]], res: u32) -> VoxelGrid {
    voxelize(v, f, &VoxelSettings { resolution: res })
}

/// Volume of solid cells the surface does not meet (a lower bound of the true volume).
fn interior_volume(v: &[Vec3], f: &[[u32; 3]], g: &VoxelGrid) -> f64 {
    volume_bounds(g, &surface(v, f, g)).0
}

/// certain cells ≤ `volume` ≤ possible cells ([`volume_bounds`] of the mesh's own surface).
fn assert_brackets(v: &[Vec3], f: &[[u32; 3]], g: &VoxelGrid, volume: f64, what: &str) {
    let (lo, hi) = volume_bounds(g, &surface(v, f, g));
    assert!(lo <= volume && volume <= hi, "{what}: {lo} ≤ {volume} ≤ {hi}");
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
    // 32 cells span the longest extent, with the empty margin of the layout around them.
    assert_eq!(g.dims.iter().copied().max(), Some(36));
    assert_brackets(&v, &f, &g, mesh_volume, "icosphere");
    // Every cell, the ones the surface cuts included, is solid exactly when its centre is inside
    // by the exact winding number (closed mesh: w is 0 or 1 off the surface).
    let w = WindingNumber::new(&v, &f);
    for k in 0..g.dims[2] {
        for j in 0..g.dims[1] {
            for i in 0..g.dims[0] {
                let inside = w.eval_exact(g.cell_center(i, j, k)) >= 0.5;
                assert_eq!(g.solid[g.index(i, j, k)], inside, "cell {i} {j} {k}");
            }
        }
    }
    // A box that does not align with the grid: brackets its exact volume.
    let (cv, cf) = cuboid(Vec3::new(-0.3, 0.1, 0.2), Vec3::new(0.8, 0.7, 1.25));
    let g = vox(&cv, &cf, 40);
    assert_brackets(&cv, &cf, &g, 1.1 * 0.6 * 1.05, "box");
}

/// A box's solid is the lattice of cell centres inside it, counted here from the grid's origin
/// and cell size alone: per axis, the centres origin + (i + ½) h in [min, max]. So its volume
/// differs from the box's by less than the cells of one layer around it, with the count known
/// exactly.
#[test]
fn box_solid_is_the_centres_inside_it() {
    let (lo, hi) = (Vec3::new(-0.31, 0.12, 0.205), Vec3::new(0.83, 0.71, 1.27));
    let (v, f) = cuboid(lo, hi);
    for res in [17, 40, 64] {
        let g = vox(&v, &f, res);
        let h = g.cell_size;
        let centres = |a: usize| -> Vec<u32> {
            (0..g.dims[a])
                .filter(|&i| {
                    let c = g.origin[a] + (i as f64 + 0.5) * h;
                    lo[a] as f64 <= c && c <= hi[a] as f64
                })
                .collect()
        };
        let (xs, ys, zs) = (centres(0), centres(1), centres(2));
        for k in 0..g.dims[2] {
            for j in 0..g.dims[1] {
                for i in 0..g.dims[0] {
                    let want = xs.contains(&i) && ys.contains(&j) && zs.contains(&k);
                    assert_eq!(g.solid[g.index(i, j, k)], want, "res {res}: cell {i} {j} {k}");
                }
            }
        }
        // Along each axis the count of centres is within one of the length in cells.
        let ext = (hi - lo).as_dvec3() / h;
        for (a, n) in [xs.len(), ys.len(), zs.len()].into_iter().enumerate() {
            assert!((n as f64 - ext[a]).abs() <= 1.0, "res {res} axis {a}: {n} centres, extent {}", ext[a]);
        }
    }
}

/// The closed icosphere's solid volume against its exact volume (the divergence theorem), within
/// what the centre rule can miss: only cells the surface cuts are in doubt, so the error is at
/// most their volume; and the cells of a ball of radius R − √3 h/2 (the inradius bound below) and
/// of R + √3 h/2 bracket it from the lattice alone (every point of the smaller ball lies in a cell
/// whose centre is inside; every solid cell lies in the larger).
#[test]
fn closed_sphere_volume_within_derived_tolerance() {
    let radius = 1.0f32;
    let (v, f) = icosphere(4, Vec3::new(0.05, -0.1, 0.2), radius);
    let exact = signed_volume(&v, &f);
    // Inradius: the nearest face plane to the centre.
    let c = DVec3::new(0.05, -0.1, 0.2);
    let inradius = f
        .iter()
        .map(|t| {
            let [a, b, d] = t.map(|i| v[i as usize].as_dvec3());
            (b - a).cross(d - a).normalize().dot(a - c)
        })
        .fold(f64::INFINITY, f64::min);
    for res in [24, 48, 96] {
        let g = vox(&v, &f, res);
        let surf = surface(&v, &f, &g);
        let cut = surf.count_ones() as f64 * g.cell_size.powi(3);
        let err = g.volume() - exact;
        println!("icosphere res {res}: solid {:.6} exact {exact:.6} error {err:+.2e}, cut cells {cut:.3e}", g.volume());
        assert!(err.abs() <= cut, "res {res}: error {err} above the cut cells' volume {cut}");
        let ball = |r: f64| 4.0 / 3.0 * std::f64::consts::PI * r.max(0.0).powi(3);
        let d = 3f64.sqrt() * g.cell_size / 2.0;
        assert!(ball(inradius - d) <= g.volume() && g.volume() <= ball(radius as f64 + d), "res {res}");
    }
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
    assert_brackets(&v, &holed, &g, signed_volume(&v, &f), "icosphere with a hole");
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
    let diff = g.solid.count_and_not(&closed.solid) + closed.solid.count_and_not(&g.solid);
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
    assert_brackets(&two.0, &two.1, &g, union, "two boxes");
    let w = WindingNumber::new(&two.0, &two.1);
    assert!((w.eval_exact(DVec3::new(0.8, 0.5, 0.6)) - 2.0).abs() < 1e-9);
    // The cells enclosed twice are exactly those whose centre lies in both boxes (counted
    // here from the boxes alone); a single closed mesh, and every soup that is not closed,
    // has none.
    let in_box = |p: DVec3, lo: [f64; 3], hi: [f64; 3]| (0..3).all(|a| lo[a] < p[a] && p[a] < hi[a]);
    let mut both = 0;
    for k in 0..g.dims[2] {
        for j in 0..g.dims[1] {
            for i in 0..g.dims[0] {
                let c = g.cell_center(i, j, k);
                both += usize::from(in_box(c, [0.0; 3], [1.0; 3]) && in_box(c, [0.6, 0.2, 0.3], [1.7, 0.8, 1.3]));
            }
        }
    }
    assert!(both > 500, "{both}");
    assert_eq!(g.covered_twice, both);
    assert_eq!(closed.covered_twice, 0);
    assert_eq!(vox(&v, &flipped, 40).covered_twice, 0);
    assert_eq!(vox(&v, &dup, 40).covered_twice, 0, "not closed: no integer count");
    // Overlapping spheres: union of two icospheres.
    let mut spheres = icosphere(3, Vec3::ZERO, 1.0);
    merge(&mut spheres, &icosphere(3, Vec3::new(0.8, 0.0, 0.0), 1.0));
    let g = vox(&spheres.0, &spheres.1, 48);
    let vi = signed_volume(&icosphere(3, Vec3::ZERO, 1.0).0, &icosphere(3, Vec3::ZERO, 1.0).1);
    // Union ≈ 2 V − lens; the icosphere is ~1% smaller than the ball, use generous bounds.
    let lens = spherebake_geom::sphere::lens_volume(1.0, 1.0, 0.8);
    let union = 2.0 * vi - lens * vi / (4.0 / 3.0 * std::f64::consts::PI);
    assert!(
        interior_volume(&spheres.0, &spheres.1, &g) < union * 1.01 && g.volume() > union * 0.99,
        "{} {} {union}",
        interior_volume(&spheres.0, &spheres.1, &g),
        g.volume()
    );
}

#[test]
fn open_sheets_and_degenerate_input() {
    // A single square sheet encloses nothing: the solid is empty; its surface cells are the
    // cells whose box meets [0, 1]² × {0}, counted from the layout: 17 per axis (the sheet's
    // edges lie 0.0137 cells into cells 1 and 17), one layer.
    let v = vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
    let f = vec![[0, 1, 2], [0, 2, 3]];
    let g = vox(&v, &f, 16);
    assert_eq!(g.dims, [20, 20, 4]);
    assert_eq!(g.solid_count(), 0);
    let surf = surface(&v, &f, &g);
    let meets = |a: usize, lo: f64, hi: f64| {
        (0..g.dims[a]).filter(|&i| g.cell_min(i, i, i)[a] <= hi && g.cell_min(i + 1, i + 1, i + 1)[a] >= lo).count()
    };
    assert_eq!((meets(0, 0.0, 1.0), meets(1, 0.0, 1.0), meets(2, 0.0, 0.0)), (17, 17, 1));
    assert_eq!(surf.count_ones(), 17 * 17);
    for idx in surf.ones() {
        let (i, j, k) = (idx as u32 % 20, idx as u32 / 20 % 20, idx as u32 / 400);
        assert!(k == 1 && (1..=17).contains(&i) && (1..=17).contains(&j), "cell {i} {j} {k}");
    }
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
    assert_eq!((g.dims, g.solid_count()), ([4, 4, 4], 0));
    let nan = [Vec3::splat(f32::NAN), Vec3::X, Vec3::Y, Vec3::Z];
    let g = vox(&nan, &[[0, 1, 2], [1, 2, 3]], 8);
    assert_eq!(g.solid_count(), 0);
    assert!(surface(&nan, &[[0, 1, 2], [1, 2, 3]], &g).count_ones() > 0);
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
    let (bv, bf, cells) = g.boundary_mesh();
    // Each triangle names the solid cell it bounds, ascending.
    assert_eq!(cells.len(), bf.len());
    assert!(cells.windows(2).all(|w| w[0] <= w[1]) && cells.iter().all(|&c| g.solid[c as usize]));
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

/// A box without its bottom face (z = min), outward-wound, and its inward-wound twin (every
/// triangle reversed). Seen from a point inside, the missing face subtends less than a
/// hemisphere, so w = ±(1 − Ω/4π) has |w| > ½ everywhere inside: the solid of either is the
/// solid of the closed box, the lattice of cell centres inside it.
/// Returns the positions, the open box's triangles and the closed box's.
fn open_box() -> (Vec<Vec3>, Vec<[u32; 3]>, Vec<[u32; 3]>) {
    let (v, f) = cuboid(Vec3::new(-0.27, 0.11, 0.3), Vec3::new(0.74, 0.93, 1.12));
    // The first two triangles are the z = min face (normal −z).
    let open: Vec<[u32; 3]> = f[2..].to_vec();
    (v, open, f)
}

#[test]
fn inward_wound_open_box_has_the_solid_of_its_outward_twin() {
    let (v, open, closed) = open_box();
    let inward: Vec<[u32; 3]> = open.iter().map(|t| [t[0], t[2], t[1]]).collect();
    // The twin really is inward: the winding number inside is negative.
    let p = DVec3::new(0.2, 0.5, 0.7);
    assert!(WindingNumber::new(&v, &open).eval_exact(p) > 0.5);
    assert!(WindingNumber::new(&v, &inward).eval_exact(p) < -0.5);
    for res in [16, 24, 40] {
        let out = vox(&v, &open, res);
        let inw = vox(&v, &inward, res);
        assert_eq!(out, inw, "res {res}: the twins' grids differ");
        let shut = vox(&v, &closed, res);
        assert_eq!(out, shut, "res {res}: the open box's solid is not the closed box's");
        let expect = (0..out.cell_count())
            .filter(|&idx| {
                let [nx, ny, _] = out.dims;
                let idx = idx as u32;
                let c = out.cell_center(idx % nx, idx / nx % ny, idx / (nx * ny));
                c.cmpge(DVec3::new(-0.27, 0.11, 0.3)).all() && c.cmple(DVec3::new(0.74, 0.93, 1.12)).all()
            })
            .count();
        assert_eq!(out.solid_count(), expect, "res {res}");
    }
}

/// The inside test at arbitrary points (the fit's pocket check) on the inward-wound open box:
/// the same answers as on the outward twin, where the signed rule w ≥ ½ would call the inside
/// of the inward one outside.
#[test]
fn pocket_test_on_an_inward_wound_open_box() {
    let (v, open, _) = open_box();
    let inward: Vec<[u32; 3]> = open.iter().map(|t| [t[0], t[2], t[1]]).collect();
    let g_out = vox(&v, &open, 24);
    let g_in = vox(&v, &inward, 24);
    let w_out = WindingNumber::new(&v, &open);
    let w_in = WindingNumber::new(&v, &inward);
    let h = g_in.cell_size;
    let (lo, hi) = (DVec3::new(-0.27, 0.11, 0.3), DVec3::new(0.74, 0.93, 1.12));
    let mut mixed = 0;
    // Points a quarter and a half cell inside and outside every wall, the open bottom included,
    // and some deep inside and far outside.
    let mid = (lo + hi) * 0.5;
    let mut points = vec![(mid, true), (hi + 3.0 * h, false), (lo - 3.0 * h, false)];
    for a in 0..3 {
        for d in [0.25, 0.5] {
            for (wall, sign) in [(lo[a], 1.0), (hi[a], -1.0)] {
                let mut p = mid + DVec3::splat(0.1);
                p[a] = wall + sign * d * h;
                points.push((p, true));
                p[a] = wall - sign * d * h;
                points.push((p, false));
            }
        }
    }
    for (p, want) in points {
        let signed = w_in.eval_exact(p);
        if g_in.neighbourhood(p) == spherebake_geom::voxel::Neighbourhood::Mixed {
            mixed += 1;
            if want {
                assert!(signed <= -0.5, "{p}: w {signed} (the signed rule would say outside)");
            }
        }
        assert_eq!(g_in.contains(p, |q| w_in.eval_exact(q)), want, "inward, {p}");
        assert_eq!(g_out.contains(p, |q| w_out.eval_exact(q)), want, "outward, {p}");
    }
    assert!(mixed >= 20, "only {mixed} points near the surface");
}

/// On a closed mesh the closed rule (one conclusive row decides) and the open rule (two agreeing
/// rows, else the winding number) are two ways to the same cells, including a mesh whose face
/// diagonals meet rows exactly (the unit cube at 8 cells: every ninth row touches an edge).
#[test]
fn closed_and_open_rules_agree_on_closed_meshes() {
    use spherebake_geom::bvh::TriangleBvh;
    use spherebake_geom::voxel::voxelize_bvh;
    let (v, f) = sphere_mesh();
    let (cv, cf) = cuboid(Vec3::ZERO, Vec3::ONE);
    for (v, f, res) in [(&v, &f, 40), (&cv, &cf, 8), (&cv, &cf, 33)] {
        let bvh = TriangleBvh::new(v, f);
        let settings = VoxelSettings { resolution: res };
        let (closed, open) = (voxelize_bvh(&bvh, true, &settings), voxelize_bvh(&bvh, false, &settings));
        assert_eq!(closed, open, "res {res}");
        assert!(closed.solid_count() > 0);
    }
}
