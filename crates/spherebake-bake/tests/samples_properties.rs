//! Sample placement properties: samples lie on the mesh and in their segment, results do not
//! depend on the thread count, and a badly wound mesh gives the samples of the well wound one.

mod samples_support;

use glam::Vec3;
use rayon::prelude::*;
use samples_support::*;
use spherebake_format::Samples;
use spherebake_geom::Mesh;

fn assert_close(a: &Samples, b: &Samples, tol: f32) {
    assert_eq!(a.sphere_count(), b.sphere_count());
    for (i, (x, y)) in a.per_sphere().zip(b.per_sphere()).enumerate() {
        let dx: Vec<(u8, u8)> = x.iter().map(|s| (s.direction, s.rule)).collect();
        let dy: Vec<(u8, u8)> = y.iter().map(|s| (s.direction, s.rule)).collect();
        assert_eq!(dx, dy, "sphere {i}: directions / rules");
        for (s, t) in x.iter().zip(y) {
            let dp = (Vec3::from_array(s.position) - Vec3::from_array(t.position)).length();
            let dn = (Vec3::from_array(s.normal) - Vec3::from_array(t.normal)).length();
            assert!(dp <= tol && dn <= tol, "sphere {i} direction {}: {s:?} vs {t:?}", s.direction);
        }
    }
}

/// Reverses the winding of triangles no two of which share a vertex (every `step`-th candidate).
fn flip_isolated(mesh: &Mesh, step: usize) -> (Mesh, Vec<bool>) {
    let mut m = mesh.clone();
    let mut used = vec![false; m.welded_positions.len()];
    let mut flipped = vec![false; m.triangles.len()];
    for t in (0..m.triangles.len()).step_by(step) {
        let w = m.triangles[t].map(|v| m.weld[v as usize] as usize);
        if w.iter().any(|&x| used[x]) {
            continue;
        }
        w.iter().for_each(|&x| used[x] = true);
        let [a, b, c] = m.triangles[t];
        m.triangles[t] = [a, c, b];
        flipped[t] = true;
    }
    (m, flipped)
}

fn capsule_spheres() -> Vec<[f32; 4]> {
    vec![[-0.7, 0.0, 0.0, 0.6], [0.0, 0.05, 0.0, 0.55], [0.7, 0.0, -0.05, 0.6], [0.0, 0.0, 0.9, 0.5]]
}

#[test]
fn isolated_flipped_triangles_are_oriented_back() {
    let mesh = capsule_mesh(1.0, 0.5, 48, 12);
    let spheres = capsule_spheres();
    let (reference, ref_stats, flip0) = run(&mesh, &spheres);
    assert!(flip0.iter().all(|f| !f));
    let (bad, flipped) = flip_isolated(&mesh, 5);
    let n_flipped = flipped.iter().filter(|f| **f).count();
    assert!(n_flipped > 50, "{n_flipped}");
    let (got, stats, flip) = run(&bad, &spheres);
    assert_eq!(flip, flipped, "orientation finds exactly the reversed triangles");
    assert_close(&got, &reference, 1e-6);
    assert_eq!(stats.per_sphere, ref_stats.per_sphere);
    // Without the orientation the flipped triangles would change the answer (the test can fail).
    let bvh = spherebake_geom::bvh::TriangleBvh::new(&bad.positions, &bad.triangles);
    let (raw, _) = spherebake_bake::samples::place_samples(&bad, &bvh, &[], &spheres);
    assert_ne!(raw, got);
}

#[test]
fn inside_out_mesh_gives_the_same_samples() {
    let mesh = capsule_mesh(1.0, 0.5, 48, 12);
    let spheres = capsule_spheres();
    let (reference, _, _) = run(&mesh, &spheres);
    let mut inv = mesh.clone();
    inv.triangles.iter_mut().for_each(|t| *t = [t[0], t[2], t[1]]);
    inv.normals.iter_mut().for_each(|n| *n = -*n);
    assert!(signed_volume(&inv) < 0.0);
    let (got, _, flip) = run(&inv, &spheres);
    assert!(flip.iter().all(|f| *f));
    assert_close(&got, &reference, 1e-6);
}

fn shared_model(rel: &str) -> Option<Mesh> {
    let path = spherebake_testkit::shared_model(rel)?;
    Some(spherebake_io::load_mesh(&path).expect("shared model loads").mesh)
}

