//! Topology report: counts, bounds, boundary / non-manifold edges, components, volume.
//!
//! Everything is computed on *welded* positions (bit-identical f32 positions are one vertex,
//! see [`Mesh::weld`]), so UV and normal seams do not split the surface. Cost: about linear in
//! the triangle count (the counting sort of the edges, [`crate::edges::sort_id_edges`], plus
//! union-find).

use glam::{DVec3, Vec3};

use crate::edges::{directed_ids, sort_id_edges, sorted_groups, EdgeClasses};
use crate::mesh::Mesh;

/// Topology facts about a mesh, on welded positions.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TopologyReport {
    pub triangle_count: usize,
    /// Stored vertices ([`Mesh::positions`] length), used or not.
    pub vertex_count: usize,
    /// Distinct welded positions used by at least one triangle.
    pub welded_vertex_count: usize,
    /// Min / max over the corners of all triangles, model space; `None` without triangles.
    pub aabb: Option<(Vec3, Vec3)>,
    /// Undirected welded edges of triangles with three distinct welded vertices (a zero-area
    /// one among them, a sliver at a T-junction, joins its edges as the fit's closed check
    /// does). The edges, `closed`,
    /// `consistently_oriented` and `signed_volume` leave out [`Mesh::surface_only`] triangles
    /// (double-sided faces, which enclose nothing); the counts, bounds, area and components
    /// include them.
    pub edge_count: usize,
    /// Undirected welded edges used by exactly one such triangle.
    pub boundary_edge_count: usize,
    /// Undirected welded edges used by three or more such triangles.
    pub non_manifold_edge_count: usize,
    /// Triangles with a repeated welded vertex or zero area (exact f64 cross product).
    pub degenerate_triangle_count: usize,
    /// Groups of triangles connected through shared welded vertices.
    pub component_count: usize,
    /// Every undirected edge is shared by exactly two such triangles (and there is at least one
    /// triangle).
    pub closed: bool,
    /// Closed, and no directed edge occurs twice (all triangles wind the same way).
    pub consistently_oriented: bool,
    /// Σ a·(b×c)/6 over all triangles, f64, cubic model units. The enclosed volume only when
    /// `closed` (positive for outward-facing counter-clockwise triangles); origin-dependent otherwise.
    pub signed_volume: f64,
    /// Σ |(b−a)×(c−a)|/2, f64, square model units.
    pub surface_area: f64,
}

fn find(parent: &mut [u32], mut x: u32) -> u32 {
    while parent[x as usize] != x {
        let p = parent[x as usize];
        parent[x as usize] = parent[p as usize];
        x = p;
    }
    x
}

/// Welded ids per vertex: the mesh's own when consistent, else recomputed (same rule as
/// [`Mesh::rebuild_weld`]).
fn weld_ids(mesh: &Mesh) -> (Vec<u32>, usize) {
    if mesh.weld.len() == mesh.positions.len() && mesh.weld.iter().all(|&w| (w as usize) < mesh.welded_positions.len())
    {
        return (mesh.weld.clone(), mesh.welded_positions.len());
    }
    let mut m = Mesh { positions: mesh.positions.clone(), ..Default::default() };
    m.rebuild_weld();
    (m.weld, m.welded_positions.len())
}

