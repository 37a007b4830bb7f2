//! The C declarations of the specification (formats/spherebake-v1.md §14.3) cannot drift:
//!
//! - `include/spherebake_file.h` is exactly the spec's code blocks of §14.3 (SPHEREBAKE_BLESS=1
//!   rewrites it);
//! - a C11 program compiled with the system `cc` prints `sizeof`, `_Alignof`, and the `offsetof`,
//!   size and element type of every field named in the byte tables of §3–§11, which must equal the
//!   tables' Offset, Size and Type columns, cover each record without gaps, and agree with the
//!   format crate's constants and section kinds;
//! - the header compiles as C99 and C++17 together with `include/spherebake.h` (no name clashes);
//! - `examples/c/read_sphb.c`, which reads a file through these structs alone (no library), prints
//!   for the golden files and their compact versions exactly what the Rust reader reads.

use spherebake_format::{read, write_compact, SectionKind, ALIGN, HEADER_SIZE, SECTION_ENTRY_SIZE};
use std::fmt::Write as _;
use std::path::Path;
use std::process::Command;

mod common;
use common::{build, compiler, golden, hf, repo, tempdir};

const HEADING: &str = "### 14.3 C declarations";

fn spec() -> String {
    std::fs::read_to_string(repo().join("formats/spherebake-v1.md")).unwrap()
}

/// The ```c blocks under [`HEADING`] up to the next heading, joined by blank lines.
fn c_blocks(spec: &str) -> String {
    let mut lines = spec.lines().skip_while(|l| *l != HEADING);
    assert!(lines.next().is_some(), "the spec has no heading `{HEADING}`");
    let mut blocks = Vec::new();
    let mut current: Option<Vec<&str>> = None;
    for l in lines {
        match (&mut current, l) {
            (None, l) if l.starts_with('#') => break,
            (None, "```c") => current = Some(Vec::new()),
            (Some(b), "```") => {
                blocks.push(b.join("\n"));
                current = None;
            }
            (Some(b), l) => b.push(l),
            _ => {}
        }
    }
    assert!(current.is_none(), "unterminated code block under {HEADING}");
    assert!(!blocks.is_empty(), "no ```c block under {HEADING}");
    blocks.join("\n\n")
}

fn header_text(spec: &str) -> String {
    format!(
        "/* The .sphb v1 file records: the C declarations of formats/spherebake-v1.md §14.3, extracted by\n \
         * crates/spherebake-capi/tests/spec_structs.rs (do not edit; it compares). Little-endian fields. */\n\
         #ifndef SPHEREBAKE_FILE_H\n#define SPHEREBAKE_FILE_H\n\n{}\n\n#endif /* SPHEREBAKE_FILE_H */\n",
        c_blocks(spec)
    )
}

#[test]
fn committed_file_header_is_the_specs() {
    let want = header_text(&spec());
    let path = repo().join("include/spherebake_file.h");
    if std::env::var_os("SPHEREBAKE_BLESS").is_some() {
        std::fs::write(&path, &want).unwrap();
    }
    let got = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        got == want,
        "include/spherebake_file.h differs from the C blocks of the spec's §14.3; regenerate it with \
         SPHEREBAKE_BLESS=1 cargo test -p spherebake-capi --test spec_structs"
    );
}

/// One row of a byte table: offset, size, element type (`u32`, `f32`, …), element count, field.
#[derive(Debug, Clone)]
struct Row {
    offset: usize,
    size: usize,
    elem: String,
    count: usize,
    field: String,
}

/// A byte table (header `| Offset | Size | Type | Field | ...`) with the heading it is under, its
/// index among that heading's byte tables and the line before it.
#[derive(Debug)]
struct Table {
    heading: String,
    index: usize,
    caption: String,
    rows: Vec<Row>,
}

