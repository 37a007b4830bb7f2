//! Whole-pipeline properties: byte-identical output for any thread count, a different seed
//! changes the random start, and the written file reads back with every section.

use spherebake_bake::{bake_path, BakeSettings};
use std::path::{Path, PathBuf};

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures").join(name)
}

/// The stored spheres of a bake as [x, y, z, r], and `mesh` evaluated against them at 48 voxels
/// with `samples` surface samples.
fn evaluate_stored(
    out: &spherebake_bake::BakeOutput,
    mesh: &spherebake_geom::Mesh,
    samples: usize,
) -> (Vec<[f32; 4]>, spherebake_fit::Evaluation) {
    let spheres: Vec<[f32; 4]> =
        out.file.spheres.iter().map(|s| [s.center[0], s.center[1], s.center[2], s.radius]).collect();
    let es = spherebake_fit::EvalSettings { voxel_resolution: 48, surface_samples: samples, ..Default::default() };
    let ev = spherebake_bake::evaluate_mesh(mesh, &spheres, &es).unwrap();
    (spheres, ev)
}

/// The unit cube's corners as OBJ `v` lines (vertex i + 1 at (i & 1, i >> 1 & 1, i >> 2 & 1)),
/// then `quads` (1-based corners) as two triangles each.
fn unit_cube_obj(quads: &[[u32; 4]]) -> String {
    let mut obj: String = (0..8).map(|i| format!("v {} {} {}\n", i & 1, (i >> 1) & 1, (i >> 2) & 1)).collect();
    for q in quads {
        obj += &format!("f {} {} {}\nf {} {} {}\n", q[0], q[1], q[2], q[0], q[2], q[3]);
    }
    obj
}

fn bake_in_pool(threads: usize, path: &Path, settings: &BakeSettings) -> Vec<u8> {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
    pool.install(|| bake_path(path, settings, &|_| {}).expect("bake").bytes)
}

#[test]
fn same_bytes_for_1_and_4_threads() {
    let settings = BakeSettings { spheres: 24, ..Default::default() };
    for name in ["capsule.obj", "textured-cube/textured-cube.gltf", "skinned-arm.gltf"] {
        let path = fixture(name);
        let one = bake_in_pool(1, &path, &settings);
        let four = bake_in_pool(4, &path, &settings);
        assert!(one == four, "{name}: output differs between 1 and 4 threads");
    }
}

#[test]
fn the_seed_changes_the_start_and_the_file_is_complete() {
    let path = fixture("capsule.obj");
    let a = bake_path(&path, &BakeSettings { spheres: 24, seed: 1, ..Default::default() }, &|_| {}).unwrap();
    let b = bake_path(&path, &BakeSettings { spheres: 24, seed: 2, ..Default::default() }, &|_| {}).unwrap();
    assert_ne!(a.bytes, b.bytes, "a different seed must change the random start");
    let file = spherebake_format::read(&a.bytes).unwrap();
    assert_eq!(file.spheres.len(), a.report.sphere_count);
    let samples = file.samples.as_ref().expect("samples section");
    assert_eq!(samples.sphere_count(), file.spheres.len());
    let sh = file.albedo_sh.as_ref().expect("albedo SH section");
    assert_eq!(sh.order, 4);
    assert_eq!(sh.coefficients.len(), 16 * file.spheres.len());
    let meta = file.metadata.as_ref().expect("metadata");
    assert_eq!(meta.units, "file units");
    assert!(meta.settings.contains("\"spheres\":24"), "{}", meta.settings);
}

/// OBJ text of a UV sphere (radius 1) without its southern quarter (triangles whose centroid has
/// z < −½: a hole too large to fill, so the fit's solid is the voxel solid), stretched to the
/// ellipsoid of semi-axes 2, 1, 0.7, every triangle reversed when `inward`.
fn cut_ellipsoid_obj(inward: bool) -> String {
    let (p, t) = spherebake_testkit::mesh::uv_sphere(16, 1.0);
    let mut s = String::new();
    for q in &p {
        s += &format!("v {} {} {}\n", (2.0 * q[0]) as f32, q[1] as f32, (0.7 * q[2]) as f32);
    }
    for f in t {
        if f.iter().map(|&i| p[i as usize][2]).sum::<f64>() / 3.0 < -0.5 {
            continue;
        }
        let f = if inward { [f[0], f[2], f[1]] } else { f };
        s += &format!("f {} {} {}\n", f[0] + 1, f[1] + 1, f[2] + 1);
    }
    s
}

