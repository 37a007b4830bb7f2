//! The owned plain-data model of a `.sphb` file.
//!
//! Every value is in model space, in the units named by [`Metadata::units`]
//! (metres for glTF input, file units for OBJ input).

use alloc::string::String;
use alloc::vec::Vec;

/// Bone index of an unused skin slot ([`SkinEntry::bone`]).
pub const UNUSED_BONE: u32 = u32::MAX;

/// Parent index of a root bone as stored in the file (the model uses `None`).
pub const NO_PARENT: u32 = u32::MAX;

/// Number of geodesic sample directions (icosahedron, frequency 3; order defined in the spec).
pub const DIRECTION_COUNT: u8 = 92;

/// Largest supported SH order (bands `0..order`, `order²` coefficients).
pub const MAX_SH_ORDER: u8 = 8;

/// Largest supported number of bones per sphere in the skin section.
pub const MAX_BONES_PER_SPHERE: u32 = 64;

/// One bounding sphere, model space.
#[repr(C)] // C-compatible layout: the C ABI hands these arrays out in place.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Sphere {
    /// Centre (x, y, z), model space.
    pub center: [f32; 3],
    /// Radius, model units; finite and greater than 0.
    pub radius: f32,
}

/// One node of the sphere hierarchy: a bounding sphere over its children and leaves, stored as
/// the file stores it (index ranges into [`Hierarchy::children`] and [`Hierarchy::leaves`]).
#[repr(C)] // C-compatible layout: the C ABI hands these arrays out in place.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct HierarchyNode {
    /// Centre (x, y, z), model space.
    pub center: [f32; 3],
    /// Radius, model units; finite and greater than 0.
    pub radius: f32,
    /// Start of this node's child nodes in [`Hierarchy::children`].
    pub first_child: u32,
    /// Number of child nodes.
    pub child_count: u32,
    /// Start of this node's leaf spheres in [`Hierarchy::leaves`].
    pub first_leaf: u32,
    /// Number of leaf spheres.
    pub leaf_count: u32,
}

/// A hierarchy node given by its own lists, for building a [`Hierarchy`] ([`Hierarchy::from_lists`]).
#[derive(Clone, Debug, PartialEq, Default)]
pub struct NodeLists {
    /// Centre (x, y, z), model space.
    pub center: [f32; 3],
    /// Radius, model units.
    pub radius: f32,
    /// Child nodes, as node indices.
    pub children: Vec<u32>,
    /// Leaf spheres, as indices into [`SphbFile::spheres`].
    pub leaf_children: Vec<u32>,
}

/// A tree of bounding spheres whose leaves are the spheres of the sphere set, in the file's flat
/// layout: one node array, one child-index array and one leaf-index array; each node names a
/// range of each array.
///
/// Every node is reachable from `root` exactly once, and every sphere is the leaf of exactly one
/// node (checked by the reader; a hand-built value may break it, and then the reader rejects
/// what the writer makes of it).
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Hierarchy {
    /// Index of the root node in `nodes`.
    pub root: u32,
    /// All nodes.
    pub nodes: Vec<HierarchyNode>,
    /// Child node indices; node `i` owns `children[first_child .. first_child + child_count]`.
    pub children: Vec<u32>,
    /// Leaf sphere indices; node `i` owns `leaves[first_leaf .. first_leaf + leaf_count]`.
    pub leaves: Vec<u32>,
}

fn range_of(items: &[u32], first: u32, count: u32) -> &[u32] {
    let (Ok(first), Ok(count)) = (usize::try_from(first), usize::try_from(count)) else {
        return &[];
    };
    first.checked_add(count).and_then(|end| items.get(first..end)).unwrap_or(&[])
}

impl Hierarchy {
    /// Builds the flat layout from per-node lists, ranges laid out in node order.
    #[must_use]
    pub fn from_lists(root: u32, nodes: impl IntoIterator<Item = NodeLists>) -> Hierarchy {
        let mut h = Hierarchy { root, ..Hierarchy::default() };
        for n in nodes {
            h.push_node(n.center, n.radius, &n.children, &n.leaf_children);
        }
        h
    }

    /// Appends a node with these children and leaves; returns its index.
    pub fn push_node(&mut self, center: [f32; 3], radius: f32, children: &[u32], leaves: &[u32]) -> u32 {
        let len = |v: usize| u32::try_from(v).unwrap_or(u32::MAX);
        self.nodes.push(HierarchyNode {
            center,
            radius,
            first_child: len(self.children.len()),
            child_count: len(children.len()),
            first_leaf: len(self.leaves.len()),
            leaf_count: len(leaves.len()),
        });
        self.children.extend_from_slice(children);
        self.leaves.extend_from_slice(leaves);
        len(self.nodes.len() - 1)
    }

