//! The OBJ geometry parse: the text [`crate::obj_import`] has checked, read into tobj's own
//! structs ([`tobj::Model`], [`tobj::Mesh`]) exactly as `tobj::load_obj_buf` 4.0.5 reads it
//! with the options this importer uses (`triangulate: false`, `single_index: true`,
//! `ignore_lines: true`, `ignore_points: true`), with the same material-loader callback
//! contract and the same errors. tobj's own parse was about 42 % of an OBJ's import (a SipHash
//! map for the vertex dedup, a `String` per line, its per-model export); this one reads the
//! text in place, without allocating per line, and numbers the vertices as the faces are read:
//! a position's first corner in a model through a table indexed by position, any other through
//! a map with [`spherebake_geom::fold_hash::FoldHasher`] ([`Parser::number`]). On a
//! 1.1 M-triangle file (43 MB) it takes 0.19 s where tobj took 0.44 s. MTL files are still
//! parsed by tobj (`tobj::load_mtl_buf`, in the callback). The differential test in
//! `obj_import` holds the two equal.
//!
//! What of tobj's behaviour is reproduced (each point also in the code):
//! - Lines end at `\n`, and a `\r` before it is dropped (`BufRead::lines`); a line's words are
//!   split at Unicode whitespace (`str::split_whitespace`); its first word is the keyword,
//!   compared exactly (case matters); `#`, an empty line and any other keyword are skipped.
//! - `v x y z` appends a position; `v x y z w` divides x, y, z by w (w = 0 is
//!   `ScalingByZeroError`); `v x y z r g b` appends the colour values to one list of all the
//!   file's colours, stopping at the first that is not a number (so vertex i's colour is the
//!   i-th triple of that list, whatever lines gave it); two, or more than three, values after
//!   x y z is `ColorParseError`. `vt` takes two numbers, `vn` three (further
//!   words are ignored).
//! - `f` and `l` read each corner `v`, `v/vt`, `v//vn` or `v/vt/vn`: an OBJ index n > 0 is
//!   n − 1, a negative one counts back from the definitions read so far, 0 and an empty `v`
//!   resolve to an index no vertex has; an empty `vt` or `vn` is absent. A face of one or two
//!   corners is a point or a line: ignored, but it still counts as a face of the current model.
//! - The current model's faces give one vertex per distinct (v, vt, vn) triple, numbered in the
//!   order of first use in the model; a vertex gets its texture coordinate only when the file
//!   has some and the corner names one (likewise normals), and its colour when the file has any
//!   colour. Indices are looked up in the definitions read when the model ends (so a face may
//!   name a vertex defined after it, before the model ends: the check in `obj_import` refuses
//!   such faces first), and one past them is `FaceVertexOutOfBounds` (`FaceTexCoordOutOfBounds`,
//!   `FaceNormalOutOfBounds`, `FaceColorOutOfBounds`).
//! - `face_arities` holds every face's corner count (points and lines are not stored), and is
//!   empty when the model's faces are all triangles.
//! - A model ends at `o` or `g` when it has a face (point and line included), then takes the
//!   line's text after its first character, trimmed (`unnamed_object` when empty; the first
//!   model's name until then); at `usemtl` when it has a face and the material changes; and at
//!   the end of the text, always (so the last model may have no faces). The name and material
//!   carry on into the next model.
//! - `usemtl NAME` and `mtllib NAME` take the text after the line's first space, trimmed (an
//!   empty `usemtl` name is `MaterialParseError`); `usemtl` looks the name up in the materials
//!   of the libraries read so far (`None` when none defines it); each `mtllib` line calls the
//!   loader once, with that name as a path, in file order. A library's materials are appended,
//!   their names overriding earlier ones; a loader error is kept. The materials result is the
//!   materials when there are any, else the last loader error, else none.
//!
//! Beyond tobj's result, [`Obj::uv_named`] says which vertices of a model have a texture
//! coordinate when only some have one: tobj leaves the others out of the model's texture
//! coordinates, which then do not pair with its vertices; and [`Obj::smoothing`] gives each
//! face its smoothing group (`s`), which tobj ignores.

use std::collections::hash_map::Entry;
use std::collections::HashMap;
use std::path::Path;

use tobj::{LoadError, MTLLoadResult, Material, Mesh, Model};

/// The name of a model before any `o` or `g` line, and of one whose line has no name (tobj's).
const UNNAMED: &str = "unnamed_object";