/// An inward-wound open mesh and its outward twin bake to the same spheres, bit for bit: the
/// bake orients the triangles outward by the solid before the fit, and the solid (|w| ≥ ½) does
/// not depend on the winding.
#[test]
fn an_inward_wound_open_mesh_bakes_the_spheres_of_its_outward_twin() {
    let dir = tempfile::tempdir().unwrap();
    let bake = |inward: bool| {
        let path = dir.path().join(if inward { "inward.obj" } else { "outward.obj" });
        std::fs::write(&path, cut_ellipsoid_obj(inward)).unwrap();
        bake_path(&path, &BakeSettings { spheres: 16, ..Default::default() }, &|_| {}).unwrap()
    };
    let (out, inw) = (bake(false), bake(true));
    assert!(!out.report.closed && !inw.report.closed);
    let voxel = |w: &[String]| w.iter().any(|x| x.contains("the solid is the voxel solid"));
    assert!(voxel(&out.report.warnings) && voxel(&inw.report.warnings), "{:?}", inw.report.warnings);
    assert!(!out.report.warnings.iter().any(|w| w.contains("face inward")), "{:?}", out.report.warnings);
    assert!(inw.report.warnings.iter().any(|w| w.contains("face inward")), "{:?}", inw.report.warnings);
    assert_eq!(out.file.spheres.len(), 16);
    // A real fit: no sphere collapsed to a point.
    assert!(out.file.spheres.iter().all(|s| s.radius > 0.01), "{:?}", out.file.spheres);
    assert_eq!(out.file.spheres, inw.file.spheres, "the twins' spheres differ");
    assert_eq!(out.report.outside_ratio_e, inw.report.outside_ratio_e);
}

/// Stacked copies of faces are one surface: a closed ellipsoid with 3 000 copies of one face
/// and every face repeated once in the other winding (a double-sided export, whose winding
/// number is 0 everywhere) bakes to the spheres of the plain mesh, bit for bit, and says how
/// many triangles it removed. Before, the copies made every stage that reads the triangles
/// near a point slow (3 000 copies: seconds; 16 000: a minute) and the double-sided mesh
/// enclosed nothing.
#[test]
fn duplicate_triangles_in_either_winding_bake_as_the_plain_mesh() {
    let dir = tempfile::tempdir().unwrap();
    let (p, t) = spherebake_testkit::mesh::uv_sphere(12, 1.0);
    let mut plain = String::new();
    for q in &p {
        plain += &format!("v {} {} {}\n", (1.5 * q[0]) as f32, q[1] as f32, (0.8 * q[2]) as f32);
    }
    let face = |f: [u32; 3]| format!("f {} {} {}\n", f[0] + 1, f[1] + 1, f[2] + 1);
    let mut stacked = plain.clone();
    for f in &t {
        plain += &face(*f);
    }
    // The plain faces, a copy of each in the other winding (a rotated corner order), and
    // 3 000 copies of the tenth face.
    for (i, f) in t.iter().enumerate() {
        stacked += &face(*f);
        stacked += &face([f[1], f[0], f[2]]);
        if i == 10 {
            for k in 0..3000 {
                stacked += &face(if k % 2 == 0 { [f[1], f[2], f[0]] } else { [f[2], f[1], f[0]] });
            }
        }
    }
    let bake = |name: &str, text: &str| {
        let path = dir.path().join(name);
        std::fs::write(&path, text).unwrap();
        bake_path(&path, &BakeSettings { spheres: 8, ..Default::default() }, &|_| {}).unwrap()
    };
    let (a, b) = (bake("plain.obj", &plain), bake("stacked.obj", &stacked));
    assert!(a.report.closed && b.report.closed, "{:?}", b.report.warnings);
    let removed = format!("{} duplicate triangles", t.len() + 3000);
    assert!(b.report.warnings.iter().any(|w| w.starts_with(&removed)), "{:?}", b.report.warnings);
    assert!(!a.report.warnings.iter().any(|w| w.contains("duplicate")), "{:?}", a.report.warnings);
    assert_eq!(a.file.spheres, b.file.spheres);
    assert_eq!(a.report.outside_ratio_e, b.report.outside_ratio_e);
}

