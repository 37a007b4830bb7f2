//! The canonical in-memory mesh every stage works on.
//!
//! Triangles index *vertices*; each vertex carries its per-corner attributes (position, normal,
//! UVs, colour, skin influences), so a UV or normal seam is two vertices. For topology, every
//! vertex also maps to a *welded* position id (bit-identical f32 positions share one id), so
//! seams do not split the surface.

use glam::{Mat4, Vec3};

/// Linear RGBA colour (not sRGB), components nominally in [0, 1].
pub type LinearRgba = [f32; 4];

/// Texture wrap mode along one axis (glTF sampler semantics).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum WrapMode {
    #[default]
    Repeat,
    MirroredRepeat,
    ClampToEdge,
}

/// Texture filter choice recorded from the glTF sampler (the bake may supersample regardless).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum FilterMode {
    Nearest,
    #[default]
    Linear,
}

/// A decoded texture image, converted to **linear** RGBA f32 where the source is sRGB
/// (glTF base colour is). Row 0 is the top row of the image (glTF UV (0,0) = top-left).
#[derive(Clone, Debug, Default)]
pub struct Texture {
    /// Human-readable origin (file name or `image[3]`), for reports only.
    pub name: String,
    pub width: u32,
    pub height: u32,
    /// `width * height` texels, row-major, linear RGBA.
    pub texels_linear: Vec<LinearRgba>,
}

/// KHR_texture_transform: uv' = T(offset) · R(rotation) · S(scale) · uv.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UvTransform {
    pub offset: [f32; 2],
    /// Rotation in radians, counter-clockwise in UV space (glTF convention).
    pub rotation_rad: f32,
    pub scale: [f32; 2],
}

impl Default for UvTransform {
    fn default() -> Self {
        Self { offset: [0.0, 0.0], rotation_rad: 0.0, scale: [1.0, 1.0] }
    }
}

impl UvTransform {
    /// Applies the transform to a UV coordinate.
    pub fn apply(&self, uv: [f32; 2]) -> [f32; 2] {
        let (s, c) = self.rotation_rad.sin_cos();
        let x = uv[0] * self.scale[0];
        let y = uv[1] * self.scale[1];
        [c * x + s * y + self.offset[0], -s * x + c * y + self.offset[1]]
    }
}

/// A reference from a material to a texture.
#[derive(Clone, Debug, PartialEq)]
pub struct TextureRef {
    /// Index into [`Mesh::textures`].
    pub texture: usize,
    /// Which UV set the texture reads (0 = TEXCOORD_0, 1 = TEXCOORD_1).
    pub uv_set: u32,
    pub wrap_s: WrapMode,
    pub wrap_t: WrapMode,
    pub mag_filter: FilterMode,
    pub transform: UvTransform,
}

/// The part of a material the bake uses: base colour (albedo).
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    /// Base colour factor, linear RGBA (glTF `baseColorFactor`, OBJ `Kd`).
    pub base_color_factor_linear: LinearRgba,
    pub base_color_texture: Option<TextureRef>,
    /// glTF `doubleSided`.
    pub double_sided: bool,
    /// glTF `alphaMode` `MASK`: its `alphaCutoff` (default 0.5). Where the base colour's alpha
    /// (factor × texture × COLOR_0) is below it the surface is a hole for the albedo (a leaf
    /// card's cut-out shows what lies behind it). `None` for `OPAQUE` and for `BLEND` (taken as
    /// opaque). OBJ: 0.5 for a material with a `map_d`, whose mask the importer makes the base
    /// colour texture's alpha; `None` otherwise (`d` alone is taken as opaque).
    pub alpha_mask_cutoff: Option<f32>,
}

impl Default for Material {
    fn default() -> Self {
        Self {
            name: String::new(),
            base_color_factor_linear: [1.0; 4],
            base_color_texture: None,
            double_sided: false,
            alpha_mask_cutoff: None,
        }
    }
}

/// Up to 8 skin influences per vertex (JOINTS_0/WEIGHTS_0 and JOINTS_1/WEIGHTS_1).
/// `joints` index [`Skeleton::bones`]; unused slots have weight 0. Weights sum to 1.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SkinInfluences {
    pub joints: [u32; 8],
    pub weights: [f32; 8],
}

/// One bone of the baked bone table.
#[derive(Clone, Debug, PartialEq)]
pub struct Bone {
    pub name: String,
    /// Index of the glTF node this bone is (for posing from animations).
    pub node: usize,
    /// Parent bone index, if the parent node is also a bone.
    pub parent: Option<u32>,
    /// glTF inverse bind matrix: maps the skin's bind (mesh) space to the joint's local space.
    pub inverse_bind: Mat4,
}

/// A node of the source scene graph (glTF nodes; OBJ has none).
#[derive(Clone, Debug, PartialEq)]
pub struct Node {
    pub name: String,
    pub parent: Option<usize>,
    /// Rest local transform, translation / rotation (quaternion xyzw) / scale.
    pub translation: [f32; 3],
    pub rotation: [f32; 4],
    pub scale: [f32; 3],
}

/// Animation interpolation (glTF `sampler.interpolation`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interpolation {
    Linear,
    Step,
    CubicSpline,
}

/// Which node property a channel drives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AnimPath {
    Translation,
    Rotation,
    Scale,
}

