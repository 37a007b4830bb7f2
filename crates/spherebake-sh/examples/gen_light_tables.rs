//! Generates `src/light_tables_data.rs`: the Voronoi-cell basis sums of the 92 geodesic directions (Guerrero et al.
//! 2008 eq. 10) and the average-radiance weights W_l(θ) (eq. 15–18), by `offline/light_tables.rs`. Run from anywhere:
//!
//! ```text
//! cargo run -p spherebake-sh --release --example gen_light_tables
//! ```
//!
//! The output is deterministic; `tests/light_tables.rs` regenerates the tables in-process and compares them.

#[path = "../offline/light_tables.rs"]
mod light_tables;

fn main() -> std::io::Result<()> {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src/light_tables_data.rs");
    let text = light_tables::render_light_tables_rs();
    let tmp = path.with_extension("rs.tmp");
    std::fs::write(&tmp, text)?;
    std::fs::rename(&tmp, &path)?;
    println!("wrote {}", path.display());
    Ok(())
}