/// `eval` measures what `bake` printed: an open mesh with some triangles facing inward has
/// another solid as stored than turned outward (its winding number is not ±1 inside), and the
/// bake fits the outward one. `evaluate_mesh` (what `eval` and the pose margin call) turns them
/// outward too, so its E is the bake's; measured on the triangles as stored, E differs.
#[test]
fn evaluate_mesh_gives_the_e_the_bake_reported_for_a_partly_inward_open_mesh() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("partly_inward.obj");
    // Every fifth face of the cut ellipsoid reversed.
    let mut k = 0;
    let text: String = cut_ellipsoid_obj(false)
        .lines()
        .map(|l| {
            let mut l = l.to_string();
            if let Some(rest) = l.strip_prefix("f ") {
                k += 1;
                if k % 5 == 0 {
                    let v: Vec<&str> = rest.split(' ').collect();
                    l = format!("f {} {} {}", v[0], v[2], v[1]);
                }
            }
            l + "\n"
        })
        .collect();
    std::fs::write(&path, text).unwrap();
    let settings = BakeSettings { spheres: 16, voxels: 48, ..Default::default() };
    let out = bake_path(&path, &settings, &|_| {}).unwrap();
    assert!(out.report.warnings.iter().any(|w| w.contains("face inward")), "{:?}", out.report.warnings);
    let mesh = spherebake_io::load_mesh(&path).unwrap().mesh;
    let (spheres, ev) = evaluate_stored(&out, &mesh, 1000);
    let e = ev.outside_ratio_e;
    let es = spherebake_fit::EvalSettings { voxel_resolution: 48, surface_samples: 1000, ..Default::default() };
    let baked = out.report.outside_ratio_e.unwrap();
    assert!((e - baked).abs() <= 1e-9 * baked, "eval {e}, bake {baked}");
    let stored = spherebake_fit::evaluate(&mesh.welded_positions, &mesh.welded_triangles(), &spheres, &es)
        .unwrap()
        .outside_ratio_e;
    assert!((stored - baked).abs() > 1e-3 * baked, "the stored winding gives the same E ({stored}): no case here");
}

/// With `--pose-margin auto` the report's E is that of the spheres written (grown by the
/// margin), as `eval` measures the file; before, it was the fit's, below the file's. A target
/// the fit met but the grown spheres miss gets a warning.
#[test]
fn the_reported_e_is_the_written_spheres_after_the_pose_margin() {
    let path = fixture("skinned-arm.gltf");
    let base = BakeSettings { spheres: 16, voxels: 48, ..Default::default() };
    let plain = bake_path(&path, &base, &|_| {}).unwrap();
    let auto = BakeSettings { pose_margin: spherebake_bake::PoseMargin::Auto, ..base.clone() };
    let out = bake_path(&path, &auto, &|_| {}).unwrap();
    let m = out.report.skin.as_ref().and_then(|s| s.pose_margin.as_ref()).expect("margin ran");
    assert!(m.grown_count > 0, "the arm's animation needs a margin");
    let mesh = spherebake_io::load_mesh(&path).unwrap().mesh;
    let e = evaluate_stored(&out, &mesh, 1000).1.outside_ratio_e;
    let reported = out.report.outside_ratio_e.unwrap();
    let fitted = plain.report.outside_ratio_e.unwrap();
    assert!((e - reported).abs() <= 1e-9 * e, "file {e}, reported {reported}");
    assert!(reported > fitted, "grown spheres add outside volume: {reported} vs {fitted}");
    // A target between the fit's E and the grown spheres' E: met by the fit, missed by the file.
    let target = 0.5 * (fitted + reported);
    let t = bake_path(&path, &BakeSettings { max_outside_ratio: Some(target), ..auto.clone() }, &|_| {}).unwrap();
    let te = t.report.outside_ratio_e.unwrap();
    let warned = t.report.warnings.iter().any(|w| w.starts_with("the pose margin raised E"));
    assert!(!t.report.warnings.iter().any(|w| w.contains("not reached")), "{:?}", t.report.warnings);
    assert_eq!(warned, te > target, "E {te}, target {target}: {:?}", t.report.warnings);
}

