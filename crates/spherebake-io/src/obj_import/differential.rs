//! The differential test of [`crate::obj_parse::load_obj`] against `tobj::load_obj_buf` 4.0.5
//! (the oracle; tobj stays a dependency for MTL files): on text that has passed
//! [`check_lines`] and been rewritten by [`tobj_text`] (the path `import` takes), every field of
//! every model and mesh (floats by their bits), the materials result, and the loader's calls
//! (names, in order) are equal. Inputs: generated OBJ texts (SplitMix64), every OBJ under
//! `../shared/models` and `fixtures`, and the fuzz seed corpora. The raw generated texts (not
//! checked) and random token soup are compared too where tobj does not panic on them: errors
//! included, the parse answers as tobj does beyond what the check lets through.

use std::cell::RefCell;
use std::path::{Path, PathBuf};

use spherebake_testkit::rng::SplitMix64;

use super::{check_lines, mtl_colours_ok, text_of, tobj_text};
use crate::obj_parse::{load_obj, tobj_options};

/// A model as comparable data: every field of `tobj::Model` and its `tobj::Mesh`, floats as
/// bits (so NaN, −0 and +0 compare exactly).
#[derive(Debug, PartialEq, Eq)]
struct Flat {
    name: String,
    material_id: Option<usize>,
    positions: Vec<u32>,
    vertex_color: Vec<u32>,
    normals: Vec<u32>,
    texcoords: Vec<u32>,
    indices: Vec<u32>,
    face_arities: Vec<u32>,
    texcoord_indices: Vec<u32>,
    normal_indices: Vec<u32>,
}

fn bits(v: &[f32]) -> Vec<u32> {
    v.iter().map(|x| x.to_bits()).collect()
}

fn flat(m: &tobj::Model) -> Flat {
    let tobj::Model { mesh, name } = m;
    // Every field by name: a field added to tobj's `Mesh` fails to build here.
    let tobj::Mesh {
        positions,
        vertex_color,
        normals,
        texcoords,
        indices,
        face_arities,
        texcoord_indices,
        normal_indices,
        material_id,
    } = mesh;
    Flat {
        name: name.clone(),
        material_id: *material_id,
        positions: bits(positions),
        vertex_color: bits(vertex_color),
        normals: bits(normals),
        texcoords: bits(texcoords),
        indices: indices.clone(),
        face_arities: face_arities.clone(),
        texcoord_indices: texcoord_indices.clone(),
        normal_indices: normal_indices.clone(),
    }
}

/// A material as text, its unknown parameters sorted (a `HashMap`'s order is not its content).
fn material_key(m: &tobj::Material) -> String {
    let mut m = m.clone();
    let mut unknown: Vec<(String, String)> = std::mem::take(&mut m.unknown_param).into_iter().collect();
    unknown.sort();
    format!("{m:?} {unknown:?}")
}

type Outcome = Result<(Vec<Flat>, Result<Vec<String>, tobj::LoadError>), tobj::LoadError>;

fn outcome(r: tobj::LoadResult) -> Outcome {
    r.map(|(models, materials)| {
        (models.iter().map(flat).collect(), materials.map(|m| m.iter().map(material_key).collect()))
    })
}

