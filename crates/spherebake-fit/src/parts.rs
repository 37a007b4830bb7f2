//! The one place the fit splits a mesh into parts that are fitted on their own solids.
//!
//! A part is a group of connected components (triangles sharing a vertex index) whose
//! bounding boxes lie close together; groups far apart from each other (a gap wider than the
//! larger of the two boxes' diagonals) become separate parts, each with its own solid, its own
//! voxel grid and its own share of the sphere budget. Without the split, one stray triangle far
//! from a model stretches the single voxel grid over the whole span and the model is fitted at
//! a useless resolution. Parts are disjoint in space (their boxes, widened by the gap rule, do
//! not overlap), so V(S ∩ T) is the sum of the parts' V(S ∩ T_p), and E can be summed.
//!
//! Cost: union-find over the triangles, then at most [`MAX_MERGE_PASSES`] passes over pairs of
//! at most [`MAX_COMPONENTS`] component groups; beyond either limit the mesh stays one part
//! (the fit then behaves as before the split).

use glam::{DVec3, Vec3};
use spherebake_geom::disjoint::{find, union};

/// More connected components than this: no split (one part, one grid).
pub const MAX_COMPONENTS: usize = 1024;

/// At most this many parts (each needs at least one sphere; more parts: no split).
pub const MAX_PARTS: usize = 64;

/// Merge passes over the groups' boxes before giving up (no split).
const MAX_MERGE_PASSES: usize = 32;

/// One part: its triangles re-indexed onto its own vertices.
#[derive(Clone, Debug, PartialEq)]
pub struct Part {
    pub positions: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
    /// Indices of this part's triangles in the input.
    pub source_triangles: Vec<usize>,
    /// Σ triangle area, square model units (f64).
    pub area: f64,
}

/// Box gap (Euclidean distance between two axis-aligned boxes; 0 when they touch).
fn gap(a: &(DVec3, DVec3), b: &(DVec3, DVec3)) -> f64 {
    let d = (a.0 - b.1).max(b.0 - a.1).max(DVec3::ZERO);
    d.length()
}

/// Two groups stay apart when the gap between their boxes exceeds the larger diagonal.
fn near(a: &(DVec3, DVec3), b: &(DVec3, DVec3)) -> bool {
    let diag = (a.1 - a.0).length().max((b.1 - b.0).length());
    gap(a, b) <= diag
}

/// Splits the mesh into parts (see the module docs). `None` (one part: the whole mesh) when
/// it does not split or the limits are exceeded; `max_parts` (the sphere budget) caps the
/// number of parts further. Indices must be in range (checked by the caller).
pub fn split(positions: &[Vec3], triangles: &[[u32; 3]], max_parts: usize) -> Option<Vec<Part>> {
    let whole = || None;
    // Connected components through shared vertex indices.
    let mut parent: Vec<usize> = (0..positions.len()).collect();
    for t in triangles {
        union(&mut parent, t[0] as usize, t[1] as usize);
        union(&mut parent, t[1] as usize, t[2] as usize);
    }
    let mut comp_of_root = std::collections::BTreeMap::new();
    let mut tri_comp = Vec::with_capacity(triangles.len());
    let mut boxes: Vec<(DVec3, DVec3)> = Vec::new();
    for t in triangles {
        let r = find(&mut parent, t[0] as usize);
        let next = comp_of_root.len();
        let c = *comp_of_root.entry(r).or_insert(next);
        if c == boxes.len() {
            if boxes.len() >= MAX_COMPONENTS {
                return whole();
            }
            boxes.push((DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)));
        }
        for &v in t {
            let p = positions[v as usize].as_dvec3();
            boxes[c].0 = boxes[c].0.min(p);
            boxes[c].1 = boxes[c].1.max(p);
        }
        tri_comp.push(c);
    }
    if boxes.len() < 2 || !boxes.iter().all(|b| b.0.is_finite() && b.1.is_finite()) {
        return whole();
    }
    // Merge groups whose boxes are near until no pair is (group boxes grow as they merge).
    let n = boxes.len();
    let mut group: Vec<usize> = (0..n).collect();
    let mut stable = false;
    for _ in 0..MAX_MERGE_PASSES {
        let roots: Vec<usize> = (0..n).filter(|&i| find(&mut group, i) == i).collect();
        let mut gbox: std::collections::BTreeMap<usize, (DVec3, DVec3)> = std::collections::BTreeMap::new();
        for (i, b) in boxes.iter().enumerate() {
            let r = find(&mut group, i);
            let e = gbox.entry(r).or_insert(*b);
            *e = (e.0.min(b.0), e.1.max(b.1));
        }
        let mut merged = false;
        for (x, &a) in roots.iter().enumerate() {
            for &b in &roots[x + 1..] {
                if near(&gbox[&a], &gbox[&b]) {
                    merged |= union(&mut group, a, b);
                }
            }
        }
        if !merged {
            stable = true;
            break;
        }
    }
    if !stable {
        return whole();
    }
    let mut part_of_root = std::collections::BTreeMap::new();
    let mut lists: Vec<Vec<usize>> = Vec::new();
    for (ti, &c) in tri_comp.iter().enumerate() {
        let r = find(&mut group, c);
        let next = part_of_root.len();
        let p = *part_of_root.entry(r).or_insert(next);
        if p == lists.len() {
            lists.push(Vec::new());
        }
        lists[p].push(ti);
    }
    if lists.len() < 2 || lists.len() > max_parts.min(MAX_PARTS) {
        return whole();
    }
    Some(lists.into_iter().map(|l| make_part(positions, triangles, l)).collect())
}

