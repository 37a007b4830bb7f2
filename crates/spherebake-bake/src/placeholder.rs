//! A simple, always-bounding sphere set used when no fitter is wired in: triangles are grouped
//! by centroid on a regular grid, and each group's sphere is the bounding ball of its corners.
//!
//! Every triangle lies inside the sphere of its group by convexity (its three corners do), so the
//! set bounds the whole surface; radii are grown to the next f32 that contains every corner when
//! tested in f64 against the stored f32 values.

use glam::{DVec3, Vec3};

/// Groups triangles into about `target` clusters and returns one bounding sphere per non-empty
/// cluster as `[x, y, z, r]` (model space, f32, as stored).
pub fn grid_bounding_spheres(positions: &[Vec3], triangles: &[[u32; 3]], target: usize) -> Vec<[f32; 4]> {
    let Some((lo, hi)) = bounds(positions, triangles) else { return Vec::new() };
    let ext = (hi - lo).max(DVec3::splat(1e-12));
    // Cells per axis proportional to the extent so cells are roughly cubic.
    let cell = (ext.x * ext.y * ext.z / target.max(1) as f64).cbrt().max(ext.max_element() / 4096.0);
    let dims = ((ext / cell).ceil().max(DVec3::ONE)).as_uvec3();
    let mut groups: std::collections::BTreeMap<u64, Vec<u32>> = Default::default();
    for (t, tri) in triangles.iter().enumerate() {
        let c = tri.iter().map(|&i| positions[i as usize].as_dvec3()).fold(DVec3::ZERO, |a, b| a + b) / 3.0;
        let g = (((c - lo) / cell).floor().max(DVec3::ZERO)).as_uvec3().min(dims - 1);
        let key = (g.z as u64 * dims.y as u64 + g.y as u64) * dims.x as u64 + g.x as u64;
        groups.entry(key).or_default().push(t as u32);
    }
    groups
        .values()
        .map(|tris| {
            let pts: Vec<DVec3> =
                tris.iter().flat_map(|t| triangles[*t as usize]).map(|i| positions[i as usize].as_dvec3()).collect();
            bounding_sphere_f32(&pts)
        })
        .collect()
}

fn bounds(positions: &[Vec3], triangles: &[[u32; 3]]) -> Option<(DVec3, DVec3)> {
    let mut it = triangles.iter().flatten().map(|&i| positions[i as usize].as_dvec3());
    let first = it.next()?;
    Some(it.fold((first, first), |(lo, hi), p| (lo.min(p), hi.max(p))))
}

/// Ritter-style bounding ball of `pts`, then rounded to f32 and grown until every point is
/// inside the stored f32 sphere (checked in f64).
pub fn bounding_sphere_f32(pts: &[DVec3]) -> [f32; 4] {
    let lo = pts.iter().fold(DVec3::splat(f64::INFINITY), |a, &p| a.min(p));
    let hi = pts.iter().fold(DVec3::splat(f64::NEG_INFINITY), |a, &p| a.max(p));
    let c = (lo + hi) * 0.5;
    let cf = c.as_vec3();
    let cd = cf.as_dvec3();
    let r = pts.iter().map(|p| p.distance(cd)).fold(0.0f64, f64::max);
    let mut rf = (r as f32).max(f32::MIN_POSITIVE);
    while (rf as f64) < r {
        rf = f32::from_bits(rf.to_bits() + 1);
    }
    [cf.x, cf.y, cf.z, rf]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_corner_is_inside_a_stored_sphere() {
        // A helix of triangles: irregular, spread out.
        let mut positions = Vec::new();
        let mut triangles = Vec::new();
        for i in 0..300u32 {
            let a = i as f32 * 0.37;
            positions.push(Vec3::new(a.cos() * 3.0, a * 0.11, a.sin() * 2.0));
            if i >= 2 {
                triangles.push([i - 2, i - 1, i]);
            }
        }
        for target in [1, 7, 64] {
            let s = grid_bounding_spheres(&positions, &triangles, target);
            assert!(!s.is_empty());
            for tri in &triangles {
                // All three corners in one common sphere (so the triangle is inside by convexity).
                let ok = s.iter().any(|s| {
                    tri.iter().all(|&i| {
                        let p = positions[i as usize].as_dvec3();
                        p.distance(DVec3::new(s[0] as f64, s[1] as f64, s[2] as f64)) <= s[3] as f64
                    })
                });
                assert!(ok, "triangle {tri:?} not inside one sphere (target {target})");
            }
        }
    }
}