/// Where two outcomes first differ (short: a model of a large file is not printed whole).
fn difference(ours: &Outcome, theirs: &Outcome) -> String {
    let short = |s: String| s.chars().take(600).collect::<String>();
    match (ours, theirs) {
        (Ok((a, ma)), Ok((b, mb))) => {
            if a.len() != b.len() {
                let names = |m: &[Flat]| m.iter().map(|m| m.name.clone()).collect::<Vec<_>>();
                return short(format!("{} models vs {}: {:?} vs {:?}", a.len(), b.len(), names(a), names(b)));
            }
            for (i, (x, y)) in a.iter().zip(b).enumerate() {
                if x != y {
                    let fields: [(&str, String, String); 10] = [
                        ("name", format!("{:?}", x.name), format!("{:?}", y.name)),
                        ("material_id", format!("{:?}", x.material_id), format!("{:?}", y.material_id)),
                        ("positions", format!("{:?}", x.positions), format!("{:?}", y.positions)),
                        ("vertex_color", format!("{:?}", x.vertex_color), format!("{:?}", y.vertex_color)),
                        ("normals", format!("{:?}", x.normals), format!("{:?}", y.normals)),
                        ("texcoords", format!("{:?}", x.texcoords), format!("{:?}", y.texcoords)),
                        ("indices", format!("{:?}", x.indices), format!("{:?}", y.indices)),
                        ("face_arities", format!("{:?}", x.face_arities), format!("{:?}", y.face_arities)),
                        ("texcoord_indices", format!("{:?}", x.texcoord_indices), format!("{:?}", y.texcoord_indices)),
                        ("normal_indices", format!("{:?}", x.normal_indices), format!("{:?}", y.normal_indices)),
                    ];
                    let (field, p, q) = fields.into_iter().find(|(_, p, q)| p != q).unwrap_or_default();
                    return format!("model {i}: {field}: ours {} tobj {}", short(p), short(q));
                }
            }
            short(format!("materials: ours {ma:?} tobj {mb:?}"))
        }
        _ => short(format!("ours {:?} tobj {:?}", ours.as_ref().err(), theirs.as_ref().err())),
    }
}

/// A material loader for the tests: the same for both parses, each recording its calls.
type Loader<'a> = &'a dyn Fn(&Path) -> tobj::MTLLoadResult;

/// Both parses of `text`, asserted equal (and the loader called with the same names in the same
/// order); tobj's answer, or `None` when tobj panicked and `guard` was set (then ours must just
/// not panic).
fn both(text: &str, mtl: Loader<'_>, label: &str, guard: bool) -> Option<Outcome> {
    let our_calls = RefCell::new(Vec::<PathBuf>::new());
    let ours = outcome(
        load_obj(text, |p: &Path| {
            our_calls.borrow_mut().push(p.to_path_buf());
            mtl(p)
        })
        .map(|o| (o.models, o.materials)),
    );
    let their_calls = RefCell::new(Vec::<PathBuf>::new());
    let tobj_run = || {
        outcome(tobj::load_obj_buf(&mut std::io::Cursor::new(text.as_bytes()), &tobj_options(), |p: &Path| {
            their_calls.borrow_mut().push(p.to_path_buf());
            mtl(p)
        }))
    };
    let theirs = if guard {
        // tobj overflows (a panic in this profile) on some index arithmetic the check refuses.
        std::panic::catch_unwind(std::panic::AssertUnwindSafe(tobj_run)).ok()?
    } else {
        tobj_run()
    };
    if ours != theirs {
        panic!("{label}: {}\ntext: {:?}", difference(&ours, &theirs), text.chars().take(3000).collect::<String>());
    }
    assert_eq!(our_calls.into_inner(), their_calls.into_inner(), "{label}: loader calls");
    Some(theirs)
}

/// `text` as `import` hands it to the parse: checked ([`check_lines`]; `None` when refused),
/// then rewritten ([`tobj_text`]); both parses compared on that.
fn checked_both(text: &str, mtl: Loader<'_>, label: &str) -> Option<Outcome> {
    let rewrite = check_lines(Path::new("t.obj"), text).ok()?;
    let fed = tobj_text(text, &rewrite);
    both(&fed, mtl, label, false)
}

