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

/// The most bytes [`export_glb`] writes (1 GiB). The export is a viewing aid, and a file of a
/// million spheres would need a 2.6 GB `.glb` and about three times that in memory while it
/// is built (a GLB cannot pass 4 GiB at all: its lengths are 32-bit).
pub const MAX_GLB_BYTES: u64 = 1 << 30;

/// Bytes of the binary chunk per sphere drawn (an icosphere of 42 vertices with position,
/// normal and colour, 80 triangles of u32 indices) and per sample marker (an octahedron: 6
/// vertices, 8 triangles).
const SPHERE_BYTES: u64 = 42 * (12 + 12 + 16) + 80 * 3 * 4;
const MARKER_BYTES: u64 = 6 * (12 + 12 + 16) + 8 * 3 * 4;
/// JSON bytes per mesh and node written (name, four accessors, four views; measured 3 500 in
/// compact JSON), a generous bound.
const MESH_JSON_BYTES: u64 = 4096;

/// The most hierarchy levels [`export_glb`] draws, one glTF mesh each. The bake's hierarchies
/// have about log₄ of the sphere count (at most 7 for 4 096 spheres); a valid file may chain
/// its nodes one below another, and 200 000 levels took 6 GB to write as JSON.
pub const MAX_LEVELS: usize = 256;

/// Why [`export_glb`] wrote nothing.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum ExportError {
    /// The hierarchy has more than [`MAX_LEVELS`] levels.
    #[error("the hierarchy has {levels} levels, more than the {max} export draws (one mesh each)")]
    TooManyLevels { levels: usize, max: usize },
    /// The `.glb` would pass [`MAX_GLB_BYTES`].
    #[error("the .glb would take about {mib} MiB ({spheres} spheres in {levels} level(s), {markers} sample markers), more than the {limit_mib} MiB export writes: export a proxy with fewer spheres or samples")]
    TooLarge { mib: u64, spheres: u64, levels: usize, markers: u64, limit_mib: u64 },
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
    // Height of each node = 1 + max height of node children (leaf-only nodes have height 1),
    // children first by an explicit depth-first walk: O(nodes + child links) for any shape (a
    // chain of 200 000 single-child nodes took minutes with repeated passes). A validated
    // file's nodes form a tree; a link back to a node still on the walk (only in a file built
    // in memory) counts as height 0.
    let n = h.nodes.len();
    let mut height = vec![0usize; n];
    let mut state = vec![0u8; n]; // 0 new, 1 on the walk, 2 done
    let mut stack: Vec<(usize, usize)> = Vec::new();
    for start in 0..n {
        if state[start] != 0 {
            continue;
        }
        state[start] = 1;
        stack.push((start, 0));
        while let Some(&mut (node, ref mut next)) = stack.last_mut() {
            let kids = h.children_of(node);
            if let Some(&c) = kids.get(*next) {
                *next += 1;
                let c = c as usize;
                if c < n && state[c] == 0 {
                    state[c] = 1;
                    stack.push((c, 0));
                }
            } else {
                height[node] = 1 + kids.iter().filter_map(|&c| height.get(c as usize).copied()).max().unwrap_or(0);
                state[node] = 2;
                stack.pop();
            }
        }
    }
    let top = height.iter().copied().max().unwrap_or(0);
    levels.resize(top + 1, Vec::new());
    // Each node into its level in one pass, in node order within a level.
    for (nd, &hh) in h.nodes.iter().zip(&height) {
        if hh > 0 {
            levels[hh].push((nd.center, nd.radius));
        }
    }
    levels
}