fn byte_tables(spec: &str) -> Vec<Table> {
    let lines: Vec<&str> = spec.lines().collect();
    let mut out: Vec<Table> = Vec::new();
    let mut heading = String::new();
    let mut i = 0;
    while i < lines.len() {
        let l = lines[i];
        if l.starts_with("## ") || l.starts_with("### ") {
            heading = l.to_string();
        }
        if l.starts_with("| Offset | Size | Type | Field |") {
            let caption = lines[..i].iter().rev().find(|c| !c.trim().is_empty()).unwrap_or(&"").to_string();
            let index = out.iter().filter(|t| t.heading == heading).count();
            let mut rows = Vec::new();
            i += 2; // the header and the separator
            while i < lines.len() && lines[i].starts_with('|') {
                let cells: Vec<&str> = lines[i].trim_matches('|').split('|').map(str::trim).collect();
                let (Ok(offset), Ok(size)) = (cells[0].parse::<usize>(), cells[1].parse::<usize>()) else {
                    i += 1;
                    continue; // a row whose offset or size is a formula (arrays after the sub-header)
                };
                let ty = cells[2];
                let (elem, count) = match ty.split_once('[') {
                    Some((e, n)) => (e.to_string(), n.trim_end_matches(']').parse().unwrap()),
                    None => (ty.to_string(), 1),
                };
                rows.push(Row { offset, size, elem, count, field: cells[3].to_string() });
                i += 1;
            }
            out.push(Table { heading: heading.clone(), index, caption, rows });
            continue;
        }
        i += 1;
    }
    out
}

/// Which table describes which struct; `sub_header`: only its rows inside the first 16 bytes.
const MAP: &[(&str, &str, usize, bool)] = &[
    ("SphbFileHeader", "## 3. Header", 0, false),
    ("SphbFileSectionEntry", "## 4. Section table", 0, false),
    ("SphbFileSpheresHeader", "## 5. Spheres", 0, true),
    ("SphbFileSphere", "## 5. Spheres", 1, false),
    ("SphbFileHierarchyHeader", "## 6. Hierarchy", 0, true),
    ("SphbFileNode", "## 6. Hierarchy", 1, false),
    ("SphbFileSamplesHeader", "## 7. Samples", 0, true),
    ("SphbFileSample", "## 7. Samples", 1, false),
    ("SphbFileSamplesHeader", "### 7.1 Compact samples", 0, true),
    ("SphbFileSampleBox", "### 7.1 Compact samples", 1, false),
    ("SphbFileSampleQ16", "### 7.1 Compact samples", 2, false),
    ("SphbFileSampleAreasHeader", "### 7.2 Sample areas", 0, true),
    ("SphbFileAlbedoShHeader", "## 8. Albedo SH", 0, true),
    ("SphbFileSkinHeader", "## 9. Skin", 0, true),
    ("SphbFileSkinSlot", "## 9. Skin", 1, false),
    ("SphbFileBonesHeader", "## 10. Bones", 0, true),
    ("SphbFileBone", "## 10. Bones", 1, false),
    ("SphbFileMetadataHeader", "## 11. Metadata", 0, true),
    ("SphbFileMetadataEntry", "## 11. Metadata", 1, false),
];

/// The record size a table states in its caption ("Sphere record (16 bytes):"), if any.
fn caption_size(caption: &str) -> Option<usize> {
    let (_, rest) = caption.split_once('(')?;
    rest.split_once(" bytes")?.0.parse().ok()
}

fn elem_size(ty: &str) -> usize {
    match ty {
        "u8" => 1,
        "u16" | "i16" => 2,
        "u32" | "f32" => 4,
        "u64" => 8,
        other => panic!("unknown element type {other}"),
    }
}

fn c_type_id() -> &'static str {
    // After lvalue conversion an array field is a pointer to its element type.
    "#define TYPE_ID(x) _Generic((x), uint8_t: \"u8\", uint8_t *: \"u8\", uint16_t: \"u16\", uint16_t *: \"u16\", \
     int16_t: \"i16\", int16_t *: \"i16\", uint32_t: \"u32\", uint32_t *: \"u32\", uint64_t: \"u64\", \
     uint64_t *: \"u64\", float: \"f32\", float *: \"f32\", default: \"?\")\n\
     #define ELEM_SIZE(t) (t[1] == '8' ? 1u : t[1] == '1' ? 2u : t[1] == '3' ? 4u : t[1] == '6' ? 8u : 0u)\n"
}

