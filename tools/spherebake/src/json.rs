//! JSON views of files and reports. The key names of `inspect --json` are a contract:
//! `format_version`, `header`, `sections`, `spheres`, `hierarchy`, `hierarchy_root`, `samples`,
//! `sample_areas_encoding`, `albedo_sh`, `albedo_sh_format`, `skin`, `bones_per_sphere`, `bones`,
//! `metadata`. Keep them stable (keys may be added, never renamed or removed).

use serde_json::{json, Value};
use spherebake_format::SphbFile;

/// The full contents of a `.sphb` file as JSON (keys per the contract above).
pub fn sphb_to_json(file: &SphbFile) -> Value {
    let spheres: Vec<Value> = file.spheres.iter().map(|s| json!({ "center": s.center, "radius": s.radius })).collect();
    let hierarchy = file.hierarchy.as_ref().map(|h| {
        let nodes: Vec<Value> = h
            .nodes
            .iter()
            .enumerate()
            .map(|(i, n)| {
                json!({ "center": n.center, "radius": n.radius, "children": h.children_of(i), "leaf_children": h.leaves_of(i) })
            })
            .collect();
        Value::Array(nodes)
    });
    let samples = file.samples.as_ref().map(|s| {
        Value::Array(
            s.per_sphere()
                .enumerate()
                .map(|(i, list)| {
                    let areas = s.areas_of(i);
                    Value::Array(
                        list.iter()
                            .enumerate()
                            .map(|(k, p)| {
                                let mut v = json!({ "position": p.position, "normal": p.normal, "direction": p.direction, "rule": p.rule });
                                if let (Some(a), Value::Object(o)) = (areas.and_then(|a| a.get(k)), &mut v) {
                                    o.insert("area".into(), json!(a));
                                }
                                v
                            })
                            .collect(),
                    )
                })
                .collect(),
        )
    });
    let albedo_sh = file.albedo_sh.as_ref().map(|a| {
        let n = a.coefficients_per_sphere().max(1);
        Value::Array(a.coefficients.chunks(n).map(|c| json!(c)).collect())
    });
    let skin = file.skin.as_ref().map(|k| {
        let per = k.bones_per_sphere.max(1) as usize;
        Value::Array(
            k.entries
                .chunks(per)
                .map(|slots| {
                    let used: Vec<_> = slots.iter().filter(|e| e.bone != spherebake_format::UNUSED_BONE).collect();
                    json!({
                        "bones": used.iter().map(|e| e.bone).collect::<Vec<_>>(),
                        "terms": used.iter().map(|e| [e.q[0], e.q[1], e.q[2], e.b]).collect::<Vec<_>>(),
                    })
                })
                .collect(),
        )
    });
    let bones = file.bones.as_ref().map(|b| {
        Value::Array(
            b.iter().map(|b| json!({ "name": b.name, "parent": b.parent, "inverse_bind": b.inverse_bind })).collect(),
        )
    });
    let metadata = file.metadata.as_ref().map(|m| {
        let mut o = serde_json::Map::new();
        o.insert("tool_version".into(), json!(m.tool_version));
        o.insert("settings".into(), serde_json::from_str(&m.settings).unwrap_or_else(|_| json!(m.settings)));
        o.insert("input_hash".into(), json!(m.input_hash));
        o.insert("units".into(), json!(m.units));
        for (k, v) in &m.extra {
            o.insert(k.clone(), json!(v));
        }
        Value::Object(o)
    });
    // The albedo's conventions as codes and names (spec §8: both have one value in version 1).
    let albedo_sh_format = file.albedo_sh.as_ref().map(|a| {
        json!({
            "order": a.order,
            "colour_space": a.colour_space.code(),
            "colour_space_name": "linear RGB (Rec. 709 primaries)",
            "basis": a.basis.code(),
            "basis_name": "real orthonormal SH, Condon-Shortley phase, index l(l+1)+m",
        })
    });
    json!({
        "spheres": spheres,
        "hierarchy": hierarchy,
        "hierarchy_root": file.hierarchy.as_ref().map(|h| h.root),
        "samples": samples,
        "albedo_sh": albedo_sh,
        "albedo_sh_format": albedo_sh_format,
        "skin": skin,
        "bones_per_sphere": file.skin.as_ref().map(|k| k.bones_per_sphere),
        "bones": bones,
        "metadata": metadata,
    })
}

