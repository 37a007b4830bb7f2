//! `spherebake inspect FILE [--json]`: a mesh's topology report, or a `.sphb` file's header,
//! section table and full contents.

use anyhow::{Context, Result};
use clap::Args;
use serde_json::{json, Value};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(Args, Debug)]
pub struct InspectArgs {
    /// A mesh (.gltf, .glb, .obj) or a baked file (.sphb)
    pub file: PathBuf,
    /// Print one JSON document instead of text
    #[arg(long)]
    pub json: bool,
}

pub fn run(a: InspectArgs) -> Result<ExitCode> {
    if is_mesh(&a.file) {
        inspect_mesh(&a.file, a.json)
    } else {
        inspect_sphb(&a.file, a.json)
    }
}

pub fn is_mesh(path: &Path) -> bool {
    matches!(
        path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref(),
        Some("gltf" | "glb" | "obj")
    )
}

fn inspect_mesh(path: &Path, as_json: bool) -> Result<ExitCode> {
    let imported = spherebake_io::load_mesh(path)?;
    let t = spherebake_geom::TopologyReport::compute(&imported.mesh);
    let warnings: Vec<&str> = imported.warnings.iter().map(|w| w.0.as_str()).collect();
    let skin = imported.mesh.skin.as_ref();
    if as_json {
        let doc = json!({
            "file": path.display().to_string(),
            "kind": "mesh",
            "topology": crate::json::topology_to_json(&t),
            "materials": imported.mesh.materials.len(),
            "textures": imported.mesh.textures.iter().map(|t| json!({"name": t.name, "width": t.width, "height": t.height})).collect::<Vec<_>>(),
            "bones": skin.map(|s| s.skeleton.bones.len()).unwrap_or(0),
            "animations": skin.map(|s| s.skeleton.animations.iter().map(|a| a.name.clone()).collect::<Vec<_>>()).unwrap_or_default(),
            "inputs": imported.inputs.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
            "warnings": warnings,
        });
        println!("{}", serde_json::to_string_pretty(&doc)?);
    } else {
        println!("{}", path.display());
        print!("{}", crate::json::topology_text(&t));
        println!("  materials         {}", imported.mesh.materials.len());
        for tex in &imported.mesh.textures {
            println!("  texture           {} ({}x{})", tex.name, tex.width, tex.height);
        }
        if let Some(s) = skin {
            println!("  bones             {}", s.skeleton.bones.len());
            for a in &s.skeleton.animations {
                println!("  animation         {} ({} channels)", a.name, a.channels.len());
            }
        }
        for w in warnings {
            println!("  warning           {w}");
        }
    }
    Ok(ExitCode::SUCCESS)
}

fn inspect_sphb(path: &Path, as_json: bool) -> Result<ExitCode> {
    let bytes = spherebake_io::read_limited(path, spherebake_io::default_options().max_input_bytes)?;
    // A file that is neither a mesh by its extension nor a .sphb by its magic (a .ply, a .stl):
    // name its type, as `bake` does, instead of reporting a malformed .sphb header.
    let extension = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    if !bytes.starts_with(&spherebake_format::MAGIC) && extension.as_deref().is_some_and(|e| e != "sphb") {
        anyhow::bail!(
            "{}: unknown file type {:?} (expected .gltf, .glb, .obj or .sphb)",
            path.display(),
            extension.unwrap_or_default()
        );
    }
    let (header, table) = spherebake_format::read_header_and_table(&bytes)
        .with_context(|| format!("{}: not a valid .sphb file", path.display()))?;
    let file =
        spherebake_format::read(&bytes).with_context(|| format!("{}: not a valid .sphb file", path.display()))?;
    if as_json {
        // The JSON document only for --json: as a tree of values it takes about 1.7 KB a
        // sphere (a 4 M-sphere file held 6.8 GB just to print its text).
        let sections: Vec<Value> = table
            .iter()
            .map(|s| {
                json!({
                    "kind": s.known_kind().map(|k| k.name().to_string()).unwrap_or_else(|| format!("unknown 0x{:08x}", s.kind)),
                    "offset": s.offset,
                    "length": s.length,
                    "crc32": format!("{:08x}", s.crc32),
                })
            })
            .collect();
        let mut doc = crate::json::sphb_to_json(&file);
        if let Value::Object(o) = &mut doc {
            o.insert("file".into(), json!(path.display().to_string()));
            o.insert("format_version".into(), json!(format!("{}.{}", header.major, header.minor)));
            o.insert(
                "header".into(),
                json!({
                    "major": header.major,
                    "minor": header.minor,
                    "header_size": header.header_size,
                    "flags": header.flags,
                    "section_count": header.section_count,
                    "table_offset": header.table_offset,
                    "file_size": header.file_size,
                    "table_crc32": format!("{:08x}", header.table_crc32),
                    "header_crc32": format!("{:08x}", header.header_crc32),
                }),
            );
            // Encoding byte of the sample_areas section (spec §7.2): 0 f32 model units², 1 f16 per r².
            let areas = table.iter().find(|s| s.known_kind() == Some(spherebake_format::SectionKind::SampleAreas));
            let encoding = areas.and_then(|s| usize::try_from(s.offset).ok()).and_then(|at| bytes.get(at + 4));
            o.insert(
                "sample_areas_encoding".into(),
                match encoding {
                    Some(0) => json!("f32 (model units squared)"),
                    Some(1) => json!("f16 (units of the sphere's radius squared)"),
                    _ => Value::Null,
                },
            );
            o.insert("file_bytes".into(), json!(bytes.len()));
            o.insert("sections".into(), Value::Array(sections));
        }
        println!("{}", serde_json::to_string_pretty(&doc)?);
        return Ok(ExitCode::SUCCESS);
    }
    println!("{}: spherebake format {}.{}, {} bytes", path.display(), header.major, header.minor, bytes.len());
    println!("sections:");
    for s in &table {
        let name = s.known_kind().map(|k| k.name().to_string()).unwrap_or_else(|| format!("unknown 0x{:08x}", s.kind));
        println!("  {name:<13} offset {:>8}  length {:>8}  crc32 {:08x}", s.offset, s.length, s.crc32);
    }
    crate::json::print_sphb_text(&file);
    Ok(ExitCode::SUCCESS)
}
