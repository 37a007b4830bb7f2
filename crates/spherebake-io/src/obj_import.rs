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
///
/// A large file is checked in pieces in parallel (rayon; a quarter of a 43 MB OBJ's import
/// was this check, serial): the text is cut at line ends that do not continue a line, and each
/// piece is checked once from its own start ([`check_piece`]), keeping its lines and `v` /
/// `vt` / `vn` counts and the face indices that need definitions before it. Then, in file
/// order with the counts of the pieces before, the first error is found: the one-piece check's
/// answer for any thread count and any cut.
fn check_lines(path: &Path, bytes: &[u8]) -> Result<(), IoError> {
    check_lines_in(path, bytes, CHECK_PIECE_BYTES)
}

/// Bytes per piece of [`check_lines`] (at least).
const CHECK_PIECE_BYTES: usize = 1 << 20;

/// [`check_lines`] with pieces of at least `piece` bytes.
fn check_lines_in(path: &Path, bytes: &[u8], piece: usize) -> Result<(), IoError> {
    use rayon::prelude::*;
    let text = String::from_utf8_lossy(bytes);
    let checks: Vec<PieceCheck> = split_pieces(&text, piece).par_iter().map(|p| check_piece(p)).collect();
    // In file order, with the counts before each piece: the first index that needs more
    // definitions than there were, else the piece's own error.
    let mut before = Counts::default();
    let err = |line: usize, message: String| {
        Err(IoError::Obj { path: path.to_path_buf(), message: format!("line {line}: {message}") })
    };
    for c in checks {
        let defined = [before.v, before.vt, before.vn];
        if let Some(n) = c.needs.iter().find(|n| defined[n.kind] < n.need) {
            let count = defined[n.kind] + n.local;
            let what = ["vertex", "texture", "normal"][n.kind];
            return err(
                before.lines + n.line,
                format!("{what} index {} out of range ({count} defined so far)", n.index),
            );
        }
        if let Some((line, message)) = c.error {
            return err(before.lines + line, message);
        }
        before = Counts {
            lines: before.lines + c.counts.lines,
            v: before.v + c.counts.v,
            vt: before.vt + c.counts.vt,
            vn: before.vn + c.counts.vn,
        };
    }
    Ok(())
}

/// Lines and `v`, `vt`, `vn` lines (a continued line counts once as a logical line, its
/// physical lines all in `lines`).
#[derive(Clone, Copy, Debug, Default)]
struct Counts {
    lines: usize,
    v: i64,
    vt: i64,
    vn: i64,
}

/// A face corner's index that is valid only when at least `need` definitions of its kind
/// come before the piece.
#[derive(Debug)]
struct Need {
    /// 1-based line in the piece.
    line: usize,
    /// 0 vertex, 1 texture, 2 normal.
    kind: usize,
    /// The index as written.
    index: i64,
    /// Definitions of its kind in the piece before it.
    local: i64,
    need: i64,
}

/// What [`check_piece`] found in a piece, counting from its start.
#[derive(Debug, Default)]
struct PieceCheck {
    /// Lines and definitions (up to the error, if any).
    counts: Counts,
    /// The corners whose index needs definitions before the piece, in file order, each needing
    /// more than every earlier one of its kind (only such a corner can be the first invalid
    /// one); an index 0 needs more than any count.
    needs: Vec<Need>,
    /// The first error that no definitions before the piece can undo: (1-based line in the
    /// piece, message). Nothing after it is read.
    error: Option<(usize, String)>,
}

/// `text` cut into pieces of at least `piece` bytes, each ending at a line end that does not
/// continue its line with `\` (or at the end of the text).
fn split_pieces(text: &str, piece: usize) -> Vec<&str> {
    let bytes = text.as_bytes();
    let mut out = Vec::new();
    let mut start = 0;
    while start < bytes.len() {
        let mut end = (start + piece.max(1)).min(bytes.len());
        loop {
            match bytes[end..].iter().position(|&b| b == b'\n') {
                None => {
                    end = bytes.len();
                    break;
                }
                Some(k) => {
                    let nl = end + k;
                    let line = &bytes[start..nl];
                    let line = line.strip_suffix(b"\r").unwrap_or(line);
                    end = nl + 1;
                    if !line.ends_with(b"\\") {
                        break;
                    }
                }
            }
        }
        // Line ends are ASCII, so `end` is a char boundary.
        out.push(&text[start..end]);
        start = end;
    }
    out
}

