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
/// vertices and line elements (`l`) with none, vertex / texture / normal indices out of range
/// in either, `v` lines that are not x y z, x y z w (w ≠ 0) or x y z r g b, `vt` lines without
/// two numbers and `vn` lines without three. Errors name the line (1-based; a `\`-continued
/// line by its first line). tobj is then given the text as checked ([`tobj_text`]).
///
/// A large file is checked in pieces in parallel (rayon; a quarter of a 43 MB OBJ's import
/// was this check, serial): the text is cut at line ends that do not continue a line, and each
/// piece is checked once from its own start ([`check_piece`]), keeping its lines and `v` /
/// `vt` / `vn` counts and the face indices that need definitions before it. Then, in file
/// order with the counts of the pieces before, the first error is found: the one-piece check's
/// answer for any thread count and any cut.
///
/// Returns whether the file has line elements (`l`), which [`tobj_text`] removes.
fn check_lines(path: &Path, bytes: &[u8]) -> Result<bool, IoError> {
    check_lines_in(path, bytes, CHECK_PIECE_BYTES)
}

/// Bytes per piece of [`check_lines`] (at least).
const CHECK_PIECE_BYTES: usize = 1 << 20;

/// [`check_lines`] with pieces of at least `piece` bytes.
fn check_lines_in(path: &Path, bytes: &[u8], piece: usize) -> Result<bool, IoError> {
    use rayon::prelude::*;
    let text = utf8_lossy(bytes);
    let checks: Vec<PieceCheck> = split_pieces(&text, piece).par_iter().map(|p| check_piece(p)).collect();
    // In file order, with the counts before each piece: the first index that needs more
    // definitions than there were, else the piece's own error.
    let mut before = Counts::default();
    let err = |line: usize, message: String| {
        Err(IoError::Obj { path: path.to_path_buf(), message: format!("line {line}: {message}") })
    };
    // The first `v` line (absolute line, coloured) and the first whose colour-ness differs.
    let mut first_v: Option<(usize, bool)> = None;
    let mut mixed: Option<(usize, bool)> = None;
    let line_elements = checks.iter().any(|c| c.line_elements);
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
        if let Some((line, coloured)) = c.first_v {
            let (_, first) = *first_v.get_or_insert((before.lines + line, coloured));
            if mixed.is_none() {
                mixed = if coloured != first { Some((before.lines + line, coloured)) } else { None };
                mixed = mixed.or(c.colour_change.map(|l| (before.lines + l, !coloured)));
            }
        }
        before = Counts {
            lines: before.lines + c.counts.lines,
            v: before.v + c.counts.v,
            vt: before.vt + c.counts.vt,
            vn: before.vn + c.counts.vn,
        };
    }
    // tobj gives vertex i the i-th colour read: with colours on some vertices only it fails
    // on a later vertex or, silently, gives vertices the wrong colours.
    if let (Some((line, coloured)), Some((first, _))) = (mixed, first_v) {
        let (this, that) = if coloured { ("with a colour", "has none") } else { ("without a colour", "has one") };
        return err(line, format!("vertex {this}, but the first vertex (line {first}) {that}"));
    }
    Ok(line_elements)
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
    /// The piece's first `v` line: (1-based line in the piece, whether it has a colour).
    first_v: Option<(usize, bool)>,
    /// The piece's first `v` line whose colour-ness differs from its first's.
    colour_change: Option<usize>,
    /// Whether the piece has a line element (`l`).
    line_elements: bool,
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
                let coloured = vertex_values(tok).map_err(|m| (at, m))?;
                match out.first_v {
                    None => out.first_v = Some((at, coloured)),
                    Some((_, first)) if first != coloured && out.colour_change.is_none() => {
                        out.colour_change = Some(at)
                    }
                    Some(_) => {}
                }
                counts.v += 1;
            }
            Some("vt") => {
                if tok.take(2).filter(|t| t.parse::<f32>().is_ok()).count() != 2 {
                    return Err((at, "texture coordinate needs two numbers".into()));
                }
                counts.vt += 1;
            }
            Some("vn") => {
                if tok.take(3).filter(|t| t.parse::<f32>().is_ok()).count() != 3 {
                    return Err((at, "normal needs three numbers".into()));
                }
                counts.vn += 1;
            }
            Some(kw @ ("f" | "l")) => {
                let corners = tok.clone().count();
                if kw == "f" && corners < 3 {
                    return Err((at, format!("face with {corners} vertices (a face needs at least 3)")));
                }
                if corners == 0 {
                    return Err((at, "line element with no vertex".into()));
                }
                out.line_elements |= kw == "l";
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

/// Checks a `v` line's values (after the keyword) as tobj reads them: x y z, then nothing, a
/// weight w (a number, not 0: tobj divides by it) or a colour r g b (three numbers: tobj keeps
/// the numbers before the first that is not one, and the next vertices' colours would shift).
/// Returns whether it has a colour.
fn vertex_values(tok: std::str::SplitWhitespace<'_>) -> Result<bool, String> {
    // No allocation per line (a large OBJ has millions of `v` lines).
    let mut values = [""; 8];
    let mut len = 0;
    for (slot, t) in values.iter_mut().zip(tok) {
        *slot = t;
        len += 1;
    }
    if values[..len.min(3)].iter().filter(|t| t.parse::<f32>().is_ok()).count() != 3 {
        return Err("vertex needs three numbers".into());
    }
    match len {
        3 => Ok(false),
        6 if values[3..6].iter().all(|t| t.parse::<f32>().is_ok()) => Ok(true),
        6 => Err("vertex colour needs three numbers".into()),
        4 => match values[3].parse::<f32>() {
            Ok(w) if w != 0.0 => Ok(false),
            Ok(_) => Err("vertex weight w is 0".into()),
            Err(_) => Err(format!("vertex weight {:?} is not a number", values[3])),
        },
        n => Err(format!(
            "vertex with {} values (expected x y z, x y z w or x y z r g b)",
            if n > 7 { "more than 7".to_string() } else { n.to_string() }
        )),
    }
}

/// The text tobj reads: the file as checked by [`check_lines`], so each of tobj's line errors
/// (which name no line) is found by the check first. tobj 4 reads each physical line on its
/// own, takes no comment after data and fails on bytes that are not UTF-8 ("read error");
/// the check joins a `\`-continued line, ends every line at `#` and reads the text as UTF-8
/// with invalid bytes replaced. tobj also reads a line element (`l`) of three or more
/// vertices as a face (and, triangulating, one of two as a zero-area triangle). So, when the
/// file has any of these, tobj is given: the text with invalid bytes replaced (U+FFFD), each
/// continued line joined (then as many empty lines as it had physical lines after its first,
/// so the line count stays), the `v`, `vt`, `vn` and `f` lines ended at `#`, and the `l` lines
/// empty (`line_elements`: the check found one). Other lines keep their `#` (names may hold
/// it). A file without `#`, `\`, invalid bytes or `l` lines is given as it is.
fn tobj_text(bytes: &[u8], line_elements: bool) -> std::borrow::Cow<'_, [u8]> {
    use std::borrow::Cow;
    let text = utf8_lossy(bytes);
    // In blocks without an early exit, so the scan vectorises (a 43 MB file: a few ms).
    let marked = |c: &[u8]| c.iter().fold(false, |a, &b| a | (b == b'#') | (b == b'\\'));
    if !line_elements && matches!(text, Cow::Borrowed(_)) && !bytes.chunks(1 << 12).any(marked) {
        return Cow::Borrowed(bytes);
    }
    let mut out = String::with_capacity(text.len());
    let mut joined = String::new();
    let mut extra = 0usize;
    let mut lines = text.lines().peekable();
    while let Some(raw) = lines.next() {
        // A last line continued into the end of the file is left as it is (tobj reports it).
        if let (Some(head), true) = (raw.strip_suffix('\\'), lines.peek().is_some()) {
            joined.push_str(head);
            joined.push(' ');
            extra += 1;
            continue;
        }
        joined.push_str(raw);
        let line = match keyword(&joined).0 {
            Some("l") => "",
            Some("v" | "vt" | "vn" | "f") => joined.split('#').next().unwrap_or(""),
            _ => &joined,
        };
        out.push_str(line);
        out.push('\n');
        for _ in 0..std::mem::take(&mut extra) {
            out.push('\n');
        }
        joined.clear();
    }
    Cow::Owned(out.into_bytes())
}

