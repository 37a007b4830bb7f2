//! Wavefront OBJ + MTL import via `tobj` (faces triangulated, one vertex per distinct
//! position / UV / normal corner).

use std::cell::RefCell;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

use glam::Vec3;
use spherebake_geom::{Material, Mesh, TextureRef};

use crate::texture::decode_srgb_texture;
use crate::{Ctx, ImportedPart, IoError, ReadLimit, MAX_IMAGE_BYTES, MAX_MTL_BYTES};

/// An MTL file tobj asked for: resolved path and its bytes (or why it could not be read).
type MtlRead = (PathBuf, Result<Vec<u8>, IoError>);

/// Checks what tobj reports without a line number (or not at all): faces with fewer than three
/// vertices, vertex / texture / normal indices out of range, unparsable `v` lines. Errors name
/// the line (1-based; a `\`-continued line by its first line).
fn check_lines(path: &Path, bytes: &[u8]) -> Result<(), IoError> {
    let text = String::from_utf8_lossy(bytes);
    let err = |line: usize, message: String| IoError::Obj {
        path: path.to_path_buf(),
        message: format!("line {line}: {message}"),
    };
    let (mut nv, mut nt, mut nn) = (0i64, 0i64, 0i64);
    let mut joined = String::new();
    let mut start = 0usize;
    for (i, raw) in text.lines().enumerate() {
        if joined.is_empty() {
            start = i + 1;
        }
        if let Some(head) = raw.strip_suffix('\\') {
            joined.push_str(head);
            joined.push(' ');
            continue;
        }
        // A continued line is joined into `whole`; every other line is read in place (no
        // allocation per line: this check was a quarter of a 43 MB OBJ's import).
        let whole: String;
        let line = if joined.is_empty() {
            raw
        } else {
            joined.push_str(raw);
            whole = std::mem::take(&mut joined);
            whole.as_str()
        };
        let line = line.split('#').next().unwrap_or("");
        let mut tok = line.split_whitespace();
        match tok.next() {
            Some("v") => {
                let ok = tok.take(3).filter(|t| t.parse::<f32>().is_ok()).count() == 3;
                if !ok {
                    return Err(err(start, "vertex needs three numbers".into()));
                }
                nv += 1;
            }
            Some("vt") => nt += 1,
            Some("vn") => nn += 1,
            Some("f") => {
                let corners = tok.clone().count();
                if corners < 3 {
                    return Err(err(start, format!("face with {corners} vertices (a face needs at least 3)")));
                }
                for c in tok {
                    for (slot, (what, count)) in c.split('/').zip([("vertex", nv), ("texture", nt), ("normal", nn)]) {
                        if slot.is_empty() && what != "vertex" {
                            continue;
                        }
                        let Ok(x) = slot.parse::<i64>() else {
                            return Err(err(start, format!("bad {what} index {slot:?} in face corner {c:?}")));
                        };
                        let resolved = if x < 0 { count + x + 1 } else { x };
                        if x == 0 || resolved < 1 || resolved > count {
                            return Err(err(start, format!("{what} index {x} out of range ({count} defined so far)")));
                        }
                    }
                }
            }
            _ => {}
        }
    }
    Ok(())
}

/// Whether every `Ka` / `Kd` / `Ks` / `Ke` line of an MTL file has three numbers (tobj takes
/// the first three and panics when there are fewer).
fn mtl_colours_ok(bytes: &[u8]) -> bool {
    String::from_utf8_lossy(bytes).lines().all(|line| {
        let mut tok = line.split_whitespace();
        match tok.next() {
            Some("Ka" | "Kd" | "Ks" | "Ke") => tok.take(3).filter(|t| t.parse::<f32>().is_ok()).count() == 3,
            _ => true,
        }
    })
}