/// A face corner as resolved from the text: 0-based indices into the file's positions, texture
/// coordinates and normals, [`ABSENT`] for an empty `vt` or `vn` (and, as in tobj, for the OBJ
/// index 0, or an empty `v`: no definition has it). Resolving wraps as tobj's casts do, so an
/// index before the first definition is a large number that no definition has either.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
struct Corner {
    v: usize,
    vt: usize,
    vn: usize,
}

/// A corner slot with no index (tobj's `MISSING_INDEX`).
const ABSENT: usize = usize::MAX;

// The corner map's hasher: `FoldKey` (each `usize` written is mixed in by a 64 × 64 → 128-bit
// multiply folded to 64 bits, from a per-map random key, so a file cannot be crafted to make
// its corners collide; std's SipHash map, as tobj used, was the larger part of tobj's cost).
// The map is only looked up, never iterated, so the key changes no output.
use spherebake_geom::fold_hash::FoldKey;

/// The words of a line, split at whitespace exactly as `str::split_whitespace` splits them
/// (`char::is_whitespace`: ASCII tab, line feed, vertical tab, form feed, carriage return and
/// space, and the Unicode `White_Space` characters). Also the line check's tokeniser
/// (`obj_import`): the two read a line's words alike.
///
/// Cost: a few instructions per ASCII byte, classed by a table ([`CLASS`]); only a non-ASCII
/// byte decodes its character ([`space_at`], out of line). `split_whitespace` decodes every
/// character: it was about a third of this parse and of the check on a 2.4 MB OBJ.
#[derive(Clone, Debug)]
pub(crate) struct Words<'a> {
    line: &'a str,
    /// Where the next word's search starts (a char boundary of `line`).
    at: usize,
}

/// Per byte: [`SPACE`] for the ASCII whitespace of `char::is_whitespace` (tab, line feed,
/// vertical tab, form feed, carriage return, space; not 0x1C–0x1F), [`WIDE`] for a byte of a
/// non-ASCII character, 0 for any other (one load per byte in [`Words`]' loops).
const CLASS: [u8; 256] = {
    let mut class = [0u8; 256];
    let mut b = 0;
    while b < 256 {
        class[b] = match b as u8 {
            b' ' | b'\t'..=b'\r' => SPACE,
            0x80.. => WIDE,
            _ => 0,
        };
        b += 1;
    }
    class
};
const SPACE: u8 = 1;
const WIDE: u8 = 2;

/// Whether the character starting at byte `i` of `s` (a char boundary) is whitespace, and its
/// length in bytes (1 where `i` is not a boundary or past the end: never met, `Words` steps
/// by whole characters). For non-ASCII characters: out of line, so the ASCII loop stays small.
#[inline(never)]
fn space_at(s: &str, i: usize) -> (bool, usize) {
    s.get(i..).and_then(|t| t.chars().next()).map_or((false, 1), |c| (c.is_whitespace(), c.len_utf8()))
}

impl<'a> Iterator for Words<'a> {
    type Item = &'a str;

    #[inline]
    fn next(&mut self) -> Option<&'a str> {
        let (s, b) = (self.line, self.line.as_bytes());
        let mut i = self.at;
        // The whitespace before the word, then the word: ASCII bytes classed by the table, a
        // non-ASCII byte's character decoded.
        loop {
            match b.get(i) {
                Some(&c) if CLASS[usize::from(c)] == SPACE => i += 1,
                Some(&c) if c >= 0x80 => match space_at(s, i) {
                    (true, len) => i += len,
                    (false, _) => break,
                },
                _ => break,
            }
        }
        let start = i;
        loop {
            match b.get(i) {
                Some(&c) if CLASS[usize::from(c)] == 0 => i += 1,
                Some(&c) if c >= 0x80 => match space_at(s, i) {
                    (false, len) => i += len,
                    (true, _) => break,
                },
                _ => break,
            }
        }
        self.at = i;
        if i == start {
            None
        } else {
            s.get(start..i)
        }
    }
}

/// The words of `line` ([`Words`]).
pub(crate) fn words(line: &str) -> Words<'_> {
    Words { line, at: 0 }
}

