//! `export`: a baked proxy as a binary glTF 2.0 file (`.glb`) for any viewer or Blender.
//!
//! Layout: one root node `spherebake proxy` whose children are one node per hierarchy level
//! (`level 0 (leaves)`, `level 1`, ... up to the root level), each holding one mesh of
//! icospheres (one per sphere of that level), plus a node `samples` with a small octahedron at
//! every surface sample point when the file has samples. Leaf spheres are coloured by their
//! albedo SH evaluated along each vertex direction (linear RGB in `COLOR_0`) when present,
//! otherwise by a fixed per-sphere hue; upper levels are drawn translucent.
//! Positions are model space, in the file's units (glTF expects metres).

use spherebake_format::SphbFile;

/// What [`export_glb`] wrote, for reports and tests.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ExportSummary {
    /// Hierarchy levels written (1 when the file has no hierarchy).
    pub levels: usize,
    /// Sample markers written.
    pub sample_markers: usize,
    /// glTF nodes written (root + levels + samples node).
    pub nodes: usize,
}

struct MeshData {
    positions: Vec<[f32; 3]>,
    normals: Vec<[f32; 3]>,
    colors: Vec<[f32; 4]>,
    indices: Vec<u32>,
}

impl MeshData {
    fn new() -> Self {
        Self { positions: Vec::new(), normals: Vec::new(), colors: Vec::new(), indices: Vec::new() }
    }
}

/// A distinct, deterministic colour per index (golden-ratio hues), linear RGBA.
pub(crate) fn hue(i: usize) -> [f32; 4] {
    // Golden-ratio hues, fixed saturation: distinct neighbours, deterministic.
    let h = (i as f32 * 0.618_034).fract() * 6.0;
    let x = 1.0 - (h % 2.0 - 1.0).abs();
    let (r, g, b) = match h as u32 {
        0 => (1.0, x, 0.0),
        1 => (x, 1.0, 0.0),
        2 => (0.0, 1.0, x),
        3 => (0.0, x, 1.0),
        4 => (x, 0.0, 1.0),
        _ => (1.0, 0.0, x),
    };
    [0.2 + 0.7 * r, 0.2 + 0.7 * g, 0.2 + 0.7 * b, 1.0]
}

/// Levels of the hierarchy as lists of (centre, radius): level 0 = the sphere set (leaves).
pub fn hierarchy_levels(file: &SphbFile) -> Vec<Vec<([f32; 3], f32)>> {
    let mut levels = vec![file.spheres.iter().map(|s| (s.center, s.radius)).collect::<Vec<_>>()];
    let Some(h) = &file.hierarchy else { return levels };
    // Height of each node = 1 + max height of node children (leaf-only nodes have height 1).
    let n = h.nodes.len();
    let mut height = vec![0usize; n];
    let mut changed = true;
    let mut guard = 0;
    while changed && guard <= n {
        changed = false;
        guard += 1;
        for i in 0..n {
            let hgt =
                1 + h.children_of(i).iter().map(|&c| height.get(c as usize).copied().unwrap_or(0)).max().unwrap_or(0);
            if hgt != height[i] {
                height[i] = hgt;
                changed = true;
            }
        }
    }
    let top = height.iter().copied().max().unwrap_or(0);
    for lvl in 1..=top {
        levels.push(
            h.nodes.iter().zip(&height).filter(|(_, &hh)| hh == lvl).map(|(nd, _)| (nd.center, nd.radius)).collect(),
        );
    }
    levels
}

