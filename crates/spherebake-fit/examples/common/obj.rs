//! Minimal OBJ reader shared by the fit examples (positions and polygon faces, fanned; no
//! welding, unreferenced vertices kept). Panics on malformed input: examples, not the product.

use glam::Vec3;

pub fn load_obj(path: &str) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let text = std::fs::read_to_string(path).expect("read OBJ");
    let mut p = Vec::new();
    let mut t = Vec::new();
    for line in text.lines() {
        let mut it = line.split_whitespace();
        match it.next() {
            Some("v") => {
                let v: Vec<f32> = it.take(3).map(|x| x.parse().expect("float")).collect();
                p.push(Vec3::new(v[0], v[1], v[2]));
            }
            Some("f") => {
                let v: Vec<u32> = it.map(|x| x.split('/').next().unwrap().parse::<u32>().expect("index") - 1).collect();
                for i in 1..v.len() - 1 {
                    t.push([v[0], v[i], v[i + 1]]);
                }
            }
            _ => {}
        }
    }
    (p, t)
}