/// One animation channel with its sampler data.
#[derive(Clone, Debug, PartialEq)]
pub struct AnimChannel {
    pub node: usize,
    pub path: AnimPath,
    pub interpolation: Interpolation,
    /// Key times in seconds, increasing.
    pub times: Vec<f32>,
    /// Flattened values: 3 (T, S) or 4 (R, xyzw) per key; for CubicSpline, (in-tangent, value,
    /// out-tangent) per key.
    pub values: Vec<f32>,
}

/// A named animation.
#[derive(Clone, Debug, PartialEq)]
pub struct Animation {
    pub name: String,
    pub channels: Vec<AnimChannel>,
}

/// Skeleton data: scene nodes, the bone table, and animations.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Skeleton {
    pub nodes: Vec<Node>,
    pub bones: Vec<Bone>,
    pub animations: Vec<Animation>,
}

/// Skinning data attached to a mesh.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Skin {
    pub skeleton: Skeleton,
    /// Per vertex: influences (same length as [`Mesh::positions`]). Vertices of rigidly attached
    /// (unskinned) parts under a joint node get weight 1 on that joint's bone.
    pub influences: Vec<SkinInfluences>,
    /// Per vertex: position in the skin's bind (mesh) space, where joint matrices
    /// `world(joint) × inverse_bind` apply. [`Mesh::positions`] holds the rest pose in scene space.
    pub bind_positions: Vec<Vec3>,
}

/// A warning found while importing or analysing (not an error: the pipeline copes).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Warning(pub String);

/// The UV of a vertex whose part has no such UV set (see [`Mesh::uvs`]): NaN, so no texture
/// lookup can take it for a coordinate; test with [`has_uv`].
pub const NO_UV: [f32; 2] = [f32::NAN, f32::NAN];

/// Whether a stored UV is a usable coordinate: finite (not [`NO_UV`], nor a NaN or infinite UV
/// read from a file, which would address no texel).
#[inline]
pub fn has_uv(uv: [f32; 2]) -> bool {
    uv[0].is_finite() && uv[1].is_finite()
}

/// Welds `positions`: bit-identical f32 positions (`-0.0` read as `0.0`) share an id, ids in
/// order of first appearance. Returns the id per position and the first position of each id
/// ([`Mesh::rebuild_weld`], `normals::crease_normals`).
pub(crate) fn weld(positions: &[Vec3]) -> (Vec<u32>, Vec<Vec3>) {
    use std::collections::HashMap;
    // Only looked up (ids come from `welded`'s order), so the hasher's random key changes
    // nothing; `FoldKey` hashes a key in a few multiplies where SipHash took most of the weld.
    let key = |p: Vec3| {
        let f = |x: f32| if x == 0.0 { 0u32 } else { x.to_bits() };
        (f(p.x), f(p.y), f(p.z))
    };
    let mut map: HashMap<(u32, u32, u32), u32, crate::fold_hash::FoldKey> =
        HashMap::with_capacity_and_hasher(positions.len(), Default::default());
    let mut welded = Vec::new();
    let ids = positions
        .iter()
        .map(|&p| {
            let next = welded.len() as u32;
            let id = *map.entry(key(p)).or_insert(next);
            if id == next {
                welded.push(p);
            }
            id
        })
        .collect();
    (ids, welded)
}

/// The canonical triangle mesh.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    /// Per-vertex position, scene (model) space, rest pose.
    pub positions: Vec<Vec3>,
    /// Per-vertex unit shading normal, scene space. Where the file gives none: computed per
    /// corner with a crease angle (OBJ), or [`crate::normals::NO_NORMAL`] (glTF: flat, each
    /// triangle shades with its geometric normal); see [`crate::normals`].
    pub normals: Vec<Vec3>,
    /// Per-vertex UV sets (`uvs[0]` = TEXCOORD_0, ...); each either empty or one per vertex.
    /// A vertex of a part (glTF primitive, OBJ group) that lacks the set holds [`NO_UV`], so a
    /// textured triangle there is known to have no UVs (its base colour factor is used), rather
    /// than reading the texel at UV (0, 0).
    pub uvs: Vec<Vec<[f32; 2]>>,
    /// Per-vertex colour (COLOR_0), linear RGBA; empty when absent.
    pub colors_linear: Vec<LinearRgba>,
    /// Triangles as vertex indices, counter-clockwise = front (outward when consistent).
    pub triangles: Vec<[u32; 3]>,
    /// Per-triangle material index into `materials`.
    pub triangle_materials: Vec<u32>,
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
    /// Per-vertex welded position id (bit-identical positions share an id).
    pub weld: Vec<u32>,
    /// Welded positions, indexed by weld id.
    pub welded_positions: Vec<Vec3>,
    pub skin: Option<Skin>,
    /// Surface-only triangles, ascending indices into `triangles`: the copy kept of a face
    /// the input held as often in one winding as in the other (a zero-thickness double-sided
    /// fin). Their solid angles cancel, so they enclose nothing: the solid, the closed check and
    /// the orientation leave them out, while the surface the spheres must cover (samples,
    /// bounding pass, coverage, albedo) includes them. Empty for most meshes, and when every
    /// triangle is such a face (a mesh exported double-sided: its kept copies are its solid).
    /// Set by [`Mesh::remove_duplicate_triangles`].
    pub surface_only: Vec<u32>,
}