/// The generated texts' libraries: `a.mtl` (red, green), `b.mtl` (green again, blue), `e.mtl`
/// (no materials), `bad.mtl` (a parse error); any other name cannot be opened.
fn fake_library(p: &Path) -> tobj::MTLLoadResult {
    let material = |name: &str, r: f32| tobj::Material {
        name: name.to_string(),
        diffuse: Some([r, 0.5, 0.25]),
        dissolve: Some(1.0),
        ..Default::default()
    };
    let library = |all: Vec<tobj::Material>| {
        let index = all.iter().enumerate().map(|(i, m)| (m.name.clone(), i)).collect();
        Ok((all, index))
    };
    match p.to_str() {
        Some("a.mtl") => library(vec![material("red", 1.0), material("green", 0.0)]),
        Some("b.mtl") => library(vec![material("green", 0.125), material("blue", 0.75)]),
        Some("e.mtl") => library(Vec::new()),
        Some("bad.mtl") => Err(tobj::LoadError::MaterialParseError),
        _ => Err(tobj::LoadError::OpenFileFailed),
    }
}

/// Uniform in 0..n.
fn below(rng: &mut SplitMix64, n: u64) -> u64 {
    rng.next_u64() % n
}

fn pick<'a>(rng: &mut SplitMix64, items: &[&'a str]) -> &'a str {
    items[below(rng, items.len() as u64) as usize]
}

/// A number as an OBJ exporter might write it (and some forms they rarely do).
fn number(rng: &mut SplitMix64) -> String {
    let x = rng.range(-4.0, 4.0);
    match below(rng, 20) {
        0 => "0".to_string(),
        1 => "-0".to_string(),
        2 => format!("{:e}", x),
        3 => format!("+{:.2}", x.abs()),
        4 => ".5".to_string(),
        5 => format!("{}", x as f32),
        _ => format!("{x:.6}"),
    }
}

/// An index into `n` definitions: absolute or relative (negative); rarely one the check
/// refuses (0, one past, or before the first), and often one past when `ahead`.
fn index(rng: &mut SplitMix64, n: i64, ahead: bool) -> String {
    if ahead && below(rng, 8) == 0 {
        // Past the definitions so far (defined later, or never): the check refuses it.
        return format!("{}", n + 1 + below(rng, 3) as i64);
    }
    match below(rng, 4000) {
        0 => "0".to_string(),
        1 => format!("{}", n + 1),
        2 => format!("-{}", n + 1),
        _ if n == 0 => "1".to_string(),
        k if k < 120 => format!("-{}", 1 + below(rng, n.min(12) as u64)),
        _ => format!("{}", 1 + below(rng, n as u64)),
    }
}

/// The colour values of a file's `v` lines: none, on all (so tobj keeps them), on some
/// (the check has them dropped), or now and then one that is not a number.
#[derive(Clone, Copy, PartialEq)]
enum Colours {
    None,
    All,
    Some,
    Bad,
}