/// Builds the `.glb` bytes of a proxy (see the module docs for the layout).
pub fn export_glb(file: &SphbFile) -> (Vec<u8>, ExportSummary) {
    // One subdivision of the icosahedron: 42 vertices, 80 triangles.
    let (ico_v, ico_f) = spherebake_geom::sphere::icosphere(1);
    let levels = hierarchy_levels(file);
    let mut meshes: Vec<(String, MeshData, bool)> = Vec::new();
    for (li, spheres) in levels.iter().enumerate() {
        let mut m = MeshData::new();
        for (si, (c, r)) in spheres.iter().enumerate() {
            let base = m.positions.len() as u32;
            let sh = if li == 0 { file.albedo_sh.as_ref().and_then(|a| a.of(si).map(|c| (a.order, c))) } else { None };
            for d in &ico_v {
                m.positions.push([c[0] + r * d[0], c[1] + r * d[1], c[2] + r * d[2]]);
                m.normals.push(*d);
                let col = match sh {
                    Some((order, coeffs)) => {
                        let mut y = [0f32; 64];
                        let n = usize::from(order) * usize::from(order);
                        if spherebake_sh::eval_sh(usize::from(order), *d, &mut y).is_ok() {
                            let mut rgb = [0f32; 3];
                            for (k, cf) in coeffs.iter().enumerate().take(n) {
                                for ch in 0..3 {
                                    rgb[ch] += cf[ch] * y[k];
                                }
                            }
                            [rgb[0].clamp(0.0, 1.0), rgb[1].clamp(0.0, 1.0), rgb[2].clamp(0.0, 1.0), 1.0]
                        } else {
                            hue(si)
                        }
                    }
                    None if li == 0 => hue(si),
                    None => {
                        let mut h = hue(li * 7 + si);
                        h[3] = 0.2;
                        h
                    }
                };
                m.colors.push(col);
            }
            for t in &ico_f {
                m.indices.extend(t.iter().map(|i| base + i));
            }
        }
        let name = if li == 0 { "level 0 (leaves)".to_string() } else { format!("level {li}") };
        meshes.push((name, m, li > 0));
    }
    let mut sample_markers = 0;
    if let Some(s) = &file.samples {
        let mut m = MeshData::new();
        let scale = file.spheres.iter().map(|s| s.radius).fold(0.0f32, f32::max) * 0.02;
        let oct: [[f32; 3]; 6] =
            [[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, -1.0]];
        let faces: [[u32; 3]; 8] =
            [[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]];
        for (si, list) in s.per_sphere().enumerate() {
            for p in list {
                let base = m.positions.len() as u32;
                for d in &oct {
                    m.positions.push([
                        p.position[0] + scale * d[0],
                        p.position[1] + scale * d[1],
                        p.position[2] + scale * d[2],
                    ]);
                    m.normals.push(*d);
                    m.colors.push(hue(si));
                }
                for f in &faces {
                    m.indices.extend(f.iter().map(|i| base + i));
                }
                sample_markers += 1;
            }
        }
        if sample_markers > 0 {
            meshes.push(("samples".to_string(), m, false));
        }
    }
    let summary = ExportSummary { levels: levels.len(), sample_markers, nodes: 1 + meshes.len() };
    (encode_glb(&meshes), summary)
}

fn encode_glb(meshes: &[(String, MeshData, bool)]) -> Vec<u8> {
    use serde_json::json;
    let mut bin: Vec<u8> = Vec::new();
    let mut views = Vec::new();
    let mut accessors = Vec::new();
    let mut gl_meshes = Vec::new();
    let mut nodes = vec![json!({"name": "spherebake proxy", "children": (1..=meshes.len()).collect::<Vec<_>>()})];
    let mut push_view = |bin: &mut Vec<u8>, data: &[u8], target: u32| -> usize {
        while bin.len() % 4 != 0 {
            bin.push(0);
        }
        views.push(json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": data.len(), "target": target}));
        bin.extend_from_slice(data);
        views.len() - 1
    };
    for (mi, (name, m, translucent)) in meshes.iter().enumerate() {
        let f32s = |v: &[[f32; 3]]| v.iter().flatten().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
        let (lo, hi) = m.positions.iter().fold(([f32::MAX; 3], [f32::MIN; 3]), |(lo, hi), p| {
            ([lo[0].min(p[0]), lo[1].min(p[1]), lo[2].min(p[2])], [hi[0].max(p[0]), hi[1].max(p[1]), hi[2].max(p[2])])
        });
        let vp = push_view(&mut bin, &f32s(&m.positions), 34962);
        let vn = push_view(&mut bin, &f32s(&m.normals), 34962);
        let cols: Vec<u8> = m.colors.iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
        let vc = push_view(&mut bin, &cols, 34962);
        let idx: Vec<u8> = m.indices.iter().flat_map(|x| x.to_le_bytes()).collect();
        let vi = push_view(&mut bin, &idx, 34963);
        let a0 = accessors.len();
        accessors.push(json!({"bufferView": vp, "componentType": 5126, "count": m.positions.len(), "type": "VEC3", "min": lo, "max": hi}));
        accessors.push(json!({"bufferView": vn, "componentType": 5126, "count": m.normals.len(), "type": "VEC3"}));
        accessors.push(json!({"bufferView": vc, "componentType": 5126, "count": m.colors.len(), "type": "VEC4"}));
        accessors.push(json!({"bufferView": vi, "componentType": 5125, "count": m.indices.len(), "type": "SCALAR"}));
        gl_meshes.push(json!({"name": name, "primitives": [{
            "attributes": {"POSITION": a0, "NORMAL": a0 + 1, "COLOR_0": a0 + 2},
            "indices": a0 + 3,
            "material": if *translucent { 1 } else { 0 },
        }]}));
        nodes.push(json!({"name": name, "mesh": mi}));
    }
    while bin.len() % 4 != 0 {
        bin.push(0);
    }
    let doc = json!({
        "asset": {"version": "2.0", "generator": crate::TOOL_VERSION},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": nodes,
        "meshes": gl_meshes,
        "materials": [
            {"name": "sphere", "pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0.0, "roughnessFactor": 0.8}},
            {"name": "parent level", "alphaMode": "BLEND", "doubleSided": true, "pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0.0, "roughnessFactor": 0.8}},
        ],
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": bin.len()}],
    });
    let mut json_bytes = serde_json::to_vec(&doc).unwrap_or_default();
    while json_bytes.len() % 4 != 0 {
        json_bytes.push(b' ');
    }
    let total = 12 + 8 + json_bytes.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json_bytes.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json_bytes);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&bin);
    out
}
