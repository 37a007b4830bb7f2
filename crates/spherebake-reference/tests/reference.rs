//! The Monte Carlo reference against answers derived independently: closed forms for the direct
//! irradiance under a sphere, the quadrature of `analytic::sphere_one_bounce` for the indirect
//! irradiance of a diffuse sphere, and bit-identical results for 1 and 2 threads.

use spherebake_reference::analytic::{
    sky_irradiance, sphere_one_bounce, sphere_one_bounce_at, uv_sphere_mesh, DiffuseSphere,
};
use spherebake_reference::{Receiver, ReferenceSettings, Scene, Sky};
use std::f64::consts::PI;

const ALBEDO: [f32; 3] = [0.8, 0.5, 0.2];

fn ground(p: [f64; 3]) -> Receiver {
    Receiver { position: p, normal: [0.0, 1.0, 0.0], surface: None }
}

#[test]
fn unoccluded_ground_point_under_the_uniform_sky_gets_pi() {
    let mesh = uv_sphere_mesh([0.0, 1.0, 0.0], 1.0, 16, 32, ALBEDO);
    let scene = Scene::new(&mesh).unwrap();
    assert!((scene.ground_y() - 0.0).abs() < 1e-6);
    let sky = Sky::uniform(1.0).unwrap();
    // Far from the sphere (and behind nothing): every cosine-weighted ray sees the sky, so the
    // estimate is π exactly, and nothing bounces onto the point.
    let far = [ground([300.0, 0.0, -200.0]), ground([-500.0, 0.0, 10.0])];
    let s = ReferenceSettings { rays: 256, shadow_rays: 1, seed: 3 };
    for e in scene.direct(&sky, &far, &s).unwrap() {
        assert!((e - PI).abs() < 1e-12, "{e}");
    }
    for e in scene.indirect(&sky, &far, &s).unwrap() {
        assert_eq!(e, [0.0; 3]);
    }
}

#[test]
fn unoccluded_direct_light_of_a_varying_sky_matches_the_quadrature() {
    // An order-3 sky with negative lobes (clamped at 0) and a strong horizon term: on receivers
    // far from the mesh, with several normals, the stratified Monte Carlo estimate matches the
    // deterministic hemisphere quadrature of ∫_{ω_y>0} sky(ω) max(0, n·ω) dω.
    let mesh = uv_sphere_mesh([0.0, 1.0, 0.0], 1.0, 8, 16, ALBEDO);
    let scene = Scene::new(&mesh).unwrap();
    let mut c = [0.0; 9];
    c[0] = 2.0;
    c[1] = 0.9;
    c[3] = -1.2;
    c[6] = 0.8;
    let sky = Sky::new(3, &c).unwrap();
    let normals = [[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.6, -0.8], [0.48, -0.6, 0.64]];
    let recv: Vec<Receiver> = normals
        .iter()
        .enumerate()
        .map(|(k, n)| Receiver { position: [200.0 + 10.0 * k as f64, 3.0, -150.0], normal: *n, surface: None })
        .collect();
    let s = ReferenceSettings { rays: 65536, shadow_rays: 1, seed: 21 };
    let est = scene.direct_with_error(&sky, &recv, &s).unwrap();
    for (n, e) in normals.iter().zip(&est) {
        let exact = sky_irradiance(&sky, *n, 256);
        assert!(exact > 0.0);
        // The naive standard error (~0.5 %) ignores the stratification; the stratified estimate
        // was measured within 5e-4 relative of the quadrature at every normal here.
        assert!((e.value[0] - exact).abs() < 2e-3 * exact, "n {n:?}: {} vs {exact} (σ {})", e.value[0], e.std_error[0]);
    }
}

