//! Generates `src/tables_data.rs`: the log-visibility tables F_l(θ) of orders 2..=8 and the OL (a, b) tables, by the
//! offline eigen-clipped SH logarithm (`offline/sh_log.rs`, nalgebra). Run from anywhere:
//!
//! ```text
//! cargo run -p spherebake-sh --release --example gen_log_table
//! ```
//!
//! The output is deterministic; `tests/tables.rs` regenerates the tables in-process and compares them with the file.

#[path = "../offline/sh_log.rs"]
mod sh_log;

fn main() -> std::io::Result<()> {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src/tables_data.rs");
    let text = sh_log::render_tables_rs();
    let tmp = path.with_extension("rs.tmp");
    std::fs::write(&tmp, text)?;
    std::fs::rename(&tmp, &path)?;
    println!("wrote {}", path.display());
    Ok(())
}