impl TopologyReport {
    /// Analyses `mesh`. Triangles must index existing vertices (the importer guarantees it);
    /// out-of-range corners are counted as degenerate and otherwise ignored rather than panicking.
    pub fn compute(mesh: &Mesh) -> TopologyReport {
        let (weld, weld_count) = weld_ids(mesh);
        let n = mesh.positions.len();
        let mut r = TopologyReport { triangle_count: mesh.triangles.len(), vertex_count: n, ..Default::default() };
        let mut used = vec![false; weld_count];
        let mut parent: Vec<u32> = (0..weld_count as u32).collect();
        // Directed edges as (undirected key, runs forward: [`directed_ids`]), for triangles
        // on three distinct welded vertices.
        let mut edges: Vec<(u64, bool)> = Vec::with_capacity(mesh.triangles.len() * 3);
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        let (mut vol, mut area) = (0.0f64, 0.0f64);
        // Surface-only triangles (`Mesh::surface_only`: double-sided faces, enclosing nothing)
        // count as surface (area, bounds, components) but not toward the edges or the volume.
        let only = |i: usize| !mesh.surface_only.is_empty() && mesh.surface_only.binary_search(&(i as u32)).is_ok();
        for (ti, t) in mesh.triangles.iter().enumerate() {
            if t.iter().any(|&v| v as usize >= n) {
                r.degenerate_triangle_count += 1;
                continue;
            }
            let p = t.map(|v| mesh.positions[v as usize]);
            for q in p {
                lo = lo.min(q);
                hi = hi.max(q);
            }
            let [a, b, c] = p.map(|q| q.as_dvec3());
            if !only(ti) {
                vol += a.dot(b.cross(c)) / 6.0;
            }
            let cr: DVec3 = (b - a).cross(c - a);
            area += cr.length() / 2.0;
            let w = t.map(|v| weld[v as usize]);
            for &x in &w {
                used[x as usize] = true;
            }
            let (ra, rb, rc) = (find(&mut parent, w[0]), find(&mut parent, w[1]), find(&mut parent, w[2]));
            parent[rb as usize] = ra;
            parent[rc as usize] = ra;
            if w[0] == w[1] || w[1] == w[2] || w[0] == w[2] {
                r.degenerate_triangle_count += 1;
                continue;
            }
            // A zero-area triangle on three distinct vertices (a sliver closing a T-junction)
            // is degenerate but still joins its edges, as it does for the fit's closed check:
            // leaving its edges out reported a closed mesh that the bake takes as closed as
            // "not closed", with three boundary edges that are no hole.
            if cr == DVec3::ZERO {
                r.degenerate_triangle_count += 1;
            }
            if only(ti) {
                continue;
            }
            for k in 0..3 {
                edges.push(directed_ids(w[k], w[(k + 1) % 3]));
            }
        }
        r.aabb = (lo.x <= hi.x).then_some((lo, hi));
        r.signed_volume = vol;
        r.surface_area = area;
        r.welded_vertex_count = used.iter().filter(|&&u| u).count();
        r.component_count = (0..weld_count as u32).filter(|&x| used[x as usize] && find(&mut parent, x) == x).count();
        let mut classes = EdgeClasses::default();
        // Sorted by a counting sort on the lower welded id (`sort_id_edges`): the order
        // `group_edges` sorts to.
        for group in sorted_groups(&sort_id_edges(&edges, weld_count)) {
            r.edge_count += 1;
            classes.add(group.class());
        }
        r.boundary_edge_count = classes.boundary;
        r.non_manifold_edge_count = classes.non_manifold;
        r.closed = !edges.is_empty() && r.boundary_edge_count == 0 && r.non_manifold_edge_count == 0;
        r.consistently_oriented = r.closed && classes.inconsistent == 0;
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Unit cube [0,1]³ with 8 shared vertices and 12 outward (CCW) triangles.
    fn cube(offset: Vec3) -> Mesh {
        let positions: Vec<Vec3> =
            (0..8).map(|i| Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32) + offset).collect();
        // Quads (outward CCW), split into two triangles each.
        let quads = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
        let triangles = quads.iter().flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]).collect();
        let mut m = Mesh { positions, triangles, ..Default::default() };
        m.rebuild_weld();
        m
    }

    fn merged(a: &Mesh, b: &Mesh) -> Mesh {
        let mut m = a.clone();
        let n = m.positions.len() as u32;
        m.positions.extend_from_slice(&b.positions);
        m.triangles.extend(b.triangles.iter().map(|t| t.map(|v| v + n)));
        m.rebuild_weld();
        m
    }

    /// The unit cube with its edge (0,0,0)–(1,0,0) split on the y = 0 side by a vertex at its
    /// middle, the T-junction closed by a zero-area sliver on the three collinear vertices (as
    /// exporters leave them): degenerate, but closed and consistently oriented, as the fit's
    /// closed check (which pairs the sliver's edges too) takes it.
    #[test]
    fn a_zero_area_sliver_at_a_t_junction_keeps_the_mesh_closed() {
        let mut m = cube(Vec3::ZERO);
        m.positions.push(Vec3::new(0.5, 0.0, 0.0)); // vertex 8
        let at = m.triangles.iter().position(|t| *t == [0, 1, 5]).expect("the y = 0 face's triangle on the edge");
        m.triangles.splice(at..=at, [[0, 8, 5], [8, 1, 5]]);
        m.triangles.push([8, 0, 1]);
        m.rebuild_weld();
        let r = TopologyReport::compute(&m);
        assert_eq!(r.degenerate_triangle_count, 1);
        assert_eq!((r.boundary_edge_count, r.non_manifold_edge_count), (0, 0), "{r:?}");
        assert!(r.closed && r.consistently_oriented, "{r:?}");
        assert!((r.signed_volume - 1.0).abs() < 1e-12, "{}", r.signed_volume);
    }

    #[test]
    fn unit_cube() {
        let r = TopologyReport::compute(&cube(Vec3::ZERO));
        assert_eq!(r.triangle_count, 12);
        assert_eq!((r.vertex_count, r.welded_vertex_count), (8, 8));
        // Euler: V − E + F = 2 for a sphere-like surface → E = 8 + 12 − 2 = 18.
        assert_eq!(r.edge_count, 18);
        assert_eq!((r.boundary_edge_count, r.non_manifold_edge_count, r.degenerate_triangle_count), (0, 0, 0));
        assert!(r.closed && r.consistently_oriented);
        assert_eq!(r.component_count, 1);
        assert!((r.signed_volume - 1.0).abs() < 1e-12, "{}", r.signed_volume);
        assert!((r.surface_area - 6.0).abs() < 1e-12);
        assert_eq!(r.aabb, Some((Vec3::ZERO, Vec3::ONE)));
    }

    #[test]
    fn cube_with_seam_duplicates_welds() {
        // Split every triangle onto its own vertices (like a UV-seamed cube): same topology.
        let c = cube(Vec3::ZERO);
        let mut m = Mesh::default();
        for t in &c.triangles {
            let n = m.positions.len() as u32;
            m.positions.extend(t.iter().map(|&v| c.positions[v as usize]));
            m.triangles.push([n, n + 1, n + 2]);
        }
        m.rebuild_weld();
        let r = TopologyReport::compute(&m);
        assert_eq!((r.vertex_count, r.welded_vertex_count), (36, 8));
        assert!(r.closed && r.consistently_oriented);
    }

    #[test]
    fn cube_missing_one_triangle_has_three_boundary_edges() {
        let mut m = cube(Vec3::ZERO);
        m.triangles.pop();
        let r = TopologyReport::compute(&m);
        assert_eq!(r.boundary_edge_count, 3);
        assert!(!r.closed && !r.consistently_oriented);
        assert!((r.surface_area - 5.5).abs() < 1e-12);
    }

    #[test]
    fn two_cubes_two_components_volume_two() {
        let m = merged(&cube(Vec3::ZERO), &cube(Vec3::new(3.0, 0.0, 0.0)));
        let r = TopologyReport::compute(&m);
        assert_eq!(r.component_count, 2);
        assert!(r.closed);
        assert!((r.signed_volume - 2.0).abs() < 1e-12);
        assert_eq!(r.aabb, Some((Vec3::ZERO, Vec3::new(4.0, 1.0, 1.0))));
        // Cubes sharing one corner vertex: one component through the shared welded vertex.
        let m = merged(&cube(Vec3::ZERO), &cube(Vec3::ONE));
        assert_eq!(TopologyReport::compute(&m).component_count, 1);
    }

    #[test]
    fn flipped_triangle_breaks_orientation_only() {
        let mut m = cube(Vec3::ZERO);
        m.triangles[0].swap(1, 2);
        let r = TopologyReport::compute(&m);
        assert!(r.closed);
        assert!(!r.consistently_oriented);
        // The flipped triangle (area 1/2) now contributes the opposite signed volume; a triangle
        // on the face z = 0 contributes 0 to Σ a·(b×c)/6, so the volume is unchanged.
        assert!((r.signed_volume - 1.0).abs() < 1e-12);
    }

    #[test]
    fn inverted_cube_has_negative_volume() {
        let mut m = cube(Vec3::new(1.0, 2.0, 3.0));
        for t in &mut m.triangles {
            t.swap(1, 2);
        }
        let r = TopologyReport::compute(&m);
        assert!(r.consistently_oriented);
        assert!((r.signed_volume + 1.0).abs() < 1e-12);
    }

    #[test]
    fn degenerate_triangles_counted_and_excluded_from_edges() {
        let mut m = cube(Vec3::ZERO);
        m.triangles.push([0, 0, 1]); // repeated vertex
        m.positions.push(Vec3::new(2.0, 0.0, 0.0));
        m.triangles.push([0, 1, 8]); // collinear: zero area
        m.rebuild_weld();
        let r = TopologyReport::compute(&m);
        assert_eq!(r.degenerate_triangle_count, 2);
        // The repeated-vertex triangle joins no edge; the zero-area one on three distinct
        // vertices joins its edges, as in the fit's closed check (which then takes the voxel
        // solid): a third user of the cube edge 0–1 and two boundary edges.
        assert_eq!((r.non_manifold_edge_count, r.boundary_edge_count), (1, 2), "{r:?}");
        assert!(!r.closed);
        assert_eq!(r.welded_vertex_count, 9);
        assert_eq!(r.aabb.unwrap().1, Vec3::new(2.0, 1.0, 1.0));
        let mut m = cube(Vec3::ZERO);
        m.triangles.push([0, 0, 1]);
        let r = TopologyReport::compute(&m);
        assert!(r.closed && r.degenerate_triangle_count == 1, "a repeated-vertex triangle is no edge user");
    }

    #[test]
    fn non_manifold_fin() {
        // Two triangles sharing edge 0-1 plus a third on the same edge.
        let mut m = Mesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::NEG_Y, Vec3::Z],
            triangles: vec![[0, 1, 2], [1, 0, 3], [0, 1, 4]],
            ..Default::default()
        };
        m.rebuild_weld();
        let r = TopologyReport::compute(&m);
        assert_eq!(r.non_manifold_edge_count, 1);
        assert_eq!(r.boundary_edge_count, 6);
        assert!(!r.closed);
    }

    #[test]
    fn unused_vertices_and_stale_weld() {
        let mut m = cube(Vec3::ZERO);
        m.positions.push(Vec3::splat(9.0)); // unused: ignored by welded count and AABB
        m.weld.clear(); // stale weld: recomputed
        let r = TopologyReport::compute(&m);
        assert_eq!((r.vertex_count, r.welded_vertex_count), (9, 8));
        assert_eq!(r.aabb, Some((Vec3::ZERO, Vec3::ONE)));
        let r = TopologyReport::compute(&Mesh::default());
        assert_eq!((r.triangle_count, r.component_count, r.closed, r.aabb), (0, 0, false, None));
    }
}