#[test]
fn spec_structs_match_the_byte_tables() {
    let cc = compiler("cc", "gcc");
    let spec = spec();
    let tables = byte_tables(&spec);
    let header = header_text(&spec);
    // Every struct the spec declares is checked against a table.
    let declared: Vec<&str> =
        header.lines().filter_map(|l| l.strip_prefix("} ")).map(|l| l.trim_end_matches(';')).collect();
    assert_eq!(declared.len(), 18, "{declared:?}");
    for d in &declared {
        assert!(MAP.iter().any(|m| m.0 == *d), "struct {d} of the spec is mapped to no byte table");
    }
    // What the C program must print, from the tables and the Rust constants.
    let mut program = String::from("#include <stddef.h>\n#include <stdio.h>\n#include \"spec_extracted.h\"\n");
    program += c_type_id();
    program += "int main(void) {\n";
    let mut want = String::new();
    for &(name, heading, index, sub_header) in MAP {
        let t = tables
            .iter()
            .find(|t| t.heading.starts_with(heading) && t.index == index)
            .unwrap_or_else(|| panic!("no byte table {index} under `{heading}`"));
        let rows: Vec<&Row> = t.rows.iter().filter(|r| !sub_header || r.offset < 16).collect();
        // The rows tile the record: contiguous from 0, sizes = count × element size.
        let mut end = 0;
        for r in &rows {
            assert_eq!(r.offset, end, "{heading} table {index}: `{}` does not start where the previous ends", r.field);
            end += r.size;
        }
        let size = if sub_header { ALIGN } else { end };
        assert_eq!(end, size, "{heading} table {index} rows cover {end} bytes");
        if let Some(c) = caption_size(&t.caption) {
            assert_eq!(c, size, "{heading} table {index}: caption `{}`", t.caption);
        }
        let _ = writeln!(program, "  printf(\"S {name} %zu\\n\", sizeof({name}));");
        let _ = writeln!(want, "S {name} {size}");
        for r in rows {
            let f = r.field.as_str();
            let _ = writeln!(
                program,
                "  {{ const char *t = TYPE_ID((({name} *)0)->{f}); printf(\"F {name} {f} %zu %zu %s %zu\\n\", \
                 offsetof({name}, {f}), sizeof((({name} *)0)->{f}), t, ELEM_SIZE(t) ? sizeof((({name} *)0)->{f}) / \
                 ELEM_SIZE(t) : 0); }}"
            );
            let _ = writeln!(want, "F {name} {f} {} {} {} {}", r.offset, r.size, r.elem, r.count);
        }
        // Natural alignment: the largest element (§14.2: 8 for the header and the entry, 2 for the
        // compact sample record, else 4).
        let align = t.rows.iter().filter(|r| !sub_header || r.offset < 16).map(|r| elem_size(&r.elem)).max().unwrap();
        let _ = writeln!(program, "  printf(\"A {name} %zu\\n\", (size_t)_Alignof({name}));");
        let _ = writeln!(want, "A {name} {align}");
    }
    // Section kinds: SPHB_KIND_<NAME> is the format crate's code of each kind.
    for k in SectionKind::ALL {
        let n = k.name().to_uppercase();
        let _ = writeln!(program, "  printf(\"K {n} %u\\n\", (unsigned)SPHB_KIND_{n});");
        let _ = writeln!(want, "K {n} {}", k.code());
    }
    program += "  return 0;\n}\n";
    assert_eq!(HEADER_SIZE, 64);
    assert_eq!(SECTION_ENTRY_SIZE, 32);
    assert!(want.contains(&format!("S SphbFileHeader {HEADER_SIZE}\n")));
    assert!(want.contains(&format!("S SphbFileSectionEntry {SECTION_ENTRY_SIZE}\n")));

    let dir = tempdir("spec");
    let inc = dir.join("include");
    std::fs::create_dir_all(&inc).unwrap();
    std::fs::write(inc.join("spec_extracted.h"), &header).unwrap();
    let src = dir.join("layout.c");
    std::fs::write(&src, &program).unwrap();
    let exe = dir.join("layout");
    // The extracted text, not the committed copy (the other test compares those).
    build(&cc, "c11", &[&src], &["-I".into(), inc.clone().into()], &exe);
    let o = Command::new(&exe).output().unwrap();
    assert!(o.status.success());
    let got = String::from_utf8(o.stdout).unwrap();
    for (g, w) in got.lines().zip(want.lines()) {
        assert_eq!(g, w, "the compiled C struct (left) differs from the spec's byte table (right)");
    }
    assert_eq!(got.lines().count(), want.lines().count());

    // C99 and C++17, together with the library's header.
    let both = "#include \"spherebake.h\"\n#include \"spec_extracted.h\"\nint main(void) { return (int)sizeof(SphbFileHeader) - 64; }\n";
    let c = dir.join("both.c");
    std::fs::write(&c, both).unwrap();
    build(&cc, "c99", &[&c], &["-I".into(), inc.clone().into()], &dir.join("both_c"));
    let cxx = compiler("c++", "g++");
    let cpp = dir.join("both.cpp");
    std::fs::write(&cpp, both.replace("(void)", "()")).unwrap();
    build(&cxx, "c++17", &[&cpp], &["-I".into(), inc.into()], &dir.join("both_cpp"));
}