    /// The per-node lists (for editing; rebuild with [`Hierarchy::from_lists`]).
    #[must_use]
    pub fn to_lists(&self) -> Vec<NodeLists> {
        (0..self.nodes.len())
            .map(|i| {
                let n = self.nodes.get(i).copied().unwrap_or_default();
                NodeLists {
                    center: n.center,
                    radius: n.radius,
                    children: self.children_of(i).to_vec(),
                    leaf_children: self.leaves_of(i).to_vec(),
                }
            })
            .collect()
    }

    /// Child node indices of node `node`; empty when out of range.
    #[must_use]
    pub fn children_of(&self, node: usize) -> &[u32] {
        self.nodes.get(node).map_or(&[], |n| range_of(&self.children, n.first_child, n.child_count))
    }

    /// Leaf sphere indices of node `node`; empty when out of range.
    #[must_use]
    pub fn leaves_of(&self, node: usize) -> &[u32] {
        self.nodes.get(node).map_or(&[], |n| range_of(&self.leaves, n.first_leaf, n.leaf_count))
    }
}

/// One surface sample point of a sphere (Guerrero et al. 2008, §4.2).
#[repr(C)] // C-compatible layout: the C ABI hands these arrays out in place.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct SamplePoint {
    /// Position on the surface (x, y, z), model space.
    pub position: [f32; 3],
    /// Outward unit surface normal (x, y, z), model space.
    pub normal: [f32; 3],
    /// Index into the 92 geodesic directions (0..92) whose ray produced the sample.
    pub direction: u8,
    /// Placement rule that produced the sample: 1, 2 or 3.
    pub rule: u8,
}

/// Surface sample points of all spheres in the file's flat layout: one point array, and per
/// sphere a range of it given by `offsets` (`sphere_count + 1` entries, starting at 0).
#[derive(Clone, Debug, PartialEq)]
pub struct Samples {
    /// Sphere `i` owns `points[offsets[i] .. offsets[i + 1]]`, in strictly increasing direction order.
    pub offsets: Vec<u32>,
    /// All samples, sphere after sphere.
    pub points: Vec<SamplePoint>,
    /// The surface area (model units², ≥ 0) each sample stands for, one per point in the same
    /// order (spec §7.2, section `sample_areas`, minor 2); `None` in files without it.
    pub areas: Option<Vec<f32>>,
}

impl Default for Samples {
    /// No spheres: `offsets == [0]`.
    fn default() -> Self {
        Samples { offsets: alloc::vec![0], points: Vec::new(), areas: None }
    }
}

impl Samples {
    /// Builds the flat layout from one list per sphere.
    #[must_use]
    pub fn from_per_sphere(per_sphere: impl IntoIterator<Item = Vec<SamplePoint>>) -> Samples {
        let mut s = Samples::default();
        for list in per_sphere {
            s.push_sphere(&list);
        }
        s
    }

    /// Appends the samples of the next sphere.
    pub fn push_sphere(&mut self, points: &[SamplePoint]) {
        self.points.extend_from_slice(points);
        self.offsets.push(u32::try_from(self.points.len()).unwrap_or(u32::MAX));
    }

    /// Number of spheres (`offsets.len() - 1`).
    #[must_use]
    pub fn sphere_count(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    /// Index range of sphere `sphere`'s samples in [`Samples::points`], empty when out of range.
    #[must_use]
    pub fn range_of(&self, sphere: usize) -> core::ops::Range<usize> {
        let bound = |i: usize| self.offsets.get(i).and_then(|&o| usize::try_from(o).ok());
        match (bound(sphere), sphere.checked_add(1).and_then(bound)) {
            (Some(a), Some(b)) if a <= b && b <= self.points.len() => a..b,
            _ => 0..0,
        }
    }

    /// Samples of sphere `sphere`, empty when out of range.
    #[must_use]
    pub fn of(&self, sphere: usize) -> &[SamplePoint] {
        self.points.get(self.range_of(sphere)).unwrap_or(&[])
    }

    /// The samples of each sphere in turn.
    pub fn per_sphere(&self) -> impl ExactSizeIterator<Item = &[SamplePoint]> + '_ {
        (0..self.sphere_count()).map(|i| self.of(i))
    }

    /// The areas of sphere `sphere`'s samples (parallel to [`Samples::of`]); `None` without
    /// areas or when they do not match the points.
    #[must_use]
    pub fn areas_of(&self, sphere: usize) -> Option<&[f32]> {
        let a = self.areas.as_ref().filter(|a| a.len() == self.points.len())?;
        a.get(self.range_of(sphere))
    }

    /// Total number of samples over all spheres.
    #[must_use]
    pub fn total(&self) -> usize {
        self.points.len()
    }
}

/// Colour space of stored colours.
#[non_exhaustive]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum ColourSpace {
    /// Linear (not sRGB-encoded) RGB with Rec. 709 primaries. Code 0.
    #[default]
    LinearRgb,
}

impl ColourSpace {
    /// Code stored in the file.
    #[must_use]
    pub const fn code(self) -> u8 {
        match self {
            ColourSpace::LinearRgb => 0,
        }
    }