/// The options whose reading [`load_obj`] reproduces, as tobj names them (for the tests, which
/// compare the two): faces as they are (polygons are triangulated by [`crate::polygon`]), one
/// vertex per distinct position / UV / normal corner; line and point elements are not surfaces
/// (`obj_import`'s rewrite also empties the `l` lines: tobj reads one of three or more vertices
/// as a face).
#[cfg(test)]
pub(crate) fn tobj_options() -> tobj::LoadOptions {
    tobj::LoadOptions { triangulate: false, single_index: true, ignore_lines: true, ignore_points: true }
}

/// What [`load_obj`] reads.
#[derive(Debug)]
pub(crate) struct Obj {
    /// tobj's models and materials result.
    pub models: Vec<Model>,
    pub materials: Result<Vec<Material>, LoadError>,
    /// Per model, whether each vertex has a texture coordinate, when the file has some and the
    /// model's corners name one only in part (a face without `vt` in a textured group); empty
    /// otherwise. The model's `texcoords` hold those of the vertices marked, in vertex order.
    pub uv_named: Vec<Vec<bool>>,
    /// Per model, the smoothing group of each face of three or more corners (`s N`: N; `s off`
    /// or `s 0`: 0, flat; before any `s` line or after one that is not a number:
    /// [`NO_SMOOTHING_GROUP`]); empty for every model when the file has no `s` line.
    pub smoothing: Vec<Vec<u32>>,
}

use spherebake_geom::normals::NO_GROUP as NO_SMOOTHING_GROUP;

/// Reads the OBJ `text` as `tobj::load_obj_buf` 4.0.5 reads it with the options this importer uses
/// (see the module doc): the models, and the materials of the libraries `material_loader`
/// returns, called once per `mtllib` line, in order, with the line's name as a path; and which
/// vertices have a texture coordinate where only some do ([`Obj::uv_named`]). Errors are
/// tobj's, at the same lines (the first a line or a model end meets). Allocates in proportion
/// to the text (its definitions, faces and vertices), no more; never panics.
pub(crate) fn load_obj<F>(text: &str, mut material_loader: F) -> Result<Obj, LoadError>
where
    F: FnMut(&Path) -> MTLLoadResult,
{
    let mut p = Parser::default();
    let mut rest = text;
    while !rest.is_empty() {
        // `BufRead::lines`: up to `\n`, without it and one `\r` before it.
        let line = match rest.find('\n') {
            Some(i) => {
                let line = &rest[..i];
                rest = &rest[i + 1..];
                line.strip_suffix('\r').unwrap_or(line)
            }
            None => std::mem::take(&mut rest),
        };
        let mut w = words(line);
        let Some(key) = w.next() else { continue };
        match key {
            "v" => p.vertex(w)?,
            "vt" => read_floats::<2>(&mut w, &mut p.texcoords).ok_or(LoadError::TexcoordParseError)?,
            "vn" => read_floats::<3>(&mut w, &mut p.normals).ok_or(LoadError::NormalParseError)?,
            "f" | "l" => p.face(w)?,
            "s" => {
                p.any_smoothing = true;
                // `off`, or a number (a comment may follow it: `s 1#c`); digits past u32 are
                // a group too (the largest).
                let word = w.next().map(|n| n.split('#').next().unwrap_or(""));
                p.smoothing_group = match word {
                    Some("off") => 0,
                    Some(n) if !n.is_empty() && n.bytes().all(|b| b.is_ascii_digit()) => n
                        .parse::<u64>()
                        .map_or(NO_SMOOTHING_GROUP - 1, |n| n.min(u64::from(NO_SMOOTHING_GROUP - 1)) as u32),
                    _ => NO_SMOOTHING_GROUP,
                };
            }
            "o" | "g" => {
                if p.faces > 0 {
                    p.end_model()?;
                }
                // After the line's first character (whitespace before the keyword is part of
                // the name then), trimmed.
                let first = line.chars().next().map_or(0, char::len_utf8);
                let name = line.get(first..).unwrap_or("").trim();
                p.name.clear();
                p.name.push_str(if name.is_empty() { UNNAMED } else { name });
            }
            "mtllib" => {
                let result = material_loader(Path::new(after_first_space(line)));
                p.materials.merge(result);
            }
            "usemtl" => {
                let name = after_first_space(line);
                if name.is_empty() {
                    return Err(LoadError::MaterialParseError);
                }
                let material = p.materials.index.get(name).copied();
                if p.material_id != material && p.faces > 0 {
                    p.end_model()?;
                }
                p.material_id = material;
            }
            _ => {}
        }
    }
    // The last model ends with the text, faces or not.
    p.end_model()?;
    let smoothing = if p.any_smoothing { p.smoothing } else { vec![Vec::new(); p.models.len()] };
    Ok(Obj { models: p.models, materials: p.materials.into_result(), uv_named: p.uv_named, smoothing })
}

