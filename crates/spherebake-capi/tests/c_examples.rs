//! Builds examples/c/load_and_shade.c (C99) and examples/cpp/load_and_shade.cpp (C++17) with the
//! system compilers against the static library, runs them on the golden fixtures and compares
//! every printed number, bit for bit (%a), with the same steps done through the Rust runtime API
//! (counts, pose, refit, cut, shadows, and both indirect-light passes).
//! A missing compiler fails the test with what to install.

use spherebake_runtime::light::{
    light_spheres, ClusterSpec, IndirectCluster, LightContext, Pass1Settings, PosedProxy, SphereLights,
};
use spherebake_runtime::shadow::{uniform_light, ClusterBlockers, ExpMethod, ShadowContext};
use spherebake_runtime::{cut, load, pose, refit, CutEntry, Sphere, DEFAULT_THETA_MAX_RAD};
use std::fmt::Write as _;
use std::path::Path;
use std::process::Command;

mod common;
use common::{build, compiler, golden, hexf, hf, link_static, repo, tempdir};

/// What load_and_shade prints for `bytes`, computed with the Rust API.
fn expected(bytes: &[u8]) -> String {
    let proxy = load(bytes).expect("golden file loads");
    let mut s = String::new();
    let node_count = proxy.hierarchy().map_or(0, |h| h.nodes.len());
    let bones = proxy.bones().len();
    writeln!(
        s,
        "spheres {} nodes {} samples {} bones {}",
        proxy.sphere_count(),
        node_count,
        proxy.sample_points().len(),
        bones
    )
    .unwrap();
    let s0 = proxy.spheres()[0];
    writeln!(s, "sphere0 {} {} {} {}", hf(s0.center[0]), hf(s0.center[1]), hf(s0.center[2]), hf(s0.radius)).unwrap();
    if let Some(sh) = proxy.albedo_sh() {
        let c = sh.coefficients[0];
        writeln!(s, "sh order {} dc {} {} {}", sh.order, hf(c[0]), hf(c[1]), hf(c[2])).unwrap();
    }
    let joints: Vec<[f32; 16]> = (0..bones)
        .map(|i| {
            let mut m = [0.0f32; 16];
            m[0] = 1.0;
            m[5] = 1.0;
            m[10] = 1.0;
            m[15] = 1.0;
            m[12] = 0.01f32 * i as f32;
            m[13] = 0.02f32;
            m
        })
        .collect();
    let mut leaves = vec![Sphere::default(); proxy.sphere_count()];
    pose(&proxy, &joints, &mut leaves).unwrap();
    let l0 = leaves[0];
    writeln!(s, "posed0 {} {} {} {}", hf(l0.center[0]), hf(l0.center[1]), hf(l0.center[2]), hf(l0.radius)).unwrap();
    let plan = proxy.hierarchy_plan();
    let mut nodes = vec![Sphere::default(); node_count];
    let (receiver, rr) = if let Some(plan) = &plan {
        refit(plan, &leaves, &mut nodes).unwrap();
        let root = nodes[plan.root() as usize];
        writeln!(s, "root {} {} {} {}", hf(root.center[0]), hf(root.center[1]), hf(root.center[2]), hf(root.radius))
            .unwrap();
        let mut r = root.center;
        r[1] -= 1.5f32 * root.radius;
        let rr = 0.25f32 * root.radius;
        let mut entries = Vec::new();
        cut(plan, &nodes, r, rr, DEFAULT_THETA_MAX_RAD, &mut entries).unwrap();
        write!(s, "cut {}:", entries.len()).unwrap();
        for e in &entries {
            match e {
                CutEntry::Leaf(i) => write!(s, " L{i}").unwrap(),
                CutEntry::Node(i) => write!(s, " N{i}").unwrap(),
                _ => unreachable!(),
            }
        }
        writeln!(s).unwrap();
        (r, rr)
    } else {
        let mut r = leaves[0].center;
        r[1] -= 1.5f32 * leaves[0].radius;
        (r, 0.25f32 * leaves[0].radius)
    };
    let ctx = ShadowContext::new(4, ExpMethod::PsStar { degree: 4 }).unwrap();
    let mut cb = ClusterBlockers::new();
    let h = plan.as_ref().map(|p| (p, nodes.as_slice()));
    cb.build(4, &leaves, h, receiver, rr, DEFAULT_THETA_MAX_RAD).unwrap();
    let mut light = [0.0; 16];
    uniform_light(4, &mut light);
    let mut t = [0.0; 16];
    ctx.shading_vector(&light, [0.0, 1.0, 0.0], &mut t).unwrap();
    for i in 0..5u32 {
        let p = [receiver[0] + rr * 0.5f32 * (i as f32 - 2.0f32), receiver[1], receiver[2]];
        let v = ctx.shade_point(&cb, p, [0.0, 1.0, 0.0], &t).unwrap();
        writeln!(s, "shade {i} {}", hexf(v)).unwrap();
    }
    // One-bounce indirect light at order min(albedo order, 3), uniform white sky, rigid pose.
    if let (Some(sh), false) = (proxy.albedo_sh(), proxy.sample_points().is_empty()) {
        let order = usize::from(sh.order).min(3);
        let lctx = LightContext::new(order, ExpMethod::PsStar { degree: 4 }).unwrap();
        let mut env = vec![0.0; order * order];
        uniform_light(order, &mut env);
        let posed = PosedProxy { proxy: &proxy, leaves: &leaves, nodes: h, rotations: None };
        let mut lights = SphereLights::new();
        let stats = light_spheres(&lctx, &posed, &env, &[], &Pass1Settings::default(), &mut lights).unwrap();
        writeln!(s, "pass1 samples {} blockers {}", stats.samples, stats.blocker_accumulations).unwrap();
        let sources = [(posed, &lights)];
        let mut ic = IndirectCluster::new();
        ic.build(&lctx, &sources, &ClusterSpec::new(receiver, rr, Some([0.0, 1.0, 0.0]))).unwrap();
        for i in 0..5u32 {
            let p = [receiver[0] + rr * 0.5f32 * (i as f32 - 2.0f32), receiver[1], receiver[2]];
            let e = ic.irradiance(&lctx, &sources, p, [0.0, 1.0, 0.0]).unwrap();
            writeln!(s, "indirect {i} {} {} {}", hexf(e[0]), hexf(e[1]), hexf(e[2])).unwrap();
        }
    }
    s
}