    /// The colour space with this code.
    #[must_use]
    pub const fn from_code(code: u8) -> Option<Self> {
        match code {
            0 => Some(ColourSpace::LinearRgb),
            _ => None,
        }
    }
}

/// Spherical harmonics basis of stored coefficients.
#[non_exhaustive]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum ShBasis {
    /// Real orthonormal SH with the Condon–Shortley phase, coefficient index `i = l(l+1) + m`. Code 0.
    #[default]
    RealOrthonormalCs,
}

impl ShBasis {
    /// Code stored in the file.
    #[must_use]
    pub const fn code(self) -> u8 {
        match self {
            ShBasis::RealOrthonormalCs => 0,
        }
    }

    /// The basis with this code.
    #[must_use]
    pub const fn from_code(code: u8) -> Option<Self> {
        match code {
            0 => Some(ShBasis::RealOrthonormalCs),
            _ => None,
        }
    }
}

/// Albedo of every sphere as an SH function over directions.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct AlbedoSh {
    /// SH order n in 1..=8: bands `0..n`, `n²` coefficients per sphere.
    pub order: u8,
    /// Colour space of the coefficients.
    pub colour_space: ColourSpace,
    /// SH basis and index order.
    pub basis: ShBasis,
    /// `sphere_count × n²` RGB coefficients; sphere `s`, coefficient `i` is at `s·n² + i`.
    pub coefficients: Vec<[f32; 3]>,
}

impl AlbedoSh {
    /// Number of coefficients per sphere (`order²`).
    #[must_use]
    pub fn coefficients_per_sphere(&self) -> usize {
        usize::from(self.order) * usize::from(self.order)
    }

    /// The `order²` RGB coefficients of sphere `sphere`, `None` when out of range.
    #[must_use]
    pub fn of(&self, sphere: usize) -> Option<&[[f32; 3]]> {
        let n = self.coefficients_per_sphere();
        let start = sphere.checked_mul(n)?;
        self.coefficients.get(start..start.checked_add(n)?)
    }
}

/// One skinning slot of a sphere.
///
/// The posed centre of a sphere is `Σ_j M_j · (q_j, b_j)` over its used slots, with `M_j`
/// the joint matrix of bone `j` (glTF convention: world transform × inverse bind matrix).
#[repr(C)] // C-compatible layout: the C ABI hands these arrays out in place.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct SkinEntry {
    /// Bone index into the bone table, or [`UNUSED_BONE`].
    pub bone: u32,
    /// Homogeneous point xyz part.
    pub q: [f32; 3],
    /// Homogeneous point w part.
    pub b: f32,
}

/// Per-sphere skinning terms: a fixed number of slots per sphere.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct SkinTerms {
    /// Slots per sphere, 1..=64.
    pub bones_per_sphere: u32,
    /// `sphere_count × bones_per_sphere` entries; sphere `s` uses `s·k .. (s+1)·k`.
    pub entries: Vec<SkinEntry>,
}

impl SkinTerms {
    /// The slots of sphere `sphere`, empty when out of range.
    #[must_use]
    pub fn of(&self, sphere: usize) -> &[SkinEntry] {
        let Ok(k) = usize::try_from(self.bones_per_sphere) else {
            return &[];
        };
        let Some(start) = sphere.checked_mul(k) else {
            return &[];
        };
        let Some(end) = start.checked_add(k) else {
            return &[];
        };
        self.entries.get(start..end).unwrap_or(&[])
    }
}

/// One bone of the skeleton.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct BoneRecord {
    /// Bone (joint node) name, UTF-8; may be empty.
    pub name: String,
    /// Parent bone index, `None` for a root.
    pub parent: Option<u32>,
    /// Inverse bind matrix, 4×4, column-major (glTF `inverseBindMatrices`).
    pub inverse_bind: [f32; 16],
}

/// Provenance and free key/value strings.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Metadata {
    /// Version of the tool that wrote the file (key `tool_version`).
    pub tool_version: String,
    /// Bake settings, e.g. as JSON (key `settings`).
    pub settings: String,
    /// Content hash of the input, e.g. hex (key `input_hash`).
    pub input_hash: String,
    /// Units of all lengths, e.g. "metres" or "file units" (key `units`).
    pub units: String,
    /// Further pairs in file order; keys are non-empty, unique and not one of the four above.
    pub extra: Vec<(String, String)>,
}

/// A whole `.sphb` file: the sphere set plus the optional sections a bake produced.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct SphbFile {
    /// The sphere set (required, at least one sphere).
    pub spheres: Vec<Sphere>,
    /// Sphere hierarchy.
    pub hierarchy: Option<Hierarchy>,
    /// Surface sample points per sphere.
    pub samples: Option<Samples>,
    /// Albedo SH per sphere.
    pub albedo_sh: Option<AlbedoSh>,
    /// Per-sphere skinning terms (requires `bones`).
    pub skin: Option<SkinTerms>,
    /// Bone table.
    pub bones: Option<Vec<BoneRecord>>,
    /// Metadata.
    pub metadata: Option<Metadata>,
}