/// A face given once in each winding (a zero-thickness double-sided fin) encloses nothing: on
/// a closed box, a fin sticking out of one of its edges leaves the box closed, so the bake
/// takes the exact closed-mesh solid, while the fin is still covered by the spheres. Before,
/// import kept one copy of the fin as an ordinary face: two boundary edges and a box edge with
/// three faces made the mesh "not closed" and the solid the voxel solid.
#[test]
fn a_double_sided_fin_on_a_closed_box_is_covered_but_leaves_the_box_closed() {
    let dir = tempfile::tempdir().unwrap();
    let mut obj = unit_cube_obj(&[[1, 3, 4, 2], [5, 6, 8, 7], [1, 2, 6, 5], [3, 7, 8, 4], [1, 5, 7, 3], [2, 4, 8, 6]]);
    obj += "v 1.6 0 0.5\n"; // the fin's tip, vertex 9
                            // The fin on the box edge from (1, 0, 0) to (1, 0, 1), in the plane y = 0, both windings.
    obj += "f 2 9 6\nf 6 9 2\n";
    let path = dir.path().join("fin.obj");
    std::fs::write(&path, &obj).unwrap();
    let imported = spherebake_io::load_mesh(&path).unwrap();
    assert_eq!(imported.mesh.triangles.len(), 13);
    assert_eq!(imported.mesh.surface_only, vec![12]);
    assert!(spherebake_geom::TopologyReport::compute(&imported.mesh).closed);
    let mesh = imported.mesh.clone();
    let out = bake_path(&path, &BakeSettings { spheres: 8, voxels: 48, ..Default::default() }, &|_| {}).unwrap();
    let w = &out.report.warnings;
    assert!(out.report.closed, "{w:?}");
    assert!(!w.iter().any(|x| x.contains("not closed") || x.contains("voxel solid")), "{w:?}");
    assert!(w.iter().any(|x| x.starts_with("1 duplicate triangles") && x.contains("1 face(s)")), "{w:?}");
    // E against the box's unit volume, and every point of the fin inside a stored sphere.
    let (spheres, ev) = evaluate_stored(&out, &mesh, 20000);
    assert_eq!(ev.solid_source, spherebake_fit::SolidSource::ClosedMesh);
    assert!((ev.object_volume - 1.0).abs() < 1e-9, "{}", ev.object_volume);
    assert_eq!(Some(ev.outside_ratio_e), out.report.outside_ratio_e);
    assert_eq!(ev.surface_coverage, 1.0);
    let [a, b, c] = [glam::DVec3::new(1.0, 0.0, 0.0), glam::DVec3::new(1.6, 0.0, 0.5), glam::DVec3::new(1.0, 0.0, 1.0)];
    let n = 60;
    for i in 0..=n {
        for j in 0..=n - i {
            let (u, v) = (i as f64 / n as f64, j as f64 / n as f64);
            let p = a + (b - a) * u + (c - a) * v;
            let inside = spheres.iter().any(|s| {
                p.distance(glam::DVec3::new(s[0] as f64, s[1] as f64, s[2] as f64)) <= s[3] as f64 * (1.0 + 1e-6)
            });
            assert!(inside, "fin point {p} outside every sphere");
        }
    }
}

/// A zero-area sliver on three collinear vertices closing a T-junction (as exporters leave
/// them; pmndrs' cube has one) leaves a closed box closed: the fit pairs the sliver's edges and
/// takes the exact closed-mesh solid, and the report says so. Before, the topology report left
/// the sliver's edges out and called the mesh "not closed" (three boundary edges) while the fit
/// used it as closed, without a warning.
#[test]
fn a_zero_area_sliver_at_a_t_junction_leaves_a_closed_box_closed() {
    let dir = tempfile::tempdir().unwrap();
    let mut obj = unit_cube_obj(&[[1, 3, 4, 2], [5, 6, 8, 7], [3, 7, 8, 4], [1, 5, 7, 3], [2, 4, 8, 6]]);
    obj += "v 0.5 0 0\n"; // vertex 9, on the box edge from vertex 1 to vertex 2
                          // The y = 0 face, its edge 1–2 split at vertex 9, and the sliver 9 1 2 closing the junction.
    obj += "f 1 9 6\nf 9 2 6\nf 1 6 5\nf 9 1 2\n";
    let path = dir.path().join("sliver.obj");
    std::fs::write(&path, &obj).unwrap();
    let imported = spherebake_io::load_mesh(&path).unwrap();
    assert_eq!(imported.mesh.triangles.len(), 14);
    let mesh = imported.mesh.clone();
    let out = bake_path(&path, &BakeSettings { spheres: 8, voxels: 48, ..Default::default() }, &|_| {}).unwrap();
    let w = &out.report.warnings;
    assert!(!w.iter().any(|x| x.contains("not closed") || x.contains("voxel solid")), "{w:?}");
    assert!(out.report.closed, "{:?} {w:?}", out.topology);
    let (_, ev) = evaluate_stored(&out, &mesh, 20000);
    assert_eq!(ev.solid_source, spherebake_fit::SolidSource::ClosedMesh);
    assert!((ev.object_volume - 1.0).abs() < 1e-9, "{}", ev.object_volume);
}