pub(crate) fn import(ctx: &mut Ctx, bytes: &[u8]) -> Result<(Mesh, Vec<ImportedPart>), IoError> {
    let path = ctx.path.clone();
    check_lines(&path, bytes)?;
    let opts = tobj::LoadOptions { triangulate: true, single_index: true, ..Default::default() };
    // MTL files read by tobj's callback: (resolved path, bytes or the read error).
    let mtl_reads: RefCell<Vec<MtlRead>> = RefCell::new(Vec::new());
    let dir = ctx.dir.clone();
    let (model, opts_in, resolver) = (ctx.path.clone(), ctx.opts, ctx.resolver.clone());
    let budget = RefCell::new(opts_in.max_input_bytes.saturating_sub(ctx.read_total));
    let (models, materials) = tobj::load_obj_buf(&mut std::io::Cursor::new(bytes), &opts, |p: &Path| {
        let full = dir.join(p);
        let uri = p.to_string_lossy();
        let limit = ReadLimit::AtMost(MAX_MTL_BYTES);
        let read =
            crate::read_confined(&model, &dir, &opts_in, &uri, &full, *budget.borrow(), limit, resolver.as_deref());
        if let Ok(b) = &read {
            let mut left = budget.borrow_mut();
            *left = left.saturating_sub(b.len() as u64);
        }
        let result = match &read {
            // tobj 4.0.5 panics on `Kd` (Ka, Ks, Ke) with fewer than three numbers (found by the
            // obj fuzz target): such a library is a parse error here instead.
            Ok(b) if !mtl_colours_ok(b) => Err(tobj::LoadError::MaterialParseError),
            Ok(b) => tobj::load_mtl_buf(&mut std::io::Cursor::new(b.as_slice())),
            Err(_) => Err(tobj::LoadError::OpenFileFailed),
        };
        mtl_reads.borrow_mut().push((full, read));
        result
    })
    .map_err(|e| IoError::Obj { path: path.clone(), message: e.to_string() })?;
    let mut mtl_dir = dir.clone();
    for (p, read) in mtl_reads.into_inner() {
        match read {
            Ok(b) => {
                ctx.record(&p, &b);
                mtl_dir = p.parent().map(Path::to_path_buf).unwrap_or_default();
            }
            Err(e) if e.is_refusal() => return Err(e),
            Err(e) => ctx.warn(format!("material library: {e}; using default materials")),
        }
    }
    let materials = match materials {
        Ok(m) => m,
        Err(e) => {
            if !matches!(e, tobj::LoadError::OpenFileFailed) {
                ctx.warn(format!("{}: cannot parse material library: {e}; using default materials", path.display()));
            }
            Vec::new()
        }
    };

    let mut mesh = Mesh::default();
    let mut material_map: HashMap<Option<usize>, u32> = HashMap::new();
    let mut texture_map: HashMap<PathBuf, Option<usize>> = HashMap::new();
    // A texture that must not be read (outside the folder, not a regular file, over budget).
    let mut refused: Option<IoError> = None;
    let mut parts = Vec::new();
    let mut has_uv = false;
    let mut uvs = Vec::new();
    for (mi, model) in models.iter().enumerate() {
        let m = &model.mesh;
        let n = m.positions.len() / 3;
        let positions: Vec<Vec3> = m.positions.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect();
        if let Some((v, p)) = positions.iter().enumerate().find(|(_, p)| !p.is_finite()) {
            return Err(IoError::NonFinitePosition {
                path,
                mesh: mi,
                mesh_name: model.name.clone(),
                primitive: 0,
                vertex: v,
                value: p.to_array(),
            });
        }
        let mut tris = Vec::with_capacity(m.indices.len() / 3);
        for (k, c) in m.indices.chunks_exact(3).enumerate() {
            for (j, &i) in c.iter().enumerate() {
                if i as usize >= n {
                    return Err(IoError::IndexOutOfRange {
                        path,
                        mesh: mi,
                        primitive: 0,
                        position: k * 3 + j,
                        index: u64::from(i),
                        vertex_count: n,
                    });
                }
            }
            tris.push([c[0], c[1], c[2]]);
        }
        let normals: Vec<Vec3> = if m.normals.len() == 3 * n && n > 0 {
            m.normals.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2]).try_normalize().unwrap_or(Vec3::Z)).collect()
        } else {
            let mut tmp = Mesh { positions: positions.clone(), triangles: tris.clone(), ..Default::default() };
            tmp.rebuild_weld();
            tmp.compute_normals();
            tmp.normals
        };
        // OBJ v runs bottom-up; glTF convention (row 0 = top) needs v' = 1 - v.
        if m.texcoords.len() == 2 * n && n > 0 {
            has_uv = true;
            uvs.extend(m.texcoords.chunks_exact(2).map(|c| [c[0], 1.0 - c[1]]));
        } else {
            uvs.resize(uvs.len() + n, [0.0, 0.0]);
        }
        let key = m.material_id.filter(|&i| i < materials.len());
        let material = match material_map.get(&key) {
            Some(&id) => id,
            None => {
                let mat = match key {
                    Some(i) => obj_material(ctx, &materials[i], &mtl_dir, &mut mesh, &mut texture_map, &mut refused),
                    None => Material { name: "default".into(), ..Default::default() },
                };
                mesh.materials.push(mat);
                let id = (mesh.materials.len() - 1) as u32;
                material_map.insert(key, id);
                id
            }
        };
        let v0 = mesh.positions.len() as u32;
        let t0 = mesh.triangles.len() as u32;
        mesh.positions.extend(positions);
        mesh.normals.extend(normals);
        mesh.triangles.extend(tris.iter().map(|t| [t[0] + v0, t[1] + v0, t[2] + v0]));
        mesh.triangle_materials.extend(std::iter::repeat_n(material, tris.len()));
        parts.push(ImportedPart {
            source_mesh: mi,
            primitive: 0,
            node: None,
            node_world: glam::Mat4::IDENTITY,
            file_vertex_count: n,
            vertices: v0..mesh.positions.len() as u32,
            triangles: t0..mesh.triangles.len() as u32,
        });
    }
    if let Some(e) = refused {
        return Err(e);
    }
    if has_uv {
        mesh.uvs = vec![uvs];
    }
    mesh.rebuild_weld();
    Ok((mesh, parts))
}

