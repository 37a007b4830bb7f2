//! Wavefront OBJ + MTL import: the OBJ's lines checked here ([`check_lines`]), its geometry read
//! by [`crate::obj_parse`] into tobj's structs exactly as `tobj` 4.0.5 reads it (one vertex per
//! distinct position / UV / normal corner; faces as they are, not triangulated), the MTL files
//! by `tobj::load_mtl_buf`; polygons triangulated by [`crate::polygon`] (tobj would fan them,
//! covering area outside a concave one). "tobj" below means tobj 4.0.5's reading of the OBJ
//! text, which [`crate::obj_parse`] reproduces: the check and the rewrite ([`tobj_text`]) are
//! written against it.

use std::cell::RefCell;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

use glam::Vec3;
use spherebake_geom::{Material, Mesh, TextureRef, UvTransform, NO_UV};

use crate::obj_parse::{words, Words};
use crate::polygon::{How, Triangulator, MAX_EAR_CLIP_CORNERS};
use crate::texture::{
    decode_mask, decode_srgb_texture, srgb_to_linear, DecodeBudget, Mask, MaskChannel, TexelBudget, OVER_DECODE_BUDGET,
};
use crate::{Ctx, ImportedPart, IoError, ReadLimit, MAX_IMAGE_BYTES, MAX_MTL_BYTES};

/// An MTL file tobj asked for: (resolved path, bytes or the read error, the parse error).
type MtlRead = (PathBuf, Result<Vec<u8>, IoError>, Option<String>);

/// Checks what tobj reports without a line number (or not at all): faces with fewer than three
/// vertices and line elements (`l`) with none, vertex / texture / normal indices out of range
/// in either (normal indices in a file without `vn` lines are not read: [`Rewrite::unread_normals`]), face corners with more than three indices, `v` lines that are not x y z,
/// x y z w (w finite, not 0) or x y z + three values, or whose position is not finite in f32
/// (`1e39`, or divided by a tiny w), `vt` lines without a number u or with a second word that is
/// not a number v (`vt u` is read with v = 0, as Blender reads it), `vn` lines without three,
/// `usemtl` or `mtllib` without a name. Errors name the line (1-based; a continued
/// line by its first line, see [`logical_lines`]). tobj is then given the text as checked
/// ([`tobj_text`]), rewritten where the returned [`Rewrite`] says so.
///
/// A large file is checked in pieces in parallel (rayon; a quarter of a 43 MB OBJ's import
/// was this check, serial): the text is cut at line ends that do not continue a line, and each
/// piece is checked once from its own start ([`check_piece`]), keeping its lines and `v` /
/// `vt` / `vn` counts and the face indices that need definitions before it. Then, in file
/// order with the counts of the pieces before, the first error is found: the one-piece check's
/// answer for any thread count and any cut.
///
/// `text` is the file read as UTF-8, invalid bytes replaced ([`utf8_lossy`]).
fn check_lines(path: &Path, text: &str) -> Result<Rewrite, IoError> {
    check_lines_in(path, text, CHECK_PIECE_BYTES)
}

/// What of the checked text tobj must not read as it is ([`tobj_text`]), and the material
/// names it uses.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
struct Rewrite {
    /// A data line (`v`, `vt`, `vn`, `f`, `l`) with a `#` comment, a continued line, an `l`
    /// line, a `vt` line with one number (the OBJ specification's `vt u [v] [w]`; tobj needs
    /// two), or a `usemtl` or `mtllib` line whose name tobj would read otherwise (it takes the
    /// text after the line's first space: a tab or a leading space gave another name).
    lines: bool,
    /// Vertex colours on some `v` lines only, or three values after x y z that are not all
    /// numbers: tobj gives vertex i the i-th colour read, so it would fail on a later vertex
    /// or shift them. It is given every `v` line with a colour instead, white (1 1 1) where
    /// there is none or it is not three numbers ([`tobj_text`]).
    colours: bool,
    /// Faces name normals (`f 1//1 2//2 3//3`) but the file has no `vn` line: the indices are
    /// not read (tobj reads no normal when there are none), and the normals are computed, as
    /// Blender does (its bug T98782: such files are written by some exporters); one warning.
    /// With some `vn` lines, a normal index out of range stays an error.
    unread_normals: bool,
    /// A `usemtl` line comes before an `mtllib` line: tobj looks a name up in the libraries
    /// read so far, so it is given every `mtllib` line first ([`tobj_text`]), and each name is
    /// looked up in all the file's libraries, as Blender does (it reads them after the OBJ).
    libraries_first: bool,
    /// The distinct `usemtl` names as tobj is given them, in the order of their first use: a
    /// name no library defines gets the default material, with a warning.
    usemtl: Vec<String>,
}

/// Bytes per piece of [`check_lines`] (at least).
const CHECK_PIECE_BYTES: usize = 1 << 20;

/// [`check_lines`] with pieces of at least `piece` bytes.
fn check_lines_in(path: &Path, text: &str, piece: usize) -> Result<Rewrite, IoError> {
    use rayon::prelude::*;
    let checks: Vec<PieceCheck> = split_pieces(text, piece).par_iter().map(|p| check_piece(p)).collect();
    // In file order, with the counts before each piece: the first index that needs more
    // definitions than there were, else the piece's own error.
    let mut before = Counts::default();
    let err = |line: usize, message: String| {
        Err(IoError::Obj { path: path.to_path_buf(), message: format!("line {line}: {message}") })
    };
    let (mut coloured, mut plain) = (0usize, 0usize);
    let mut rewrite = Rewrite::default();
    // Every piece's names, in file order, an `mtllib` in an earlier piece counting as before.
    let mut usemtl = UsemtlNames::default();
    // An `mtllib` line so far.
    let mut mtllib = false;
    // Whether the file has no `vn` line: found when a normal index is first out of range.
    let mut no_normals = None;
    for c in checks {
        let defined = [before.v, before.vt, before.vn];
        let mut out_of_range = c.needs.iter().filter(|n| defined[n.kind] < n.need);
        // Normal indices in a file without normals are not read ([`Rewrite::unread_normals`]).
        let first = out_of_range.find(|n| {
            let unread = n.kind == 2 && *no_normals.get_or_insert_with(|| !has_normals(text));
            rewrite.unread_normals |= unread;
            !unread
        });
        if let Some(n) = first {
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
        coloured += c.coloured;
        plain += c.plain;
        rewrite.lines |= c.rewrite_lines;
        rewrite.colours |= c.bad_colour;
        rewrite.libraries_first |= c.usemtl.unlibraried && !mtllib;
        mtllib |= c.usemtl.mtllib;
        for name in c.usemtl.names {
            usemtl.add(name);
        }
        before = Counts {
            lines: before.lines + c.counts.lines,
            v: before.v + c.counts.v,
            vt: before.vt + c.counts.vt,
            vn: before.vn + c.counts.vn,
        };
    }
    rewrite.colours |= coloured > 0 && plain > 0;
    // Libraries come first only when there are some.
    rewrite.libraries_first &= mtllib;
    rewrite.usemtl = usemtl.names;
    Ok(rewrite)
}

/// Whether `text` has a `vn` line (a logical line, comment removed: [`logical_lines`]).
fn has_normals(text: &str) -> bool {
    // No "vn" anywhere is no `vn` line (one fast search); else the lines are read.
    text.contains("vn")
        && logical_lines(
            text,
            |_, line, _| if keyword(line).0 == Some("vn") { Err((0, String::new())) } else { Ok(()) },
        )
        .is_err()
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
    /// `v` lines with three values after x y z, and with none or a weight.
    coloured: usize,
    plain: usize,
    /// A `v` line's three values after x y z are not all numbers.
    bad_colour: bool,
    /// [`Rewrite::lines`] for the piece.
    rewrite_lines: bool,
    /// [`Rewrite::usemtl`] for the piece, counting from its start.
    usemtl: UsemtlNames,
}

/// The distinct `usemtl` names of a piece in the order of first use, whether the piece has an
/// `mtllib` line, and whether a `usemtl` line comes before its first.
#[derive(Debug, Default)]
struct UsemtlNames {
    names: Vec<String>,
    seen: std::collections::HashSet<String>,
    mtllib: bool,
    unlibraried: bool,
}

impl UsemtlNames {
    /// Adds `name` unless already listed.
    fn add(&mut self, name: String) {
        if self.seen.insert(name.clone()) {
            self.names.push(name);
        }
    }
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
/// line with its continued lines joined by spaces, whether it was joined), comments not yet
/// removed; stops at `f`'s first error. Returns the piece's physical line count.
///
/// A line ending in `\` continues on the next only when it is a data line (`v`, `vt`, `vn`,
/// `f`, `l`) and has no `#` so far: a comment's `\` (`# exported from C:\work\`) and the end
/// of a name (`o name \`) are text, as tobj reads them, not a join that would swallow the
/// next line. A data line continued into the end of the file ends there.
fn logical_lines(
    text: &str,
    mut f: impl FnMut(usize, &str, bool) -> Result<(), (usize, String)>,
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
            // `joined`, when not empty, is a data line without `#` already.
            let data = !joined.is_empty() || is_data(keyword(head).0);
            if data && !head.contains('#') {
                joined.push_str(head);
                joined.push(' ');
                continue;
            }
        }
        // A continued line is joined into `whole`; every other line is read in place (no
        // allocation per line: this check was a quarter of a 43 MB OBJ's import).
        if joined.is_empty() {
            f(start, raw, false)?;
        } else {
            joined.push_str(raw);
            let whole = std::mem::take(&mut joined);
            f(start, &whole, true)?;
        }
    }
    if !joined.is_empty() {
        f(start, &joined, true)?;
    }
    Ok(n)
}

/// Whether a keyword starts a data line (one that may be continued and whose `#` starts a
/// comment for tobj too, once [`tobj_text`] has cut it).
fn is_data(key: Option<&str>) -> bool {
    matches!(key, Some("v" | "vt" | "vn" | "f" | "l"))
}

