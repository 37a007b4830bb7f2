//! Colour bleeding of two spheres: red at x = −3, green at x = +3 (unit radius, standing on the ground, 6 radii
//! apart) under the uniform sky above the horizon. Ground receivers on the red side are redder, on the green side
//! greener; the mirror symmetry of the scene swaps the channels; and the values match a ray-traced one-bounce
//! reference (nearest hit among both spheres, each sphere's exit radiance from the sky it sees).

#![allow(clippy::needless_range_loop)] // channel loops

mod common;
use common::sphere_proxy as sphere_proxy_of_order;

fn sphere_proxy(spheres: &[(Sphere, [f32; 3])]) -> Proxy {
    sphere_proxy_of_order(spheres, 4)
}

use spherebake_runtime::light::{
    clip_below_horizon, light_spheres, ClusterSpec, IndirectCluster, LightContext, Pass1Settings, PosedProxy,
    SphereLights,
};
use spherebake_runtime::shadow::{uniform_light, ExpMethod};
use spherebake_runtime::{Proxy, Sphere};
use std::f64::consts::PI;

const RED: [f32; 3] = [0.8, 0.1, 0.05];
const GREEN: [f32; 3] = [0.1, 0.8, 0.05];
const SPHERES: [Sphere; 2] =
    [Sphere { center: [-3.0, 1.0, 0.0], radius: 1.0 }, Sphere { center: [3.0, 1.0, 0.0], radius: 1.0 }];

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

/// An orthonormal frame (u, v) around the unit w.
fn frame(w: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let t = if w[0].abs() < 0.9 { [1.0, 0.0, 0.0] } else { [0.0, 1.0, 0.0] };
    let u = cross(t, w);
    let un = dot(u, u).sqrt();
    let u = u.map(|v| v / un);
    (u, cross(w, u))
}

/// Calls `f(ω, dω)` for midpoint-rule directions (cos ψ × φ, `m × 2m`) over the cone of the ball (c, r) seen from x.
fn over_cone(x: [f64; 3], c: [f64; 3], r: f64, m: usize, mut f: impl FnMut([f64; 3], f64)) {
    let d = sub(c, x);
    let dist = dot(d, d).sqrt();
    let w = d.map(|v| v / dist);
    let cos_t = (1.0 - (r / dist).powi(2)).max(0.0).sqrt();
    let (u, v) = frame(w);
    let dw = (1.0 - cos_t) * 2.0 * PI / (2 * m * m) as f64;
    for i in 0..m {
        let cz = cos_t + (1.0 - cos_t) * (i as f64 + 0.5) / m as f64;
        let sz = (1.0 - cz * cz).max(0.0).sqrt();
        for k in 0..2 * m {
            let phi = PI * (k as f64 + 0.5) / m as f64;
            let (s, co) = phi.sin_cos();
            f([0, 1, 2].map(|q| cz * w[q] + sz * (co * u[q] + s * v[q])), dw);
        }
    }
}

/// Entry distance of the ray into the ball, `None` on a miss.
fn hit(x: [f64; 3], dir: [f64; 3], c: [f64; 3], r: f64) -> Option<f64> {
    let d = sub(c, x);
    let b = dot(dir, d);
    let disc = b * b - (dot(d, d) - r * r);
    (disc >= 0.0 && b > disc.sqrt()).then(|| b - disc.sqrt())
}

/// The sky a point of one sphere does not see because of the other sphere: (1/π) ∫ over the other's cone of
/// max(n·ω, 0) for ω above the horizon, on a grid of the point's normal (θ from +y in `NT` rows, φ in `2 NT`
/// columns), bilinearly interpolated.
struct SkyLoss {
    grid: Vec<f64>,
}

const NT: usize = 48;

impl SkyLoss {
    fn new(me: Sphere, other: Sphere) -> SkyLoss {
        let c = me.center.map(f64::from);
        let r = f64::from(me.radius);
        let co = other.center.map(f64::from);
        let ro = f64::from(other.radius);
        let mut grid = vec![0.0; (NT + 1) * 2 * NT];
        for i in 0..=NT {
            let t = PI * i as f64 / NT as f64;
            for k in 0..2 * NT {
                let p = PI * k as f64 / NT as f64;
                let n = [t.sin() * p.cos(), t.cos(), t.sin() * p.sin()];
                let x = [0, 1, 2].map(|q| c[q] + r * n[q]);
                let mut loss = 0.0;
                over_cone(x, co, ro, 24, |w, dw| {
                    if w[1] > 0.0 {
                        loss += dot(n, w).max(0.0) * dw;
                    }
                });
                grid[i * 2 * NT + k] = loss / PI;
            }
        }
        SkyLoss { grid }
    }

