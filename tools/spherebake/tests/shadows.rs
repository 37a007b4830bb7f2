//! `spherebake shadows` on a tiny fixture: a tessellated unit ball resting on the ground, whose
//! proxy is the exact ball, so the only differences are the log-SH approximations, the
//! tessellation and the Monte Carlo noise. Few receivers and rays: fast.

use std::path::Path;
use std::process::{Command, Output};

fn run(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_spherebake")).args(args).current_dir(dir).output().expect("run spherebake")
}

/// Icosphere of radius 1 about (0, 1, 0) (4 subdivisions of an octahedron, projected) as OBJ text.
fn ball_obj() -> String {
    let mut v: Vec<[f64; 3]> =
        vec![[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, -1.0]];
    let mut f: Vec<[usize; 3]> =
        vec![[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]];
    for _ in 0..4 {
        let mut next = Vec::new();
        let mut mid = std::collections::BTreeMap::new();
        let mut m = |a: usize, b: usize, v: &mut Vec<[f64; 3]>| {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                let p = [0.5 * (v[a][0] + v[b][0]), 0.5 * (v[a][1] + v[b][1]), 0.5 * (v[a][2] + v[b][2])];
                let n = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
                v.push([p[0] / n, p[1] / n, p[2] / n]);
                v.len() - 1
            })
        };
        for [a, b, c] in f {
            let (ab, bc, ca) = (m(a, b, &mut v), m(b, c, &mut v), m(c, a, &mut v));
            next.extend([[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
        }
        f = next;
    }
    let mut s = String::new();
    for p in &v {
        s += &format!("v {} {} {}\n", p[0], p[1] + 1.0, p[2]);
    }
    for t in &f {
        s += &format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    s
}

fn fixture(dir: &Path) {
    std::fs::write(dir.join("ball.obj"), ball_obj()).unwrap();
    // The proxy: the circumscribed ball (the tessellation is inside the unit ball).
    let file = spherebake_format::SphbFile {
        spheres: vec![spherebake_format::Sphere { center: [0.0, 1.0, 0.0], radius: 1.0 }],
        ..Default::default()
    };
    std::fs::write(dir.join("ball.sphb"), spherebake_format::write(&file)).unwrap();
}

fn json_of(o: &Output) -> serde_json::Value {
    assert_eq!(o.status.code(), Some(0), "stderr: {}", String::from_utf8_lossy(&o.stderr));
    serde_json::from_slice(&o.stdout).expect("JSON on stdout")
}

#[test]
fn exact_ball_proxy_matches_ray_traced_truth() {
    let dir = tempfile::tempdir().unwrap();
    fixture(dir.path());
    let args = [
        "shadows",
        "ball.sphb",
        "--model",
        "ball.obj",
        "--resolution",
        "16",
        "--rays",
        "256",
        "--json",
        "-o",
        "cmp.png",
    ];
    let j = json_of(&run(&args, dir.path()));
    assert_eq!(j["receivers"], 256);
    assert_eq!(j["spheres"], 1);
    let rel = j["rel_rmse"].as_f64().unwrap();
    // The ball touches the ground at the centre receivers (θ → 90°), where the clipped SH log loses
    // up to ~6% (math reference §3, 60° round trip); averaged over the ground the error is small.
    assert!(rel.is_finite() && rel < 0.05, "rel_rmse {rel}");
    // Mean visible fraction: an unoccluded ground would be 1; the ball darkens it, so both are < 1.
    let (t, p) = (j["mean_truth"].as_f64().unwrap(), j["mean_proxy"].as_f64().unwrap());
    assert!(t > 0.5 && t < 1.0 && p > 0.5 && p < 1.0, "{t} {p}");
    let img = image::open(dir.path().join("cmp.png")).unwrap();
    assert_eq!((img.width(), img.height()), (3 * 16 + 8, 16));
    // Deterministic.
    let j2 = json_of(&run(&args, dir.path()));
    assert_eq!(j["rel_rmse"], j2["rel_rmse"]);
    // The lobe light runs too, and the wrong proxy (a ball twice as large) is worse.
    let mut lobe = args.to_vec();
    lobe.extend(["--light", "lobe"]);
    let jl = json_of(&run(&lobe, dir.path()));
    assert!(jl["rel_rmse"].as_f64().unwrap().is_finite());
    let big = spherebake_format::SphbFile {
        spheres: vec![spherebake_format::Sphere { center: [0.0, 2.0, 0.0], radius: 2.0 }],
        ..Default::default()
    };
    std::fs::write(dir.path().join("big.sphb"), spherebake_format::write(&big)).unwrap();
    let mut wrong = args.to_vec();
    wrong[1] = "big.sphb";
    let jw = json_of(&run(&wrong, dir.path()));
    eprintln!("rel_rmse: exact ball {rel}, lobe {}, doubled ball {}", jl["rel_rmse"], jw["rel_rmse"]);
    assert!(jw["rel_rmse"].as_f64().unwrap() > 2.0 * rel, "{} vs {rel}", jw["rel_rmse"]);
}

#[test]
fn bad_arguments() {
    let dir = tempfile::tempdir().unwrap();
    fixture(dir.path());
    let o = run(&["shadows", "ball.sphb", "--model", "ball.obj", "--light", "sun"], dir.path());
    assert_eq!(o.status.code(), Some(2));
    // A value out of its range is a usage error, as clap's own.
    let o = run(&["shadows", "ball.sphb", "--model", "ball.obj", "--resolution", "1"], dir.path());
    assert_eq!(o.status.code(), Some(2));
    let o = run(&["shadows", "ball.sphb", "--model", "ball.obj", "--cluster", "0"], dir.path());
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).starts_with("spherebake: error: --cluster"));
    let o = run(&["shadows", "missing.sphb", "--model", "ball.obj"], dir.path());
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("missing.sphb"));
    // The picture's type follows its extension, as `render`'s: .jpg is JPEG, .bmp is refused
    // (naming the file) and nothing is written; it once wrote PNG bytes under any name.
    let small = ["shadows", "ball.sphb", "--model", "ball.obj", "--resolution", "8", "--rays", "16", "-o"];
    let o = run(&[&small[..], &["cmp.jpg"]].concat(), dir.path());
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(&std::fs::read(dir.path().join("cmp.jpg")).unwrap()[..3], &[0xFF, 0xD8, 0xFF], "JPEG magic");
    let o = run(&[&small[..], &["cmp.bmp"]].concat(), dir.path());
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("cmp.bmp"));
    assert!(!dir.path().join("cmp.bmp").exists());
}