/// Calls `f` on each logical line of a piece: (index of its first physical line, 0-based, the
/// line with its `\`-continued lines joined by spaces), comments not yet removed; stops at
/// `f`'s first error. Returns the piece's physical line count.
fn logical_lines(
    text: &str,
    mut f: impl FnMut(usize, &str) -> Result<(), (usize, String)>,
) -> Result<usize, (usize, String)> {
    let mut joined = String::new();
    let mut start = 0usize;
    let mut n = 0usize;
    for (i, raw) in text.lines().enumerate() {
        n = i + 1;
        if joined.is_empty() {
            start = i;
        }
        if let Some(head) = raw.strip_suffix('\\') {
            joined.push_str(head);
            joined.push(' ');
            continue;
        }
        // A continued line is joined into `whole`; every other line is read in place (no
        // allocation per line: this check was a quarter of a 43 MB OBJ's import).
        if joined.is_empty() {
            f(start, raw)?;
        } else {
            joined.push_str(raw);
            let whole = std::mem::take(&mut joined);
            f(start, &whole)?;
        }
    }
    // A last line continued into the end of the file is left to tobj (it reports it).
    Ok(n)
}

/// The keyword of a logical line (comment removed) and its other tokens.
fn keyword(line: &str) -> (Option<&str>, std::str::SplitWhitespace<'_>) {
    let mut tok = line.split('#').next().unwrap_or("").split_whitespace();
    (tok.next(), tok)
}