/// A random OBJ text: `v` (with w, colours, comments), `vt` (two or three values), `vn`, faces
/// of 3 to 8 corners in every index form (one per face, or mixed), absolute and negative
/// indices, `o` / `g` with and without names (repeated, with tabs, leading whitespace, `#`),
/// `usemtl` (known, unknown, before and after its `mtllib`, mid-group), `mtllib`, `s`, `l`,
/// comments, blank and whitespace lines, trailing spaces and tabs, CRLF, Unicode whitespace,
/// `\`-continued faces, other keywords, and a last line with or without its line end.
fn random_obj(rng: &mut SplitMix64) -> String {
    let colours = [Colours::None, Colours::None, Colours::All, Colours::Some, Colours::Bad][below(rng, 5) as usize];
    let (mut nv, mut nt, mut nn) = (0i64, 0i64, 0i64);
    // Now and then a file whose faces name vertices ahead of their definitions.
    let ahead = below(rng, 10) == 0;
    let mut s = String::new();
    if below(rng, 3) == 0 {
        s.push_str("# generated\n");
    }
    let lines = 3 + below(rng, 150);
    // Faces lean on vertices: start with a few.
    let start = below(rng, 8);
    for i in 0..lines {
        let mut kind = if i < start { 0 } else { below(rng, 100) };
        if nv == 0 && (36..=63).contains(&kind) && below(rng, 8) > 0 {
            // A face before any vertex: now and then (the check refuses it).
            kind = 0;
        }
        let line: String = match kind {
            0..=21 => {
                nv += 1;
                let mut v = format!("v {} {} {}", number(rng), number(rng), number(rng));
                let coloured = match colours {
                    Colours::None => false,
                    Colours::All | Colours::Bad => true,
                    Colours::Some => below(rng, 2) == 0,
                };
                if coloured {
                    let bad = colours == Colours::Bad && below(rng, 10) == 0;
                    let c = |rng: &mut SplitMix64| format!("{:.3}", rng.next_f64());
                    v += &format!(" {} {} {}", c(rng), if bad { "x".to_string() } else { c(rng) }, c(rng));
                } else if colours != Colours::All && below(rng, 12) == 0 {
                    v += pick(rng, &[" 2", " 0.5", " -1", " 1"]);
                }
                if below(rng, 30) == 0 {
                    v += " # a vertex";
                }
                v
            }
            22..=28 => {
                nt += 1;
                let w = if below(rng, 6) == 0 { " 0" } else { "" };
                format!("vt {:.4} {:.4}{w}", rng.next_f64(), rng.next_f64())
            }
            29..=35 => {
                nn += 1;
                format!("vn {} {} {}", number(rng), number(rng), number(rng))
            }
            36..=63 => {
                let arity = match below(rng, 10) {
                    0..=4 => 3,
                    5..=7 => 4,
                    _ => 5 + below(rng, 4),
                };
                // 0 v, 1 v/vt, 2 v//vn, 3 v/vt/vn, 4 mixed per corner.
                let form = below(rng, 5);
                let mut f = String::from("f");
                for _ in 0..arity {
                    let form = if form == 4 { below(rng, 4) } else { form };
                    let v = index(rng, nv, ahead);
                    let corner = match form {
                        1 if nt > 0 => format!("{v}/{}", index(rng, nt, ahead)),
                        2 if nn > 0 => format!("{v}//{}", index(rng, nn, ahead)),
                        3 if nt > 0 && nn > 0 => format!("{v}/{}/{}", index(rng, nt, ahead), index(rng, nn, ahead)),
                        _ => match below(rng, 40) {
                            0 => format!("{v}/"),
                            1 => format!("{v}//"),
                            _ => v,
                        },
                    };
                    f.push(if below(rng, 25) == 0 { '\t' } else { ' ' });
                    f += &corner;
                }
                if below(rng, 40) == 0 {
                    f += " # a face";
                }
                f
            }
            64..=71 => {
                let key = pick(rng, &["o", "g"]);
                match below(rng, 12) {
                    0 => key.to_string(),
                    1 => format!("{key} "),
                    2 => format!("{key}\tpart"),
                    3 => format!(" {key} indented"),
                    4 => format!("{key} two words"),
                    5 => format!("{key} name # note"),
                    6 => format!("{key}  \t "),
                    _ => format!("{key} {}", pick(rng, &["body", "wheel", "body", "lid", "x"])),
                }
            }
            72..=77 => match below(rng, 8) {
                0 => "usemtl nothere".to_string(),
                1 => "usemtl\tred".to_string(),
                2 => "usemtl  blue ".to_string(),
                _ => format!("usemtl {}", pick(rng, &["red", "green", "blue"])),
            },
            78..=80 => format!("mtllib {}", pick(rng, &["a.mtl", "b.mtl", "a.mtl", "e.mtl", "bad.mtl", "none.mtl"])),
            81..=83 => pick(rng, &["s 1", "s off", "s 0", "s 2"]).to_string(),
            84..=87 => pick(rng, &["# comment", "#", "#no space", "   # indented", "# f 1 2 3"]).to_string(),
            88..=91 => pick(rng, &["", "", " ", "\t", " \t "]).to_string(),
            92 => format!("l {} {}", index(rng, nv, ahead), index(rng, nv, ahead)),
            93 if nv > 0 => {
                format!("f {} \\\n{} {}", index(rng, nv, ahead), index(rng, nv, ahead), index(rng, nv, ahead))
            }
            94 if nv > 0 => {
                let ws = pick(rng, &["\u{a0}", "\u{3000}", "\u{0b}", "\u{0c}", "\u{2009}"]);
                format!("f{ws}{}{ws}{} {}", index(rng, nv, ahead), index(rng, nv, ahead), index(rng, nv, ahead))
            }
            95 => pick(rng, &["vp 0.5 0.5", "cstype bezier", "usemap tex", "lod 1", "V 1 2 3", "F 1 2 3"]).to_string(),
            96 => {
                nv += 1;
                "\u{0b}v 1 2 3".to_string()
            }
            _ => {
                // An empty group between two, or a material switch with no face.
                pick(rng, &["g empty\ng next", "o a\no a", "usemtl red\nusemtl green", "g\ng"]).to_string()
            }
        };
        s += &line;
        if below(rng, 12) == 0 {
            s += pick(rng, &[" ", "\t", "  \t"]);
        }
        if i + 1 < lines || below(rng, 3) > 0 {
            s += if below(rng, 5) == 0 { "\r\n" } else { "\n" };
        }
    }
    s
}