#[test]
fn direct_under_a_sphere_matches_the_cap_formula() {
    // Sphere radius r, centre height h above the ground; a ground point at horizontal distance d
    // sees it as a cap of half-angle α (sin α = r/D, D = √(h² + d²)) whose axis makes angle β with
    // +Y (cos β = h/D). When the cap is above the horizon, the blocked cosine integral is
    // π sin²α cos β, so E_d = π(1 − sin²α cos β) under the uniform sky.
    let (r, h) = (1.0, 1.5);
    let mut mesh = uv_sphere_mesh([0.0, h, 0.0], r, 96, 192, ALBEDO);
    // A tiny flat triangle far away sets the ground at y = 0 (the mesh stands on its lowest point).
    let v0 = mesh.positions.len() as u32;
    for p in [[40.0, 0.0, 40.0], [40.1, 0.0, 40.0], [40.0, 0.0, 40.1]] {
        mesh.positions.push(glam::Vec3::from_array(p));
        mesh.normals.push(glam::Vec3::Y);
    }
    mesh.triangles.push([v0, v0 + 2, v0 + 1]);
    mesh.triangle_materials.push(0);
    mesh.rebuild_weld();
    let scene = Scene::new(&mesh).unwrap();
    let y0 = scene.ground_y();
    assert_eq!(y0, 0.0);
    let hh = h - y0;
    let sky = Sky::uniform(1.0).unwrap();
    let s = ReferenceSettings { rays: 4096, shadow_rays: 1, seed: 11 };
    let ds = [0.0, 0.3, 0.7, 1.2];
    let recv: Vec<Receiver> = ds.iter().map(|&d| ground([d, y0, 0.0])).collect();
    let est = scene.direct_with_error(&sky, &recv, &s).unwrap();
    for (d, e) in ds.iter().zip(&est) {
        let dd = (hh * hh + d * d).sqrt();
        let (sa, cb) = (r / dd, hh / dd);
        assert!(sa.asin() + cb.acos() <= PI / 2.0, "test point must see the whole cap");
        let exact = PI * (1.0 - sa * sa * cb);
        // The inscribed polyhedron is smaller than the sphere by < r(1 − cos(π/96)) ≈ 5e-4 r.
        let tol = 4.0 * e.std_error[0] + 2e-3 * exact;
        assert!((e.value[0] - exact).abs() < tol, "d {d}: {} vs {exact} (σ {})", e.value[0], e.std_error[0]);
    }
}

#[test]
fn model_receivers_lie_on_the_sphere_with_outward_normals_and_get_the_unshadowed_sky() {
    // Every triangle wound inward: the orientation by the solid must still give outward normals.
    let mut mesh = uv_sphere_mesh([0.5, 2.0, -0.25], 1.0, 48, 96, ALBEDO);
    for t in &mut mesh.triangles {
        t.swap(1, 2);
    }
    for n in &mut mesh.normals {
        *n = -*n;
    }
    let scene = Scene::new(&mesh).unwrap();
    let recv = scene.model_receivers(400, 5).unwrap();
    assert_eq!(recv.len(), 400);
    let c = [0.5, 2.0, -0.25];
    let mut upper = 0;
    for r in &recv {
        let v = [r.position[0] - c[0], r.position[1] - c[1], r.position[2] - c[2]];
        let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        assert!((len - 1.0).abs() < 2e-3, "{len}");
        let dot = (v[0] * r.normal[0] + v[1] * r.normal[1] + v[2] * r.normal[2]) / len;
        assert!(dot > 0.995, "normal not outward: {dot}");
        upper += usize::from(v[1] > 0.0);
    }
    // Area-weighted and stratified: half the area is above the centre.
    assert!((upper as i64 - 200).abs() <= 12, "{upper}");
    // A convex sphere shadows none of its own sky: E_d(n) = π(1 + n_y)/2 under the uniform sky.
    let sky = Sky::uniform(1.0).unwrap();
    let s = ReferenceSettings { rays: 1024, shadow_rays: 1, seed: 9 };
    let pick: Vec<Receiver> = recv.iter().step_by(10).copied().collect();
    let est = scene.direct_with_error(&sky, &pick, &s).unwrap();
    for (r, e) in pick.iter().zip(&est) {
        let exact = PI * (1.0 + r.normal[1]) / 2.0;
        assert!((e.value[0] - exact).abs() < 4.0 * e.std_error[0] + 0.01, "{r:?}: {} vs {exact}", e.value[0]);
    }
}