/// The text after a line's first space, trimmed (`""` without a space): tobj's `usemtl` and
/// `mtllib` name (the line check in `obj_import` reads it here too).
pub(crate) fn after_first_space(line: &str) -> &str {
    line.split_once(' ').map_or("", |(_, name)| name.trim())
}

/// `str::parse::<isize>` on ASCII bytes: an optional `+` or `-`, then at least one decimal
/// digit, the value in range; `None` otherwise.
fn parse_isize(text: &[u8]) -> Option<isize> {
    let (negative, digits) = match text {
        [b'-', rest @ ..] => (true, rest),
        [b'+', rest @ ..] => (false, rest),
        _ => (false, text),
    };
    if digits.is_empty() {
        return None;
    }
    let mut x: isize = 0;
    for &b in digits {
        let d = b.wrapping_sub(b'0');
        if d > 9 {
            return None;
        }
        x = x.checked_mul(10)?;
        // Negative values are summed down, so `isize::MIN` is read too.
        x = if negative { x.checked_sub(isize::from(d))? } else { x.checked_add(isize::from(d))? };
    }
    Some(x)
}

/// Appends the next `N` words as numbers to `out`; `None` when there are fewer or one is not a
/// number (the load fails then, so what was appended does not matter).
fn read_floats<const N: usize>(w: &mut Words<'_>, out: &mut Vec<f32>) -> Option<()> {
    for _ in 0..N {
        out.push(w.next()?.parse().ok()?);
    }
    Some(())
}

/// The materials of the libraries read so far (tobj's `TmpMaterials`).
#[derive(Debug, Default)]
struct Materials {
    all: Vec<Material>,
    /// Name → index in `all`; a later library's name wins.
    index: HashMap<String, usize>,
    /// The last loader error.
    error: Option<LoadError>,
}

impl Materials {
    fn merge(&mut self, result: MTLLoadResult) {
        match result {
            Ok((mut materials, names)) => {
                let offset = self.all.len();
                self.all.append(&mut materials);
                self.index.extend(names.into_iter().map(|(name, i)| (name, i + offset)));
            }
            Err(e) => self.error = Some(e),
        }
    }

    fn into_result(self) -> Result<Vec<Material>, LoadError> {
        match self.error {
            Some(e) if self.all.is_empty() => Err(e),
            _ => Ok(self.all),
        }
    }
}

/// The parse state: the file's definitions so far, the models ended, and the current model.
#[derive(Debug)]
struct Parser {
    /// x y z per `v` line (divided by w), in file order.
    positions: Vec<f32>,
    /// The colour values of all `v` lines, in file order (not necessarily three per vertex).
    colours: Vec<f32>,
    /// u v per `vt` line.
    texcoords: Vec<f32>,
    /// x y z per `vn` line.
    normals: Vec<f32>,
    models: Vec<Model>,
    /// [`Obj::uv_named`] of the models ended.
    uv_named: Vec<Vec<bool>>,
    materials: Materials,
    /// The current model's name and material.
    name: String,
    material_id: Option<usize>,
    /// Faces of the current model, points and lines included.
    faces: usize,
    /// The current model's corners (as vertex numbers), faces of three or more corners.
    indices: Vec<u32>,
    /// Corner count per face of three or more corners.
    arities: Vec<u32>,
    /// No face of the current model has other than three corners.
    all_triangles: bool,
    /// The current model's distinct corners, in the order of first use: vertex i is `unique[i]`.
    unique: Vec<Corner>,
    /// Position index → (generation, vertex number) of the current model's first corner with
    /// that position, when its generation is `generation` (see [`Parser::number`]).
    first: Vec<(u32, u32)>,
    /// The current model's generation (never 0: 0 marks an unused `first` entry).
    generation: u32,
    /// Corner → its vertex number in the current model, for the corners not in `first`.
    numbers: HashMap<Corner, u32, FoldKey>,
    /// A corner of the current model named a position not yet defined.
    ahead: bool,
    /// The corners of the face being read (reused).
    face: Vec<Corner>,
    /// The `s` group in force, per face of the current model, per model ended
    /// ([`Obj::smoothing`]), and whether the file had an `s` line.
    smoothing_group: u32,
    face_groups: Vec<u32>,
    smoothing: Vec<Vec<u32>>,
    any_smoothing: bool,
}