/// The truth's rays pass through the holes of an alpha-masked material: a 20 × 20 card at
/// height 1, whose factor alpha 0.25 is below the MASK cutoff 0.5 everywhere, shadows nothing
/// (every receiver gets the unoccluded value 1 of the uniform light), while the same card
/// opaque shadows the receivers under it. The proxy (the ball fixture's sphere file) is the
/// same for both, so only the truth differs.
#[test]
fn the_truth_sees_through_an_alpha_masked_card() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    fixture(d);
    // The card, and a small triangle on the ground far away that sets the ground plane y = 0.
    let p: [[f32; 3]; 7] = [
        [-10.0, 1.0, -10.0],
        [10.0, 1.0, -10.0],
        [10.0, 1.0, 10.0],
        [-10.0, 1.0, 10.0],
        [50.0, 0.0, 0.0],
        [51.0, 0.0, 0.0],
        [50.0, 0.0, 1.0],
    ];
    let idx: [u32; 9] = [0, 2, 1, 0, 3, 2, 4, 6, 5];
    let mut bin: Vec<u8> = p.iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
    bin.extend(idx.iter().flat_map(|i| i.to_le_bytes()));
    std::fs::write(d.join("card.bin"), &bin).unwrap();
    let mean_truth = |mode: &str| -> f64 {
        let json = format!(
            r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1,"material":0}}]}}],
"materials":[{{{mode}"pbrMetallicRoughness":{{"baseColorFactor":[0.5,0.5,0.5,0.25]}}}}],
"buffers":[{{"byteLength":120,"uri":"card.bin"}}],
"bufferViews":[{{"buffer":0,"byteLength":84}},{{"buffer":0,"byteOffset":84,"byteLength":36}}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":7,"type":"VEC3","min":[-10,0,-10],"max":[51,1,10]}},
 {{"bufferView":1,"componentType":5125,"count":9,"type":"SCALAR"}}]}}"#
        );
        std::fs::write(d.join("card.gltf"), json).unwrap();
        let o = run(&["shadows", "ball.sphb", "card.gltf", "--json", "--resolution", "8", "--rays", "64"], d);
        json_of(&o)["mean_truth"].as_f64().unwrap()
    };
    let masked = mean_truth(r#""alphaMode":"MASK","#);
    assert!((masked - 1.0).abs() < 1e-9, "masked card: mean truth {masked}");
    let opaque = mean_truth("");
    assert!(opaque < 1.0 - 1e-3, "opaque card: mean truth {opaque}");
}