#[test]
fn indirect_on_the_ground_matches_the_quadrature_of_a_diffuse_sphere() {
    let (r, h) = (1.0, 1.0);
    let mesh = uv_sphere_mesh([0.0, h, 0.0], r, 64, 128, ALBEDO);
    let scene = Scene::new(&mesh).unwrap();
    let sky = Sky::uniform(1.0).unwrap();
    let recv: Vec<Receiver> = scene.ground_receivers(6).unwrap();
    let s = ReferenceSettings { rays: 16384, shadow_rays: 4, seed: 2 };
    let est = scene.indirect_with_error(&sky, &recv, &s).unwrap();
    let sphere = DiffuseSphere { centre: [0.0, h, 0.0], radius: r, albedo: ALBEDO.map(f64::from) };
    let pts: Vec<[f64; 3]> = recv.iter().map(|r| r.position).collect();
    let exact = sphere_one_bounce(&sky, &sphere, 0.0, &pts, 48).unwrap();
    // The same quadrature with fewer nodes agrees to 1e-6: it has converged.
    let coarse = sphere_one_bounce(&sky, &sphere, 0.0, &pts, 24).unwrap();
    let (mut se, mut sum) = (0.0, 0.0);
    for ((e, x), c) in est.iter().zip(&exact).zip(&coarse) {
        for k in 0..3 {
            assert!((x[k] - c[k]).abs() <= 1e-6 * x[k].max(1e-3), "quadrature not converged: {x:?} {c:?}");
            let tol = 5.0 * e.std_error[k] + 0.01 * x[k] + 1e-4;
            assert!((e.value[k] - x[k]).abs() < tol, "{:?}: {:?} vs {x:?} (σ {:?})", pts, e.value, e.std_error);
            se += (e.value[k] - x[k]).powi(2);
            sum += x[k];
        }
    }
    let n = (3 * est.len()) as f64;
    let rel_rmse = (se / n).sqrt() / (sum / n);
    eprintln!("relative RMSE {rel_rmse}");
    assert!(rel_rmse < 0.02, "relative RMSE {rel_rmse}");
    let mean = |v: &dyn Fn(usize) -> f64| (0..est.len()).map(v).sum::<f64>() / est.len() as f64;
    let bias = mean(&|i| est[i].value[0]) / mean(&|i| exact[i][0]) - 1.0;
    eprintln!("mean bias {bias}");
    assert!(bias.abs() < 0.01, "mean bias {bias}");
    // The colour is the albedo's: R/G = 0.8/0.5 at every receiver with light.
    for e in &est {
        if e.value[1] > 0.0 {
            assert!((e.value[0] / e.value[1] - 1.6).abs() < 1e-6, "{:?}", e.value);
        }
    }
}

#[test]
fn indirect_at_tilted_free_receivers_matches_the_quadrature() {
    // Receivers in the air beside the sphere, facing it at several tilts: the plane of each
    // receiver cuts the sphere's visible cap for some of them (max(0, n·ω) inside the cap).
    let (r, h) = (1.0, 1.0);
    let mesh = uv_sphere_mesh([0.0, h, 0.0], r, 64, 128, ALBEDO);
    let scene = Scene::new(&mesh).unwrap();
    let sky = Sky::uniform(1.0).unwrap();
    let tilts: [[f64; 3]; 4] = [[-1.0, 0.0, 0.0], [-0.6, -0.8, 0.0], [-0.6, 0.8, 0.0], [0.0, 0.0, 1.0]];
    let pts = [[2.2, 1.0, 0.0], [1.6, 2.0, 0.3], [1.8, 0.4, -0.2], [0.2, 0.8, -1.7]];
    let recv: Vec<Receiver> =
        pts.iter().zip(&tilts).map(|(p, n)| Receiver { position: *p, normal: *n, surface: None }).collect();
    let s = ReferenceSettings { rays: 16384, shadow_rays: 4, seed: 4 };
    let est = scene.indirect_with_error(&sky, &recv, &s).unwrap();
    let sphere = DiffuseSphere { centre: [0.0, h, 0.0], radius: r, albedo: ALBEDO.map(f64::from) };
    let exact = sphere_one_bounce_at(&sky, &sphere, 0.0, &pts, &tilts, 96).unwrap();
    let finer = sphere_one_bounce_at(&sky, &sphere, 0.0, &pts, &tilts, 192).unwrap();
    for ((e, x), f) in est.iter().zip(&exact).zip(&finer) {
        assert!(x[0] > 0.0);
        assert!((x[0] - f[0]).abs() < 1e-4 * f[0], "quadrature not converged: {x:?} {f:?}");
        for k in 0..3 {
            let tol = 5.0 * e.std_error[k] + 0.01 * x[k];
            assert!((e.value[k] - x[k]).abs() < tol, "{:?} vs {x:?} (σ {:?})", e.value, e.std_error);
        }
    }
    // Facing away from the sphere: nothing.
    let away = [Receiver { position: [2.2, 1.0, 0.0], normal: [1.0, 0.0, 0.0], surface: None }];
    assert_eq!(scene.indirect(&sky, &away, &s).unwrap()[0], [0.0; 3]);
    let none = sphere_one_bounce_at(&sky, &sphere, 0.0, &[[2.2, 1.0, 0.0]], &[[1.0, 0.0, 0.0]], 32).unwrap();
    assert_eq!(none[0], [0.0; 3]);
}