impl Default for Parser {
    fn default() -> Self {
        Parser {
            positions: Vec::new(),
            colours: Vec::new(),
            texcoords: Vec::new(),
            normals: Vec::new(),
            models: Vec::new(),
            uv_named: Vec::new(),
            smoothing_group: NO_SMOOTHING_GROUP,
            face_groups: Vec::new(),
            smoothing: Vec::new(),
            any_smoothing: false,
            materials: Materials::default(),
            name: UNNAMED.to_string(),
            material_id: None,
            faces: 0,
            indices: Vec::new(),
            arities: Vec::new(),
            all_triangles: true,
            unique: Vec::new(),
            first: Vec::new(),
            generation: 1,
            numbers: HashMap::default(),
            ahead: false,
            face: Vec::new(),
        }
    }
}

impl Parser {
    /// A `v` line's values (after the keyword).
    fn vertex(&mut self, mut w: Words<'_>) -> Result<(), LoadError> {
        read_floats::<3>(&mut w, &mut self.positions).ok_or(LoadError::PositionParseError)?;
        let Some(first) = w.next() else { return Ok(()) };
        match (w.next(), w.next()) {
            (None, _) => {
                let weight: f32 = first.parse().map_err(|_| LoadError::PositionParseError)?;
                if weight == 0.0 {
                    return Err(LoadError::ScalingByZeroError);
                }
                let n = self.positions.len();
                for x in &mut self.positions[n - 3..] {
                    *x /= weight;
                }
            }
            (Some(_), None) => return Err(LoadError::ColorParseError),
            (Some(second), Some(third)) => {
                if w.next().is_some() {
                    return Err(LoadError::ColorParseError);
                }
                // Up to the first value that is not a number, without an error.
                for value in [first, second, third] {
                    match value.parse() {
                        Ok(x) => self.colours.push(x),
                        Err(_) => break,
                    }
                }
            }
        }
        Ok(())
    }

    /// An `f` or `l` line's corners (after the keyword).
    fn face(&mut self, w: Words<'_>) -> Result<(), LoadError> {
        let defined = [self.positions.len() / 3, self.texcoords.len() / 2, self.normals.len() / 3];
        self.face.clear();
        for corner in w {
            let mut at = [ABSENT; 3];
            for (slot, text) in corner.as_bytes().split(|&b| b == b'/').enumerate() {
                if text.is_empty() {
                    continue;
                }
                let x = parse_isize(text).ok_or(LoadError::FaceParseError)?;
                let Some(index) = at.get_mut(slot) else { return Err(LoadError::FaceParseError) };
                // n − 1, or back from the count for n < 0 (0 wraps to ABSENT, as in tobj).
                *index = if x < 0 { (defined[slot] as isize + x) as usize } else { (x - 1) as usize };
            }
            self.face.push(Corner { v: at[0], vt: at[1], vn: at[2] });
        }
        self.faces += 1;
        let n = self.face.len();
        // Points and lines are ignored (but counted above).
        if n == 1 || n == 2 {
            return Ok(());
        }
        for i in 0..n {
            let number = self.number(self.face[i], defined[0]);
            self.indices.push(number);
        }
        self.all_triangles &= n == 3;
        self.arities.push(n as u32);
        self.face_groups.push(self.smoothing_group);
        Ok(())
    }

