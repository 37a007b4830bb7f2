//! The runtime loads what the format writes, evaluates albedo SH against the math reference's
//! basis constants, and never panics on any bytes.

use proptest::prelude::*;
use spherebake_format::{repair_checksums, write};
use spherebake_runtime::{
    direction, load, AlbedoSh, BoneRecord, ColourSpace, Hierarchy, Metadata, NodeLists, Proxy, Rule, SamplePoint,
    Samples, ShBasis, SkinEntry, SkinTerms, SphbFile, Sphere, UNUSED_BONE,
};

/// Math reference §1: c0 = 1/(2√π), c1 = √(3/(4π)).
const C0: f32 = 0.282_094_8;
const C1: f32 = 0.488_602_5;

fn file() -> SphbFile {
    let mut identity = [0.0f32; 16];
    for i in 0..4 {
        identity[5 * i] = 1.0;
    }
    SphbFile {
        spheres: vec![Sphere { center: [0.0, 0.0, 0.0], radius: 1.0 }, Sphere { center: [2.0, 0.0, 0.0], radius: 0.5 }],
        hierarchy: Some(Hierarchy::from_lists(
            0,
            vec![NodeLists { center: [1.0, 0.0, 0.0], radius: 2.0, children: vec![], leaf_children: vec![0, 1] }],
        )),
        samples: Some(Samples::from_per_sphere(vec![
            vec![SamplePoint { position: [0.0, 0.0, 1.0], normal: [0.0, 0.0, 1.0], direction: 72, rule: 1 }],
            vec![],
        ])),
        albedo_sh: Some(AlbedoSh {
            order: 2,
            colour_space: ColourSpace::LinearRgb,
            basis: ShBasis::RealOrthonormalCs,
            // Sphere 0: constant 1.0 (f0 = 1/c0). Sphere 1: f2 (l=1, m=0) = 1 in red only.
            coefficients: vec![
                [1.0 / C0; 3],
                [0.0; 3],
                [0.0; 3],
                [0.0; 3],
                [0.0; 3],
                [0.0; 3],
                [1.0, 0.0, 0.0],
                [0.0; 3],
            ],
        }),
        skin: Some(SkinTerms {
            bones_per_sphere: 1,
            entries: vec![
                SkinEntry { bone: 0, q: [0.0; 3], b: 1.0 },
                SkinEntry { bone: UNUSED_BONE, q: [0.0; 3], b: 0.0 },
            ],
        }),
        bones: Some(vec![BoneRecord { name: "root".into(), parent: None, inverse_bind: identity }]),
        metadata: Some(Metadata {
            tool_version: "test".into(),
            settings: "{}".into(),
            input_hash: "0".into(),
            units: "metres".into(),
            extra: vec![],
        }),
    }
}

#[test]
fn load_gives_views_of_every_section() {
    let f = file();
    let bytes = write(&f);
    let p = load(&bytes).unwrap();
    assert_eq!(p.sphere_count(), 2);
    assert_eq!(p.spheres()[1].center, [2.0, 0.0, 0.0]);
    assert_eq!(p.hierarchy().unwrap().leaves_of(0), [0, 1]);
    assert_eq!(p.sample_offsets(), [0, 1, 1]);
    assert_eq!(p.sample_points().len(), 1);
    assert_eq!(p.samples_of(0).len(), 1);
    assert!(p.samples_of(1).is_empty());
    assert!(p.samples_of(2).is_empty());
    assert_eq!(p.skin_slots(1)[0].bone, UNUSED_BONE);
    assert!(p.skin_slots(7).is_empty());
    assert_eq!(p.bones()[0].name, "root");
    assert_eq!(p.metadata().unwrap().units, "metres");
    assert_eq!(p.albedo_coefficients(1).unwrap().len(), 4);
    assert!(p.albedo_coefficients(2).is_none());
    assert_eq!(p.to_bytes(), bytes);
    assert_eq!(p.file(), &f);
    assert_eq!(Proxy::from_file(&f).unwrap(), p);
    assert_eq!(p.into_file(), f);
}