/// Human-readable full contents of a `.sphb` file.
pub fn print_sphb_text(file: &SphbFile) {
    println!("spheres: {} (centre xyz, radius; model space)", file.spheres.len());
    for (i, s) in file.spheres.iter().enumerate() {
        println!("  [{i:>4}] ({:>12.6}, {:>12.6}, {:>12.6})  r {:.6}", s.center[0], s.center[1], s.center[2], s.radius);
    }
    if let Some(h) = &file.hierarchy {
        println!("hierarchy: {} nodes, root {}", h.nodes.len(), h.root);
        for (i, n) in h.nodes.iter().enumerate() {
            println!(
                "  [{i:>4}] ({:>12.6}, {:>12.6}, {:>12.6})  r {:.6}  children {:?}  leaves {:?}",
                n.center[0],
                n.center[1],
                n.center[2],
                n.radius,
                h.children_of(i),
                h.leaves_of(i)
            );
        }
    }
    if let Some(s) = &file.samples {
        let with_areas = s.areas.is_some();
        println!(
            "samples: {} over {} spheres (position, normal, direction, rule{})",
            s.total(),
            s.sphere_count(),
            if with_areas { ", surface area" } else { "" }
        );
        for (i, list) in s.per_sphere().enumerate() {
            println!("  sphere {i}: {} samples", list.len());
            let areas = s.areas_of(i);
            for (k, p) in list.iter().enumerate() {
                let area = areas.and_then(|a| a.get(k)).map_or(String::new(), |a| format!("  area {a:.6e}"));
                println!(
                    "    dir {:>2} rule {}  p ({:.6}, {:.6}, {:.6})  n ({:.4}, {:.4}, {:.4}){area}",
                    p.direction,
                    p.rule,
                    p.position[0],
                    p.position[1],
                    p.position[2],
                    p.normal[0],
                    p.normal[1],
                    p.normal[2]
                );
            }
        }
    }
    if let Some(a) = &file.albedo_sh {
        println!(
            "albedo SH: order {} ({} coefficients per sphere, linear RGB, real orthonormal SH, CS phase)",
            a.order,
            a.coefficients_per_sphere()
        );
        for i in 0..file.spheres.len() {
            if let Some(c) = a.of(i) {
                let parts: Vec<String> = c
                    .iter()
                    .enumerate()
                    .map(|(k, v)| {
                        let l = (k as f64).sqrt().floor() as i64;
                        let m = k as i64 - l * (l + 1);
                        format!("l{l}m{m} ({:.4} {:.4} {:.4})", v[0], v[1], v[2])
                    })
                    .collect();
                println!("  sphere {i}: {}", parts.join(" "));
            }
        }
    }
    if let Some(k) = &file.skin {
        println!("skin: {} bones per sphere (bone, q xyz, b)", k.bones_per_sphere);
        for i in 0..file.spheres.len() {
            let slots: Vec<String> = k
                .of(i)
                .iter()
                .filter(|e| e.bone != spherebake_format::UNUSED_BONE)
                .map(|e| format!("{}: ({:.5}, {:.5}, {:.5}, {:.5})", e.bone, e.q[0], e.q[1], e.q[2], e.b))
                .collect();
            println!("  sphere {i}: {}", slots.join("  "));
        }
    }
    if let Some(b) = &file.bones {
        println!("bones: {}", b.len());
        for (i, b) in b.iter().enumerate() {
            println!("  [{i:>3}] {:<24} parent {:?}", b.name, b.parent);
        }
    }
    if let Some(m) = &file.metadata {
        println!("metadata:");
        println!("  tool_version  {}", m.tool_version);
        println!("  settings      {}", m.settings);
        println!("  input_hash    {}", m.input_hash);
        println!("  units         {}", m.units);
        for (k, v) in &m.extra {
            println!("  {k:<13} {v}");
        }
    }
}

/// The topology report as JSON.
pub fn topology_to_json(t: &spherebake_geom::TopologyReport) -> Value {
    json!({
        "triangles": t.triangle_count,
        "vertices": t.vertex_count,
        "welded_vertices": t.welded_vertex_count,
        "aabb": t.aabb.map(|(lo, hi)| json!({"min": lo.to_array(), "max": hi.to_array()})),
        "edges": t.edge_count,
        "boundary_edges": t.boundary_edge_count,
        "non_manifold_edges": t.non_manifold_edge_count,
        "degenerate_triangles": t.degenerate_triangle_count,
        "components": t.component_count,
        "closed": t.closed,
        "consistently_oriented": t.consistently_oriented,
        "signed_volume": t.signed_volume,
        "surface_area": t.surface_area,
    })
}

/// The topology report as aligned text lines.
pub fn topology_text(t: &spherebake_geom::TopologyReport) -> String {
    let mut s = String::new();
    let mut line = |k: &str, v: String| s.push_str(&format!("  {k:<17} {v}\n"));
    line("triangles", t.triangle_count.to_string());
    line("vertices", format!("{} stored, {} welded", t.vertex_count, t.welded_vertex_count));
    if let Some((lo, hi)) = t.aabb {
        line("bounding box", format!("[{}, {}, {}] – [{}, {}, {}]", lo.x, lo.y, lo.z, hi.x, hi.y, hi.z));
    }
    line(
        "edges",
        format!("{} ({} boundary, {} non-manifold)", t.edge_count, t.boundary_edge_count, t.non_manifold_edge_count),
    );
    line("degenerate tris", t.degenerate_triangle_count.to_string());
    line("components", t.component_count.to_string());
    line(
        "closed",
        if t.closed {
            format!(
                "yes, {}",
                if t.consistently_oriented { "consistently oriented" } else { "NOT consistently oriented" }
            )
        } else {
            "no".to_string()
        },
    );
    line(
        "signed volume",
        if t.closed {
            format!("{:.7}", t.signed_volume)
        } else {
            format!("({:.7}, meaningless: not closed)", t.signed_volume)
        },
    );
    line("surface area", format!("{:.7}", t.surface_area));
    s
}