    /// The vertex number of `corner` in the current model (a new one, the next, for a corner
    /// not used in it before: numbered in the order of first use). `defined` is the number of
    /// positions read so far.
    ///
    /// The first corner of the model with each position (`v` < `defined`) is found through
    /// `first` (no hashing: most files use a position with one texture coordinate and normal);
    /// any other corner of that position, and every corner whose `v` is not defined yet, through
    /// `numbers`. Such a corner can be defined later in the model (a face naming a vertex ahead
    /// of it, which tobj allows), so once one is seen (`ahead`), a corner new to `first` is
    /// looked up in `numbers` too.
    fn number(&mut self, corner: Corner, defined: usize) -> u32 {
        let next = self.unique.len() as u32;
        if corner.v < defined {
            if self.first.len() < defined {
                self.first.resize(defined, (0, 0));
            }
            let generation = self.generation;
            if let Some(slot) = self.first.get_mut(corner.v) {
                if slot.0 != generation {
                    let known = if self.ahead { self.numbers.get(&corner).copied() } else { None };
                    let number = known.unwrap_or(next);
                    *slot = (generation, number);
                    if known.is_none() {
                        self.unique.push(corner);
                    }
                    return number;
                }
                if self.unique.get(slot.1 as usize) == Some(&corner) {
                    return slot.1;
                }
            }
        } else {
            self.ahead = true;
        }
        match self.numbers.entry(corner) {
            Entry::Occupied(e) => *e.get(),
            Entry::Vacant(e) => {
                self.unique.push(corner);
                *e.insert(next)
            }
        }
    }

    /// Ends the current model: its vertices from the definitions read so far, in the order of
    /// their numbers (the bounds are checked in that order, as tobj checks each new vertex).
    fn end_model(&mut self) -> Result<(), LoadError> {
        let n = self.unique.len();
        let mut mesh = Mesh { material_id: self.material_id, ..Default::default() };
        mesh.positions.reserve(3 * n);
        for c in &self.unique {
            let p = definition(&self.positions, c.v, 3);
            mesh.positions.extend_from_slice(p.ok_or(LoadError::FaceVertexOutOfBounds)?);
            if !self.texcoords.is_empty() && c.vt != ABSENT {
                let t = definition(&self.texcoords, c.vt, 2);
                mesh.texcoords.extend_from_slice(t.ok_or(LoadError::FaceTexCoordOutOfBounds)?);
            }
            if !self.normals.is_empty() && c.vn != ABSENT {
                let m = definition(&self.normals, c.vn, 3);
                mesh.normals.extend_from_slice(m.ok_or(LoadError::FaceNormalOutOfBounds)?);
            }
            if !self.colours.is_empty() {
                let k = definition(&self.colours, c.v, 3);
                mesh.vertex_color.extend_from_slice(k.ok_or(LoadError::FaceColorOutOfBounds)?);
            }
        }
        let named = self.unique.iter().filter(|c| c.vt != ABSENT).count();
        let some = !self.texcoords.is_empty() && named > 0 && named < n;
        self.uv_named.push(if some { self.unique.iter().map(|c| c.vt != ABSENT).collect() } else { Vec::new() });
        mesh.indices = std::mem::take(&mut self.indices);
        mesh.face_arities = std::mem::take(&mut self.arities);
        self.smoothing.push(std::mem::take(&mut self.face_groups));
        if self.all_triangles {
            mesh.face_arities = Vec::new();
        }
        self.models.push(Model::new(mesh, self.name.clone()));
        self.faces = 0;
        self.all_triangles = true;
        self.unique.clear();
        // A map's `clear` costs its capacity: after a model that filled a large map, many small
        // models would each pay for it. A map much larger than its use is replaced instead, so
        // a model's end costs what the model used (regrowing is amortised in its insertions).
        if self.numbers.capacity() > 4 * self.numbers.len() + 64 {
            self.numbers = HashMap::default();
        } else {
            self.numbers.clear();
        }
        self.ahead = false;
        // A new generation leaves every `first` entry stale (cleared when the count wraps).
        self.generation = self.generation.wrapping_add(1);
        if self.generation == 0 {
            self.first.fill((0, 0));
            self.generation = 1;
        }
        Ok(())
    }
}