/// What read_sphb prints for `bytes`, from the Rust reader.
fn expected(bytes: &[u8]) -> String {
    let (h, entries) = spherebake_format::read_header_and_table(bytes).unwrap();
    let f = read(bytes).unwrap();
    let mut s = String::new();
    let _ = writeln!(s, "header major {} minor {} sections {} size {}", h.major, h.minor, h.section_count, h.file_size);
    for e in &entries {
        let _ = writeln!(s, "section {} offset {} length {}", e.kind, e.offset, e.length);
    }
    let _ = writeln!(s, "spheres {}", f.spheres.len());
    for (i, sp) in f.spheres.iter().enumerate() {
        let c = sp.center;
        let _ = writeln!(s, "sphere {i} {} {} {} {}", hf(c[0]), hf(c[1]), hf(c[2]), hf(sp.radius));
    }
    if let Some(bones) = &f.bones {
        let _ = writeln!(s, "bones {}", bones.len());
        for (i, b) in bones.iter().enumerate() {
            let p = b.parent.map_or(-1, i64::from);
            let _ = writeln!(s, "bone {i} parent {p} name {} m12 {}", b.name, hf(b.inverse_bind[12]));
        }
    }
    if let Some(hy) = &f.hierarchy {
        let _ = writeln!(
            s,
            "nodes {} root {} children {} leaves {}",
            hy.nodes.len(),
            hy.root,
            hy.children.len(),
            hy.leaves.len()
        );
        // Pre-order from the root, children in array order.
        let mut stack = vec![hy.root as usize];
        while let Some(k) = stack.pop() {
            let n = &hy.nodes[k];
            let kids = &hy.children[n.first_child as usize..(n.first_child + n.child_count) as usize];
            let leaves = &hy.leaves[n.first_leaf as usize..(n.first_leaf + n.leaf_count) as usize];
            let c = n.center;
            let _ = write!(s, "node {k} {} {} {} {} children", hf(c[0]), hf(c[1]), hf(c[2]), hf(n.radius));
            for x in kids {
                let _ = write!(s, " {x}");
            }
            s += " leaves";
            for x in leaves {
                let _ = write!(s, " {x}");
            }
            s += "\n";
            stack.extend(kids.iter().rev().map(|&x| x as usize));
        }
    }
    if let Some(sm) = &f.samples {
        let compact = entries.iter().any(|e| e.kind == SectionKind::CompactSamples.code());
        let _ = writeln!(s, "samples {} kind {}", sm.points.len(), if compact { 8 } else { 3 });
        for i in 0..f.spheres.len() {
            let (first, end) = (sm.offsets[i], sm.offsets[i + 1]);
            let _ = writeln!(s, "sphere {i} first {first} count {}", end - first);
            for j in first..end {
                let p = sm.points[j as usize];
                let (q, n) = (p.position, p.normal);
                let _ = writeln!(
                    s,
                    "sample {j} {} {} {} {} {} {} {} {}",
                    hf(q[0]),
                    hf(q[1]),
                    hf(q[2]),
                    hf(n[0]),
                    hf(n[1]),
                    hf(n[2]),
                    p.direction,
                    p.rule
                );
            }
        }
    }
    if let Some(a) = f.samples.as_ref().and_then(|sm| sm.areas.as_ref()) {
        let _ = write!(s, "areas {}", a.len());
        for v in a.iter().take(4) {
            let _ = write!(s, " {}", hf(*v));
        }
        let sum: f64 = a.iter().map(|&v| f64::from(v)).sum();
        let _ = writeln!(s, " sum {sum:.6}");
    }
    if let Some(a) = &f.albedo_sh {
        let compact = entries.iter().any(|e| e.kind == SectionKind::CompactAlbedoSh.code());
        let _ = write!(s, "albedo order {} kind {} sphere0", a.order, if compact { 9 } else { 4 });
        for c in &a.coefficients[..usize::from(a.order) * usize::from(a.order)] {
            for v in c {
                let _ = write!(s, " {}", hf(*v));
            }
        }
        s += "\n";
    }
    if let Some(k) = &f.skin {
        let _ = write!(s, "skin {} per sphere, sphere0", k.bones_per_sphere);
        for e in &k.entries[..k.bones_per_sphere as usize] {
            let bone = if e.bone == u32::MAX { -1 } else { i64::from(e.bone) };
            let _ = write!(s, " {bone}:{}", hf(e.b));
        }
        s += "\n";
    }
    if let Some(m) = &f.metadata {
        for k in
            ["tool_version", "settings", "input_hash", "units"].into_iter().chain(m.extra.iter().map(|e| e.0.as_str()))
        {
            let _ = writeln!(s, "meta {k}");
        }
    }
    s
}