#[test]
fn sphere_one_bounce_checks_its_inputs() {
    let sky = Sky::uniform(1.0).unwrap();
    let s = DiffuseSphere { centre: [0.0, 0.5, 0.0], radius: 1.0, albedo: [1.0; 3] };
    assert!(sphere_one_bounce(&sky, &s, 0.0, &[[3.0, 0.0, 0.0]], 8).is_err(), "sphere below the ground");
    let s = DiffuseSphere { centre: [0.0, 1.0, 0.0], radius: 1.0, albedo: [1.0; 3] };
    assert!(sphere_one_bounce(&sky, &s, 0.0, &[[0.0, 1.2, 0.0]], 8).is_err(), "point inside");
    assert!(sphere_one_bounce(&sky, &s, 0.0, &[[3.0, 0.0, 0.0]], 0).is_err());
    let bad = DiffuseSphere { radius: f64::NAN, ..s };
    assert!(sphere_one_bounce(&sky, &bad, 0.0, &[[3.0, 0.0, 0.0]], 8).is_err());
}

#[test]
fn results_are_identical_for_one_and_two_threads() {
    let mesh = uv_sphere_mesh([0.0, 1.0, 0.0], 1.0, 24, 48, ALBEDO);
    let scene = Scene::new(&mesh).unwrap();
    let mut c = [0.0; 16];
    c[0] = 2.0;
    c[2] = 1.0;
    c[5] = -0.4;
    let sky = Sky::new(4, &c).unwrap();
    let s = ReferenceSettings { rays: 64, shadow_rays: 4, seed: 7 };
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| {
            let mut recv = scene.ground_receivers(6).unwrap();
            recv.extend(scene.model_receivers(30, 1).unwrap());
            let d = scene.direct(&sky, &recv, &s).unwrap();
            let i = scene.indirect(&sky, &recv, &s).unwrap();
            (recv, d, i)
        })
    };
    let (r1, d1, i1) = run(1);
    let (r2, d2, i2) = run(2);
    assert_eq!(r1, r2);
    assert_eq!(d1.iter().map(|v| v.to_bits()).collect::<Vec<_>>(), d2.iter().map(|v| v.to_bits()).collect::<Vec<_>>());
    let bits = |v: &[[f64; 3]]| v.iter().flat_map(|x| x.map(f64::to_bits)).collect::<Vec<_>>();
    assert_eq!(bits(&i1), bits(&i2));
    assert!(i1.iter().any(|x| x[0] > 0.0));
}

#[test]
fn bad_inputs_are_errors() {
    let mesh = uv_sphere_mesh([0.0, 1.0, 0.0], 1.0, 8, 16, ALBEDO);
    let scene = Scene::new(&mesh).unwrap();
    let sky = Sky::uniform(1.0).unwrap();
    let recv = [Receiver { position: [0.0; 3], normal: [0.0, 1.0, 0.0], surface: Some((1 << 30, [1.0, 0.0, 0.0])) }];
    assert!(scene.direct(&sky, &recv, &ReferenceSettings::default()).is_err());
    let ok = [ground([5.0, 0.0, 0.0])];
    assert!(scene.direct(&sky, &ok, &ReferenceSettings { rays: 0, ..Default::default() }).is_err());
    assert!(scene.ground_receivers(0).is_err());
    assert!(Scene::with_positions(&mesh, vec![]).is_err());
    let mut flat = mesh.clone();
    for p in &mut flat.positions {
        p.x = 0.0;
        p.z = 0.0;
    }
    assert!(Scene::new(&flat).is_err(), "no horizontal extent");
    let mut broken = mesh.clone();
    broken.triangles[0][0] = 1 << 20;
    assert!(Scene::new(&broken).is_err(), "vertex index out of range");
}

#[test]
fn segment_visibility_and_albedo_under_a_point_follow_the_sphere() {
    // A unit sphere at (0, 1, 0): a segment between two outside points is blocked exactly when the line passes
    // within the radius of the centre (distance of the centre to the segment < 1); the albedo just under a
    // surface point is the sphere's colour, and a point far from any surface finds none.
    let mesh = uv_sphere_mesh([0.0, 1.0, 0.0], 1.0, 48, 96, ALBEDO);
    let scene = Scene::new(&mesh).unwrap();
    for (a, b, clear) in [
        ([-3.0, 1.0, 0.0], [3.0, 1.0, 0.0], false),
        ([-3.0, 2.2, 0.0], [3.0, 2.2, 0.0], true),
        ([-3.0, 1.9, 0.0], [3.0, 1.9, 0.0], false),
        ([-3.0, 1.0, 0.0], [-1.5, 1.0, 0.0], true),
        ([2.0, 0.0, 2.0], [2.0, 3.0, -2.0], true),
    ] {
        assert_eq!(scene.segment_clear(a, b), clear, "{a:?} → {b:?}");
    }
    // A point on the sphere (on a vertex ring, so on the mesh up to its chord error) with its outward normal.
    let n = [0.6f64, 0.0, 0.8];
    let p = [n[0], 1.0 + n[1], n[2]];
    let got = scene.albedo_near(p, n).expect("a surface under the point");
    for k in 0..3 {
        assert!((got[k] - f64::from(ALBEDO[k])).abs() < 1e-6, "{got:?} vs {ALBEDO:?}");
    }
    assert!(scene.albedo_near([5.0, 5.0, 5.0], [0.0, 1.0, 0.0]).is_none());
}