    fn at(&self, n: [f64; 3]) -> f64 {
        let t = n[1].clamp(-1.0, 1.0).acos() / PI * NT as f64;
        let p = n[2].atan2(n[0]).rem_euclid(2.0 * PI) / PI * NT as f64;
        let (i, k) = ((t as usize).min(NT - 1), p as usize % (2 * NT));
        let (ft, fp) = (t - i as f64, p - p.floor());
        let k1 = (k + 1) % (2 * NT);
        let g = |i: usize, k: usize| self.grid[i * 2 * NT + k];
        (1.0 - ft) * ((1.0 - fp) * g(i, k) + fp * g(i, k1)) + ft * ((1.0 - fp) * g(i + 1, k) + fp * g(i + 1, k1))
    }
}

/// Ray-traced one-bounce ground irradiance at x (normal +Y): over each sphere's cone, rays above the horizon that
/// reach that sphere first, weighted by ω_y, times its exit radiance a (E_sky/π − loss): E_sky/π = (1 + n_y)/2 for
/// the sky above the horizon and the ground plane's horizon on a sphere's own tangent plane, `loss` the other
/// sphere's share (`SkyLoss`, or none for the simple reference).
fn reference(x: [f64; 3], losses: Option<&[SkyLoss; 2]>) -> [f64; 3] {
    let mut e = [0.0f64; 3];
    for i in 0..2 {
        let (me, other) = (SPHERES[i], SPHERES[1 - i]);
        let a = if i == 0 { RED } else { GREEN };
        let c = me.center.map(f64::from);
        let r = f64::from(me.radius);
        let co = other.center.map(f64::from);
        let ro = f64::from(other.radius);
        let mut sum = 0.0;
        over_cone(x, c, r, 120, |w, dw| {
            if w[1] <= 0.0 {
                return;
            }
            let Some(t) = hit(x, w, c, r) else { return };
            if hit(x, w, co, ro).is_some_and(|to| to < t) {
                return;
            }
            let p = [0, 1, 2].map(|q| x[q] + t * w[q]);
            let n = sub(p, c).map(|v| v / r);
            let exit = 0.5 * (1.0 + n[1]) - losses.map_or(0.0, |l| l[i].at(n));
            sum += exit * w[1] * dw;
        });
        for ch in 0..3 {
            e[ch] += f64::from(a[ch]) * sum;
        }
    }
    e
}

/// Ground receivers x ∈ [−7, 7], z ∈ [−3, 3] (step 0.5; x = 0 and the two contact points included).
fn receivers() -> Vec<[f32; 3]> {
    let mut xs = Vec::new();
    for i in 0..=28 {
        for k in 0..=12 {
            xs.push([-7.0 + 0.5 * i as f32, 0.0, -3.0 + 0.5 * k as f32]);
        }
    }
    xs
}

fn proxy_values(xs: &[[f32; 3]]) -> Vec<[f64; 3]> {
    let proxy = sphere_proxy(&[(SPHERES[0], RED), (SPHERES[1], GREEN)]);
    let ctx = LightContext::new(4, ExpMethod::default()).unwrap();
    let mut l = vec![0.0; 16];
    uniform_light(4, &mut l);
    let mut env = vec![0.0; 16];
    clip_below_horizon(&ctx, &l, [0.0, 1.0, 0.0], &mut env).unwrap();
    let posed = PosedProxy::at_rest(&proxy);
    let mut lights = SphereLights::new();
    light_spheres(&ctx, &posed, &env, &[], &Pass1Settings::default(), &mut lights).unwrap();
    let sources = [(posed, &lights)];
    let up = [0.0f32, 1.0, 0.0];
    let mut cl = IndirectCluster::new();
    xs.iter()
        .map(|&x| {
            cl.build(&ctx, &sources, &ClusterSpec::new(x, 0.0, Some(up))).unwrap();
            cl.irradiance(&ctx, &sources, x, up).unwrap()
        })
        .collect()
}