fn check_program(exe: &Path) {
    for name in ["capsule-16.sphb", "skinned-arm-16.sphb"] {
        let file = repo().join("fixtures/golden").join(name);
        let bytes = golden(name);
        let o = Command::new(exe).arg(&file).output().unwrap();
        assert!(o.status.success(), "{name}: {}", String::from_utf8_lossy(&o.stderr));
        let got = String::from_utf8(o.stdout).unwrap();
        assert!(got.starts_with("spheres "), "{got}");
        assert_eq!(got, expected(&bytes), "{} on {name}", exe.display());
    }
    // A damaged file: one byte of the spheres section changed (its checksum no longer matches).
    let mut bytes = golden("capsule-16.sphb");
    let at = bytes.len() - 40;
    bytes[at] ^= 0x5a;
    let rust_err = load(&bytes).unwrap_err();
    let dir = tempdir("examples");
    let bad = dir.join("bad.sphb");
    std::fs::write(&bad, &bytes).unwrap();
    let o = Command::new(exe).arg(&bad).output().unwrap();
    assert_eq!(o.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains(&format!("rule {}: {}", rust_err.rule.id(), rust_err)), "{stderr}");
    assert!(o.stdout.is_empty());
}

#[test]
fn c_example_prints_the_rust_numbers() {
    let cc = compiler("cc", "gcc");
    let exe = tempdir("examples").join("load_and_shade_c");
    build(&cc, "c99", &[&repo().join("examples/c/load_and_shade.c")], &link_static(), &exe);
    check_program(&exe);
}

#[test]
fn cpp_example_prints_the_rust_numbers() {
    let cxx = compiler("c++", "g++");
    let exe = tempdir("examples").join("load_and_shade_cpp");
    build(&cxx, "c++17", &[&repo().join("examples/cpp/load_and_shade.cpp")], &link_static(), &exe);
    check_program(&exe);
}