#[test]
fn albedo_evaluates_the_condon_shortley_basis() {
    let p = load(&write(&file())).unwrap();
    // Constant function: f0 · c0 = 1 in every direction.
    for d in [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.6, 0.0, -0.8]] {
        let a = p.albedo(0, d).unwrap();
        for c in a {
            assert!((c - 1.0).abs() < 1e-6, "{a:?}");
        }
    }
    // y_{1,0} = c1 · z.
    let up = p.albedo(1, [0.0, 0.0, 1.0]).unwrap();
    assert!((up[0] - C1).abs() < 1e-6 && up[1] == 0.0, "{up:?}");
    let tilted = p.albedo(1, [0.6, 0.0, -0.8]).unwrap();
    assert!((tilted[0] + 0.8 * C1).abs() < 1e-6, "{tilted:?}");
    assert!(p.albedo(2, [0.0, 0.0, 1.0]).is_none());
}

#[test]
fn sample_directions_follow_the_spec_order() {
    // Math reference §5: d72 = (0, 0.934172359, 0.3568220898), d0 = (-0.5257311121, 0.8506508084, 0).
    let d72 = direction(72).unwrap();
    assert!((d72[1] - 0.934_172_36).abs() < 1e-6 && (d72[2] - 0.356_822_1).abs() < 1e-6);
    let d0 = direction(0).unwrap();
    assert!((d0[0] + 0.525_731_1).abs() < 1e-6 && (d0[1] - 0.850_650_8).abs() < 1e-6);
    assert!(direction(91).is_some());
    assert!(direction(92).is_none());
}

#[test]
fn version_policy() {
    let mut newer = write(&file());
    newer[10] = 3; // minor 3
    repair_checksums(&mut newer);
    assert!(load(&newer).is_ok());
    let mut major2 = write(&file());
    major2[8] = 2;
    repair_checksums(&mut major2);
    let e = load(&major2).unwrap_err();
    assert_eq!(e.rule, Rule::UnsupportedMajor);
    assert_eq!(e.rule.id(), 1003);
}

#[test]
fn invalid_models_are_refused_with_their_rule() {
    let mut f = file();
    f.spheres[1].radius = 0.0;
    assert_eq!(Proxy::from_file(&f).unwrap_err().rule.id(), 3004);
    let mut f = file();
    f.hierarchy.as_mut().unwrap().leaves = vec![0, 0];
    assert_eq!(Proxy::from_file(&f).unwrap_err().rule, Rule::LeafRevisited);
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 1000, ..ProptestConfig::default() })]

    #[test]
    fn any_bytes_load_or_fail(bytes in proptest::collection::vec(any::<u8>(), 0..1024)) {
        let _ = load(&bytes);
    }

    #[test]
    fn mutated_files_load_or_fail(
        edits in proptest::collection::vec((any::<usize>(), any::<u8>()), 1..8),
        cut in proptest::option::of(any::<usize>()),
        fix in any::<bool>(),
    ) {
        let mut b = write(&file());
        let n = b.len();
        for (at, v) in &edits { b[at % n] = *v; }
        if let Some(c) = cut { b.truncate(c % (n + 1)); }
        if fix { repair_checksums(&mut b); }
        if let Ok(p) = load(&b) {
            let again = load(&p.to_bytes()).expect("re-encoded proxy loads");
            prop_assert_eq!(again.to_bytes(), p.to_bytes());
        }
    }
}

/// Architecture invariant: the runtime depends on `spherebake-format` and `spherebake-sh` only.
#[test]
fn runtime_dependencies_stay_minimal() {
    let toml = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/Cargo.toml")).unwrap();
    let deps: Vec<&str> = toml
        .split("\n[dependencies]\n")
        .nth(1)
        .expect("a [dependencies] table")
        .split("\n[")
        .next()
        .unwrap()
        .lines()
        .filter(|l| !l.trim().is_empty() && !l.trim_start().starts_with('#'))
        .map(|l| l.split(['=', '.']).next().unwrap().trim())
        .collect();
    assert_eq!(deps, ["spherebake-format", "spherebake-sh"]);
}