/// Random token soup: keywords, numbers, slashes, signs, huge and odd indices, names, line ends
/// (no structure: most of it is refused by the check; the raw comparison is the point).
fn soup(rng: &mut SplitMix64) -> String {
    let tokens = [
        "v",
        "vt",
        "vn",
        "f",
        "l",
        "o",
        "g",
        "usemtl",
        "mtllib",
        "s",
        "#",
        " ",
        " ",
        " ",
        "\t",
        "\n",
        "\n",
        "\r\n",
        "\r",
        "1",
        "2",
        "3",
        "-1",
        "-2",
        "0",
        "/",
        "//",
        "1/1",
        "1//1",
        "1/1/1",
        "-1/-1/-1",
        "a.mtl",
        "red",
        "x",
        "1e39",
        "nan",
        "inf",
        "+1",
        "-0",
        "99999999999999999999",
        "9223372036854775807",
        "-9223372036854775808",
        "3074457345618258603",
        "6148914691236517206",
        "0.5",
        "\u{a0}",
        "é",
    ];
    let n = below(rng, 200);
    (0..n).map(|_| pick(rng, &tokens)).collect()
}

/// Tallies of what the generated inputs covered.
#[derive(Debug, Default)]
struct Seen {
    accepted: usize,
    refused: usize,
    many_models: usize,
    polygons: usize,
    colours: usize,
    texcoords: usize,
    normals: usize,
    materials: usize,
    unnamed: usize,
    /// A model with no faces (the last one, or one of points and lines only).
    empty: usize,
    material_errors: usize,
}

impl Seen {
    fn add(&mut self, o: &Outcome) {
        let Ok((models, materials)) = o else { return };
        self.accepted += 1;
        self.many_models += usize::from(models.len() > 2);
        self.polygons += usize::from(models.iter().any(|m| !m.face_arities.is_empty()));
        self.colours += usize::from(models.iter().any(|m| !m.vertex_color.is_empty()));
        self.texcoords += usize::from(models.iter().any(|m| !m.texcoords.is_empty()));
        self.normals += usize::from(models.iter().any(|m| !m.normals.is_empty()));
        self.materials += usize::from(models.iter().any(|m| m.material_id.is_some()));
        self.unnamed += usize::from(models.iter().any(|m| m.name == "unnamed_object"));
        self.empty += usize::from(models.iter().any(|m| m.indices.is_empty()));
        self.material_errors += usize::from(materials.is_err());
    }
}