/// Builds the `.glb` bytes of a proxy (see the module docs for the layout).
///
/// # Errors
///
/// [`ExportError::TooManyLevels`] past [`MAX_LEVELS`] hierarchy levels and
/// [`ExportError::TooLarge`] when the file would pass [`MAX_GLB_BYTES`], both checked from the
/// counts before anything is built. Cost O(spheres + hierarchy nodes + samples).
pub fn export_glb(file: &SphbFile) -> Result<(Vec<u8>, ExportSummary), ExportError> {
    // One subdivision of the icosahedron: 42 vertices, 80 triangles.
    let (ico_v, ico_f) = spherebake_geom::sphere::icosphere(1);
    let levels = hierarchy_levels(file);
    if levels.len() > MAX_LEVELS {
        return Err(ExportError::TooManyLevels { levels: levels.len(), max: MAX_LEVELS });
    }
    let spheres: u64 = levels.iter().map(|l| l.len() as u64).sum();
    let markers = file.samples.as_ref().map_or(0, |s| s.per_sphere().map(|l| l.len() as u64).sum());
    let estimate = spheres * SPHERE_BYTES + markers * MARKER_BYTES + (levels.len() as u64 + 2) * MESH_JSON_BYTES + 4096;
    if estimate > MAX_GLB_BYTES {
        return Err(ExportError::TooLarge {
            mib: estimate.div_ceil(1 << 20),
            spheres,
            levels: levels.len(),
            markers,
            limit_mib: MAX_GLB_BYTES >> 20,
        });
    }
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
    Ok((encode_glb(&meshes), summary))
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

#[cfg(test)]
mod tests {
    use super::*;
    use spherebake_format::{Hierarchy, NodeLists, Sphere};

    fn file_with(spheres: usize, nodes: Vec<NodeLists>) -> SphbFile {
        let s = Sphere { center: [0.0; 3], radius: 1.0 };
        let hierarchy = (!nodes.is_empty()).then(|| Hierarchy::from_lists(0, nodes));
        SphbFile { spheres: vec![s; spheres], hierarchy, ..SphbFile::default() }
    }

    fn node(children: Vec<u32>, leaves: Vec<u32>) -> NodeLists {
        NodeLists { center: [0.0; 3], radius: 1.0, children, leaf_children: leaves }
    }

    /// Random trees (each node's parent an earlier node) against heights from the definition,
    /// 1 + the children's largest, computed from the last node back (a child comes after its
    /// parent): level L holds the nodes of height L, in node order.
    #[test]
    fn levels_hold_the_nodes_of_each_height_in_node_order() {
        let mut rng = spherebake_geom::rng::SplitMix64::new(3);
        for case in 0..50 {
            let n = 1 + rng.below(40) as usize;
            let parent: Vec<usize> = (0..n).map(|i| if i == 0 { 0 } else { rng.below(i as u64) as usize }).collect();
            let mut kids = vec![Vec::new(); n];
            for i in 1..n {
                kids[parent[i]].push(i as u32);
            }
            let mut height = vec![1usize; n];
            for i in (0..n).rev() {
                height[i] = 1 + kids[i].iter().map(|&c| height[c as usize]).max().unwrap_or(0);
            }
            let nodes: Vec<NodeLists> =
                (0..n).map(|i| NodeLists { center: [i as f32, 0.0, 0.0], ..node(kids[i].clone(), vec![]) }).collect();
            let levels = hierarchy_levels(&file_with(3, nodes));
            assert_eq!(levels[0].len(), 3, "case {case}: the leaves");
            assert_eq!(levels.len(), 1 + height.iter().max().unwrap(), "case {case}");
            for (l, level) in levels.iter().enumerate().skip(1) {
                let want: Vec<f32> = (0..n).filter(|&i| height[i] == l).map(|i| i as f32).collect();
                let got: Vec<f32> = level.iter().map(|(c, _)| c[0]).collect();
                assert_eq!(got, want, "case {case}, level {l}");
            }
        }
    }

    /// A chain of 100 000 single-child nodes is walked in linear time (it took minutes with
    /// repeated passes) and refused past [`MAX_LEVELS`]; a file whose `.glb` would pass
    /// [`MAX_GLB_BYTES`] is refused from its counts; a small file exports.
    #[test]
    fn deep_chains_and_huge_files_are_refused_before_anything_is_built() {
        let n = 100_000u32;
        let chain: Vec<NodeLists> =
            (0..n).map(|i| if i + 1 < n { node(vec![i + 1], vec![]) } else { node(vec![], vec![0]) }).collect();
        let f = file_with(1, chain);
        assert_eq!(hierarchy_levels(&f).len(), n as usize + 1);
        assert_eq!(export_glb(&f).unwrap_err(), ExportError::TooManyLevels { levels: n as usize + 1, max: MAX_LEVELS });
        let spheres = (MAX_GLB_BYTES / SPHERE_BYTES) as usize + 1;
        match export_glb(&file_with(spheres, vec![])) {
            Err(ExportError::TooLarge { spheres: s, levels: 1, markers: 0, .. }) => assert_eq!(s, spheres as u64),
            other => panic!("{:?}", other.map(|(b, s)| (b.len(), s))),
        }
        let (bytes, summary) = export_glb(&file_with(1000, vec![])).expect("a small file exports");
        assert_eq!((summary.levels, summary.sample_markers), (1, 0));
        assert!((bytes.len() as u64) < 1000 * SPHERE_BYTES + 2 * MESH_JSON_BYTES + 4096);
        assert!((bytes.len() as u64) > 1000 * SPHERE_BYTES, "the estimate counts each sphere's bytes");
    }
}