/// `--pose-margin auto` on a skinned model without animations (WebXR's generic hands, driven
/// by live tracking) has nothing to grow for: the bake says so instead of printing a margin of
/// "0 spheres grown over 1 frames" alone. The arm with its animation gets no such warning.
#[test]
fn the_pose_margin_warns_when_a_skinned_model_has_no_animations() {
    let dir = tempfile::tempdir().unwrap();
    let mut doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(fixture("skinned-arm.gltf")).unwrap()).unwrap();
    doc.as_object_mut().unwrap().remove("animations").expect("the fixture has an animation");
    let still = dir.path().join("still-arm.gltf");
    std::fs::write(&still, serde_json::to_string(&doc).unwrap()).unwrap();
    let auto =
        BakeSettings { spheres: 8, voxels: 48, pose_margin: spherebake_bake::PoseMargin::Auto, ..Default::default() };
    let no_anim = |w: &String| w.starts_with("pose margin: the model has no animations");
    let out = bake_path(&still, &auto, &|_| {}).unwrap();
    assert!(out.report.skin.is_some(), "still skinned");
    assert_eq!(out.report.warnings.iter().filter(|w| no_anim(w)).count(), 1, "{:?}", out.report.warnings);
    let plain =
        bake_path(&still, &BakeSettings { pose_margin: spherebake_bake::PoseMargin::None, ..auto.clone() }, &|_| {});
    assert!(!plain.unwrap().report.warnings.iter().any(no_anim), "only asked for with --pose-margin auto");
    let arm = bake_path(&fixture("skinned-arm.gltf"), &auto, &|_| {}).unwrap();
    assert!(!arm.report.warnings.iter().any(no_anim), "{:?}", arm.report.warnings);
}

/// `--pose-margin auto` on a model without a skin has nothing to move: the bake says so once,
/// and says nothing without the flag or on a skinned model.
#[test]
fn the_pose_margin_warns_when_the_model_has_no_skin() {
    let no_skin = |w: &String| w.starts_with("pose margin: the model has no skin");
    let auto =
        BakeSettings { spheres: 8, voxels: 48, pose_margin: spherebake_bake::PoseMargin::Auto, ..Default::default() };
    let out = bake_path(&fixture("capsule.obj"), &auto, &|_| {}).unwrap();
    assert!(out.report.skin.is_none());
    assert_eq!(out.report.warnings.iter().filter(|w| no_skin(w)).count(), 1, "{:?}", out.report.warnings);
    let plain = bake_path(
        &fixture("capsule.obj"),
        &BakeSettings { pose_margin: spherebake_bake::PoseMargin::None, ..auto.clone() },
        &|_| {},
    )
    .unwrap();
    assert!(!plain.report.warnings.iter().any(no_skin), "{:?}", plain.report.warnings);
    let arm = bake_path(&fixture("skinned-arm.gltf"), &auto, &|_| {}).unwrap();
    assert!(!arm.report.warnings.iter().any(no_skin), "{:?}", arm.report.warnings);
}

/// A model far from the origin for its size gets one warning: the unit cube moved by 10⁵ has
/// f32 steps of 2⁻⁷ there, a whole cell of its 128-cell grid (more than the 1/16 of a cell
/// the warning allows); moved by 10³ (steps of 2⁻¹⁴, 1/128 of a cell) or at the origin, none.
#[test]
fn a_model_far_from_the_origin_for_its_size_is_warned_about() {
    let dir = tempfile::tempdir().unwrap();
    let quads = [[1, 3, 4, 2], [5, 6, 8, 7], [1, 2, 6, 5], [3, 7, 8, 4], [1, 5, 7, 3], [2, 4, 8, 6]];
    let far = |w: &String| w.starts_with("coordinates far from the origin");
    for (offset, warned) in [(0.0, false), (1e3, false), (1e5, true)] {
        let obj: String = unit_cube_obj(&quads)
            .lines()
            .map(|l| match l.strip_prefix("v ") {
                Some(v) => {
                    let c: Vec<f64> = v.split(' ').map(|x| x.parse::<f64>().unwrap() + offset).collect();
                    format!("v {} {} {}\n", c[0], c[1], c[2])
                }
                None => format!("{l}\n"),
            })
            .collect();
        let path = dir.path().join(format!("cube{offset}.obj"));
        std::fs::write(&path, obj).unwrap();
        let out = bake_path(&path, &BakeSettings { spheres: 4, voxels: 128, ..Default::default() }, &|_| {}).unwrap();
        let n = out.report.warnings.iter().filter(|w| far(w)).count();
        assert_eq!(n, usize::from(warned), "offset {offset}: {:?}", out.report.warnings);
    }
}