#[test]
fn each_side_takes_its_spheres_colour() {
    let xs = receivers();
    let e = proxy_values(&xs);
    for (x, v) in xs.iter().zip(&e) {
        assert!(v.iter().all(|&c| c > 0.0), "{x:?}: {v:?}");
        // Dominant channel: the nearer sphere's colour (|x| ≥ 1.5: off the middle band where both are similar), except
        // in a sphere's footprint, where the ground sees only its dark underside (exit radiance a(1 + n_y)/2 → 0)
        // and the far sphere wins.
        let footprint = SPHERES.iter().any(|s| (x[0] - s.center[0]).hypot(x[2] - s.center[2]) < 1.0);
        if footprint {
            continue;
        }
        if x[0] <= -1.5 {
            assert!(v[0] > v[1], "red side {x:?}: {v:?}");
        } else if x[0] >= 1.5 {
            assert!(v[1] > v[0], "green side {x:?}: {v:?}");
        }
    }
    // R/G falls from the red side to the green side: every receiver at x < 0 is redder than its mirror image
    // (outside the footprints).
    let n_z = 13;
    for i in 0..14 {
        for k in 0..n_z {
            let x = xs[i * n_z + k];
            if (x[0] + 3.0).hypot(x[2]) < 1.0 {
                continue;
            }
            let (a, b) = (&e[i * n_z + k], &e[(28 - i) * n_z + k]);
            assert!(a[0] / a[1] > b[0] / b[1], "{:?} vs {:?}", xs[i * n_z + k], xs[(28 - i) * n_z + k]);
        }
    }
    // Mirror symmetry (x → −x swaps the spheres and the red and green channels; blue is the same; the geodesic
    // directions are mirror symmetric too). Not on the mirror plane x = 0 itself: there both spheres have the same
    // power, the tie keeps the cut order, and eq. 23 lets the first (red) occlude the second by 7 % although their
    // cones are 143° apart — the order-4 truncation of two 18° caps (`light_visibility` computes it: 0.92).
    let mut worst = 0.0f64;
    for i in (0..=28).filter(|&i| i != 14) {
        for k in 0..n_z {
            let (a, b) = (&e[i * n_z + k], &e[(28 - i) * n_z + k]);
            let scale = a[0].max(a[1]);
            worst = worst.max((a[0] - b[1]).abs() / scale).max((a[2] - b[2]).abs() / scale);
        }
    }
    println!("mirror asymmetry {worst:.2e}");
    assert!(worst < 1e-3, "mirror asymmetry {worst}");
}

fn rel_rmse(got: &[[f64; 3]], want: &[[f64; 3]]) -> (f64, f64) {
    let (mut se, mut sum, mut bias) = (0.0, 0.0, 0.0);
    for (g, w) in got.iter().zip(want) {
        for c in 0..3 {
            se += (g[c] - w[c]).powi(2);
            sum += w[c];
            bias += g[c] - w[c];
        }
    }
    let n = (got.len() * 3) as f64;
    ((se / n).sqrt() / (sum / n), bias / sum)
}

#[test]
fn matches_the_ray_traced_one_bounce() {
    let xs = receivers();
    let got = proxy_values(&xs);
    let losses = [SkyLoss::new(SPHERES[0], SPHERES[1]), SkyLoss::new(SPHERES[1], SPHERES[0])];
    let exact: Vec<[f64; 3]> = xs.iter().map(|x| reference(x.map(f64::from), Some(&losses))).collect();
    let simple: Vec<[f64; 3]> = xs.iter().map(|x| reference(x.map(f64::from), None)).collect();
    let (rmse_exact, bias_exact) = rel_rmse(&got, &exact);
    let (rmse_simple, bias_simple) = rel_rmse(&got, &simple);
    let (gap, gap_bias) = rel_rmse(&exact, &simple);
    println!(
        "relative RMSE vs the reference with the mutual sky occlusion {rmse_exact:.4} (bias {bias_exact:+.4}); vs the \
         one with a(1 + n_y)/2 exit radiance {rmse_simple:.4} (bias {bias_simple:+.4}); between the references \
         {gap:.4} (bias {gap_bias:+.4})"
    );
    // The exit radiance a(1 + n_y)/2 ignores the other sphere in each sphere's sky. From 5–7 radii away it covers
    // sin²θ ≤ 1/25 of the cosine lobe: 4 % of the sky at the point facing it, but ~10 % of the little sky the lower
    // inner faces see, and those are what the ground between the spheres sees (at x = ∓2, z = 0 the simple
    // reference is 10 % brighter). Measured between the references: RMSE 6.3 %, bias −1.8 %.
    assert!(gap < 0.08 && gap_bias < 0.0, "the mutual sky occlusion darkens: {gap}, {gap_bias}");
    // Pass 1 models that occlusion, so the proxy is closer to the exact reference than to the simple one.
    assert!(rmse_exact < rmse_simple, "{rmse_exact} vs {rmse_simple}");
    // Proxy vs the exact reference. What remains is order-4 truncation: of the dent the other sphere makes in each
    // sphere's sky (an 11° cap in the emission), and of eq. 23's share of a sphere hidden behind the other (small
    // caps: a third of the green light leaks through the red sphere for receivers on the line x < −4, z = 0;
    // `light_visibility` measures that truncation). Measured: RMSE 3.1 %, bias −0.02 %; single-sphere scenes reach
    // 0.2 % (`light_known`).
    assert!(rmse_exact < 0.04, "relative RMSE vs the exact reference {rmse_exact}");
    assert!(bias_exact.abs() < 0.01, "bias vs the exact reference {bias_exact}");
}