#[test]
fn the_parse_reads_generated_obj_text_as_tobj_does() {
    let mut rng = SplitMix64::new(0x0b1_9a45e);
    let mut seen = Seen::default();
    let (mut raw, mut raw_errors, mut raw_read_refused) = (0usize, 0usize, 0usize);
    for case in 0..3000 {
        let text = random_obj(&mut rng);
        let refused = match checked_both(&text, &fake_library, &format!("case {case}")) {
            Some(o) => {
                seen.add(&o);
                false
            }
            None => {
                seen.refused += 1;
                true
            }
        };
        // The text as generated, unchecked: tobj's answer too (where tobj does not panic).
        if let Some(o) = both(&text, &fake_library, &format!("raw case {case}"), true) {
            raw += 1;
            raw_errors += usize::from(o.is_err());
            // Read by tobj though refused by the check: an index ahead of its definition, say.
            raw_read_refused += usize::from(refused && o.is_ok());
        }
    }
    for case in 0..3000 {
        let text = soup(&mut rng);
        if let Some(o) = both(&text, &fake_library, &format!("soup {case}"), true) {
            raw += 1;
            raw_errors += usize::from(o.is_err());
        }
        let _ = checked_both(&text, &fake_library, &format!("checked soup {case}"));
    }
    eprintln!(
        "{seen:?}; raw comparisons {raw} ({raw_errors} errors, {raw_read_refused} read but refused by the check)"
    );
    let s = &seen;
    assert!(
        s.accepted > 2000
            && s.refused > 100
            && s.many_models > 1000
            && s.polygons > 1500
            && s.colours > 200
            && s.texcoords > 1500
            && s.normals > 1500
            && s.materials > 600
            && s.unnamed > 1500
            && s.empty > 500
            && s.material_errors > 150
            && raw > 5000
            && raw_errors > 1500
            && raw_read_refused > 5,
        "coverage: {seen:?}; raw {raw} ({raw_errors} errors)"
    );
}

/// Hand-written texts for what tobj reads that the check refuses or the generator rarely makes,
/// compared as they are: faces naming vertices defined later in their model (the same corner
/// used before and after its position is defined, with and without the first corner of that
/// position), `v` with w, colours on some vertices only or cut short, models that end empty,
/// names after leading whitespace, `\r` without `\n`, an empty text.
#[test]
fn the_parse_reads_hand_written_edge_cases_as_tobj_does() {
    let cases = [
        "v 0 0 0\nv 1 0 0\nf 1 2 3\nf 3 1 2\nv 0 1 0\nf 3 2 1\n",
        "v 0 0 0\nf 1 2 3\nf 2 3 1\nv 1 0 0\nf 2 1 2\nv 0 1 0\nvt 0 0\nf 3/1 3 1/1\n",
        "v 0 0 0\nvt 0 0\nf 1 1/1 2\nv 1 1 1\nf 2 2/1 1/1\nv 2 2 2\ng next\nf 3 1 2\n",
        "v 1 2 3 2\nv 1 2 3 -0.5\nv 1 2 3 1e-30\nf 1 2 3\n",
        "v 0 0 0 1 0 0\nv 1 0 0\nv 0 1 0 0 0 1\nf 1 2 3\n",
        "v 0 0 0 1 0 0\nv 1 0 0 0.5 x 1\nv 0 1 0 0 0 1\nv 0 0 1 1 1 1\nf 1 2 3\n",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\ng\n",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\n g  lead\nf 1 2 3\n\to tab\nf 3 2 1\n",
        "v 0 0 0\rv 1 0 0\rf 1 2 3\r",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\r",
        "",
        "\n\n",
        "g only a name",
        "v 0 0 0\nf 1 1 1\nf 1\nf 1 1\ng a\nf 1\ng b\nf 1 1 1 1\n",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl red\nf 1 2 3\nmtllib a.mtl\nusemtl red\nf 1 2 3\nusemtl red\nf 1 2 3\n",
        "mtllib b.mtl\nmtllib a.mtl\nv 0 0 0\nusemtl green\nf 1 1 1\nmtllib bad.mtl\nusemtl blue\nf 1 1 1\n",
        "v 0 0 0\nvn 0 0 1\nvt 0 0\nf 1/1/1 1//1 1/1 1 -1/-1/-1 +1/+1/+1\n",
        "v 0 0 0\nf 1/1/1/ 1/ 1//\nf 1/1/1/1 1 1\n",
        "v 0 0 0\nf 0 1 1\n",
        "v 0 0 0\nvt 0 0\nf 1/0 1/1 1\n",
        "v 0 0 0\nf -2 1 1\n",
        "v 0 0 0\nf 99999999999999999999 1 1\n",
    ];
    for (i, text) in cases.iter().enumerate() {
        // tobj answers each (none panics).
        assert!(both(text, &fake_library, &format!("hand-written case {i}"), true).is_some(), "case {i}");
        let _ = checked_both(text, &fake_library, &format!("checked hand-written case {i}"));
    }
}