/// A box whose file gives no normals keeps flat faces: every surface sample's normal is the
/// outward normal of the face it lies on. From a glTF without NORMAL, as the spec requires
/// (§3.7.2.1, "MUST calculate flat normals"); from an OBJ without `vn`, whose faces meet at 90°,
/// past the crease angle. The normals were smoothed across the edges before, tilting the
/// samples near each corner towards the diagonal (up to 55°).
#[test]
fn a_box_without_normals_gets_the_normals_of_its_faces() {
    let dir = tempfile::tempdir().unwrap();
    let quads = [[1, 3, 4, 2], [5, 6, 8, 7], [1, 2, 6, 5], [3, 7, 8, 4], [1, 5, 7, 3], [2, 4, 8, 6]];
    let obj = dir.path().join("box.obj");
    std::fs::write(&obj, unit_cube_obj(&quads)).unwrap();
    // The same box as glTF: 8 shared vertices, 12 triangles, POSITION only.
    let mut bin = Vec::new();
    for i in 0..8u32 {
        for c in [i & 1, (i >> 1) & 1, (i >> 2) & 1] {
            bin.extend((c as f32).to_le_bytes());
        }
    }
    for q in quads {
        for v in [q[0], q[1], q[2], q[0], q[2], q[3]] {
            bin.extend(((v - 1) as u16).to_le_bytes());
        }
    }
    std::fs::write(dir.path().join("box.bin"), &bin).unwrap();
    let gltf = r#"{"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],
        "meshes":[{"primitives":[{"attributes":{"POSITION":0},"indices":1}]}],
        "buffers":[{"uri":"box.bin","byteLength":168}],
        "bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":96},{"buffer":0,"byteOffset":96,"byteLength":72}],
        "accessors":[{"bufferView":0,"componentType":5126,"count":8,"type":"VEC3","min":[0,0,0],"max":[1,1,1]},
                     {"bufferView":1,"componentType":5123,"count":36,"type":"SCALAR"}]}"#;
    let gl = dir.path().join("box.gltf");
    std::fs::write(&gl, gltf).unwrap();
    // The OBJ again with a normal of no direction at every corner (`vn 0 0 0`): no normal.
    let zero = dir.path().join("zero.obj");
    let with_vn = unit_cube_obj(&quads)
        .replace("f ", "f_")
        .split('\n')
        .map(|l| match l.strip_prefix("f_") {
            Some(f) => "f ".to_string() + &f.split(' ').map(|v| format!("{v}//1")).collect::<Vec<_>>().join(" "),
            None => l.to_string(),
        })
        .collect::<Vec<_>>()
        .join("\n");
    std::fs::write(&zero, format!("vn 0 0 0\n{with_vn}")).unwrap();
    for path in [obj, gl, zero] {
        let out = bake_path(&path, &BakeSettings { spheres: 8, voxels: 48, ..Default::default() }, &|_| {}).unwrap();
        let samples = out.file.samples.as_ref().expect("samples");
        let mut checked = 0;
        for s in samples.per_sphere().flatten() {
            let p = glam::Vec3::from_array(s.position) - glam::Vec3::splat(0.5);
            // The face: the axis where the point is on the surface (|p| = 0.5); points within
            // 10⁻³ of an edge are on two faces and left out.
            let on: Vec<usize> = (0..3).filter(|&i| (p[i].abs() - 0.5).abs() < 1e-3).collect();
            assert!(!on.is_empty(), "{path:?}: sample {p} off the box");
            if on.len() > 1 {
                continue;
            }
            let mut want = glam::Vec3::ZERO;
            want[on[0]] = p[on[0]].signum();
            let n = glam::Vec3::from_array(s.normal);
            assert!((n - want).length() < 1e-5, "{path:?}: sample at {p}: normal {n}, face {want}");
            checked += 1;
        }
        assert!(checked > 50, "{path:?}: {checked} samples checked");
    }
}