/// Definition `index` of `data`, `k` values each (`None` past the end).
fn definition(data: &[f32], index: usize, k: usize) -> Option<&[f32]> {
    let start = index.checked_mul(k)?;
    data.get(start..start.checked_add(k)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A model's end costs what the model used: after a model whose corners filled a large map,
    /// a small model's end leaves a small map, not the large one cleared (a clear costs the
    /// capacity, at every later model's end).
    #[test]
    fn a_small_model_after_a_large_one_does_not_keep_its_map() {
        let mut text = String::from("o big\n");
        for i in 0..3000 {
            text.push_str(&format!("v {i} 0 0\nvt 0 0\nvt 1 0\nvt 0 1\n"));
        }
        // Each position with three texture coordinates: two of each three corners go through the map.
        for i in 1..=3000 {
            let t = 3 * i - 2;
            text.push_str(&format!("f {i}/{t} {i}/{} {i}/{}\n", t + 1, t + 2));
        }
        let mut p = Parser::default();
        for line in text.lines() {
            if let Some(rest) = line.strip_prefix("v ") {
                p.vertex(words(rest)).unwrap();
            } else if let Some(rest) = line.strip_prefix("vt ") {
                read_floats::<2>(&mut words(rest), &mut p.texcoords).unwrap();
            } else if let Some(rest) = line.strip_prefix("f ") {
                p.face(words(rest)).unwrap();
            }
        }
        let used = p.numbers.len();
        assert!(used >= 6000, "{used}");
        // The model that filled the map keeps it, cleared: the next may need as much.
        p.end_model().unwrap();
        assert!(p.numbers.is_empty() && p.numbers.capacity() >= used, "{}", p.numbers.capacity());
        // A small model after it (two corners through the map) ends with a small map.
        p.face(words("1/1 1/2 1/3")).unwrap();
        assert_eq!(p.numbers.len(), 2);
        p.end_model().unwrap();
        assert!(p.numbers.capacity() < 256, "{}", p.numbers.capacity());
    }

    /// Each map's hasher starts from its own random key, so which corners share a bucket
    /// cannot be known from the file (and the same corner hashes alike within one map).
    #[test]
    fn each_corner_map_has_its_own_key() {
        use std::hash::BuildHasher;
        let corner = Corner { v: 7, vt: ABSENT, vn: 3 };
        let keys: Vec<FoldKey> = (0..4).map(|_| FoldKey::default()).collect();
        let hashes: std::collections::BTreeSet<u64> = keys.iter().map(|k| k.hash_one(corner)).collect();
        assert_eq!(hashes.len(), 4, "{keys:?}");
        assert_eq!(keys[0].hash_one(corner), keys[0].hash_one(corner));
    }

    /// [`Words`] splits as `str::split_whitespace` does, every whitespace character included.
    #[test]
    fn words_split_as_split_whitespace() {
        let spaces: Vec<char> = (0..=0x3000u32).filter_map(char::from_u32).filter(|c| c.is_whitespace()).collect();
        assert_eq!(spaces.len(), 25, "{spaces:?}");
        let mut lines = vec![String::new(), " ".into(), "f 1 2 3".into(), "  v\t1  2 3 \r".into(), "é x\u{85}y".into()];
        // Every ASCII byte (the table's classes) and words that start or end with a wide character.
        lines.push((0..0x80u8).map(char::from).flat_map(|c| [c, 'a']).collect());
        lines.extend(
            ["é", "\u{3000}", "a\u{a0}", " \u{2028}x", "\u{b}v\u{c}1\u{85}", "x\u{1c}\u{1d}\u{1e}\u{1f}y", "éé é\té"]
                .map(String::from),
        );
        for &c in &spaces {
            lines.push(format!("{c}a{c}{c}bé{c}\u{200b}c{c}"));
            lines.push(format!("v{c}1"));
        }
        // Not whitespace for `char::is_whitespace`: zero-width space, BOM, NUL, 0x1C–0x1F.
        lines.push("a\u{200b}b\u{feff}c\u{0}d\u{1c}e\u{1f}f".into());
        for line in &lines {
            assert_eq!(words(line).collect::<Vec<_>>(), line.split_whitespace().collect::<Vec<_>>(), "{line:?}");
            // Exhausted, it stays so.
            let mut w = words(line);
            w.by_ref().for_each(drop);
            assert_eq!(w.next(), None, "{line:?}");
        }
    }

    /// [`parse_isize`] answers as `str::parse::<isize>`.
    #[test]
    fn parse_isize_matches_std() {
        let max = isize::MAX.to_string();
        let min = isize::MIN.to_string();
        let over = format!("{max}0");
        let cases = [
            "0",
            "1",
            "-1",
            "+1",
            "-0",
            "+0",
            "00012",
            "-",
            "+",
            "",
            "--1",
            "+-1",
            "1-",
            "1a",
            " 1",
            "1 ",
            "١",
            "9",
            &max,
            &min,
            &over,
            "9223372036854775808",
            "-9223372036854775809",
            "18446744073709551616",
        ];
        for c in cases {
            assert_eq!(parse_isize(c.as_bytes()), c.parse::<isize>().ok(), "{c:?}");
        }
    }
}
