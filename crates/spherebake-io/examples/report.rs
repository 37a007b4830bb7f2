//! Prints the import summary and topology report of each model given on the command line.
use spherebake_geom::topology::TopologyReport;

fn main() {
    for arg in std::env::args().skip(1) {
        match spherebake_io::load_mesh(std::path::Path::new(&arg)) {
            Ok(imp) => {
                let r = TopologyReport::compute(&imp.mesh);
                println!("{arg}: {r:?}");
                println!(
                    "  parts {} materials {} textures {:?} skin {:?} hash {:016x} inputs {:?}",
                    imp.parts.len(),
                    imp.mesh.materials.len(),
                    imp.mesh.textures.iter().map(|t| (t.name.as_str(), t.width, t.height)).collect::<Vec<_>>(),
                    imp.mesh.skin.as_ref().map(|s| (s.skeleton.bones.len(), s.skeleton.animations.len())),
                    imp.content_hash,
                    imp.inputs
                );
                for w in &imp.warnings {
                    println!("  warning: {}", w.0);
                }
            }
            Err(e) => println!("{arg}: ERROR {e}"),
        }
    }
}