/// Checks one piece on its own (see [`PieceCheck`]).
fn check_piece(text: &str) -> PieceCheck {
    let mut out = PieceCheck::default();
    let (mut counts, mut most) = (Counts::default(), [0i64; 3]);
    let lines = logical_lines(text, |i, line| {
        let at = i + 1;
        let (key, tok) = keyword(line);
        match key {
            Some("v") => {
                let ok = tok.take(3).filter(|t| t.parse::<f32>().is_ok()).count() == 3;
                if !ok {
                    return Err((at, "vertex needs three numbers".into()));
                }
                counts.v += 1;
            }
            Some("vt") => counts.vt += 1,
            Some("vn") => counts.vn += 1,
            Some("f") => {
                let corners = tok.clone().count();
                if corners < 3 {
                    return Err((at, format!("face with {corners} vertices (a face needs at least 3)")));
                }
                for c in tok {
                    for (kind, slot) in c.split('/').take(3).enumerate() {
                        let what = ["vertex", "texture", "normal"][kind];
                        if slot.is_empty() && kind > 0 {
                            continue;
                        }
                        let Ok(x) = slot.parse::<i64>() else {
                            return Err((at, format!("bad {what} index {slot:?} in face corner {c:?}")));
                        };
                        // Valid when 1 ≤ resolved ≤ defined, defined = before + local: x ≤ defined
                        // for x > 0, −x ≤ defined for x < 0; never for 0.
                        let local = [counts.v, counts.vt, counts.vn][kind];
                        let need = if x == 0 { i64::MAX } else { x.unsigned_abs().min(i64::MAX as u64) as i64 - local };
                        if need > most[kind] {
                            most[kind] = need;
                            out.needs.push(Need { line: at, kind, index: x, local, need });
                        }
                    }
                }
            }
            _ => {}
        }
        Ok(())
    });
    match lines {
        Ok(n) => counts.lines = n,
        Err(e) => out.error = Some(e),
    }
    out.counts = counts;
    out
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A random OBJ-like text: vertex lines (some bad), vt / vn, faces with absolute, negative,
    /// zero and out-of-range indices, comments, blank lines, `\`-continued lines, CRLF.
    fn random_obj(seed: u64, lines: usize) -> String {
        let mut x = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
        let mut next = move |n: u64| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x % n
        };
        // 30 vertices and normals first, so most faces are valid.
        let mut s = "v 0 0 0\nvn 0 0 1\n".repeat(30);
        for _ in 0..lines {
            let line = match next(12) {
                0..=3 => {
                    if next(300) == 0 {
                        "v 1 2 x".to_string()
                    } else {
                        "v 0.5 1 -2".to_string()
                    }
                }
                4 => "vt 0 1".to_string(),
                5 => "vn 0 0 1".to_string(),
                6..=8 => {
                    let corners = if next(300) == 0 { 2 } else { 3 + next(2) };
                    let idx = |n: u64| match n % 400 {
                        0 => "0".to_string(),
                        1..=30 => format!("-{}", 1 + n % 3),
                        // Rarely past what is defined (30 at first, more later), either way.
                        31 => format!("{}", 1 + n % 90),
                        32 => format!("-{}", 1 + n % 90),
                        k => format!("{}", 1 + k % 25),
                    };
                    let mut f = String::from("f");
                    for _ in 0..corners {
                        f.push(' ');
                        f.push_str(&idx(next(1000)));
                        if next(4) == 0 {
                            f.push_str(&format!("//{}", idx(next(1000))));
                        }
                    }
                    f
                }
                9 => "# f 0 0".to_string(),
                10 => String::new(),
                _ => "f 1 \\\n 2 \\\n3".to_string(),
            };
            s.push_str(&line);
            s.push_str(if next(5) == 0 { "\r\n" } else { "\n" });
        }
        s
    }

    /// The check written apart, line by line over the whole text, as tobj's users read OBJ:
    /// the first error's message, or `None`.
    fn oracle(text: &str) -> Option<String> {
        let mut logical: Vec<(usize, String)> = Vec::new();
        let mut pending: Option<(usize, String)> = None;
        for (i, raw) in text.lines().enumerate() {
            let (first, mut acc) = pending.take().unwrap_or((i + 1, String::new()));
            match raw.strip_suffix('\\') {
                Some(head) => {
                    acc += head;
                    acc += " ";
                    pending = Some((first, acc));
                }
                None => {
                    acc += raw;
                    logical.push((first, acc));
                }
            }
        }
        let mut defined = [0i64; 3];
        for (line, text) in logical {
            let body = text.split('#').next().unwrap_or("");
            let tokens: Vec<&str> = body.split_whitespace().collect();
            match tokens.first().copied() {
                Some("v") => {
                    if tokens[1..].iter().take(3).filter(|t| t.parse::<f32>().is_ok()).count() != 3 {
                        return Some(format!("line {line}: vertex needs three numbers"));
                    }
                    defined[0] += 1;
                }
                Some("vt") => defined[1] += 1,
                Some("vn") => defined[2] += 1,
                Some("f") => {
                    if tokens.len() < 4 {
                        return Some(format!(
                            "line {line}: face with {} vertices (a face needs at least 3)",
                            tokens.len() - 1
                        ));
                    }
                    for corner in &tokens[1..] {
                        for (kind, slot) in corner.split('/').take(3).enumerate() {
                            let what = ["vertex", "texture", "normal"][kind];
                            if kind > 0 && slot.is_empty() {
                                continue;
                            }
                            let Ok(x) = slot.parse::<i64>() else {
                                return Some(format!(
                                    "line {line}: bad {what} index {slot:?} in face corner {corner:?}"
                                ));
                            };
                            let n = defined[kind];
                            let ok = if x > 0 { x <= n } else { x < 0 && -x <= n };
                            if !ok {
                                return Some(format!(
                                    "line {line}: {what} index {x} out of range ({n} defined so far)"
                                ));
                            }
                        }
                    }
                }
                _ => {}
            }
        }
        None
    }

    #[test]
    fn the_check_in_pieces_answers_as_in_one() {
        let path = Path::new("x.obj");
        let message = |r: Result<(), IoError>| match r {
            Ok(()) => None,
            Err(IoError::Obj { message, .. }) => Some(message),
            Err(e) => panic!("{e:?}"),
        };
        let (mut errors, mut oks, mut late) = (0, 0, 0);
        for seed in 0..300u64 {
            let text = random_obj(seed, 20 + (seed as usize % 7) * 30);
            let whole = message(check_lines_in(path, text.as_bytes(), usize::MAX));
            assert_eq!(whole, oracle(&text), "seed {seed}");
            if let Some(m) = &whole {
                errors += 1;
                // An error past the first piece of the smallest size: the counts before a piece matter.
                let line: usize = m.trim_start_matches("line ").split(':').next().unwrap().parse().unwrap();
                late += usize::from(line > 70);
            } else {
                oks += 1;
            }
            for piece in [1, 7, 40, 200] {
                assert_eq!(
                    message(check_lines_in(path, text.as_bytes(), piece)),
                    whole,
                    "seed {seed}, pieces of {piece}"
                );
            }
            // Every piece ends at a line end that does not continue a line, and they join to the text.
            let pieces = split_pieces(&text, 7);
            assert_eq!(pieces.concat(), text);
            for p in &pieces[..pieces.len() - 1] {
                assert!(p.ends_with('\n') && !p.trim_end_matches('\n').trim_end_matches('\r').ends_with('\\'));
            }
        }
        assert!(errors > 50 && oks > 20 && late > 30, "{errors} errors ({late} late), {oks} clean");
    }
}