impl Mesh {
    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// Triangle `t` as three positions.
    pub fn triangle(&self, t: usize) -> [Vec3; 3] {
        let [a, b, c] = self.triangles[t];
        [self.positions[a as usize], self.positions[b as usize], self.positions[c as usize]]
    }

    /// Triangles as welded position ids.
    pub fn welded_triangles(&self) -> Vec<[u32; 3]> {
        self.triangles
            .iter()
            .map(|t| [self.weld[t[0] as usize], self.weld[t[1] as usize], self.weld[t[2] as usize]])
            .collect()
    }

    /// Rebuilds `weld` and `welded_positions` from `positions`: bit-identical f32 positions
    /// share an id (ids in order of first appearance, so the result is deterministic).
    /// `-0.0` and `0.0` are treated as equal.
    pub fn rebuild_weld(&mut self) {
        (self.weld, self.welded_positions) = weld(&self.positions);
    }

    /// Removes every triangle whose three welded corners are those of an earlier triangle, in
    /// either orientation (a face exported twice, or once per side), keeping the first, with
    /// its material; returns how many were removed. Vertices are kept.
    ///
    /// Why: stacked copies of one face are no more surface, but they cost every stage that
    /// reads the triangles near a point (the winding number sums each copy exactly, the BVH
    /// builder degrades on identical boxes): 16 000 copies of one triangle took minutes to
    /// bake. A closed mesh exported double-sided (each face once per winding) has winding
    /// number 0 everywhere, and encloses its solid again once each face is left once.
    ///
    /// A face kept that the input held as often in one winding as in the other (a double-sided
    /// fin on an otherwise single-sided mesh) encloses nothing: it becomes
    /// [`Mesh::surface_only`], so the solid is the mesh without it (closed again when the fin
    /// was its only defect) while its surface is still covered. When every face kept is such a
    /// face (the whole mesh exported double-sided), none is: the kept copies are the solid.
    ///
    /// On a skinned mesh two corners are the same only when their influences and bind
    /// positions are too: layers that coincide at rest but move apart when animated are kept.
    ///
    /// Cost: O(T) (a counting sort of the corner triples, `sorted_corner_keys`), and O(T) to
    /// rebuild only when some triangle is removed.
    pub fn remove_duplicate_triangles(&mut self) -> usize {
        let (removed, balanced) = self.duplicate_triangles_balanced();
        self.set_surface_only(&removed, &balanced);
        self.remove_triangles(&removed)
    }

    /// Sets [`Mesh::surface_only`] to the triangles marked in `balanced` and those it held
    /// (indices before the triangles marked in `removed` are removed: [`Mesh::remove_triangles`]
    /// renumbers them), except those on closed surfaces of such triangles (a part exported
    /// double-sided: [`Mesh::closed_groups`]) that are not wholly inside the solid of the other
    /// triangles ([`Mesh::inside_groups`]: the faces between touching boxes each given whole
    /// are), and none when that would be every triangle kept (the whole mesh double-sided).
    /// Returns how many were set. Cost O(n log n) in the triangles, plus a winding-number tree
    /// over the single-sided ones when a closed surface of such triangles is found.
    pub fn set_surface_only(&mut self, removed: &[bool], balanced: &[bool]) -> usize {
        let kept = (0..self.triangles.len()).filter(|&i| !removed.get(i).copied().unwrap_or(false));
        let held = std::mem::take(&mut self.surface_only);
        let is_balanced =
            |i: &usize| balanced.get(*i).copied().unwrap_or(false) || held.binary_search(&(*i as u32)).is_ok();
        let candidates: Vec<usize> = kept.clone().filter(is_balanced).collect();
        let mut enclosing = self.closed_groups(&candidates);
        // A closed surface of such faces inside the solid of the single-sided ones (the faces
        // between touching boxes, each given once per box: voxel art, modular kits) encloses
        // nothing that solid does not: surface only too.
        if enclosing.contains(&true) {
            let single: Vec<[u32; 3]> = kept.clone().filter(|i| !is_balanced(i)).map(|i| self.triangles[i]).collect();
            for group in self.inside_groups(&candidates, &enclosing, &single) {
                for n in group {
                    enclosing[n] = false;
                }
            }
        }
        self.surface_only = candidates.iter().zip(&enclosing).filter(|(_, &e)| !e).map(|(&i, _)| i as u32).collect();
        if self.surface_only.len() == kept.count() {
            self.surface_only.clear();
        }
        self.surface_only.len()
    }