/// `String::from_utf8_lossy`, with the common case (valid UTF-8) checked by the faster
/// `str::from_utf8` first (the lossy decoder's walk cost a 43 MB OBJ 60 ms).
fn utf8_lossy(bytes: &[u8]) -> std::borrow::Cow<'_, str> {
    match std::str::from_utf8(bytes) {
        Ok(s) => std::borrow::Cow::Borrowed(s),
        Err(_) => String::from_utf8_lossy(bytes),
    }
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
    let line_elements = check_lines(&path, bytes)?;
    // Line and point elements are not surfaces (`tobj_text` has removed the `l` lines: tobj
    // reads one of three or more vertices as a face).
    let opts = tobj::LoadOptions { triangulate: true, single_index: true, ignore_lines: true, ignore_points: true };
    // MTL files read by tobj's callback: (resolved path, bytes or the read error).
    let mtl_reads: RefCell<Vec<MtlRead>> = RefCell::new(Vec::new());
    let dir = ctx.dir.clone();
    let (model, opts_in, resolver) = (ctx.path.clone(), ctx.opts, ctx.resolver.clone());
    let budget = RefCell::new(opts_in.max_input_bytes.saturating_sub(ctx.read_total));
    let text = tobj_text(bytes, line_elements);
    let (models, materials) = tobj::load_obj_buf(&mut std::io::Cursor::new(&text[..]), &opts, |p: &Path| {
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
        // 30 vertices and normals first, so most faces are valid; every third file's
        // vertices have colours (and now and then one has none, or the other way round).
        let coloured = seed % 3 == 0;
        let plain = if coloured { "v 0.5 1 -2 0.2 0.4 1" } else { "v 0.5 1 -2" };
        let first = if coloured { "v 0 0 0 0.2 0.4 1\nvn 0 0 1\n" } else { "v 0 0 0\nvn 0 0 1\n" };
        let mut s = first.repeat(30);
        for _ in 0..lines {
            let line = match next(12) {
                0..=3 => match next(1200) {
                    0..=3 => "v 1 2 x".to_string(),
                    4 => "v 1 2 3 0".to_string(),
                    5 => "v 1 2 3 y".to_string(),
                    6 => "v 1 2 3 1 1".to_string(),
                    7 => "v 1 2 3 1 1 1 1".to_string(),
                    8..=20 if coloured => "v 1 2 3 2".to_string(),
                    8..=20 => "v 1 2 3 0.5 1 1 # colour".to_string(),
                    21 => "v 1 2 3 0.5 x 1".to_string(),
                    _ => plain.to_string(),
                },
                4 => match next(200) {
                    0 => "vt 0".to_string(),
                    1 => "vt 0 1 # uv".to_string(),
                    _ => "vt 0 1".to_string(),
                },
                5 => match next(200) {
                    0 => "vn 0 1".to_string(),
                    1 => "l".to_string(),
                    2..=5 => format!("l {} {}", 1 + next(40), 1 + next(40)),
                    _ => "vn 0 0 1".to_string(),
                },
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
    fn oracle(text: &str) -> Result<bool, String> {
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
        let mut line_elements = false;
        // Every `v` line: (line, whether it has a colour).
        let mut colours: Vec<(usize, bool)> = Vec::new();
        for (line, text) in logical {
            let body = text.split('#').next().unwrap_or("");
            let tokens: Vec<&str> = body.split_whitespace().collect();
            match tokens.first().copied() {
                Some("v") => {
                    let numbers: Vec<Option<f32>> = tokens[1..].iter().map(|t| t.parse::<f32>().ok()).collect();
                    if numbers.len() < 3 || numbers[..3].iter().any(Option::is_none) {
                        return Err(format!("line {line}: vertex needs three numbers"));
                    }
                    match (numbers.len(), numbers.get(3)) {
                        (3, _) => colours.push((line, false)),
                        (6, _) if numbers[3..].iter().all(Option::is_some) => colours.push((line, true)),
                        (6, _) => return Err(format!("line {line}: vertex colour needs three numbers")),
                        (4, Some(Some(w))) if *w != 0.0 => colours.push((line, false)),
                        (4, Some(Some(_))) => return Err(format!("line {line}: vertex weight w is 0")),
                        (4, _) => return Err(format!("line {line}: vertex weight {:?} is not a number", tokens[4])),
                        (n, _) => {
                            return Err(format!(
                                "line {line}: vertex with {n} values (expected x y z, x y z w or x y z r g b)"
                            ))
                        }
                    }
                    defined[0] += 1;
                }
                Some("vt") => {
                    if tokens.len() < 3 || tokens[1..3].iter().any(|t| t.parse::<f32>().is_err()) {
                        return Err(format!("line {line}: texture coordinate needs two numbers"));
                    }
                    defined[1] += 1;
                }
                Some("vn") => {
                    if tokens.len() < 4 || tokens[1..4].iter().any(|t| t.parse::<f32>().is_err()) {
                        return Err(format!("line {line}: normal needs three numbers"));
                    }
                    defined[2] += 1;
                }
                Some(kw @ ("f" | "l")) => {
                    if kw == "f" && tokens.len() < 4 {
                        return Err(format!(
                            "line {line}: face with {} vertices (a face needs at least 3)",
                            tokens.len() - 1
                        ));
                    }
                    if tokens.len() == 1 {
                        return Err(format!("line {line}: line element with no vertex"));
                    }
                    line_elements |= kw == "l";
                    for corner in &tokens[1..] {
                        for (kind, slot) in corner.split('/').take(3).enumerate() {
                            let what = ["vertex", "texture", "normal"][kind];
                            if kind > 0 && slot.is_empty() {
                                continue;
                            }
                            let Ok(x) = slot.parse::<i64>() else {
                                return Err(format!(
                                    "line {line}: bad {what} index {slot:?} in face corner {corner:?}"
                                ));
                            };
                            let n = defined[kind];
                            let ok = if x > 0 { x <= n } else { x < 0 && -x <= n };
                            if !ok {
                                return Err(format!("line {line}: {what} index {x} out of range ({n} defined so far)"));
                            }
                        }
                    }
                }
                _ => {}
            }
        }
        // No other error: vertices with and without colours.
        if let Some(&(first, coloured)) = colours.first() {
            if let Some(&(line, c)) = colours.iter().find(|x| x.1 != coloured) {
                let (this, that) = if c { ("with a colour", "has none") } else { ("without a colour", "has one") };
                return Err(format!("line {line}: vertex {this}, but the first vertex (line {first}) {that}"));
            }
        }
        Ok(line_elements)
    }

    #[test]
    fn the_check_in_pieces_answers_as_in_one() {
        let path = Path::new("x.obj");
        let message = |r: Result<bool, IoError>| match r {
            Ok(line_elements) => Ok(line_elements),
            Err(IoError::Obj { message, .. }) => Err(message),
            Err(e) => panic!("{e:?}"),
        };
        let (mut errors, mut oks, mut late, mut with_lines) = (0, 0, 0, 0);
        for seed in 0..300u64 {
            let text = random_obj(seed, 20 + (seed as usize % 7) * 30);
            let whole = message(check_lines_in(path, text.as_bytes(), usize::MAX));
            assert_eq!(whole, oracle(&text), "seed {seed}");
            match &whole {
                Err(m) => {
                    errors += 1;
                    // An error past the first piece of the smallest size: the counts before a piece matter.
                    let line: usize = m.trim_start_matches("line ").split(':').next().unwrap().parse().unwrap();
                    late += usize::from(line > 70);
                }
                Ok(l) => {
                    oks += 1;
                    with_lines += usize::from(*l);
                }
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
        assert!(
            errors > 50 && oks > 20 && late > 30 && with_lines > 5 && with_lines < oks,
            "{errors} errors ({late} late), {oks} clean ({with_lines} with line elements)"
        );
    }
}
