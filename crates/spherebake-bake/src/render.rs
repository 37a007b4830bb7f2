//! `render`: a headless picture of a mesh with its sphere set, from three orthographic views
//! (front: looking along −Z; side: along −X; top: along −Y), side by side.
//!
//! The mesh is drawn with a z-buffer and flat Lambert shading (grey); each sphere is drawn as
//! its silhouette circle (an orthographic view of a sphere is a circle of the same radius) in a
//! per-sphere colour, over a faint translucent fill. Cost: O(pixels touched by triangles +
//! spheres × circumference) per view.

use glam::Vec3;

/// An RGB8 image, row-major, row 0 at the top.
pub struct Image {
    pub width: u32,
    pub height: u32,
    pub rgb: Vec<u8>,
}

/// Renders `width × height` pixels: three square-ish panels of the mesh (`positions`,
/// `triangles`) and `spheres` (`[x, y, z, r]`, same space).
pub fn render_views(
    positions: &[Vec3],
    triangles: &[[u32; 3]],
    spheres: &[[f32; 4]],
    width: u32,
    height: u32,
) -> Image {
    let (w, h) = (width.max(3) as usize, height.max(1) as usize);
    let mut rgb = vec![255u8; w * h * 3];
    // Bounds over mesh and spheres so everything is in view.
    let mut lo = Vec3::splat(f32::MAX);
    let mut hi = Vec3::splat(f32::MIN);
    for t in triangles {
        for &i in t {
            let p = positions[i as usize];
            lo = lo.min(p);
            hi = hi.max(p);
        }
    }
    for s in spheres {
        let c = Vec3::new(s[0], s[1], s[2]);
        lo = lo.min(c - s[3]);
        hi = hi.max(c + s[3]);
    }
    if lo.x > hi.x {
        return Image { width: w as u32, height: h as u32, rgb };
    }
    let panel_w = w / 3;
    // View frames: (right, up, towards viewer).
    let views = [(Vec3::X, Vec3::Y, Vec3::Z), (Vec3::NEG_Z, Vec3::Y, Vec3::X), (Vec3::X, Vec3::NEG_Z, Vec3::Y)];
    let light = Vec3::new(0.4, 0.7, 0.6).normalize();
    for (vi, (right, up, toward)) in views.iter().enumerate() {
        let x0 = vi * panel_w;
        let centre = (lo + hi) * 0.5;
        let ext_u = ((hi - lo).abs().dot(right.abs())).max(1e-12);
        let ext_v = ((hi - lo).abs().dot(up.abs())).max(1e-12);
        let scale = 0.92 * (panel_w as f32 / ext_u).min(h as f32 / ext_v);
        let project = |p: Vec3| -> (f32, f32, f32) {
            let d = p - centre;
            (
                x0 as f32 + panel_w as f32 * 0.5 + d.dot(*right) * scale,
                h as f32 * 0.5 - d.dot(*up) * scale,
                d.dot(*toward),
            )
        };
        let mut zbuf = vec![f32::MIN; panel_w * h];
        for t in triangles {
            let [a, b, c] = t.map(|i| positions[i as usize]);
            let n = (b - a).cross(c - a);
            let Some(n) = n.try_normalize() else { continue };
            // Two-sided shading: real meshes are not always consistently oriented.
            let shade = 0.25 + 0.7 * n.dot(light).abs();
            let g = (shade * 200.0) as u8;
            let pa = project(a);
            let pb = project(b);
            let pc = project(c);
            let minx = pa.0.min(pb.0).min(pc.0).floor().max(x0 as f32) as usize;
            let maxx = pa.0.max(pb.0).max(pc.0).ceil().min((x0 + panel_w - 1) as f32) as usize;
            let miny = pa.1.min(pb.1).min(pc.1).floor().max(0.0) as usize;
            let maxy = pa.1.max(pb.1).max(pc.1).ceil().min((h - 1) as f32) as usize;
            let area = (pb.0 - pa.0) * (pc.1 - pa.1) - (pc.0 - pa.0) * (pb.1 - pa.1);
            if area.abs() < 1e-12 {
                continue;
            }
            for y in miny..=maxy {
                for x in minx..=maxx {
                    let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
                    let w0 = ((pb.0 - px) * (pc.1 - py) - (pc.0 - px) * (pb.1 - py)) / area;
                    let w1 = ((pc.0 - px) * (pa.1 - py) - (pa.0 - px) * (pc.1 - py)) / area;
                    let w2 = 1.0 - w0 - w1;
                    if w0 < 0.0 || w1 < 0.0 || w2 < 0.0 {
                        continue;
                    }
                    let z = w0 * pa.2 + w1 * pb.2 + w2 * pc.2;
                    let zi = y * panel_w + (x - x0);
                    if z > zbuf[zi] {
                        zbuf[zi] = z;
                        let o = (y * w + x) * 3;
                        rgb[o..o + 3].copy_from_slice(&[g, g, g]);
                    }
                }
            }
        }
        for (si, s) in spheres.iter().enumerate() {
            let (cx, cy, _) = project(Vec3::new(s[0], s[1], s[2]));
            let r = s[3] * scale;
            let col = colour(si);
            // Faint fill, then the silhouette circle.
            let (minx, maxx) =
                ((cx - r).floor().max(x0 as f32) as usize, (cx + r).ceil().min((x0 + panel_w - 1) as f32) as usize);
            let (miny, maxy) = ((cy - r).floor().max(0.0) as usize, (cy + r).ceil().min((h - 1) as f32) as usize);
            for y in miny..=maxy {
                for x in minx..=maxx {
                    let d = ((x as f32 + 0.5 - cx).powi(2) + (y as f32 + 0.5 - cy).powi(2)).sqrt();
                    let o = (y * w + x) * 3;
                    if (d - r).abs() <= 0.75 {
                        rgb[o..o + 3].copy_from_slice(&col);
                    } else if d < r {
                        for k in 0..3 {
                            rgb[o + k] = ((rgb[o + k] as u32 * 7 + col[k] as u32) / 8) as u8;
                        }
                    }
                }
            }
        }
    }
    Image { width: w as u32, height: h as u32, rgb }
}

/// The per-sphere colour `export` uses, as RGB8.
fn colour(i: usize) -> [u8; 3] {
    let c = crate::export::hue(i);
    [(c[0] * 255.0) as u8, (c[1] * 255.0) as u8, (c[2] * 255.0) as u8]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sphere_over_a_triangle_draws_both() {
        let pos = [Vec3::new(-1.0, -1.0, 0.0), Vec3::new(1.0, -1.0, 0.0), Vec3::new(0.0, 1.0, 0.0)];
        let img = render_views(&pos, &[[0, 1, 2]], &[[0.0, 0.0, 0.0, 0.5]], 300, 100);
        assert_eq!(img.rgb.len(), 300 * 100 * 3);
        // Front panel centre pixel: inside the triangle (grey, shaded) and inside the sphere fill.
        let o = (50 * 300 + 50) * 3;
        assert_ne!(&img.rgb[o..o + 3], &[255, 255, 255]);
        // A corner far from everything stays white.
        assert_eq!(&img.rgb[0..3], &[255, 255, 255]);
    }
}