    /// The connected groups (triangles sharing a welded edge) of the triangles of `tris` marked
    /// in `closed`, as positions in `tris`, whose every triangle's centroid is inside the solid
    /// of `single` (|w| ≥ ½, [`crate::voxel::inside`]). None when `single` is empty. Cost: a
    /// winding-number tree over `single` and one evaluation per marked triangle.
    fn inside_groups(&self, tris: &[usize], closed: &[bool], single: &[[u32; 3]]) -> Vec<Vec<usize>> {
        if single.is_empty() {
            return Vec::new();
        }
        let w = |v: u32| self.weld.get(v as usize).copied().unwrap_or(v);
        let marked: Vec<usize> = (0..tris.len()).filter(|&n| closed[n]).collect();
        // Disjoint sets over `marked` through shared edges.
        let mut parent: Vec<usize> = (0..marked.len()).collect();
        let mut edges: Vec<([u32; 2], usize)> = Vec::with_capacity(3 * marked.len());
        for (m, &n) in marked.iter().enumerate() {
            let c = self.triangles[tris[n]].map(w);
            for e in 0..3 {
                let (a, b) = (c[e], c[(e + 1) % 3]);
                edges.push(([a.min(b), a.max(b)], m));
            }
        }
        edges.sort_unstable();
        for run in edges.chunk_by(|a, b| a.0 == b.0) {
            for x in &run[1..] {
                crate::disjoint::union(&mut parent, run[0].1, x.1);
            }
        }
        let wn = crate::winding::WindingNumber::new(&self.positions, single);
        let centroid = |t: usize| {
            let [a, b, c] = self.triangles[t].map(|v| self.positions[v as usize].as_dvec3());
            (a + b + c) / 3.0
        };
        let mut groups: std::collections::BTreeMap<usize, (Vec<usize>, bool)> = std::collections::BTreeMap::new();
        for (m, &n) in marked.iter().enumerate() {
            let r = crate::disjoint::find(&mut parent, m);
            let g = groups.entry(r).or_insert((Vec::new(), true));
            g.0.push(n);
            g.1 &= crate::voxel::inside(wn.eval(centroid(tris[n])));
        }
        groups.into_values().filter(|g| g.1).map(|g| g.0).collect()
    }

    /// Per triangle of `tris` (indices into `triangles`): whether it is left after peeling,
    /// from `tris`, every triangle with an edge (welded corners, windings aside) that no other
    /// remaining triangle of `tris` shares, until none has one. What is left has every edge in
    /// two or more triangles: closed surfaces, such as a part exported double-sided beside
    /// single-sided ones (a closed box given once per winding), whose kept copies enclose its
    /// solid, so they are not surface only. Fins and open double-sided sheets peel away, also
    /// where they meet a closed part along an edge. Cost O(n log n) in `tris`.
    fn closed_groups(&self, tris: &[usize]) -> Vec<bool> {
        let w = |v: u32| self.weld.get(v as usize).copied().unwrap_or(v);
        // (undirected edge, position in `tris`), sorted: an edge's triangles are adjacent.
        let mut edges: Vec<([u32; 2], u32)> = Vec::with_capacity(3 * tris.len());
        for (n, &t) in tris.iter().enumerate() {
            let c = self.triangles[t].map(w);
            for e in 0..3 {
                let (a, b) = (c[e], c[(e + 1) % 3]);
                edges.push(([a.min(b), a.max(b)], n as u32));
            }
        }
        edges.sort_unstable();
        // Per edge run: its triangles (`edges[run]`) and how many remain; per triangle its runs.
        let runs: Vec<std::ops::Range<usize>> = {
            let mut v = Vec::new();
            let mut at = 0;
            for r in edges.chunk_by(|a, b| a.0 == b.0) {
                v.push(at..at + r.len());
                at += r.len();
            }
            v
        };
        let mut left: Vec<usize> = runs.iter().map(|r| r.len()).collect();
        let mut of_tri: Vec<Vec<u32>> = vec![Vec::with_capacity(3); tris.len()];
        for (ri, r) in runs.iter().enumerate() {
            for &(_, n) in &edges[r.clone()] {
                of_tri[n as usize].push(ri as u32);
            }
        }
        let mut kept = vec![true; tris.len()];
        let mut queue: Vec<u32> =
            (0..tris.len() as u32).filter(|&n| of_tri[n as usize].iter().any(|&r| left[r as usize] == 1)).collect();
        // Each triangle is peeled at most once, so the loop ends after at most n removals.
        while let Some(n) = queue.pop() {
            if !kept[n as usize] {
                continue;
            }
            kept[n as usize] = false;
            for &r in &of_tri[n as usize] {
                left[r as usize] -= 1;
                if left[r as usize] == 1 {
                    queue.extend(edges[runs[r as usize].clone()].iter().map(|e| e.1).filter(|&m| kept[m as usize]));
                }
            }
        }
        kept
    }

    /// Removes triangle i (and its material entry) where `removed[i]`; returns how many.
    /// [`Mesh::surface_only`] is renumbered (a removed triangle leaves it).
    pub fn remove_triangles(&mut self, removed: &[bool]) -> usize {
        let count = removed.iter().filter(|&&r| r).count();
        if count > 0 {
            let keep = |i: &usize| !removed.get(*i).copied().unwrap_or(false);
            self.triangles = (0..self.triangles.len()).filter(keep).map(|i| self.triangles[i]).collect();
            self.triangle_materials =
                (0..self.triangle_materials.len()).filter(keep).map(|i| self.triangle_materials[i]).collect();
            if !self.surface_only.is_empty() {
                let mut kept_before = Vec::with_capacity(removed.len());
                let mut n = 0u32;
                for i in 0..removed.len() {
                    kept_before.push(n);
                    n += u32::from(keep(&i));
                }
                // Past `removed`, every removed triangle is before i (lazily: i < the count
                // removed would underflow).
                let at =
                    |i: u32| kept_before.get(i as usize).copied().unwrap_or_else(|| i - (removed.len() as u32 - n));
                self.surface_only =
                    self.surface_only.iter().filter(|&&i| keep(&(i as usize))).map(|&i| at(i)).collect();
            }
        }
        count
    }

