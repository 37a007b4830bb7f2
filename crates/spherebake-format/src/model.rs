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
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Sphere {
    /// Centre (x, y, z), model space.
    pub center: [f32; 3],
    /// Radius, model units; finite and greater than 0.
    pub radius: f32,
}

/// One node of the sphere hierarchy: a bounding sphere over its children and leaves.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct HierarchyNode {
    /// Centre (x, y, z), model space.
    pub center: [f32; 3],
    /// Radius, model units; finite and greater than 0.
    pub radius: f32,
    /// Child nodes, as indices into [`Hierarchy::nodes`].
    pub children: Vec<u32>,
    /// Leaf spheres, as indices into [`SphbFile::spheres`].
    pub leaf_children: Vec<u32>,
}

/// A tree of bounding spheres whose leaves are the spheres of the sphere set.
///
/// Every node is reachable from `root` exactly once, and every sphere is the leaf of exactly one node.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Hierarchy {
    /// Index of the root node in `nodes`.
    pub root: u32,
    /// All nodes.
    pub nodes: Vec<HierarchyNode>,
}

/// One surface sample point of a sphere (Guerrero et al. 2008, §4.2).
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

/// Surface sample points, grouped per sphere.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Samples {
    /// `per_sphere[i]` holds sphere `i`'s samples in strictly increasing direction order.
    pub per_sphere: Vec<Vec<SamplePoint>>,
}

impl Samples {
    /// Samples of sphere `sphere`, empty when out of range.
    #[must_use]
    pub fn of(&self, sphere: usize) -> &[SamplePoint] {
        self.per_sphere.get(sphere).map_or(&[], Vec::as_slice)
    }

    /// Total number of samples over all spheres.
    #[must_use]
    pub fn total(&self) -> usize {
        self.per_sphere.iter().map(Vec::len).sum()
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