/// An alpha-masked card is a hole where its alpha is below the cutoff: rays pass through it as
/// the albedo bake sees through it. A 20 × 20 card at height 1 over a ground point, whose
/// factor alpha 0.25 is below the cutoff 0.5 everywhere, leaves the point's sky unoccluded (π
/// under the uniform sky, exactly, as in the first test); opaque, it blocks most of it.
#[test]
fn rays_pass_through_the_holes_of_an_alpha_masked_card() {
    use spherebake_geom::glam::Vec3;
    use spherebake_geom::{Material, Mesh};
    let card = |cutoff: Option<f32>| {
        let mut positions = vec![
            Vec3::new(-10.0, 1.0, -10.0),
            Vec3::new(10.0, 1.0, -10.0),
            Vec3::new(10.0, 1.0, 10.0),
            Vec3::new(-10.0, 1.0, 10.0),
        ];
        // A small opaque triangle on the ground far away sets the ground plane y = 0.
        positions.extend([Vec3::new(50.0, 0.0, 0.0), Vec3::new(51.0, 0.0, 0.0), Vec3::new(50.0, 0.0, 1.0)]);
        let mut m = Mesh {
            normals: vec![Vec3::Y; positions.len()],
            positions,
            triangles: vec![[0, 2, 1], [0, 3, 2], [4, 6, 5]],
            triangle_materials: vec![0, 0, 1],
            materials: vec![
                Material {
                    base_color_factor_linear: [0.5, 0.5, 0.5, 0.25],
                    alpha_mask_cutoff: cutoff,
                    ..Default::default()
                },
                Material::default(),
            ],
            ..Default::default()
        };
        m.rebuild_weld();
        m
    };
    let sky = Sky::uniform(1.0).unwrap();
    let s = ReferenceSettings { rays: 256, shadow_rays: 1, seed: 5 };
    let at = [ground([0.0, 0.0, 0.0]), ground([3.0, 0.0, -4.0])];
    let masked = card(Some(0.5));
    let scene = Scene::new(&masked).unwrap();
    assert!(scene.ground_y().abs() < 1e-9);
    for e in scene.direct(&sky, &at, &s).unwrap() {
        assert!((e - PI).abs() < 1e-12, "masked card: {e}");
    }
    let opaque = card(None);
    for e in Scene::new(&opaque).unwrap().direct(&sky, &at, &s).unwrap() {
        assert!(e < 0.5 * PI, "opaque card: {e}");
    }
    // An opaque roof at height 2 over the holes: the rays go through the card and stop there
    // (a search that gave up at the first hole would see the sky).
    let mut roofed = card(Some(0.5));
    let r0 = roofed.positions.len() as u32;
    roofed
        .positions
        .extend([[-10.0, 2.0, -10.0], [10.0, 2.0, -10.0], [10.0, 2.0, 10.0], [-10.0, 2.0, 10.0]].map(Vec3::from));
    roofed.normals = vec![Vec3::Y; roofed.positions.len()];
    roofed.triangles.extend([[r0, r0 + 2, r0 + 1], [r0, r0 + 3, r0 + 2]]);
    roofed.triangle_materials.extend([1, 1]);
    roofed.rebuild_weld();
    for e in Scene::new(&roofed).unwrap().direct(&sky, &at, &s).unwrap() {
        assert!(e < 0.5 * PI, "a roof over the masked card: {e}");
    }
    // At the cutoff 0.25 the alpha 0.25 is not below it: opaque again.
    let at_cutoff = card(Some(0.25));
    for e in Scene::new(&at_cutoff).unwrap().direct(&sky, &at, &s).unwrap() {
        assert!(e < 0.5 * PI, "alpha equal to the cutoff: {e}");
    }
}