/// Every file under `dir` (recursively) for which `keep` holds, sorted.
fn files_under(dir: &Path, keep: &dyn Fn(&Path) -> bool, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    let mut paths: Vec<PathBuf> = entries.filter_map(|e| e.ok().map(|e| e.path())).collect();
    paths.sort();
    for p in paths {
        if p.is_dir() {
            files_under(&p, keep, out);
        } else if keep(&p) {
            out.push(p);
        }
    }
}

/// A file's libraries as `import` parses them: the bytes next to the OBJ (or, for a fuzz seed,
/// the text after its `#MTL` line under any name), tobj's MTL parse, a library whose colour
/// lines tobj would panic on refused.
fn library_of(dir: PathBuf, served: Option<Vec<u8>>) -> impl Fn(&Path) -> tobj::MTLLoadResult {
    move |p: &Path| {
        let bytes = match &served {
            Some(b) => b.clone(),
            None => std::fs::read(dir.join(p)).map_err(|_| tobj::LoadError::OpenFileFailed)?,
        };
        if !mtl_colours_ok(&bytes) {
            return Err(tobj::LoadError::MaterialParseError);
        }
        tobj::load_mtl_buf(&mut std::io::Cursor::new(text_of(&bytes).as_bytes()))
    }
}

#[test]
fn the_parse_reads_the_shared_models_fixtures_and_fuzz_seeds_as_tobj_does() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let obj = |p: &Path| p.extension().is_some_and(|e| e.eq_ignore_ascii_case("obj"));
    let mut files = Vec::new();
    if let Some(models) = spherebake_testkit::shared_models_dir() {
        files_under(&models, &obj, &mut files);
        assert!(files.len() >= 5, "{files:?}");
    }
    files_under(&root.join("fixtures"), &obj, &mut files);
    let seeds = files.len();
    for corpus in ["fuzz/seeds-obj", "fuzz/seeds"] {
        files_under(&root.join(corpus), &|_| true, &mut files);
    }
    assert!(files.len() >= seeds + 10, "{files:?}");
    let (mut accepted, mut triangles) = (0usize, 0usize);
    for path in &files {
        let bytes = std::fs::read(path).unwrap();
        let fuzz_seed = path.components().any(|c| c.as_os_str().to_str().is_some_and(|c| c.starts_with("seeds")));
        // A fuzz seed: the OBJ up to the `#MTL` line, the MTL served after it (the fuzz target's layout).
        let (obj_bytes, served) = match bytes.windows(6).position(|w| w == b"\n#MTL\n").filter(|_| fuzz_seed) {
            Some(i) => (&bytes[..i + 1], Some(bytes[i + 6..].to_vec())),
            None => (&bytes[..], fuzz_seed.then(Vec::new)),
        };
        let text = text_of(obj_bytes);
        let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        let loader = library_of(dir, served);
        let label = path.display().to_string();
        if let Some(o) = checked_both(&text, &loader, &label) {
            accepted += 1;
            if let Ok((models, _)) = &o {
                triangles += models.iter().map(|m| m.indices.len()).sum::<usize>();
            }
        }
        let _ = both(&text, &loader, &format!("raw {label}"), true);
    }
    eprintln!("{} files, {accepted} accepted by the check, {triangles} corners", files.len());
    assert!(accepted >= 6, "{accepted} of {files:?}");
}