/// The name of a `usemtl` or `mtllib` line (`key`) as this importer means it (the text after
/// the keyword, trimmed), and as tobj 4.0.5 reads it (after the line's first space, trimmed).
fn names<'a>(line: &'a str, key: &str) -> (&'a str, &'a str) {
    let ours = line.trim_start().get(key.len()..).unwrap_or("").trim();
    (ours, crate::obj_parse::after_first_space(line))
}

/// The keyword of a logical line (comment removed) and its other tokens.
fn keyword(line: &str) -> (Option<&str>, Words<'_>) {
    let mut tok = words(line.split('#').next().unwrap_or(""));
    (tok.next(), tok)
}

/// Checks one piece on its own (see [`PieceCheck`]).
fn check_piece(text: &str) -> PieceCheck {
    let mut out = PieceCheck::default();
    let (mut counts, mut most) = (Counts::default(), [0i64; 3]);
    // The `#` of the piece in the lines not yet read (each physical line is in one logical
    // line): once none is left, a line is not searched for one (a search per line was 6 % of
    // a 2.4 MB OBJ's check, whose comments are at its start).
    let mut hashes = text.matches('#').count();
    let lines = logical_lines(text, |i, line, joined| {
        let at = i + 1;
        // At most one search for `#` per line (a second cost a 43 MB OBJ 90 ms).
        let found = if hashes > 0 { line.split_once('#') } else { None };
        let (body, commented) = match found {
            Some((body, _)) => {
                hashes = hashes.saturating_sub(line.matches('#').count());
                (body, true)
            }
            None => (line, false),
        };
        let mut tok = words(body);
        let key = tok.next();
        out.rewrite_lines |= joined || (commented && is_data(key));
        match key {
            Some("v") => {
                match vertex_values(tok).map_err(|m| (at, m))? {
                    Vertex::Plain => out.plain += 1,
                    Vertex::Coloured => out.coloured += 1,
                    Vertex::BadColour => {
                        out.coloured += 1;
                        out.bad_colour = true;
                    }
                }
                counts.v += 1;
            }
            Some(kw @ ("usemtl" | "mtllib")) => match names(line, kw) {
                ("", _) if kw == "usemtl" => return Err((at, "usemtl without a material name".into())),
                ("", _) => return Err((at, "mtllib without a file name".into())),
                (ours, theirs) => {
                    out.rewrite_lines |= ours != theirs;
                    let u = &mut out.usemtl;
                    if kw == "mtllib" {
                        u.mtllib = true;
                    } else {
                        u.unlibraried |= !u.mtllib;
                        u.add(ours.to_string());
                    }
                }
            },
            Some("vt") => {
                // `vt u [v [w]]`: u, and v when given, are numbers; further words are not read.
                let (u, v) = (tok.next(), tok.next());
                if u.is_none_or(|u| u.parse::<f32>().is_err()) || v.is_some_and(|v| v.parse::<f32>().is_err()) {
                    return Err((at, "texture coordinate needs one or two numbers (u [v])".into()));
                }
                // tobj needs two: `vt u` is given to it as `vt u 0` ([`tobj_text`]).
                out.rewrite_lines |= v.is_none();
                counts.vt += 1;
            }
            Some("vn") => {
                if tok.take(3).filter(|t| t.parse::<f32>().is_ok()).count() != 3 {
                    return Err((at, "normal needs three numbers".into()));
                }
                counts.vn += 1;
            }
            Some(kw @ ("f" | "l")) => {
                // Too few corners is the line's error before any of its corners' (so what its
                // corners added to `needs` is taken back then). The corners are read in one
                // pass and counted as they go: counting them first tokenised each face twice.
                let few = |corners: usize| match corners {
                    n if kw == "f" && n < 3 => Some(format!("face with {n} vertices (a face needs at least 3)")),
                    0 => Some("line element with no vertex".to_string()),
                    _ => None,
                };
                let needs_before = out.needs.len();
                let mut corners = 0;
                while let Some(c) = tok.next() {
                    corners += 1;
                    let local = [counts.v, counts.vt, counts.vn];
                    if let Some(message) = check_corner(c, local, &mut most, at, &mut out.needs) {
                        // Unless the line has too few corners (below), this is its error.
                        corners += tok.by_ref().count();
                        if few(corners).is_none() {
                            return Err((at, message));
                        }
                    }
                }
                if let Some(message) = few(corners) {
                    out.needs.truncate(needs_before);
                    return Err((at, message));
                }
                out.rewrite_lines |= kw == "l";
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

/// Checks a face corner `c` (`v`, `v/vt`, `v//vn`, `v/vt/vn`) of line `at` of a piece with
/// `local` definitions (v, vt, vn) in the piece before it: each index is a number, valid when
/// at least `need` definitions of its kind come before the piece; one needing more than every
/// earlier one of its kind (`most`) is appended to `needs`. Returns the corner's error.
fn check_corner(c: &str, local: [i64; 3], most: &mut [i64; 3], at: usize, needs: &mut Vec<Need>) -> Option<String> {
    for (kind, slot) in slots(c).enumerate() {
        if kind >= 3 && !slot.is_empty() {
            return Some(format!("face corner {c:?} has more than three indices"));
        }
        if kind >= 3 || (slot.is_empty() && kind > 0) {
            continue;
        }
        let what = ["vertex", "texture", "normal"][kind];
        let Ok(x) = slot.parse::<i64>() else {
            return Some(format!("bad {what} index {slot:?} in face corner {c:?}"));
        };
        // Valid when 1 ≤ resolved ≤ defined, defined = before + local: x ≤ defined for x > 0,
        // −x ≤ defined for x < 0; never for 0.
        let local = local[kind];
        let need = if x == 0 { i64::MAX } else { x.unsigned_abs().min(i64::MAX as u64) as i64 - local };
        if need > most[kind] {
            most[kind] = need;
            needs.push(Need { line: at, kind, index: x, local, need });
        }
    }
    None
}

/// The `/`-separated slots of a face corner, as `str::split('/')` gives them, found by a byte
/// search (`/` is ASCII; `split`'s char searcher cost more per corner than the search).
fn slots(corner: &str) -> impl Iterator<Item = &str> {
    let mut rest = Some(corner);
    std::iter::from_fn(move || {
        let r = rest?;
        match r.bytes().position(|b| b == b'/') {
            Some(i) => {
                rest = r.get(i + 1..);
                r.get(..i)
            }
            None => {
                rest = None;
                Some(r)
            }
        }
    })
}

/// A `v` line's kind ([`vertex_values`]).
enum Vertex {
    /// x y z, or x y z w.
    Plain,
    /// x y z r g b.
    Coloured,
    /// x y z and three values that are not all numbers (tobj keeps the numbers before the
    /// first that is not one, shifting the next vertices' colours).
    BadColour,
}

/// Checks a `v` line's values (after the keyword) as tobj reads them: x y z, then nothing, a
/// weight w (a finite number, not 0: tobj divides by it) or three colour values.
fn vertex_values(tok: Words<'_>) -> Result<Vertex, String> {
    // No allocation per line (a large OBJ has millions of `v` lines).
    let mut values = [""; 8];
    let mut len = 0;
    for (slot, t) in values.iter_mut().zip(tok) {
        *slot = t;
        len += 1;
    }
    let mut xyz = [0.0f32; 3];
    if len < 3 || xyz.iter_mut().zip(&values).any(|(x, t)| t.parse().map(|v| *x = v).is_err()) {
        return Err("vertex needs three numbers".into());
    }
    // The position tobj stores: x y z, divided by w when there is one.
    let weight = (len == 4).then(|| values[3].parse::<f32>());
    let w = weight.clone().and_then(Result::ok).unwrap_or(1.0);
    if w != 0.0 && w.is_finite() && xyz.iter().any(|x| !(x / w).is_finite()) {
        let w = if len == 4 { format!(" / {}", values[3]) } else { String::new() };
        return Err(format!("vertex position ({} {} {}){w} is not finite in f32", values[0], values[1], values[2]));
    }
    match (len, weight) {
        (3, _) => Ok(Vertex::Plain),
        (6, _) if values[3..6].iter().all(|t| t.parse::<f32>().is_ok()) => Ok(Vertex::Coloured),
        (6, _) => Ok(Vertex::BadColour),
        (_, Some(weight)) => match weight {
            Ok(w) if w != 0.0 && w.is_finite() => Ok(Vertex::Plain),
            Ok(w) => Err(format!("vertex weight w is {w} (a weight must be finite and not 0)")),
            Err(_) => Err(format!("vertex weight {:?} is not a number", values[3])),
        },
        (n, None) => Err(format!(
            "vertex with {} values (expected x y z, x y z w or x y z r g b)",
            if n > 7 { "more than 7".to_string() } else { n.to_string() }
        )),
    }
}

/// The text tobj reads: the file as checked by [`check_lines`], so each of tobj's line errors
/// (which name no line) is found by the check first. tobj 4.0.5 reads each physical line on
/// its own, takes no comment after data, reads an `l` line of three or more vertices as a face
/// (and, triangulating, one of two as a zero-area triangle that makes a closed mesh
/// non-manifold), takes a `usemtl` name after the line's first space, and misplaces vertex
/// colours given on some vertices only. `text` is already valid UTF-8 ([`utf8_lossy`]). When
/// `rewrite` says so, tobj is given the text with: each continued line joined
/// ([`logical_lines`]; then as many empty lines as it had physical lines after its first, so
/// the line count stays), the `v`, `vt`, `vn` and `f` lines ended at `#`, the `l` lines empty,
/// `usemtl` and `mtllib` lines as `KEYWORD NAME`, a `vt u` line as `vt u 0`, and, for
/// [`Rewrite::colours`], every `v` line as x y z r g b: its position (x y z divided by w as
/// tobj divides it, in f32, written so it reads back to the same value) and its colour, or
/// white. For [`Rewrite::libraries_first`],
/// the `mtllib` lines are moved to the start, in their order (the text has as many more lines
/// as they are). Other lines are kept as they are (a name may hold `#`). Else it is `text` itself:
/// the check found nothing to rewrite (a file's `#` header lines alone are read by tobj
/// as comments).
fn tobj_text<'a>(text: &'a str, rewrite: &Rewrite) -> std::borrow::Cow<'a, str> {
    if !rewrite.lines && !rewrite.colours && !rewrite.libraries_first {
        return std::borrow::Cow::Borrowed(text);
    }
    let mut out = String::with_capacity(text.len());
    if rewrite.libraries_first {
        // The callback never fails.
        let _ = logical_lines(text, |_, line, _| {
            if keyword(line).0 == Some("mtllib") {
                out.push_str("mtllib ");
                out.push_str(names(line, "mtllib").0);
                out.push('\n');
            }
            Ok(())
        });
    }
    let mut written = 0usize;
    let pad = |out: &mut String, written: &mut usize, to: usize| {
        while *written < to {
            out.push('\n');
            *written += 1;
        }
    };
    let n = logical_lines(text, |start, line, _| {
        pad(&mut out, &mut written, start);
        let (key, tok) = keyword(line);
        match key {
            Some("l") => {}
            Some("v") if rewrite.colours => {
                // The check has made sure of x y z, x y z w (w finite, not 0, x / w finite) or
                // x y z c c c.
                let values: Vec<&str> = tok.take(7).collect();
                out.push('v');
                if let [x, y, z, w] = values[..] {
                    let w: f32 = w.parse().unwrap_or(1.0);
                    for x in [x, y, z] {
                        // `Display` of an f32 is the shortest text that reads back to it.
                        out.push_str(&format!(" {}", x.parse::<f32>().unwrap_or(0.0) / w));
                    }
                } else {
                    for v in values.iter().take(3) {
                        out.push(' ');
                        out.push_str(v);
                    }
                }
                match &values[..] {
                    [_, _, _, c @ ..] if c.len() == 3 && c.iter().all(|t| t.parse::<f32>().is_ok()) => {
                        for v in c {
                            out.push(' ');
                            out.push_str(v);
                        }
                    }
                    _ => out.push_str(" 1 1 1"),
                }
            }
            Some("mtllib") if rewrite.libraries_first => {}
            Some(kw @ ("usemtl" | "mtllib")) => {
                out.push_str(kw);
                out.push(' ');
                out.push_str(names(line, kw).0);
            }
            // `vt u`: v is 0, as Blender reads it (the check has made sure u is a number).
            Some("vt") if tok.clone().nth(1).is_none() => {
                out.push_str("vt ");
                out.push_str(tok.clone().next().unwrap_or("0"));
                out.push_str(" 0");
            }
            k if is_data(k) => out.push_str(line.split('#').next().unwrap_or("")),
            _ => out.push_str(line),
        }
        out.push('\n');
        written = start + 1;
        Ok(())
    });
    // The callback never fails.
    let n = n.unwrap_or(0);
    pad(&mut out, &mut written, n);
    std::borrow::Cow::Owned(out)
}

/// The faces of a tobj mesh as [`crate::obj_parse::load_obj`] reads them (not triangulated):
/// each face's corners (indices into its vertices). `face_arities` is empty when every face is
/// a triangle.
fn faces(m: &tobj::Mesh) -> impl Iterator<Item = &[u32]> {
    let mut rest = m.indices.as_slice();
    let mut arities = m.face_arities.iter();
    std::iter::from_fn(move || {
        let k = if m.face_arities.is_empty() { 3 } else { *arities.next()? as usize };
        if rest.len() < k || k == 0 {
            return None;
        }
        let (face, after) = rest.split_at(k);
        rest = after;
        Some(face)
    })
}

/// `String::from_utf8_lossy`, with the common case (valid UTF-8) checked by the faster
/// `str::from_utf8` first (the lossy decoder's walk cost a 43 MB OBJ 60 ms).
fn utf8_lossy(bytes: &[u8]) -> std::borrow::Cow<'_, str> {
    match std::str::from_utf8(bytes) {
        Ok(s) => std::borrow::Cow::Borrowed(s),
        Err(_) => String::from_utf8_lossy(bytes),
    }
}

/// An OBJ or MTL file as text ([`utf8_lossy`]) without a leading byte-order mark, which would
/// otherwise be read as part of the first keyword (a first `v` or `mtllib` line lost), and
/// with classic Mac OS line ends (a `\r` not followed by `\n`) read as line ends, as Python's
/// universal newlines read them: tobj and the line check split lines at `\n` only, so such a
/// file was one line, refused with a misleading error ("vertex with more than 7 values"), and
/// such an MTL one material with a name no `usemtl` matched. Files without a lone `\r` are
/// returned as they are.
fn text_of(bytes: &[u8]) -> std::borrow::Cow<'_, str> {
    const BOM: &[u8] = b"\xEF\xBB\xBF";
    let text = utf8_lossy(bytes.strip_prefix(BOM).unwrap_or(bytes));
    // Only the `\r` are visited (a memchr search): a LF or CRLF file costs one fast scan.
    let b = text.as_bytes();
    let lone = |i: usize| b.get(i + 1) != Some(&b'\n');
    if !text.match_indices('\r').any(|(i, _)| lone(i)) {
        return text;
    }
    // One copy: a lone `\r` becomes `\n`, the `\r` of `\r\n` is dropped (one line end, so the
    // line count is what an editor shows).
    let mut out = String::with_capacity(text.len());
    let mut last = 0;
    for (i, _) in text.match_indices('\r') {
        out.push_str(&text[last..i]);
        if lone(i) {
            out.push('\n');
        }
        last = i + 1;
    }
    out.push_str(&text[last..]);
    std::borrow::Cow::Owned(out)
}

/// Whether every `Ka` / `Kd` / `Ks` / `Ke` line of an MTL file has three numbers (tobj takes
/// the first three and panics when there are fewer).
fn mtl_colours_ok(bytes: &[u8]) -> bool {
    text_of(bytes).lines().all(|line| {
        let mut tok = line.split_whitespace();
        match tok.next() {
            Some("Ka" | "Kd" | "Ks" | "Ke") => tok.take(3).filter(|t| t.parse::<f32>().is_ok()).count() == 3,
            _ => true,
        }
    })
}

/// Why `bytes` are plainly not OBJ text: a UTF-16 byte-order mark, or a NUL byte in the first
/// KiB (UTF-16 text without a mark has one in each ASCII character, a binary file some). Read
/// as UTF-8 they gave no line and were refused as "no triangles to import". Bytes that are
/// merely not UTF-8 (a Latin-1 comment or name) are read as U+FFFD ([`utf8_lossy`]), and said
/// to be no UTF-8 text only when they then give no triangle ([`import`]).
fn not_text(bytes: &[u8]) -> Option<String> {
    match bytes {
        [0xFF, 0xFE, ..] => return Some("it starts with a UTF-16 little-endian byte-order mark".into()),
        [0xFE, 0xFF, ..] => return Some("it starts with a UTF-16 big-endian byte-order mark".into()),
        _ => {}
    }
    let first = &bytes[..bytes.len().min(1024)];
    let nul = first.iter().position(|&b| b == 0)?;
    Some(format!("a NUL byte at offset {nul}: UTF-16 or binary"))
}

pub(crate) fn import(ctx: &mut Ctx, bytes: &[u8]) -> Result<(Mesh, Vec<ImportedPart>), IoError> {
    let path = ctx.path.clone();
    if let Some(why) = not_text(bytes) {
        return Err(IoError::NotText { path, why });
    }
    let text = text_of(bytes);
    let rewrite = check_lines(&path, &text)?;
    if rewrite.unread_normals {
        ctx.warn(String::from(
            "faces name normals (f v//vn) but the file defines no vn; the normal indices are ignored and the normals computed from the faces"
        ));
    }
    // MTL files read by tobj's callback: (resolved path, bytes or the read error).
    let mtl_reads: RefCell<Vec<MtlRead>> = RefCell::new(Vec::new());
    // The folder of each library tobj appends materials from, with their count, in order: a
    // material's texture paths are relative to the library that defines it.
    let libraries: RefCell<Vec<(PathBuf, usize)>> = RefCell::new(Vec::new());
    let dir = ctx.dir.clone();
    let (model, opts_in, resolver) = (ctx.path.clone(), ctx.opts, ctx.resolver.clone());
    let budget = RefCell::new(opts_in.max_input_bytes.saturating_sub(ctx.read_total));
    let text = tobj_text(&text, &rewrite);
    // Reads the library `name` (relative to the model's folder): its path and bytes.
    let read = |name: &str| {
        let full = dir.join(name);
        let limit = ReadLimit::AtMost(MAX_MTL_BYTES);
        let read =
            crate::read_confined(&model, &dir, &opts_in, name, &full, *budget.borrow(), limit, resolver.as_deref());
        if let Ok(b) = &read {
            let mut left = budget.borrow_mut();
            *left = left.saturating_sub(b.len() as u64);
        }
        (full, read)
    };
    // Parses a library read, noting it in `mtl_reads` (and `libraries`).
    let parse = |(full, read): (PathBuf, Result<Vec<u8>, IoError>)| {
        let result = match &read {
            // tobj 4.0.5 panics on `Kd` (Ka, Ks, Ke) with fewer than three numbers (found by the
            // obj fuzz target): such a library is a parse error here instead.
            Ok(b) if !mtl_colours_ok(b) => Err(tobj::LoadError::MaterialParseError),
            // Bytes that are not UTF-8 (a Latin-1 material name) are read as U+FFFD, as in the OBJ.
            Ok(b) => tobj::load_mtl_buf(&mut std::io::Cursor::new(text_of(b).as_bytes())),
            Err(_) => Err(tobj::LoadError::OpenFileFailed),
        };
        let parse_error = match (&read, &result) {
            (Ok(_), Err(e)) => Some(e.to_string()),
            _ => None,
        };
        if let Ok((m, _)) = &result {
            libraries.borrow_mut().push((full.parent().map(Path::to_path_buf).unwrap_or_default(), m.len()));
        }
        mtl_reads.borrow_mut().push((full, read, parse_error));
        result
    };
    let obj = crate::obj_parse::load_obj(&text, |p: &Path| {
        // tobj gives the `mtllib` line's text after the keyword ([`tobj_text`]). One statement may
        // name several libraries (`mtllib a.mtl b.mtl`), but a file whose name has spaces
        // (`mtllib my lib.mtl`) is read whole when there is one, and a name in double quotes
        // (`mtllib "my lib.mtl"`, as some exporters write one with spaces) is one file. A
        // Windows path's `\` is a folder separator (`mtllib mats\m.mtl`), as in `map_Kd`.
        let given = p.to_string_lossy().replace('\\', "/");
        let quoted = unquoted(&given);
        let name = quoted.unwrap_or(&given);
        let whole = read(name);
        let several = quoted.is_none() && name.split_whitespace().nth(1).is_some();
        if !several || !matches!(whole.1, Err(IoError::ReferenceNotFound { .. })) {
            return parse(whole);
        }
        // Each library's materials after the last's, as tobj merges those of `mtllib` lines: a
        // name defined twice is the later one; the error of the last library that failed when
        // none read.
        let mut merged: Option<(Vec<tobj::Material>, HashMap<String, usize>)> = None;
        let mut error = tobj::LoadError::OpenFileFailed;
        for one in name.split_whitespace() {
            match parse(read(one)) {
                Ok((mut materials, names)) => {
                    let (all, index) = merged.get_or_insert_with(Default::default);
                    let offset = all.len();
                    all.append(&mut materials);
                    index.extend(names.into_iter().map(|(k, i)| (k, i + offset)));
                }
                Err(e) => error = e,
            }
        }
        merged.ok_or(error)
    })
    .map_err(|e| IoError::Obj { path: path.clone(), message: e.to_string() })?;
    let (models, materials, uv_named, smoothing) = (obj.models, obj.materials, obj.uv_named, obj.smoothing);
    let mut library_failed = materials.is_err();
    for (p, read, parse_error) in mtl_reads.into_inner() {
        match read {
            Ok(b) => {
                ctx.record(&p, &b);
                // When another library was read, tobj drops this one's error: said here (when
                // none was, tobj's error is, below).
                if let (Some(e), Ok(_)) = (parse_error, &materials) {
                    library_failed = true;
                    ctx.warn(format!(
                        "{}: cannot parse material library: {e}; its materials are the default",
                        p.display()
                    ));
                }
            }
            Err(e) if e.is_refusal() => return Err(e),
            Err(e) => {
                library_failed = true;
                // A library that does not exist yet is still a dependency (`Imported::missing`).
                if matches!(e, IoError::ReferenceNotFound { .. }) && !ctx.missing.contains(&p) {
                    ctx.missing.push(p.clone());
                }
                ctx.warn(format!("material library: {e}; using default materials"))
            }
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
    // Material i's library folder: tobj appends each library's materials in the order read, so
    // it is that of the first library whose materials end past i.
    let mut libraries = libraries.into_inner();
    let mut end = 0;
    for (_, k) in &mut libraries {
        end += *k;
        *k = end;
    }
    let mtl_dir_of = |i: usize| libraries.get(libraries.partition_point(|(_, end)| *end <= i)).map(|(d, _)| d);
    // A `usemtl` name that no library defines (a typo, another case, a library not shipped)
    // gets the default material: said once, naming the first in the file, unless a library
    // could not be read at all (warned about above).
    if !library_failed {
        let defined: std::collections::HashSet<&str> = materials.iter().map(|m| m.name.as_str()).collect();
        let unknown: Vec<&str> =
            rewrite.usemtl.iter().map(String::as_str).filter(|name| !defined.contains(name)).collect();
        if let Some(first) = unknown.first() {
            let more = match unknown.len() {
                1 => String::new(),
                n => format!(" (and {} more)", n - 1),
            };
            ctx.warn(format!("usemtl {first:?}{more}: no material library defines it; using the default material"));
        }
    }

    let mut mesh = Mesh::default();
    let mut material_map: HashMap<Option<usize>, u32> = HashMap::new();
    let mut texture_map = ObjTextures {
        colour: HashMap::new(),
        cut: HashMap::new(),
        counted: Default::default(),
        budget: TexelBudget::new(ctx.opts.max_texels),
        decode: DecodeBudget::new(ctx.opts.max_decoded_pixels, ctx.opts.max_input_bytes),
        refused: None,
    };
    let mut parts = Vec::new();
    let mut has_uv = false;
    let mut uvs = Vec::new();
    // OBJ vertex colours (`v x y z r g b`, as scanners and Blender write them): sRGB, read as
    // Blender's importer reads them (it converts them to linear, `srgb_to_linearrgb`, into a
    // float colour attribute), alpha 1; a vertex without one is white (the rewrite gives it
    // 1 1 1: [`Rewrite::colours`]). Values outside [0, 1] are clamped after, with a warning
    // (`clamp_colours`: the conversion keeps 0 and 1, so that is clamping the sRGB values).
    // Only a file with colours has them.
    let coloured = models.iter().any(|m| !m.mesh.vertex_color.is_empty());
    let mut colours: Vec<[f32; 4]> = Vec::new();
    let mut mixed_vt: Vec<&str> = Vec::new();
    let mut mixed_vn: Vec<&str> = Vec::new();
    let mut triangulator = Triangulator::default();
    let mut repeated = RepeatedPolygons::new(&models);
    let mut fanned = Fanned::default();
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
        if let Some((position, &i)) = m.indices.iter().enumerate().find(|(_, &i)| i as usize >= n) {
            return Err(IoError::IndexOutOfRange {
                path,
                mesh: mi,
                primitive: 0,
                position,
                index: u64::from(i),
                vertex_count: n,
            });
        }
        // n − 2 triangles per face of n corners.
        let faces_n = if m.face_arities.is_empty() { m.indices.len() / 3 } else { m.face_arities.len() };
        let mut tris = Vec::with_capacity(m.indices.len().saturating_sub(2 * faces_n));
        // Each triangle's smoothing group (`s`), when the file has any.
        let face_groups = smoothing.get(mi).map_or(&[][..], Vec::as_slice);
        let mut tri_groups: Vec<u32> = Vec::new();
        for (fi, face) in faces(m).enumerate() {
            let mirrored = repeated.mirror(&positions, face, &mut tris);
            if let Some(&g) = face_groups.get(fi) {
                tri_groups.resize(tris.len(), g);
            }
            if mirrored {
                continue;
            }
            let first = tris.len();
            match triangulator.polygon(&positions, face, &mut tris) {
                How::Fan | How::Halves | How::EarClipped => {}
                How::FanOverCap => fanned.over_cap += 1,
                How::FanNoEar => fanned.no_ear += 1,
            }
            if let Some(&g) = face_groups.get(fi) {
                tri_groups.resize(tris.len(), g);
            }
            repeated.remember(&positions, face, &tris[first..]);
            if fanned.first.is_none() && fanned.over_cap + fanned.no_ear > 0 {
                fanned.first = Some(model.name.as_str());
            }
        }
        // OBJ v runs bottom-up; glTF convention (row 0 = top) needs v' = 1 - v. A vertex
        // without a texture coordinate holds NO_UV (a textured material shows its Kd there).
        let flip = |c: &[f32]| [c[0], 1.0 - c[1]];
        let named = uv_named.get(mi).map_or(&[][..], Vec::as_slice);
        let group_uvs: Vec<[f32; 2]> = if !named.is_empty() {
            // Faces with and without `vt` in one group: the corners without have no UV, the
            // others keep theirs. One warning for all groups.
            mixed_vt.push(model.name.as_str());
            has_uv = true;
            let mut t = m.texcoords.chunks_exact(2);
            named.iter().map(|&k| if k { t.next().map_or(NO_UV, flip) } else { NO_UV }).collect()
        } else if m.texcoords.len() == 2 * n && n > 0 {
            has_uv = true;
            m.texcoords.chunks_exact(2).map(flip).collect()
        } else {
            vec![NO_UV; n]
        };
        let group_colours: Vec<[f32; 4]> = if coloured {
            let srgb = m.vertex_color.chunks_exact(3).take(n);
            let mut c: Vec<[f32; 4]> =
                srgb.map(|c| [srgb_to_linear(c[0]), srgb_to_linear(c[1]), srgb_to_linear(c[2]), 1.0]).collect();
            c.resize(n, [1.0; 4]);
            c
        } else {
            Vec::new()
        };
        // A group without normals (or with some missing) gets them from its faces, smoothed
        // across edges of at most the crease angle and sharp across harder ones; a vertex on a
        // sharp edge is split, its copies keeping its UV and colour
        // (`spherebake_geom::normals::crease_normals`). A `vn` without a direction (`vn 0 0 0`)
        // is no normal (`NO_NORMAL`): it drops out of the interpolation of its triangle's
        // corners, and a triangle with none at any corner shades with its face's normal.
        let has_normals = m.normals.len() == 3 * n && n > 0;
        if !has_normals && !m.normals.is_empty() {
            mixed_vn.push(model.name.as_str());
        }
        let (positions, tris, normals, group_uvs, group_colours) = if has_normals {
            let normals = m
                .normals
                .chunks_exact(3)
                .map(|c| Vec3::new(c[0], c[1], c[2]).try_normalize().unwrap_or(spherebake_geom::normals::NO_NORMAL))
                .collect();
            (positions, tris, normals, group_uvs, group_colours)
        } else {
            let groups = (tri_groups.len() == tris.len() && !tris.is_empty()).then_some(&tri_groups[..]);
            let r = spherebake_geom::normals::crease_normals(&positions, &tris, groups);
            fn gather<T: Copy>(v: &[T], source: &[u32]) -> Vec<T> {
                if v.is_empty() {
                    Vec::new()
                } else {
                    source.iter().map(|&i| v[i as usize]).collect()
                }
            }
            let (p, uv, c) =
                (gather(&positions, &r.source), gather(&group_uvs, &r.source), gather(&group_colours, &r.source));
            (p, r.triangles, r.normals, uv, c)
        };
        let key = m.material_id.filter(|&i| i < materials.len());
        let material = match material_map.get(&key) {
            Some(&id) => id,
            None => {
                let mat = match key {
                    Some(i) => {
                        let mtl_dir = mtl_dir_of(i).unwrap_or(&dir);
                        obj_material(ctx, &materials[i], mtl_dir, &mut mesh, &mut texture_map)
                    }
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
        uvs.extend(group_uvs);
        colours.extend(group_colours);
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
    // "object "a"" or "object "a" (and 2 more)" for the groups named.
    let objects = |names: &[&str]| -> Option<String> {
        let first = names.first()?;
        Some(match names.len() {
            1 => format!("object {first:?}"),
            k => format!("object {first:?} (and {} more)", k - 1),
        })
    };
    if let Some(objects) = objects(&mixed_vn) {
        ctx.warn(format!(
            "{objects}: some faces have no normals (vn); the group's normals are all computed from its faces (60° crease), the vn it gives are not used"
        ));
    }
    if let Some(objects) = objects(&mixed_vt) {
        ctx.warn(format!(
            "{objects}: some faces have no texture coordinates (vt); a texture does not reach them (their material's Kd is used)"
        ));
    }
    if let Some(first) = fanned.first {
        ctx.warn(format!(
            "{} concave polygon(s) triangulated as a fan from the first corner, which may cover area outside them \
             (the first in object {first:?}; {} with more than {MAX_EAR_CLIP_CORNERS} corners, {} self-intersecting \
             or degenerate: no ear to clip)",
            fanned.over_cap + fanned.no_ear,
            fanned.over_cap,
            fanned.no_ear
        ));
    }
    if let Some(w) = texture_map.decode.warning() {
        ctx.warn(w);
    }
    if let Some(w) = texture_map.budget.warning(&mesh.textures) {
        ctx.warn(w);
    }
    if let Some(e) = texture_map.refused {
        return Err(e);
    }
    if coloured {
        mesh.colors_linear = colours;
    }
    // Bytes that are not UTF-8, read as no triangle and with no vertex or face line at all:
    // said so, rather than "no triangles" (a point cloud with a Latin-1 comment is an OBJ
    // without faces, and says that).
    let objish = || {
        bytes
            .split(|&b| b == b'\n')
            .any(|l| l.trim_ascii_start().starts_with(b"v ") || l.trim_ascii_start().starts_with(b"f "))
    };
    if let (true, Err(e)) = (mesh.triangles.is_empty() && !objish(), std::str::from_utf8(bytes)) {
        let at = e.valid_up_to();
        let why = format!("byte 0x{:02x} at offset {at} is not UTF-8", bytes[at]);
        return Err(IoError::NotText { path, why });
    }
    if has_uv {
        mesh.uvs = vec![uvs];
    }
    mesh.rebuild_weld();
    Ok((mesh, parts))
}

/// Polygons of four or more corners given again, in any group of the file, with the same corner
/// positions in the same cyclic order or reversed (a face exported twice, or once per side:
/// `f 1 2 4 3`, then `f 3 4 2 1` or `f 2 4 3 1`), get the first one's triangles (reversed with it),
/// so the duplicate removal finds every copy: triangulated on their own, from their own first
/// corners, the copies of a quad take different diagonals and no triangle repeats (a double-sided
/// quad cube baked as an open sheet, E 53 at 8 spheres instead of 0.90). Memory: a hash per
/// polygon of four or more corners while the file is read, and the corner positions and
/// triangles of the first of each repeated one; corners that repeat a position leave a polygon
/// out.
struct RepeatedPolygons {
    /// Hashes of the sorted corner positions that occur more than once in the file (a first
    /// pass): only such polygons are remembered, so a file of distinct quads costs 16–24 bytes
    /// a quad while it is read, not its polygons.
    candidates: std::collections::HashSet<u64>,
    /// Sorted corner positions (bits) → the first such polygon.
    seen: HashMap<Vec<[u32; 3]>, FirstPolygon>,
}

/// Two lists of corner positions (bits) or triangles (corner numbers): the first polygon of
/// some corner positions is (its corner positions in its order, its triangles).
type FirstPolygon = (Vec<[u32; 3]>, Vec<[u32; 3]>);

impl RepeatedPolygons {
    /// The first pass over every group's faces (corners out of range are left to the import's
    /// own check).
    fn new(models: &[tobj::Model]) -> Self {
        let mut count: HashMap<u64, u8> = HashMap::new();
        for model in models {
            let p = &model.mesh.positions;
            for face in faces(&model.mesh).filter(|f| f.len() >= 4) {
                let corners: Option<Vec<[u32; 3]>> = face
                    .iter()
                    .map(|&v| p.get(3 * v as usize..3 * v as usize + 3).map(|c| [c[0], c[1], c[2]].map(f32::to_bits)))
                    .collect();
                if let Some(mut corners) = corners {
                    corners.sort_unstable();
                    let n = count.entry(Self::hash(&corners)).or_insert(0);
                    *n = n.saturating_add(1);
                }
            }
        }
        let candidates = count.into_iter().filter(|&(_, n)| n > 1).map(|(h, _)| h).collect();
        RepeatedPolygons { candidates, seen: HashMap::new() }
    }

    fn hash(sorted: &[[u32; 3]]) -> u64 {
        use std::hash::{Hash, Hasher};
        let mut h = std::collections::hash_map::DefaultHasher::new();
        sorted.hash(&mut h);
        h.finish()
    }

    /// (sorted corner positions, corner positions in the face's order), as bits; `None` below
    /// four corners, when a position repeats, or when no other polygon of the file may have these
    /// corner positions.
    fn key(&self, positions: &[Vec3], face: &[u32]) -> Option<FirstPolygon> {
        if face.len() < 4 || self.candidates.is_empty() {
            return None;
        }
        let order: Vec<[u32; 3]> = face.iter().map(|&v| positions[v as usize].to_array().map(f32::to_bits)).collect();
        let mut sorted = order.clone();
        sorted.sort_unstable();
        (sorted.windows(2).all(|w| w[0] != w[1]) && self.candidates.contains(&Self::hash(&sorted)))
            .then_some((sorted, order))
    }

    /// Remembers `face`'s triangles `tris` (vertex ids of `face`), unless a polygon with its
    /// corner positions was seen.
    fn remember(&mut self, positions: &[Vec3], face: &[u32], tris: &[[u32; 3]]) {
        let Some((key, order)) = self.key(positions, face) else { return };
        let local = |v: u32| face.iter().position(|&f| f == v).map(|i| i as u32);
        let Some(corners) = tris.iter().map(|t| Some([local(t[0])?, local(t[1])?, local(t[2])?])).collect() else {
            return;
        };
        self.seen.entry(key).or_insert((order, corners));
    }

    /// When `face` repeats a remembered polygon (same cyclic order of positions, or reversed),
    /// appends that polygon's triangles on `face`'s vertices (reversed with it) and returns true.
    fn mirror(&self, positions: &[Vec3], face: &[u32], out: &mut Vec<[u32; 3]>) -> bool {
        let Some((key, order)) = self.key(positions, face) else { return false };
        let Some((first, corners)) = self.seen.get(&key) else { return false };
        let n = order.len();
        let Some(o) = first.iter().position(|p| *p == order[0]) else { return false };
        // face corner i is first's corner (o + i) (same order) or (o − i) (reversed).
        let same = (0..n).all(|i| order[i] == first[(o + i) % n]);
        let reversed = !same && (0..n).all(|i| order[i] == first[(o + n - i) % n]);
        if !same && !reversed {
            return false;
        }
        let at = |a: u32| {
            let a = a as usize;
            face[if same { (a + n - o) % n } else { (o + n - a) % n }]
        };
        out.extend(corners.iter().map(|&[a, b, c]| if same { [at(a), at(b), at(c)] } else { [at(a), at(c), at(b)] }));
        true
    }
}

/// The concave polygons of a file that got the fan ([`crate::polygon`]): more than
/// [`MAX_EAR_CLIP_CORNERS`] corners, no ear found, and the object of the first.
#[derive(Default)]
struct Fanned<'a> {
    over_cap: usize,
    no_ear: usize,
    first: Option<&'a str>,
}

/// A texture statement's `-o` and `-s` as written (offset, scale).
type Placement = ([f32; 2], [f32; 2]);

/// The alpha cutoff of an OBJ material with a `map_d` (MTL has none; 0.5 is glTF's default
/// `alphaCutoff` and the usual alpha test).
pub const OBJ_MASK_CUTOFF: f32 = 0.5;

/// The textures an OBJ's materials share, each decoded once.
struct ObjTextures {
    /// `map_Kd` file → its index in `Mesh::textures` (`None`: it could not be read).
    colour: HashMap<PathBuf, Option<usize>>,
    /// (`map_Kd` file, `map_d` file, channel) → the cut-out texture's index (`None`: the mask
    /// could not be read). A mask is decoded for its cut-out and dropped.
    cut: HashMap<(Option<PathBuf>, PathBuf, MaskChannel), Option<usize>>,
    /// The colour textures counted against `budget`: those a material reads directly (not only
    /// through a cut-out).
    counted: std::collections::HashSet<usize>,
    /// Holds the decoded textures to [`crate::texture::MAX_TOTAL_TEXELS`] together.
    budget: TexelBudget,
    /// Bounds the pixels the images decode together ([`crate::texture::MAX_DECODED_PIXELS`]).
    decode: DecodeBudget,
    /// A texture that must not be read (outside the folder, not a regular file, over the input
    /// budget): the import fails with it.
    refused: Option<IoError>,
}

/// The texture a material with a `map_d` reads: the colour texture's colour (white without
/// one) with the mask as its alpha (the colour texture's own alpha is not MTL's dissolve), at
/// the larger of the two sizes on each axis, each read at its nearest texel (both follow the
/// same UVs), so neither loses resolution.
fn cut_out_texture(
    colour: Option<&spherebake_geom::Texture>,
    mask: &Mask,
    mask_name: &str,
) -> spherebake_geom::Texture {
    let (cw, ch) = colour.map_or((1, 1), |t| (t.width as usize, t.height as usize));
    let (mw, mh) = (mask.width as usize, mask.height as usize);
    let (w, h) = (cw.max(mw), ch.max(mh));
    let near = |x: usize, n: usize, m: usize| (((x as f64 + 0.5) * m as f64 / n as f64) as usize).min(m - 1);
    let mut texels = Vec::with_capacity(w * h);
    for y in 0..h {
        let (my, cy) = (near(y, h, mh), near(y, h, ch));
        for x in 0..w {
            let mut t = colour.map_or([1.0; 4], |c| c.texels_linear[cy * cw + near(x, w, cw)]);
            t[3] = mask.values[my * mw + near(x, w, mw)];
            texels.push(t);
        }
    }
    let name = match colour {
        Some(c) => format!("{} cut out by {mask_name}", c.name),
        None => format!("white cut out by {mask_name}"),
    };
    spherebake_geom::Texture { name, width: w as u32, height: h as u32, texels_linear: texels }
}

fn obj_material(
    ctx: &mut Ctx,
    m: &tobj::Material,
    mtl_dir: &Path,
    mesh: &mut Mesh,
    textures: &mut ObjTextures,
) -> Material {
    let texture_map = &mut textures.colour;
    let kd = m.diffuse.unwrap_or([1.0; 3]);
    let mut out = Material {
        name: m.name.clone(),
        // MTL `Kd` is taken as linear RGB; `d` (dissolve) as alpha.
        base_color_factor_linear: [kd[0], kd[1], kd[2], m.dissolve.unwrap_or(1.0)],
        base_color_texture: None,
        double_sided: false,
        alpha_mask_cutoff: None,
    };
    let map = m.diffuse_texture.as_deref().map(parse_map_args);
    if map.as_ref().is_some_and(|a| a.file.is_empty()) {
        ctx.warn(format!("material {:?}: map_Kd names no file; using Kd", m.name));
    }
    // map_Kd's file, and its -o and -s as written (the cut-out checks map_d's are the same).
    let mut kd: Option<(PathBuf, Placement)> = None;
    if let Some(map) = map.filter(|a| !a.file.is_empty()) {
        let file = map.file;
        let p = texture_path(mtl_dir, file);
        kd = Some((p.clone(), (map.offset, map.scale)));
        let slot = match texture_map.get(&p) {
            Some(s) => *s,
            None => {
                let read =
                    read_image(ctx, &mut textures.refused, &m.name, ("", "texture", "using Kd"), file, mtl_dir, |b| {
                        decode_srgb_texture(file.to_owned(), b, &mut textures.decode)
                    });
                let s = read.map(|d| {
                    if let Some(w) = d.reduction_warning(&format!("material {:?}", m.name)) {
                        ctx.warn(w);
                    }
                    mesh.textures.push(d.texture);
                    mesh.textures.len() - 1
                });
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
                transform: map.transform().unwrap_or_else(|| {
                    ctx.warn(format!("material {:?}: map_Kd -o / -s out of range; ignored", m.name));
                    UvTransform::default()
                }),
            });
        }
    }
    let colour = out.base_color_texture.as_ref().map(|t| t.texture);
    obj_cut_out(ctx, m, mtl_dir, mesh, textures, kd.as_ref().map(|(p, pl)| (p.as_path(), *pl)), &mut out);
    // The colour texture counts against the texel budget once a material reads it directly. One
    // only cut-outs read is dropped (they hold its colour, built from it at full size), so it
    // costs neither memory nor budget; a later material reading it directly decodes it again.
    if let (Some((p, _)), Some(slot)) = (kd, colour) {
        if out.alpha_mask_cutoff.is_none() {
            if textures.counted.insert(slot) {
                textures.budget.add(&mut mesh.textures, slot);
            }
        } else if !textures.counted.contains(&slot) {
            let t = &mut mesh.textures[slot];
            (t.width, t.height, t.texels_linear) = (1, 1, vec![[0.0; 4]]);
            textures.colour.remove(&p);
        }
    }
    out
}

/// A material's `map_d` (MTL's dissolve texture): a cut-out, like glTF's `alphaMode` `MASK`
/// with a cutoff of [`OBJ_MASK_CUTOFF`]. Where `d` × the map's value (the channel
/// [`MaskChannel`] picks) is below it, the surface is a hole for the albedo. The material then
/// reads [`cut_out_texture`]. A `map_d` that cannot be read leaves the material opaque, with
/// a warning. `kd`: the material's `map_Kd` file and its `-o` / `-s` as written.
fn obj_cut_out(
    ctx: &mut Ctx,
    m: &tobj::Material,
    mtl_dir: &Path,
    mesh: &mut Mesh,
    textures: &mut ObjTextures,
    kd: Option<(&Path, Placement)>,
    out: &mut Material,
) {
    let (kd_path, kd_placement) = (kd.map(|k| k.0), kd.map(|k| k.1));
    let Some(dmap) = m.dissolve_texture.as_deref().map(parse_map_args) else { return };
    if dmap.file.is_empty() {
        ctx.warn(format!("material {:?}: map_d names no file; no cut-out", m.name));
        return;
    }
    let file = dmap.file;
    let p = texture_path(mtl_dir, file);
    let colour = out.base_color_texture.as_ref().map(|t| t.texture);
    let key = (kd_path.map(Path::to_path_buf), p.clone(), dmap.channel);
    let index = match textures.cut.get(&key) {
        Some(&index) => index,
        None => {
            let read = read_image(
                ctx,
                &mut textures.refused,
                &m.name,
                ("map_d ", "map_d", "no cut-out"),
                file,
                mtl_dir,
                |b| decode_mask(file.to_owned(), b, dmap.channel, &mut textures.decode),
            );
            let mask = read.inspect(|mask| {
                if let Some((w, h)) = mask.reduced_from {
                    ctx.warn(format!(
                        "material {:?}: map_d {file} is {w}×{h}; read box-filtered to {}×{}",
                        m.name, mask.width, mask.height
                    ));
                }
            });
            let index = mask.map(|mask| {
                mesh.textures.push(cut_out_texture(colour.map(|i| &mesh.textures[i]), &mask, file));
                let i = mesh.textures.len() - 1;
                textures.budget.add(&mut mesh.textures, i);
                i
            });
            textures.cut.insert(key, index);
            index
        }
    };
    let Some(index) = index else { return };
    let transform = match &out.base_color_texture {
        Some(t) => {
            if kd_placement != Some((dmap.offset, dmap.scale)) {
                ctx.warn(format!(
                    "material {:?}: map_d's -o / -s differ from map_Kd's; the cut-out is read with map_Kd's",
                    m.name
                ));
            }
            t.transform
        }
        None => dmap.transform().unwrap_or_else(|| {
            ctx.warn(format!("material {:?}: map_d -o / -s out of range; ignored", m.name));
            UvTransform::default()
        }),
    };
    out.base_color_texture = Some(TextureRef {
        texture: index,
        uv_set: 0,
        wrap_s: Default::default(),
        wrap_t: Default::default(),
        mag_filter: Default::default(),
        transform,
    });
    out.alpha_mask_cutoff = Some(OBJ_MASK_CUTOFF);
}

/// Where a texture statement's `file` is: in `mtl_dir`, the folder of the library that
/// defines the material, `\` read as a folder separator (a Windows path).
fn texture_path(mtl_dir: &Path, file: &str) -> PathBuf {
    mtl_dir.join(file.replace('\\', "/"))
}

/// The file name of a Windows absolute path (a drive letter, `:` and a separator:
/// `C:\Users\bob\tex\red.png`), which elsewhere reads as a relative name; `None` for any other
/// path, or when its last component is no file name (`C:\tex\..`).
fn windows_file_name(file: &str) -> Option<&str> {
    let b = file.as_bytes();
    let absolute = b.len() > 3 && b[0].is_ascii_alphabetic() && b[1] == b':' && matches!(b[2], b'\\' | b'/');
    let name = file.rsplit(['\\', '/']).next()?;
    (absolute && !matches!(name, "" | "." | "..")).then_some(name)
}

/// Reads the image `file` (in `mtl_dir`: [`texture_path`]) a texture statement of material
/// `material` names and decodes it with `decode`. A Windows absolute path that is not found is
/// looked for by its file name alone in `mtl_dir`, as Blender's `load_texture_image` does (the
/// textures of a model moved off the machine that wrote it often sit next to its MTL), with a
/// warning naming both; still inside the model's folder as [`Ctx::read_referenced`] holds it.
/// On failure, warns and gives `None`: "material M: cannot decode {what}P: E; {fallback}" or
/// "material M: {reading} E; {fallback}" (`labels` = (what, reading, fallback)); a reference
/// that must not be read (outside the folder, not a regular file, over the input budget) is
/// kept in `refused` instead, failing the import.
fn read_image<T>(
    ctx: &mut Ctx,
    refused: &mut Option<IoError>,
    material: &str,
    labels: (&str, &str, &str),
    file: &str,
    mtl_dir: &Path,
    decode: impl FnOnce(&[u8]) -> Result<T, String>,
) -> Option<T> {
    let (what, reading, fallback) = labels;
    let limit = ReadLimit::AtMost(MAX_IMAGE_BYTES);
    let mut p = texture_path(mtl_dir, file);
    let mut read = ctx.read_referenced(file, &p, limit);
    if let (Err(IoError::ReferenceNotFound { .. }), Some(name)) = (&read, windows_file_name(file)) {
        let near = mtl_dir.join(name);
        read = ctx.read_referenced(file, &near, limit);
        if read.is_ok() {
            // Found: the path as written is no dependency.
            ctx.missing.retain(|m| *m != p);
            ctx.warn(format!(
                "material {material:?}: {file:?} not found (looked for {}); read {}, its file name next to the material library",
                p.display(),
                near.display()
            ));
            p = near;
        }
    }
    match read {
        Ok(bytes) => match decode(&bytes) {
            Ok(v) => Some(v),
            Err(e) if e == OVER_DECODE_BUDGET => None, // one warning for all (`DecodeBudget::warning`)
            Err(e) => {
                ctx.warn(format!("material {material:?}: cannot decode {what}{}: {e}; {fallback}", p.display()));
                None
            }
        },
        Err(e) if e.is_refusal() => {
            refused.get_or_insert(e);
            None
        }
        Err(e) => {
            ctx.warn(format!("material {material:?}: {reading} {e}; {fallback}"));
            None
        }
    }
}

/// The arguments of an MTL texture statement (`map_Kd [options] file`).
#[derive(Debug, PartialEq)]
struct MapArgs<'a> {
    /// The rest of the line after the options, inner spaces kept (`my texture.png`), without
    /// surrounding double quotes.
    file: &'a str,
    /// `-o u v`: the texture's origin offset, OBJ texture space (v up).
    offset: [f32; 2],
    /// `-s u v`: the texture's scale, OBJ texture space.
    scale: [f32; 2],
    /// `-imfchan r|g|b|m|l`: the channel a scalar texture (`map_d`) reads; `Auto` without it
    /// (and for `z` or anything else).
    channel: MaskChannel,
}

impl MapArgs<'_> {
    /// The lookup the options ask for, in the importer's UV convention: OBJ maps t = s·uv + o
    /// in its own space (v up); with V = 1 − v on both sides that is
    /// T = (s_u·U + o_u, s_v·V + 1 − s_v − o_v). `None` when that offset is not a finite f32.
    fn transform(&self) -> Option<UvTransform> {
        let [su, sv] = self.scale;
        let [ou, ov] = self.offset;
        let ov = (1.0 - f64::from(sv) - f64::from(ov)) as f32;
        ov.is_finite().then_some(UvTransform { offset: [ou, ov], rotation_rad: 0.0, scale: [su, sv] })
    }
}

/// The name inside double quotes (`"my lib.mtl"`, as some exporters write a name with spaces),
/// `None` when `s` is not one quoted name (an empty one, or one holding `"`, is not).
fn unquoted(s: &str) -> Option<&str> {
    s.strip_prefix('"').and_then(|s| s.strip_suffix('"')).filter(|s| !s.is_empty() && !s.contains('"'))
}

/// Splits `[options] file` by the options of the MTL specification, each with its argument
/// count (`-o`, `-s`, `-t` take one to three numbers); anything else ends the options and the
/// rest of the line is the file name, so a name with spaces survives, its double quotes removed
/// as an `mtllib` name's are (`map_Kd "my tex.png"`). A missing `v` of `-o` or
/// `-s` keeps its default (0 and 1).
fn parse_map_args(line: &str) -> MapArgs<'_> {
    fn pop(s: &str) -> (&str, &str) {
        let s = s.trim_start();
        let end = s.find(char::is_whitespace).unwrap_or(s.len());
        (&s[..end], &s[end..])
    }
    let mut rest = line.trim();
    let mut args = MapArgs { file: "", offset: [0.0, 0.0], scale: [1.0, 1.0], channel: MaskChannel::Auto };
    loop {
        let (opt, after) = pop(rest);
        let fixed = match opt {
            "-blendu" | "-blendv" | "-boost" | "-cc" | "-clamp" | "-imfchan" | "-texres" | "-bm" | "-type" => 1,
            "-mm" => 2,
            "-o" | "-s" | "-t" => 0,
            _ => break,
        };
        rest = after;
        if opt == "-imfchan" {
            args.channel = match pop(rest).0 {
                "r" => MaskChannel::R,
                "g" => MaskChannel::G,
                "b" => MaskChannel::B,
                "m" => MaskChannel::Alpha,
                "l" => MaskChannel::Luminance,
                _ => MaskChannel::Auto,
            };
        }
        if fixed > 0 {
            for _ in 0..fixed {
                rest = pop(rest).1;
            }
            continue;
        }
        // One to three numbers.
        let mut values = Vec::new();
        while values.len() < 3 {
            let (tok, after) = pop(rest);
            match tok.parse::<f32>() {
                Ok(v) if v.is_finite() => {
                    values.push(v);
                    rest = after;
                }
                _ => break,
            }
        }
        let target = match opt {
            "-o" => Some(&mut args.offset),
            "-s" => Some(&mut args.scale),
            _ => None,
        };
        if let Some(t) = target {
            for (k, v) in values.into_iter().take(2).enumerate() {
                t[k] = v;
            }
        }
    }
    let file = rest.trim();
    args.file = unquoted(file).unwrap_or(file);
    args
}

#[cfg(test)]
mod differential;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn map_arguments_are_split_by_the_mtl_options() {
        let args = |file, offset, scale| MapArgs { file, offset, scale, channel: MaskChannel::Auto };
        assert_eq!(parse_map_args("tex.png"), args("tex.png", [0.0, 0.0], [1.0, 1.0]));
        assert_eq!(parse_map_args("  my wood floor.jpg "), args("my wood floor.jpg", [0.0, 0.0], [1.0, 1.0]));
        assert_eq!(
            parse_map_args("-s 2 3 1 -o 0.5 0.25 0 -clamp on -mm 0 1 -bm 0.5 Textures\\a b.png"),
            args("Textures\\a b.png", [0.5, 0.25], [2.0, 3.0])
        );
        // Optional components: -s u alone keeps v = 1; -t takes its numbers and no more.
        assert_eq!(parse_map_args("-s 4 -t 1 2 x.png"), args("x.png", [0.0, 0.0], [4.0, 1.0]));
        // An unknown option ends the options: it is part of the name, as is a name that is a number.
        assert_eq!(parse_map_args("-weird x.png"), args("-weird x.png", [0.0, 0.0], [1.0, 1.0]));
        assert_eq!(parse_map_args("-o 1 2 3 4.png"), args("4.png", [1.0, 2.0], [1.0, 1.0]));
        assert_eq!(parse_map_args("-s"), args("", [0.0, 0.0], [1.0, 1.0]));
        // A name in double quotes is the name inside them, as an `mtllib` name; an empty or
        // unbalanced one is kept as written.
        assert_eq!(parse_map_args("\"my red.png\""), args("my red.png", [0.0, 0.0], [1.0, 1.0]));
        assert_eq!(parse_map_args("-s 2 \"a \\b.png\" "), args("a \\b.png", [0.0, 0.0], [2.0, 1.0]));
        assert_eq!(parse_map_args("\"a.png"), args("\"a.png", [0.0, 0.0], [1.0, 1.0]));
        assert_eq!(parse_map_args("\"\""), args("\"\"", [0.0, 0.0], [1.0, 1.0]));
        // -imfchan names the channel a scalar map reads (z and anything else: the default).
        for (c, want) in [
            ("r", MaskChannel::R),
            ("g", MaskChannel::G),
            ("b", MaskChannel::B),
            ("m", MaskChannel::Alpha),
            ("l", MaskChannel::Luminance),
            ("z", MaskChannel::Auto),
        ] {
            let line = format!("-imfchan {c} -o 0.5 mask.png");
            let a = parse_map_args(&line);
            assert_eq!((a.file, a.channel, a.offset), ("mask.png", want, [0.5, 0.0]), "-imfchan {c}");
        }
    }

    /// The transform maps the importer's UV (U, V = 1 − v) to where OBJ looks: its own
    /// t = s·uv + o (v up), flipped the same way.
    #[test]
    fn map_offset_and_scale_become_the_uv_transform() {
        let a = parse_map_args("-s 2 0.5 -o 0.25 0.1 t.png");
        let tr = a.transform().unwrap();
        for (u, v) in [(0.1f32, 0.2f32), (0.0, 0.0), (0.9, 0.7)] {
            let obj = [2.0 * u + 0.25, 0.5 * v + 0.1];
            let want = [obj[0], 1.0 - obj[1]];
            let got = tr.apply([u, 1.0 - v]);
            assert!((got[0] - want[0]).abs() < 1e-6 && (got[1] - want[1]).abs() < 1e-6, "{got:?} vs {want:?}");
        }
        assert_eq!(parse_map_args("t.png").transform(), Some(UvTransform::default()));
        // An offset that overflows f32 is refused rather than made infinite.
        assert_eq!(parse_map_args("-o 0 3e38 -s 1 3e38 t.png").transform(), None);
    }

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
        // Every fifth file has no `vn` line (its normal indices are not checked).
        let normals = seed % 5 != 4;
        let first = if normals { first.to_string() } else { first.replace("vn 0 0 1", "vt 0 0") };
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
                    6..=8 => format!("l {} {} {}", 1 + next(30), 1 + next(30), 1 + next(30)),
                    9 => "f 1 2 3 # a face".to_string(),
                    10 => "v 1 2 3 #c".to_string(),
                    _ if normals => "vn 0 0 1".to_string(),
                    _ => "vt 1 0".to_string(),
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
                9 => match next(40) {
                    // A comment's or a name's `\` continues nothing.
                    0 => "# exported from C:\\work\\".to_string(),
                    1 => "o part \\".to_string(),
                    2 => "v 1 2 3 # x \\".to_string(),
                    3 => "v 1 2 \\\n 3".to_string(),
                    4 => "vt 0 \\\r\n1".to_string(),
                    5 => "usemtl".to_string(),
                    6 => "usemtl\tred".to_string(),
                    7 => " usemtl red # the red one".to_string(),
                    8 => "f 1//1/ 2 3".to_string(),
                    9 if next(4) == 0 => "f 1//1/1 2 3".to_string(),
                    10 => "mtllib".to_string(),
                    11 => "mtllib\tm.mtl".to_string(),
                    12 if next(4) == 0 => "v 1e39 0 0".to_string(),
                    13 if next(4) == 0 => "v 1 0 0 1e-40".to_string(),
                    _ => "# f 0 0".to_string(),
                },
                10 => String::new(),
                _ => "f 1 \\\n 2 \\\n3".to_string(),
            };
            s.push_str(&line);
            s.push_str(if next(5) == 0 { "\r\n" } else { "\n" });
        }
        // Now and then a data line continued into the end of the file.
        if next(8) == 0 {
            s.push_str("f 1 2 3 \\");
        }
        s
    }

    /// The check written apart, line by line over the whole text, from the rules as the docs
    /// state them: the first error's message, else the number of triangles the faces make
    /// (a face of n corners, n − 2).
    fn oracle(text: &str) -> Result<usize, String> {
        let data = |s: &str| {
            let k = s.split('#').next().unwrap_or("").split_whitespace().next();
            matches!(k, Some("v" | "vt" | "vn" | "f" | "l"))
        };
        // Logical lines: a data line ending in `\` with no `#` so far continues on the next.
        let mut logical: Vec<(usize, String)> = Vec::new();
        let mut pending: Option<(usize, String)> = None;
        for (i, raw) in text.lines().enumerate() {
            let (first, mut acc) = pending.take().unwrap_or((i + 1, String::new()));
            let head = raw.strip_suffix('\\').unwrap_or(raw);
            let candidate = format!("{acc}{head}");
            if raw.ends_with('\\') && data(&candidate) && !candidate.contains('#') {
                acc = candidate + " ";
                pending = Some((first, acc));
            } else {
                acc += raw;
                logical.push((first, acc));
            }
        }
        logical.extend(pending);
        // A file without `vn` lines: its faces' normal indices are not checked.
        let no_normals =
            !logical.iter().any(|(_, l)| l.split('#').next().unwrap_or("").split_whitespace().next() == Some("vn"));
        let mut defined = [0i64; 3];
        let mut triangles = 0usize;
        for (line, text) in logical {
            let body = text.split('#').next().unwrap_or("");
            let tokens: Vec<&str> = body.split_whitespace().collect();
            let numbers = |from: usize, n: usize| {
                tokens.len() >= from + n && tokens[from..from + n].iter().all(|t| t.parse::<f32>().is_ok())
            };
            match tokens.first().copied() {
                Some("v") => {
                    if !numbers(1, 3) {
                        return Err(format!("line {line}: vertex needs three numbers"));
                    }
                    let w: f32 = if tokens.len() == 5 { tokens[4].parse().unwrap_or(1.0) } else { 1.0 };
                    let p: Vec<f32> = tokens[1..4].iter().map(|t| t.parse::<f32>().unwrap() / w).collect();
                    if w != 0.0 && w.is_finite() && p.iter().any(|x| !x.is_finite()) {
                        let w = if tokens.len() == 5 { format!(" / {}", tokens[4]) } else { String::new() };
                        return Err(format!(
                            "line {line}: vertex position ({} {} {}){w} is not finite in f32",
                            tokens[1], tokens[2], tokens[3]
                        ));
                    }
                    match tokens.len() - 1 {
                        3 | 6 => {}
                        4 => {
                            let w = tokens[4].parse::<f32>();
                            match w {
                                Ok(w) if w.is_finite() && w != 0.0 => {}
                                Ok(w) => {
                                    return Err(format!(
                                        "line {line}: vertex weight w is {w} (a weight must be finite and not 0)"
                                    ))
                                }
                                Err(_) => {
                                    return Err(format!("line {line}: vertex weight {:?} is not a number", tokens[4]))
                                }
                            }
                        }
                        n => {
                            let n = if n > 7 { "more than 7".to_string() } else { n.to_string() };
                            return Err(format!(
                                "line {line}: vertex with {n} values (expected x y z, x y z w or x y z r g b)"
                            ));
                        }
                    }
                    defined[0] += 1;
                }
                Some("vt") => {
                    if !numbers(1, 1) || (tokens.len() > 2 && !numbers(2, 1)) {
                        return Err(format!("line {line}: texture coordinate needs one or two numbers (u [v])"));
                    }
                    defined[1] += 1;
                }
                Some("vn") => {
                    if !numbers(1, 3) {
                        return Err(format!("line {line}: normal needs three numbers"));
                    }
                    defined[2] += 1;
                }
                Some("usemtl") if text.trim_start()[6..].trim().is_empty() => {
                    return Err(format!("line {line}: usemtl without a material name"));
                }
                Some("mtllib") if text.trim_start()[6..].trim().is_empty() => {
                    return Err(format!("line {line}: mtllib without a file name"));
                }
                Some(kw @ ("f" | "l")) => {
                    let corners = tokens.len() - 1;
                    if kw == "f" && corners < 3 {
                        return Err(format!("line {line}: face with {corners} vertices (a face needs at least 3)"));
                    }
                    if corners == 0 {
                        return Err(format!("line {line}: line element with no vertex"));
                    }
                    for corner in &tokens[1..] {
                        let slots: Vec<&str> = corner.split('/').collect();
                        for (kind, slot) in slots.iter().enumerate() {
                            if kind >= 3 {
                                if !slot.is_empty() {
                                    return Err(format!(
                                        "line {line}: face corner {corner:?} has more than three indices"
                                    ));
                                }
                                continue;
                            }
                            let what = ["vertex", "texture", "normal"][kind];
                            if kind > 0 && slot.is_empty() {
                                continue;
                            }
                            if kind == 2 && no_normals && slot.parse::<i64>().is_ok() {
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
                    if kw == "f" {
                        triangles += corners - 2;
                    }
                }
                _ => {}
            }
        }
        Ok(triangles)
    }

    /// [`slots`] splits a corner as `str::split('/')` does.
    #[test]
    fn slots_split_as_split() {
        for c in ["", "/", "//", "1", "1/2", "1//3", "1/2/3", "/2/", "1/2/3/", "é/1/", "-1//-2", "a/b/c/d"] {
            assert_eq!(slots(c).collect::<Vec<_>>(), c.split('/').collect::<Vec<_>>(), "{c:?}");
        }
    }

    /// A face or line element with too few corners is refused for that, whatever its corners
    /// hold (bad or out-of-range indices), in one piece or many; else its first bad corner
    /// or, before it, an index out of range is the error.
    #[test]
    fn too_few_corners_is_the_error_before_the_corners() {
        let cases = [
            ("v 0 0 0\nf 1 99\n", "line 2: face with 2 vertices (a face needs at least 3)"),
            ("v 0 0 0\nf 99 x\n", "line 2: face with 2 vertices (a face needs at least 3)"),
            ("f x\n", "line 1: face with 1 vertices (a face needs at least 3)"),
            ("f # 1 2 3\n", "line 1: face with 0 vertices (a face needs at least 3)"),
            ("l\n", "line 1: line element with no vertex"),
            ("v 0 0 0\nl 99\n", "line 2: vertex index 99 out of range (1 defined so far)"),
            ("v 0 0 0\nl 1 x\n", "line 2: bad vertex index \"x\" in face corner \"x\""),
            ("v 0 0 0\nf 1 1 99 x\n", "line 2: vertex index 99 out of range (1 defined so far)"),
            ("v 0 0 0\nf 1 x 99\n", "line 2: bad vertex index \"x\" in face corner \"x\""),
            ("v 0 0 0\nf 1 1///4 1\n", "line 2: face corner \"1///4\" has more than three indices"),
            ("v 0 0 0\nv 0 0 0\nf 1 2 1\nf 3 -9\nf 1 2 3\n", "line 4: face with 2 vertices (a face needs at least 3)"),
        ];
        for (text, want) in cases {
            for piece in [1, 8, usize::MAX] {
                match check_lines_in(Path::new("x.obj"), text, piece) {
                    Err(IoError::Obj { message, .. }) => assert_eq!(message, want, "{text:?}, pieces of {piece}"),
                    other => panic!("{text:?}: {other:?}"),
                }
            }
        }
    }

    #[test]
    fn the_check_in_pieces_answers_as_in_one() {
        let path = Path::new("x.obj");
        let message = |r: Result<Rewrite, IoError>| match r {
            Ok(_) => Ok(()),
            Err(IoError::Obj { message, .. }) => Err(message),
            Err(e) => panic!("{e:?}"),
        };
        let (mut errors, mut oks, mut late, mut rewritten) = (0, 0, 0, 0);
        for seed in 0..400u64 {
            let text = random_obj(seed, 20 + (seed as usize % 7) * 30);
            let whole = check_lines_in(path, &text, usize::MAX);
            let rewrite = whole.as_ref().ok().cloned();
            let whole = message(whole);
            let want = oracle(&text);
            assert_eq!(whole, want.clone().map(|_| ()), "seed {seed}");
            match (&whole, &rewrite, want) {
                (Err(m), _, _) => {
                    errors += 1;
                    // An error past the first piece of the smallest size: the counts before a piece matter.
                    let line: usize = m.trim_start_matches("line ").split(':').next().unwrap().parse().unwrap();
                    late += usize::from(line > 70);
                }
                (Ok(()), Some(rewrite), Ok(triangles)) => {
                    oks += 1;
                    rewritten += usize::from(rewrite.lines || rewrite.colours);
                    // What the check accepts, tobj reads from the text it is given, with every
                    // face and no more: no error without a line number after the check.
                    let fed = tobj_text(&text, rewrite);
                    let (models, _) = tobj::load_obj_buf(
                        &mut std::io::Cursor::new(fed.as_bytes()),
                        &crate::obj_parse::tobj_options(),
                        |_| Err(tobj::LoadError::OpenFileFailed),
                    )
                    .unwrap_or_else(|e| panic!("seed {seed}: tobj: {e}"));
                    let got: usize = models.iter().flat_map(|m| faces(&m.mesh)).map(|f| f.len() - 2).sum();
                    assert_eq!(got, triangles, "seed {seed}: triangles");
                    // As many lines, and the `mtllib` lines again when they are moved first.
                    let moved = text.lines().filter(|l| l.split_whitespace().next() == Some("mtllib")).count();
                    let more = if rewrite.libraries_first { moved } else { 0 };
                    assert_eq!(fed.lines().count(), text.lines().count() + more, "seed {seed}: line count");
                }
                other => panic!("seed {seed}: {other:?}"),
            }
            for piece in [1, 7, 40, 200] {
                let r = check_lines_in(path, &text, piece);
                if let Ok(rw) = &r {
                    assert_eq!(Some(rw), rewrite.as_ref(), "seed {seed}, pieces of {piece}");
                }
                assert_eq!(message(r), whole, "seed {seed}, pieces of {piece}");
            }
            // Every piece ends at a line end that does not continue a line, and they join to the text.
            let pieces = split_pieces(&text, 7);
            assert_eq!(pieces.concat(), text);
            for p in &pieces[..pieces.len() - 1] {
                let last = p.strip_suffix('\n').map(|q| q.rsplit('\n').next().unwrap_or(q));
                assert!(last.is_some_and(|l| !l.trim_end_matches('\r').ends_with('\\')), "{p:?}");
            }
        }
        assert!(
            errors > 50 && oks > 20 && late > 30 && rewritten > 5 && rewritten < oks,
            "{errors} errors ({late} late), {oks} clean ({rewritten} rewritten for tobj)"
        );
    }
}