#[test]
fn samples_lie_on_the_mesh_and_in_their_segment() {
    for (rel, k) in [("gltf/Duck.glb", 3), ("obj/spot/spot_triangulated.obj", 3), ("obj/stanford-bunny.obj", 2)] {
        let Some(mesh) = shared_model(rel) else { continue };
        let spheres = grid_spheres(&mesh, k);
        let (samples, stats, _) = run(&mesh, &spheres);
        let (lo, hi) = mesh.bounds().unwrap();
        let diag = (hi - lo).as_dvec3().length();
        let tris: Vec<[glam::DVec3; 3]> =
            (0..mesh.triangles.len()).map(|t| mesh.triangle(t).map(|p| p.as_dvec3())).collect();
        let all: Vec<(usize, spherebake_format::SamplePoint)> =
            samples.per_sphere().enumerate().flat_map(|(i, s)| s.iter().map(move |p| (i, *p))).collect();
        assert!(all.len() > 20 * spheres.len(), "{rel}: {} samples for {} spheres", all.len(), spheres.len());
        all.par_iter().for_each(|(i, s)| {
            let p = Vec3::from_array(s.position).as_dvec3();
            let d = tris.iter().map(|t| point_triangle_distance(p, t[0], t[1], t[2])).fold(f64::INFINITY, f64::min);
            assert!(d <= 1e-5 * diag, "{rel}: sphere {i} dir {}: {d} from the mesh", s.direction);
            assert_eq!(argmin_segment(p, &spheres), *i, "{rel}: sample outside its segment");
            let n = Vec3::from_array(s.normal).length();
            assert!((n - 1.0).abs() < 1e-5, "{rel}: normal length {n}");
            assert!(s.rule == 1 || s.rule == 3);
        });
        let c = stats.counts;
        assert_eq!(c.total() as usize, 92 * spheres.len());
        assert_eq!((c.rule1 + c.rule3) as usize, all.len());
        println!(
            "{rel}: {} spheres, mean {:.1} min {} samples, rule 2 empty {:.3}, rule 3 empty {:.3}",
            spheres.len(),
            stats.samples_per_sphere_mean,
            stats.samples_per_sphere_min,
            stats.share_rule2_empty,
            stats.share_rule3_empty
        );
    }
}

#[test]
fn identical_for_one_and_four_threads() {
    let mesh = shared_model("obj/stanford-bunny.obj").unwrap_or_else(|| capsule_mesh(1.0, 0.5, 48, 12));
    let spheres = grid_spheres(&mesh, 4);
    let pool = |n| rayon::ThreadPoolBuilder::new().num_threads(n).build().unwrap();
    let (a, sa, fa) = pool(1).install(|| run(&mesh, &spheres));
    let (b, sb, fb) = pool(4).install(|| run(&mesh, &spheres));
    assert_eq!(fa, fb);
    assert_eq!(a, b);
    assert_eq!(sa.per_sphere, sb.per_sphere);
    assert!(a.total() > 0);
}

/// A flipped patch larger than the rest of the surface (the +x cap and most of the cylinder).
#[test]
fn large_flipped_patch_is_oriented_back() {
    let mesh = capsule_mesh(1.0, 0.5, 48, 12);
    let spheres = capsule_spheres();
    let (reference, _, _) = run(&mesh, &spheres);
    let mut bad = mesh.clone();
    let mut expect = vec![false; bad.triangles.len()];
    for (t, tri) in bad.triangles.iter_mut().enumerate() {
        let cx: f32 = tri.iter().map(|&v| mesh.positions[v as usize].x).sum::<f32>() / 3.0;
        if cx > -1.25 {
            *tri = [tri[0], tri[2], tri[1]];
            expect[t] = true;
        }
    }
    let share = expect.iter().filter(|f| **f).count() as f64 / expect.len() as f64;
    assert!(share > 0.55, "{share}");
    let (got, _, flip) = run(&bad, &spheres);
    assert_eq!(flip, expect);
    assert_close(&got, &reference, 1e-6);
}

/// A sphere the fit left empty (radius the least positive normal f32, a point) owns no segment:
/// it gets no samples, its 92 directions are counted as skipped, and the other spheres' samples
/// are those they get without it. Below it in radius, a subnormal, the same; one float above it,
/// a sphere again. Empty spheres used to carry samples of no area, which the runtime drops (the
/// capsule fixture at 64 spheres: 193 of its 405 samples).
#[test]
fn an_empty_sphere_owns_no_samples_and_changes_no_others() {
    let mesh = capsule_mesh(1.0, 0.5, 48, 12);
    let real = [[-0.5, 0.0, 0.0, 0.75], [0.5, 0.0, 0.0, 0.75]];
    let (alone, _, _) = run(&mesh, &real);
    for (r, owns) in [(f32::MIN_POSITIVE, false), (f32::from_bits(1), false), (f32::from_bits(0x0080_0001), true)] {
        let mut with = real.to_vec();
        with.insert(1, [0.0, 0.2, 0.1, r]);
        let (s, st, _) = run(&mesh, &with);
        let per: Vec<_> = s.per_sphere().collect();
        if owns {
            assert!(st.per_sphere[1].skipped == 0, "radius {r:e} is a sphere");
            continue;
        }
        assert!(per[1].is_empty() && st.per_sphere[1].skipped == 92, "radius {r:e}: {} samples", per[1].len());
        let others: Vec<_> = alone.per_sphere().collect();
        assert_eq!((per[0], per[2]), (others[0], others[1]), "radius {r:e} changed the others' samples");
    }
}