fn make_part(positions: &[Vec3], triangles: &[[u32; 3]], source_triangles: Vec<usize>) -> Part {
    let mut map = std::collections::HashMap::new();
    let mut pos = Vec::new();
    let mut tris = Vec::with_capacity(source_triangles.len());
    let mut area = 0.0;
    for &ti in &source_triangles {
        let t = triangles[ti];
        let mut nt = [0u32; 3];
        for (k, &v) in t.iter().enumerate() {
            nt[k] = *map.entry(v).or_insert_with(|| {
                pos.push(positions[v as usize]);
                pos.len() as u32 - 1
            });
        }
        let [a, b, c] = t.map(|v| positions[v as usize].as_dvec3());
        area += 0.5 * (b - a).cross(c - a).length();
        tris.push(nt);
    }
    Part { positions: pos, triangles: tris, source_triangles, area }
}

/// Splits `k` spheres over parts in proportion to their surface area (largest remainder),
/// at least one each; `k` ≥ the number of parts. Area, because covering a surface of area A
/// with n balls leaves an outside volume ∝ A^{3/2} n^{-1/2}, whose sum is smallest at n ∝ A.
pub fn allocate(parts: &[Part], k: usize) -> Vec<usize> {
    let n = parts.len();
    let total: f64 = parts.iter().map(|p| p.area).sum();
    let spare = k.saturating_sub(n);
    let share = |p: &Part| if total > 0.0 { spare as f64 * p.area / total } else { spare as f64 / n as f64 };
    let mut counts: Vec<usize> = parts.iter().map(|p| 1 + share(p).floor() as usize).collect();
    let mut rest: Vec<(f64, usize)> = parts.iter().enumerate().map(|(i, p)| (share(p) - share(p).floor(), i)).collect();
    rest.sort_unstable_by(crate::largest_first);
    let mut left = k.saturating_sub(counts.iter().sum::<usize>());
    for &(_, i) in rest.iter().cycle().take(n * 2) {
        if left == 0 {
            break;
        }
        counts[i] += 1;
        left -= 1;
    }
    counts
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tri_at(o: Vec3, s: f32, base: u32) -> ([Vec3; 3], [u32; 3]) {
        ([o, o + Vec3::new(s, 0.0, 0.0), o + Vec3::new(0.0, s, 0.0)], [base, base + 1, base + 2])
    }

    fn mesh(items: &[(Vec3, f32)]) -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let (mut p, mut t) = (Vec::new(), Vec::new());
        for &(o, s) in items {
            let (q, i) = tri_at(o, s, p.len() as u32);
            p.extend(q);
            t.push(i);
        }
        (p, t)
    }

    #[test]
    fn far_groups_split_and_near_ones_stay_together() {
        // Two triangles 0.5 apart (gap < diagonal 1.41: one group), one 1000 away.
        let (p, t) = mesh(&[(Vec3::ZERO, 1.0), (Vec3::new(1.5, 0.0, 0.0), 1.0), (Vec3::new(1000.0, 0.0, 0.0), 1.0)]);
        let parts = split(&p, &t, 64).expect("splits");
        assert_eq!(parts.len(), 2);
        assert_eq!(parts[0].source_triangles, vec![0, 1]);
        assert_eq!(parts[1].source_triangles, vec![2]);
        assert_eq!(parts[1].positions[0], Vec3::new(1000.0, 0.0, 0.0));
        assert!((parts[0].area - 1.0).abs() < 1e-9 && (parts[1].area - 0.5).abs() < 1e-9);
        // The budget caps the number of parts: two spheres cannot split three parts... but can
        // split two; one sphere keeps the whole mesh.
        assert_eq!(split(&p, &t, 1), None);
        assert_eq!(split(&p, &t, 2).map(|v| v.len()), Some(2));
    }

    #[test]
    fn merging_grows_boxes_until_stable() {
        // a at 0, b at 3 (gap 2 > 1.41 from a), but a big triangle c spanning 0..4 joins
        // both; the result is one part.
        let (p, t) = mesh(&[(Vec3::ZERO, 1.0), (Vec3::new(3.0, 0.0, 0.0), 1.0), (Vec3::new(0.0, 2.0, 0.0), 4.0)]);
        assert_eq!(split(&p, &t, 64), None);
        // Without c, a and b split.
        assert_eq!(split(&p, &t[..2], 64).map(|v| v.len()), Some(2));
    }

    #[test]
    fn allocation_follows_area_and_gives_everyone_one() {
        let (p, t) = mesh(&[(Vec3::ZERO, 3.0), (Vec3::new(100.0, 0.0, 0.0), 1.0), (Vec3::new(-100.0, 0.0, 0.0), 1e-3)]);
        let parts = split(&p, &t, 64).expect("splits");
        assert_eq!(parts.len(), 3);
        let c = allocate(&parts, 64);
        assert_eq!(c.iter().sum::<usize>(), 64);
        // Areas 4.5 : 0.5 : 5e-7 of 61 spare spheres: 54.9, 6.1, 0 -> 55 + 1, 6 + 1, 0 + 1.
        assert_eq!(c, vec![56, 7, 1]);
        assert_eq!(allocate(&parts, 3), vec![1, 1, 1]);
    }
}