fn obj_material(
    ctx: &mut Ctx,
    m: &tobj::Material,
    mtl_dir: &Path,
    mesh: &mut Mesh,
    texture_map: &mut HashMap<PathBuf, Option<usize>>,
    refused: &mut Option<IoError>,
) -> Material {
    let kd = m.diffuse.unwrap_or([1.0; 3]);
    let mut out = Material {
        name: m.name.clone(),
        // MTL `Kd` is taken as linear RGB; `d` (dissolve) as alpha.
        base_color_factor_linear: [kd[0], kd[1], kd[2], m.dissolve.unwrap_or(1.0)],
        base_color_texture: None,
        double_sided: false,
    };
    if let Some(tex) = &m.diffuse_texture {
        // Options such as `-s 1 1 1` may precede the file name; the file name is the last token.
        let file = tex.split_whitespace().last().unwrap_or("");
        let p = mtl_dir.join(file.replace('\\', "/"));
        let slot = match texture_map.get(&p) {
            Some(s) => *s,
            None => {
                let s = match ctx.read_referenced(file, &p, ReadLimit::AtMost(MAX_IMAGE_BYTES)) {
                    Ok(bytes) => match decode_srgb_texture(file.to_owned(), &bytes) {
                        Ok(t) => {
                            mesh.textures.push(t);
                            Some(mesh.textures.len() - 1)
                        }
                        Err(e) => {
                            ctx.warn(format!("material {:?}: cannot decode {}: {e}; using Kd", m.name, p.display()));
                            None
                        }
                    },
                    Err(e) if e.is_refusal() => {
                        refused.get_or_insert(e);
                        None
                    }
                    Err(e) => {
                        ctx.warn(format!("material {:?}: texture {e}; using Kd", m.name));
                        None
                    }
                };
                texture_map.insert(p, s);
                s
            }
        };
        if let Some(texture) = slot {
            out.base_color_texture = Some(TextureRef {
                texture,
                uv_set: 0,
                wrap_s: Default::default(),
                wrap_t: Default::default(),
                mag_filter: Default::default(),
                transform: Default::default(),
            });
        }
    }
    out
}
