//! Mesh resizing for the speed and scale tables: midpoint 1→4 subdivision, vertex-clustering
//! decimation, and an OBJ writer. Output order depends only on the input order (deterministic).

use anyhow::{Context, Result};
use spherebake_geom::glam::Vec3;
use std::collections::{HashMap, HashSet};
use std::io::{BufWriter, Write};
use std::path::Path;

/// An indexed triangle mesh (positions in model units).
pub struct TriMesh {
    pub positions: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
}

/// Midpoint subdivision: every triangle becomes four, each edge gets one new vertex (shared by
/// the triangles on both sides). The shape is unchanged; the triangle count is multiplied by 4.
pub fn subdivide(m: &TriMesh) -> TriMesh {
    let mut positions = m.positions.clone();
    let mut midpoints: HashMap<(u32, u32), u32> = HashMap::new();
    let mut mid = |a: u32, b: u32, positions: &mut Vec<Vec3>| {
        let key = (a.min(b), a.max(b));
        *midpoints.entry(key).or_insert_with(|| {
            positions.push((positions[a as usize] + positions[b as usize]) * 0.5);
            (positions.len() - 1) as u32
        })
    };
    let mut triangles = Vec::with_capacity(m.triangles.len() * 4);
    for &[a, b, c] in &m.triangles {
        let ab = mid(a, b, &mut positions);
        let bc = mid(b, c, &mut positions);
        let ca = mid(c, a, &mut positions);
        triangles.extend_from_slice(&[[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
    }
    TriMesh { positions, triangles }
}

/// Vertex-clustering decimation: vertices are merged per cell of a grid with `cells` cells along
/// the longest bounding-box axis (each cluster placed at the mean of its vertices); triangles
/// that collapse, and repeated triangles, are dropped.
pub fn decimate(m: &TriMesh, cells: u32) -> TriMesh {
    let (lo, hi) =
        m.positions.iter().fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
    let h = (hi - lo).max_element().max(f32::MIN_POSITIVE) / cells as f32;
    let cell_of = |p: Vec3| {
        let c = ((p - lo) / h).floor().as_uvec3().min(spherebake_geom::glam::UVec3::splat(cells));
        (c.x as u64) | (c.y as u64) << 21 | (c.z as u64) << 42
    };
    let mut cluster: HashMap<u64, u32> = HashMap::new();
    let mut sums: Vec<(Vec3, u32)> = Vec::new();
    let remap: Vec<u32> = m
        .positions
        .iter()
        .map(|&p| {
            let id = *cluster.entry(cell_of(p)).or_insert_with(|| {
                sums.push((Vec3::ZERO, 0));
                (sums.len() - 1) as u32
            });
            sums[id as usize].0 += p;
            sums[id as usize].1 += 1;
            id
        })
        .collect();
    let mut seen = HashSet::new();
    let mut used = vec![false; sums.len()];
    let mut triangles = Vec::new();
    for t in &m.triangles {
        let [a, b, c] = t.map(|v| remap[v as usize]);
        let mut key = [a, b, c];
        key.sort_unstable();
        if a != b && b != c && c != a && seen.insert(key) {
            triangles.push([a, b, c]);
            used[a as usize] = true;
            used[b as usize] = true;
            used[c as usize] = true;
        }
    }
    // Drop clusters no triangle uses (they would only be unreferenced vertices).
    let mut new_index = vec![u32::MAX; sums.len()];
    let mut positions = Vec::new();
    for (i, &(sum, n)) in sums.iter().enumerate() {
        if used[i] {
            new_index[i] = positions.len() as u32;
            positions.push(sum / n as f32);
        }
    }
    for t in &mut triangles {
        *t = t.map(|v| new_index[v as usize]);
    }
    TriMesh { positions, triangles }
}

/// The coarsest vertex-clustering decimation (cells along the longest axis, in steps of 8) that
/// keeps at least `target` triangles.
pub fn decimate_to(m: &TriMesh, target: usize) -> TriMesh {
    (16..=1024)
        .step_by(8)
        .map(|cells| decimate(m, cells))
        .find(|d| d.triangles.len() >= target)
        .unwrap_or_else(|| TriMesh { positions: m.positions.clone(), triangles: m.triangles.clone() })
}

/// Writes `m` as a Wavefront OBJ (`v` and `f` lines; f32 values written exactly).
pub fn write_obj(m: &TriMesh, path: &Path) -> Result<()> {
    let file = std::fs::File::create(path).with_context(|| format!("creating {}", path.display()))?;
    let mut w = BufWriter::new(file);
    for p in &m.positions {
        writeln!(w, "v {} {} {}", p.x, p.y, p.z)?;
    }
    for t in &m.triangles {
        writeln!(w, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1)?;
    }
    w.flush().with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}
