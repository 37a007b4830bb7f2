//! The OBJ reader of the fit examples and tests: `spherebake_testkit::mesh::load_obj` with glam
//! positions (polygon faces fanned; no welding, unreferenced vertices kept). Panics on malformed
//! input: examples, not the product.

use glam::Vec3;

pub fn load_obj(path: &str) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let (v, f) = spherebake_testkit::mesh::load_obj::<f32>(std::path::Path::new(path));
    (v.into_iter().map(Vec3::from).collect(), f)
}