fn build_reader() -> std::path::PathBuf {
    let cc = compiler("cc", "gcc");
    let exe = tempdir("spec").join("read_sphb");
    build(&cc, "c99", &[&repo().join("examples/c/read_sphb.c")], &["-lm".into()], &exe);
    exe
}

fn run(exe: &Path, bytes: &[u8], name: &str) -> std::process::Output {
    let file = tempdir("spec").join(name);
    std::fs::write(&file, bytes).unwrap();
    Command::new(exe).arg(&file).output().unwrap()
}

#[test]
fn c_reader_without_the_library_reads_what_rust_reads() {
    let exe = build_reader();
    for name in ["capsule-16.sphb", "skinned-arm-16.sphb"] {
        let lossless = golden(name);
        let compact = write_compact(&read(&lossless).unwrap()).unwrap();
        for (tag, bytes) in [("lossless", &lossless), ("compact", &compact)] {
            let o = run(&exe, bytes, &format!("{tag}-{name}"));
            assert!(o.status.success(), "{tag} {name}: {}", String::from_utf8_lossy(&o.stderr));
            let got = String::from_utf8(o.stdout).unwrap();
            let want = expected(bytes);
            assert!(want.contains("\nsample ") && want.contains("\nnode "), "{want}");
            for (g, w) in got.lines().zip(want.lines()) {
                assert_eq!(g, w, "read_sphb (left) and the Rust reader (right) on {tag} {name}");
            }
            assert_eq!(got.lines().count(), want.lines().count(), "{tag} {name}");
        }
    }
    // Damaged files: the rule the Rust reader names (header, table and section checks).
    let good = golden("capsule-16.sphb");
    let mut crc = good.clone();
    let at = crc.len() - 40;
    crc[at] ^= 0x5a;
    let mut bad_minor = good.clone();
    bad_minor[12] = 80; // header_size 80 with minor 2 (64 for minors 0 to 2)
    let damaged: [(&str, Vec<u8>); 4] = [
        ("truncated", good[..good.len() - 16].to_vec()),
        ("short", good[..40].to_vec()),
        ("checksum", crc),
        ("header-size", bad_minor),
    ];
    for (tag, bytes) in damaged {
        let rule = spherebake_runtime::load(&bytes).unwrap_err().rule.id();
        let o = run(&exe, &bytes, tag);
        assert_eq!(o.status.code(), Some(1), "{tag}");
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(stderr.contains(&format!(": rule {rule}: ")), "{tag}: Rust says rule {rule}, read_sphb: {stderr}");
    }
}