    /// Per triangle: whether [`Mesh::remove_duplicate_triangles`] removes it.
    pub fn duplicate_triangles(&self) -> Vec<bool> {
        self.duplicate_triangles_balanced().0
    }

    /// Per triangle: whether [`Mesh::remove_duplicate_triangles`] removes it, and whether it is
    /// the copy kept of a balanced face: three distinct corners present as often in one
    /// winding as in the other (a face exported once per side), whose solid angles cancel.
    /// Stacked copies of one winding, or an unequal count of each, are not balanced.
    pub fn duplicate_triangles_balanced(&self) -> (Vec<bool>, Vec<bool>) {
        let ids = self.corner_ids();
        let keys = sorted_corner_keys(&self.triangles, &ids);
        let mut removed = vec![false; self.triangles.len()];
        let mut balanced = vec![false; self.triangles.len()];
        for group in keys.chunk_by(|a, b| a.0 == b.0) {
            // Sorted by (corners, index): the first of a run of equal corners is kept.
            for k in &group[1..] {
                removed[k.1 as usize] = true;
            }
            let k = group[0].0;
            let even = group.iter().filter(|g| g.2).count();
            if k[0] != k[1] && k[1] != k[2] && 2 * even == group.len() {
                balanced[group[0].1 as usize] = true;
            }
        }
        (removed, balanced)
    }

    /// Per vertex: an id shared by the vertices that are one corner for
    /// [`Mesh::remove_duplicate_triangles`]: the weld id, and on a skinned mesh also the same
    /// influences and bind position (bits; ids in order of first appearance).
    fn corner_ids(&self) -> Vec<u32> {
        let Some(skin) = &self.skin else { return self.weld.clone() };
        // (weld id, joints, weight bits, bind position bits).
        type Corner = (u32, [u32; 8], [u32; 8], [u32; 3]);
        let mut map: std::collections::HashMap<Corner, u32> = std::collections::HashMap::with_capacity(self.weld.len());
        (0..self.weld.len())
            .map(|v| {
                let inf = skin.influences.get(v).copied().unwrap_or_default();
                let bind = skin.bind_positions.get(v).copied().unwrap_or(Vec3::NAN);
                let key = (self.weld[v], inf.joints, inf.weights.map(f32::to_bits), bind.to_array().map(f32::to_bits));
                let next = map.len() as u32;
                *map.entry(key).or_insert(next)
            })
            .collect()
    }

    /// Axis-aligned bounds over the corners of all triangles (unused vertices ignored).
    /// Returns `None` for a mesh without triangles.
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        let mut it = self.triangles.iter().flatten();
        let first = self.positions[*it.next()? as usize];
        let (mut lo, mut hi) = (first, first);
        for &v in it {
            let p = self.positions[v as usize];
            lo = lo.min(p);
            hi = hi.max(p);
        }
        Some((lo, hi))
    }

    /// Appends another mesh (materials, textures and vertices re-indexed). Skins are not merged:
    /// the importer builds the skin after appending all parts.
    pub fn append(&mut self, other: &Mesh) {
        let v0 = self.positions.len() as u32;
        let m0 = self.materials.len() as u32;
        let t0 = self.textures.len();
        let n_self = self.positions.len();
        self.positions.extend_from_slice(&other.positions);
        self.normals.extend_from_slice(&other.normals);
        let sets = self.uvs.len().max(other.uvs.len());
        self.uvs.resize(sets, Vec::new());
        for s in 0..sets {
            let theirs = other.uvs.get(s).filter(|o| !o.is_empty());
            let mine = &mut self.uvs[s];
            if mine.is_empty() && theirs.is_none() {
                continue; // absent from both: stays absent (empty)
            }
            if mine.len() < n_self {
                mine.resize(n_self, NO_UV);
            }
            match theirs {
                Some(o) => mine.extend_from_slice(o),
                None => mine.resize(n_self + other.positions.len(), NO_UV),
            }
        }
        if !self.colors_linear.is_empty() || !other.colors_linear.is_empty() {
            self.colors_linear.resize(n_self, [1.0; 4]);
            if other.colors_linear.is_empty() {
                self.colors_linear.resize(n_self + other.positions.len(), [1.0; 4]);
            } else {
                self.colors_linear.extend_from_slice(&other.colors_linear);
            }
        }
        self.triangles.extend(other.triangles.iter().map(|t| [t[0] + v0, t[1] + v0, t[2] + v0]));
        self.triangle_materials.extend(other.triangle_materials.iter().map(|m| m + m0));
        self.materials.extend(other.materials.iter().map(|m| {
            let mut m = m.clone();
            if let Some(t) = &mut m.base_color_texture {
                t.texture += t0;
            }
            m
        }));
        self.textures.extend_from_slice(&other.textures);
        self.rebuild_weld();
    }
}

