//! `docs/ARCHITECTURE.md` stays a true map: its dependency table lists every workspace crate with exactly the
//! normal dependencies `cargo metadata` reports, and the module names the docs give for the runtime exist.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;
use std::process::Command;

type Deps = BTreeMap<String, (BTreeSet<String>, BTreeSet<String>)>;

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().and_then(Path::parent).expect("tools/spherebake is two levels down")
}

fn names(cell: &str) -> BTreeSet<String> {
    cell.split(',').map(str::trim).filter(|n| !n.is_empty() && *n != "–" && *n != "-").map(str::to_string).collect()
}

/// The table under "### Dependency table": crate → (workspace crates, external crates).
fn documented() -> Deps {
    let text = std::fs::read_to_string(root().join("docs/ARCHITECTURE.md")).expect("docs/ARCHITECTURE.md");
    let start = text.find("### Dependency table").expect("ARCHITECTURE.md has a '### Dependency table' section");
    let mut out = Deps::new();
    let mut in_table = false;
    for line in text[start..].lines().skip(1) {
        let line = line.trim();
        if line.starts_with("###") || line.starts_with("## ") {
            break;
        }
        if !line.starts_with('|') {
            if in_table {
                break;
            }
            continue;
        }
        in_table = true;
        let cells: Vec<&str> = line.trim_matches('|').split('|').map(str::trim).collect();
        if cells.len() != 3 || cells[0] == "crate" || cells[0].starts_with("---") {
            continue;
        }
        let prev = out.insert(cells[0].to_string(), (names(cells[1]), names(cells[2])));
        assert!(prev.is_none(), "{} is listed twice", cells[0]);
    }
    out
}

/// `cargo metadata --no-deps`: every workspace package's normal dependencies, split into workspace and external.
fn actual() -> Deps {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = Command::new(cargo)
        .args(["metadata", "--format-version", "1", "--no-deps", "--offline"])
        .current_dir(root())
        .output()
        .expect("run cargo metadata");
    assert!(out.status.success(), "cargo metadata failed: {}", String::from_utf8_lossy(&out.stderr));
    let meta: serde_json::Value = serde_json::from_slice(&out.stdout).expect("cargo metadata JSON");
    let members: BTreeSet<String> = meta["packages"]
        .as_array()
        .expect("packages")
        .iter()
        .map(|p| p["name"].as_str().expect("name").to_string())
        .collect();
    let mut deps = Deps::new();
    for p in meta["packages"].as_array().expect("packages") {
        let mut ws = BTreeSet::new();
        let mut ext = BTreeSet::new();
        for d in p["dependencies"].as_array().expect("dependencies") {
            // kind: null for normal dependencies, "dev" / "build" otherwise.
            if !d["kind"].is_null() {
                continue;
            }
            let name = d["name"].as_str().expect("dependency name").to_string();
            if members.contains(&name) {
                ws.insert(name);
            } else {
                ext.insert(name);
            }
        }
        deps.insert(p["name"].as_str().expect("name").to_string(), (ws, ext));
    }
    deps
}

#[test]
fn the_dependency_table_matches_cargo_metadata() {
    let doc = documented();
    let real = actual();
    assert!(real.len() >= 12, "cargo metadata found only {} packages", real.len());
    let mut problems = Vec::new();
    for (name, (ws, ext)) in &real {
        match doc.get(name) {
            None => problems.push(format!("{name} is missing from the table")),
            Some((dws, dext)) => {
                if dws != ws {
                    problems.push(format!("{name}: workspace crates documented {dws:?}, Cargo.toml says {ws:?}"));
                }
                if dext != ext {
                    problems.push(format!("{name}: external crates documented {dext:?}, Cargo.toml says {ext:?}"));
                }
            }
        }
    }
    for name in doc.keys().filter(|n| !real.contains_key(*n)) {
        problems.push(format!("{name} is in the table but not in the workspace"));
    }
    assert!(problems.is_empty(), "docs/ARCHITECTURE.md's dependency table is out of date:\n{}", problems.join("\n"));
}

#[test]
fn the_runtime_depends_on_no_baker_crate() {
    // The invariant the table encodes for engines: the runtime and the C ABI link only the format and SH crates.
    let real = actual();
    let allowed: BTreeSet<String> =
        ["spherebake-format", "spherebake-sh", "spherebake-runtime"].into_iter().map(str::to_string).collect();
    for krate in ["spherebake-runtime", "spherebake-capi"] {
        let (ws, ext) = &real[krate];
        assert!(ws.is_subset(&allowed), "{krate} depends on {ws:?}");
        assert!(ext.is_empty(), "{krate} depends on external crates {ext:?}");
    }
}

#[test]
fn the_table_parser_sees_a_change() {
    // The check can fail: a table that drops a dependency differs from cargo metadata.
    let mut doc = documented();
    let real = actual();
    let (ws, _) = doc.get_mut("spherebake-fit").expect("spherebake-fit is documented");
    assert!(ws.remove("spherebake-format"), "the table lists spherebake-fit -> spherebake-format");
    assert_ne!(doc.get("spherebake-fit"), real.get("spherebake-fit"));
}