/// Per triangle (corner ids by `ids`, [`Mesh::corner_ids`]; `u32::MAX` for a vertex out of
/// range): (its corner ids sorted, its index, whether it is counter-clockwise in the sorted
/// order), the list in ascending tuple order, as sorting it would give (the indices make the
/// tuples distinct, so the order is unique). Bucketed by the smallest corner id (a counting
/// sort over the ids; every id out of range, `u32::MAX`, in one last bucket), then each bucket
/// sorted on its own: a corner is the smallest of a handful of triangles, so this is O(T)
/// where a comparison sort of all T tuples was a tenth of the bunny's OBJ import.
fn sorted_corner_keys(triangles: &[[u32; 3]], ids: &[u32]) -> Vec<([u32; 3], u32, bool)> {
    let id = |v: u32| ids.get(v as usize).copied().unwrap_or(u32::MAX);
    let key = |i: usize, t: &[u32; 3]| {
        let c = [id(t[0]), id(t[1]), id(t[2])];
        let even = u8::from(c[0] < c[1]) + u8::from(c[1] < c[2]) + u8::from(c[2] < c[0]) == 2;
        let mut k = c;
        k.sort_unstable();
        (k, i as u32, even)
    };
    // Ids are below `ids.len()` (or `u32::MAX`): bucket `b` holds the smallest id b, the last
    // bucket the rest.
    let buckets = ids.len() + 1;
    let keys = || triangles.iter().enumerate().map(|(i, t)| key(i, t));
    crate::bucket::bucket_sorted(keys, buckets, |k| (k.0[0] as usize).min(buckets - 1))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The bucketed corner keys are the keys sorted, as a comparison sort gives them (repeated,
    /// reversed and out-of-range corners, ids shared by several vertices, a vertex of many).
    #[test]
    fn sorted_corner_keys_are_the_sorted_tuples() {
        let mut rng = spherebake_testkit::rng::SplitMix64::new(0x9E37_79B9_7F4A_7C15);
        let mut next = |n: u64| (rng.next_u64() % n) as u32;
        for round in 0..50u32 {
            let verts = 1 + round * 5;
            // Ids shared by vertex pairs (a weld); vertices past `verts` are out of range.
            let ids: Vec<u32> = (0..verts).map(|v| v / 2).collect();
            let tris: Vec<[u32; 3]> = (0..round * 11)
                .map(|i| match i % 6 {
                    0 => [0, next(verts as u64), next(verts as u64)],
                    1 => [next(verts as u64 + 3), verts + next(4), next(verts as u64)],
                    2 => [verts + 1, verts + 2, verts + next(3)],
                    _ => [0; 3].map(|_| next(verts as u64)),
                })
                .collect();
            let id = |v: u32| ids.get(v as usize).copied().unwrap_or(u32::MAX);
            let mut want: Vec<([u32; 3], u32, bool)> = tris
                .iter()
                .enumerate()
                .map(|(i, t)| {
                    let c = t.map(id);
                    let even = u8::from(c[0] < c[1]) + u8::from(c[1] < c[2]) + u8::from(c[2] < c[0]) == 2;
                    let mut k = c;
                    k.sort_unstable();
                    (k, i as u32, even)
                })
                .collect();
            want.sort_unstable();
            assert_eq!(sorted_corner_keys(&tris, &ids), want, "round {round}");
        }
        assert!(sorted_corner_keys(&[], &[]).is_empty());
        assert_eq!(sorted_corner_keys(&[[5, 6, 7]], &[]), vec![([u32::MAX; 3], 0, false)]);
    }

    /// `append` keeps uvs[k] = TEXCOORD_k for every vertex: a part without a set gets
    /// [`NO_UV`] (not (0, 0), which would read a texel), and a set absent from both stays empty.
    #[test]
    fn append_fills_a_missing_uv_set_with_no_uv_and_keeps_absent_sets_empty() {
        let part = |n: usize, uvs: Vec<Vec<[f32; 2]>>| Mesh {
            positions: vec![Vec3::ZERO; n],
            normals: vec![Vec3::Z; n],
            uvs,
            ..Default::default()
        };
        let mut a = part(2, vec![vec![[0.25, 0.5]; 2], Vec::new()]);
        a.append(&part(3, Vec::new()));
        assert_eq!(a.uvs.len(), 2);
        assert_eq!(a.uvs[0][..2], [[0.25, 0.5]; 2]);
        assert!(a.uvs[0][2..].iter().all(|&uv| !has_uv(uv)) && a.uvs[0].len() == 5, "{:?}", a.uvs[0]);
        assert!(a.uvs[1].is_empty(), "absent from both parts: {:?}", a.uvs[1]);
        let mut b = part(2, Vec::new());
        b.append(&part(1, vec![vec![[0.75, 1.0]]]));
        assert_eq!(b.uvs.len(), 1);
        assert!(!has_uv(b.uvs[0][0]) && !has_uv(b.uvs[0][1]));
        assert_eq!(b.uvs[0][2], [0.75, 1.0]);
        // Usable means finite: NaN and infinite UVs read from a file address no texel either.
        assert!(has_uv([0.0, 1.0]) && !has_uv([f32::INFINITY, 0.0]) && !has_uv([0.0, f32::NAN]));
    }

    /// Against a brute-force pass over every earlier triangle (the same corner set): the same
    /// triangles and materials kept in order, the count of the others; a position written twice
    /// (one vertex per corner) is one corner, either winding is a copy.
    #[test]
    fn duplicate_triangles_are_those_with_an_earlier_triangles_corners() {
        let mut rng = crate::rng::SplitMix64::new(7);
        for round in 0..40 {
            let n = 3 + (rng.next_u64() % 6) as usize;
            // Each position twice: vertex v and v + n are welded.
            let pts: Vec<Vec3> = (0..n).map(|i| Vec3::new(i as f32, (i * i % 5) as f32, -(i as f32))).collect();
            let mut m = Mesh { positions: [pts.clone(), pts].concat(), ..Default::default() };
            m.rebuild_weld();
            let tris = 1 + (rng.next_u64() % 40) as usize;
            for _ in 0..tris {
                let mut t = [0u32; 3];
                for c in &mut t {
                    *c = (rng.next_u64() % (2 * n as u64)) as u32;
                }
                m.triangles.push(t);
                m.triangle_materials.push((rng.next_u64() % 3) as u32);
            }
            let set = |t: &[u32; 3]| {
                let mut k = t.map(|v| v % n as u32);
                k.sort_unstable();
                k
            };
            let keep: Vec<usize> =
                (0..tris).filter(|&i| (0..i).all(|j| set(&m.triangles[j]) != set(&m.triangles[i]))).collect();
            let want_tris: Vec<[u32; 3]> = keep.iter().map(|&i| m.triangles[i]).collect();
            let want_mats: Vec<u32> = keep.iter().map(|&i| m.triangle_materials[i]).collect();
            let removed = m.remove_duplicate_triangles();
            assert_eq!(removed, tris - keep.len(), "round {round}");
            assert_eq!(m.triangles, want_tris, "round {round}");
            assert_eq!(m.triangle_materials, want_mats, "round {round}");
            assert_eq!(m.remove_duplicate_triangles(), 0, "round {round}: a second pass");
        }
        // The other winding is a copy; a triangle sharing two of its corners is not.
        let mut m = Mesh { positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::NEG_X], ..Default::default() };
        m.rebuild_weld();
        m.triangles = vec![[0, 1, 2], [0, 2, 3], [2, 1, 0]];
        assert_eq!(m.remove_duplicate_triangles(), 1);
        assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3]]);
        // Skinned: vertices 3..6 repeat 0..3's positions; a copy on 3..6 is removed only while
        // those vertices follow the same joints with the same weights from the same bind position.
        let skinned = |influence_3: u32, bind_3: Vec3| {
            let pos = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::ZERO, Vec3::X, Vec3::Y];
            let inf = |j: u32| SkinInfluences {
                joints: [j, 0, 0, 0, 0, 0, 0, 0],
                weights: [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            };
            let mut m = Mesh {
                positions: pos.clone(),
                skin: Some(Skin {
                    influences: vec![inf(0), inf(0), inf(0), inf(influence_3), inf(0), inf(0)],
                    bind_positions: [&pos[..3], &[bind_3], &pos[4..]].concat(),
                    ..Default::default()
                }),
                triangles: vec![[0, 1, 2], [4, 3, 5]],
                ..Default::default()
            };
            m.rebuild_weld();
            m.remove_duplicate_triangles()
        };
        assert_eq!(skinned(0, Vec3::ZERO), 1);
        assert_eq!(skinned(1, Vec3::ZERO), 0, "another joint");
        assert_eq!(skinned(0, Vec3::Z), 0, "another bind position");
    }

    /// A face present as often in each winding is kept once as surface only, unless every face
    /// kept is one (a mesh exported double-sided keeps its copies as the solid); stacked copies
    /// of one winding, or unequal counts, stay ordinary faces; the indices follow the removal.
    #[test]
    fn balanced_faces_are_kept_once_as_surface_only() {
        let mesh = |tris: Vec<[u32; 3]>| {
            let mut m = Mesh {
                positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z, Vec3::ONE, Vec3::X],
                triangles: tris,
                ..Default::default()
            };
            m.triangle_materials = (0..m.triangles.len() as u32).collect();
            m.rebuild_weld();
            m
        };
        // 0: plain; 1 and 3: one face each way (vertex 5 is vertex 1 welded); 2: plain;
        // 4 and 5: stacked one way; 6, 7, 8: two one way, one the other.
        let mut m = mesh(vec![
            [0, 1, 2],
            [0, 1, 3],
            [1, 2, 3],
            [3, 5, 0],
            [0, 2, 3],
            [2, 3, 0],
            [1, 2, 4],
            [4, 1, 2],
            [2, 1, 4],
        ]);
        assert_eq!(m.remove_duplicate_triangles(), 4);
        assert_eq!(m.triangles, vec![[0, 1, 2], [0, 1, 3], [1, 2, 3], [0, 2, 3], [1, 2, 4]]);
        assert_eq!(m.triangle_materials, vec![0, 1, 2, 4, 6]);
        assert_eq!(m.surface_only, vec![1]);
        // Two each way is balanced too; a second pass keeps the surface-only face.
        let mut m = mesh(vec![[0, 1, 2], [0, 1, 3], [1, 0, 3], [3, 0, 1], [3, 1, 0]]);
        assert_eq!(m.remove_duplicate_triangles(), 3);
        assert_eq!(m.surface_only, vec![1]);
        assert_eq!(m.remove_duplicate_triangles(), 0);
        assert_eq!(m.surface_only, vec![1]);
        // Every face kept balanced: a double-sided export, no surface-only face.
        let mut m = mesh(vec![[0, 1, 2], [0, 1, 3], [2, 1, 0], [1, 0, 3]]);
        assert_eq!(m.remove_duplicate_triangles(), 2);
        assert!(m.surface_only.is_empty());
        // A closed tetrahedron (0, 1, 2, 3) given once per winding beside a single-sided face
        // (1, 2, 4): its kept copies are closed on their own, so they stay solid; a fin (0, 1, 4)
        // given both ways beside them is surface only.
        let tet = [[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]];
        let mut tris: Vec<[u32; 3]> = tet.to_vec();
        tris.extend(tet.iter().map(|t| [t[0], t[2], t[1]]));
        tris.push([1, 2, 4]);
        let mut m = mesh(tris.clone());
        assert_eq!(m.remove_duplicate_triangles(), 4);
        assert!(m.surface_only.is_empty(), "{:?}", m.surface_only);
        tris.extend([[0, 1, 4], [0, 4, 1]]);
        let mut m = mesh(tris);
        assert_eq!(m.remove_duplicate_triangles(), 5);
        assert_eq!(m.surface_only, vec![5]);
        // Renumbering: a removed triangle before a surface-only one shifts it.
        let mut m = mesh(vec![[0, 1, 2], [0, 1, 3]]);
        m.surface_only = vec![1];
        assert_eq!(m.remove_triangles(&[true, false]), 1);
        assert_eq!(m.surface_only, vec![0]);
    }

    /// Axis-aligned cubes `(min corner, edge)`, each whole (8 corners of its own, 12 outward
    /// triangles, the quads split on the same diagonal wherever two cubes touch).
    fn boxes(list: &[(Vec3, f32)]) -> Mesh {
        let mut m = Mesh::default();
        for &(o, e) in list {
            let b = m.positions.len() as u32;
            m.positions.extend(
                (0..8).map(|i| o + e * Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32)),
            );
            for q in [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]] {
                m.triangles.push([b + q[0], b + q[1], b + q[2]]);
                m.triangles.push([b + q[0], b + q[2], b + q[3]]);
            }
        }
        m.triangle_materials = vec![0; m.triangles.len()];
        m.rebuild_weld();
        m
    }

    /// Touching boxes each given whole (voxel art, modular kits): every face between two of
    /// them is there once per winding, and the faces around the middle box of a 3 × 3 × 3
    /// block close a surface among themselves, inside the block. All 54 such faces (3 axes ×
    /// 2 inner planes × 9 squares, 108 triangles) are surface only, and the 54 outer squares
    /// are the closed solid. A closed box given double-sided is still solid beside a
    /// single-sided one and where it reaches out of it, and surface only wholly inside it.
    #[test]
    fn closed_double_sided_faces_inside_the_single_sided_solid_are_surface_only() {
        let block: Vec<(Vec3, f32)> =
            (0..27).map(|i| (Vec3::new((i % 3) as f32, ((i / 3) % 3) as f32, (i / 9) as f32), 1.0)).collect();
        let mut m = boxes(&block);
        assert_eq!(m.remove_duplicate_triangles(), 108);
        assert_eq!(m.surface_only.len(), 108);
        let solid: Vec<[u32; 3]> = (0..m.triangles.len())
            .filter(|i| m.surface_only.binary_search(&(*i as u32)).is_err())
            .map(|i| m.triangles[i].map(|v| m.weld[v as usize]))
            .collect();
        assert_eq!(solid.len(), 6 * 9 * 2);
        assert!(crate::voxel::is_closed(&m.welded_positions, &solid));

        // A single-sided box (0..4)³ and a second box given once per winding.
        let double = |o: Vec3, e: f32| {
            let mut m = boxes(&[(Vec3::ZERO, 4.0), (o, e)]);
            let copy: Vec<[u32; 3]> = m.triangles[12..].iter().map(|t| [t[0], t[2], t[1]]).collect();
            m.triangles.extend(copy);
            m.triangle_materials = vec![0; m.triangles.len()];
            m.remove_duplicate_triangles();
            m.surface_only.len()
        };
        assert_eq!(double(Vec3::splat(1.0), 2.0), 12, "wholly inside: surface only");
        assert_eq!(double(Vec3::splat(6.0), 1.0), 0, "beside: its own solid");
        assert_eq!(double(Vec3::splat(3.0), 2.0), 0, "reaching out: its own solid");
    }

    #[test]
    fn weld_merges_bit_identical_positions_only() {
        let mut m = Mesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::new(-0.0, 0.0, 0.0), Vec3::new(1.0 + f32::EPSILON, 0.0, 0.0)],
            ..Default::default()
        };
        m.rebuild_weld();
        assert_eq!(m.weld, vec![0, 1, 0, 2]);
        assert_eq!(m.welded_positions.len(), 3);
    }

    #[test]
    fn uv_transform_matches_gltf_matrix() {
        // KHR_texture_transform example: offset (0.5, 0), rotation 90°, scale (2, 1).
        let t = UvTransform { offset: [0.5, 0.0], rotation_rad: std::f32::consts::FRAC_PI_2, scale: [2.0, 1.0] };
        // uv (1, 0) -> scale (2, 0) -> rotate: (c*2 + s*0, -s*2 + c*0) = (0, -2) -> offset (0.5, -2).
        let r = t.apply([1.0, 0.0]);
        assert!((r[0] - 0.5).abs() < 1e-6 && (r[1] + 2.0).abs() < 1e-6, "{r:?}");
    }
}
