//! Runtime reader of `.sphb` sphere-set files: bytes in, validated plain-data views out.
//!
//! This is the crate an engine links.
//! It validates a file once ([`load`]) and then hands out slices of plain structs of `f32`
//! arrays (`[f32; 3]` centres, `f32` radii, `[f32; 16]` column-major matrices); bring your own
//! math library.
//!
//! # Conventions
//!
//! - **Space and units.** Every centre, radius, sample position and normal is in *model space*:
//!   the asset's scene at rest (glTF: node world transforms applied, skinned meshes posed at
//!   their rest pose; OBJ: the file's coordinates), right-handed, in the units
//!   named by [`Metadata::units`]: metres for glTF input, the file's units for OBJ input.
//! - **Colour.** Albedo is *linear* RGB (not sRGB-encoded).
//! - **SH.** Real orthonormal spherical harmonics with the Condon–Shortley phase, coefficient
//!   index `i = l(l+1) + m`, order n = bands `0..n` = `n²` coefficients; directions are unit
//!   vectors, θ from +z, φ from +x towards +y. [`Proxy::albedo`] evaluates them.
//! - **Skinning.** The posed centre of sphere `s` is `Σ_j M_j · (q_j, b_j)` over its slots
//!   ([`Proxy::skin_slots`]), with `M_j` the joint matrix of bone `j` in glTF convention
//!   (joint world transform × inverse bind matrix); unused slots ([`UNUSED_BONE`]) hold zeros.
//!   Radii do not change.
//! - **Sample directions.** [`SamplePoint::direction`] indexes [`GEODESIC_DIRECTIONS`], the 92
//!   icosahedral directions in the order the specification fixes.
//!
//! # Use
//!
//! ```
//! # use spherebake_format::{write, Sphere, SphbFile};
//! # let bytes = write(&SphbFile {
//! #     spheres: vec![Sphere { center: [0.0, 1.0, 0.0], radius: 0.5 }],
//! #     ..SphbFile::default()
//! # });
//! // `bytes` is the content of a .sphb file, read by the engine's own file system.
//! let proxy = spherebake_runtime::load(&bytes)?;
//! for sphere in proxy.spheres() {
//!     let [x, y, z] = sphere.center;
//!     assert!(sphere.radius > 0.0 && (x + y + z).is_finite());
//! }
//! if let Some(h) = proxy.hierarchy() {
//!     let root = h.root as usize; // in range: validated by `load`
//!     let _ = (h.nodes[root].center, h.nodes[root].radius, h.children_of(root), h.leaves_of(root));
//! }
//! # Ok::<(), spherebake_runtime::Error>(())
//! ```
//!
//! # Animation and cut queries
//!
//! [`HierarchyPlan`] (built once, [`Proxy::hierarchy_plan`]) drives [`refit`], which recomputes
//! the hierarchy's node spheres from posed leaves without allocating, and [`cut`], which lists
//! the nodes and leaves subtending less than θmax (radians) over a receiver ball (Ren 2006 eq. 36).
//!
//! ```
//! # use spherebake_runtime::{Hierarchy, NodeLists, Sphere, HierarchyPlan, CutEntry};
//! let leaves = [
//!     Sphere { center: [-0.5, 0.0, 0.0], radius: 0.5 },
//!     Sphere { center: [0.7, 0.2, 0.0], radius: 0.4 },
//! ];
//! let h = Hierarchy::from_lists(
//!     0,
//!     [NodeLists { center: [0.0; 3], radius: 1.5, children: vec![], leaf_children: vec![0, 1] }],
//! );
//! let plan = HierarchyPlan::new(&h)?;
//! let mut nodes = spherebake_runtime::rest_node_spheres(&h);
//! spherebake_runtime::refit(&plan, &leaves, &mut nodes)?; // after posing the leaves
//! let mut cut = Vec::new();
//! let theta_max_rad = spherebake_runtime::DEFAULT_THETA_MAX_RAD;
//! spherebake_runtime::cut(&plan, &nodes, [0.0, 0.0, 2.0], 0.3, theta_max_rad, &mut cut)?;
//! assert_eq!(cut.len(), 2); // the parent is too close: both leaves
//! # Ok::<(), spherebake_runtime::QueryError>(())
//! ```
//!
//! Errors name a stable rule ID of the specification (`formats/spherebake-v1.md`), the section,
//! the byte offset and the expected and actual values; see [`ValidationError`].
//!
//! # Architecture invariant
//!
//! `no_std` + `alloc`.
//! Depends only on `spherebake-format` and `spherebake-sh`: no file system, no threads, no math
//! library, nothing from the baker.
//! No function panics on any input; indices out of range give empty slices or `None`.

#![no_std]
#![forbid(unsafe_code)]
#![warn(missing_docs)]

extern crate alloc;

pub mod cut;
pub mod light;
pub mod pose;
pub mod refit;
pub mod shadow;
pub mod tile;

use alloc::vec::Vec;

pub use cut::{cut, cut_accepts, cut_threshold, CutEntry, DEFAULT_THETA_MAX_RAD};
pub use pose::{pose, pose_and_refit, PoseError};
pub use refit::{refit, rest_node_spheres, HierarchyPlan, QueryError};

pub use spherebake_format::{
    AlbedoSh, BoneRecord, ColourSpace, Detail, Hierarchy, HierarchyNode, Metadata, NodeLists, Rule, SamplePoint,
    Samples, SectionKind, ShBasis, SkinEntry, SkinTerms, SphbFile, Sphere, ValidationError, FORMAT_MAJOR, FORMAT_MINOR,
    UNUSED_BONE,
};
pub use spherebake_sh::{GEODESIC_DIRECTIONS, GEODESIC_DIRECTION_COUNT};

/// Why a file could not be loaded: the violated validation rule and where.
pub type Error = ValidationError;

/// A validated sphere-set proxy: one owned copy of the file's data.
///
/// Every invariant of the specification holds (indices in range, finite values, positive radii,
/// a tree hierarchy, unit normals), so views need no further checks.
#[derive(Clone, Debug, PartialEq)]
pub struct Proxy {
    file: SphbFile,
}

/// Reads and validates a `.sphb` file.
///
/// Accepts every minor version of format major 1, skips unknown sections.
/// Compact files (format 1.1, `bake --compact`) are dequantised here, once: their samples and
/// albedo SH come out as the same f32 records as a lossless file's, so every accessor and view
/// is the same for both (chosen by measurement: a compact file loads faster than its lossless
/// twin, since it has fewer bytes to checksum; docs/benchmarks.md, "File size").
///
/// # Errors
///
/// The first violated rule of the specification, with section, byte offset, expected and actual value.
///
/// # Panics
///
/// Never, for any byte string.
///
/// # Performance
///
/// One pass over the bytes plus one copy of the data: linear in the file size.
/// Measured (`examples/load_timing.rs FILE...`, release build, median of 201 runs, 2-core machine
/// shared with other jobs, load average 12–14): the Stanford bunny baked at 64 spheres (88,160
/// bytes) loads in 0.10 ms (850–940 MB/s), at 256 spheres (223,488 bytes) in 0.23 ms
/// (940–980 MB/s). With one `Vec` per sphere's samples and per node's index lists (before the
/// flat layout) the same files took 0.11 ms (760–790 MB/s) and 0.28 ms (780–800 MB/s).
///
/// # What is copied
///
/// Nothing in a [`Proxy`] borrows the caller's bytes: `load` validates and copies every record
/// once, so `bytes` may be freed right after it returns and a `Proxy` has no lifetime parameter.
/// The copy keeps the file's flat layout (one array per record kind plus per-sphere / per-node
/// ranges: [`Proxy::sample_points`] with [`Proxy::sample_offsets`], [`Hierarchy::children`] and
/// [`Hierarchy::leaves`] with each node's `first_*` / `*_count`), so each array is one allocation
/// filled in order. The records are not handed out in place because the caller's buffer has no
/// alignment guarantee (a `&[u8]` may start at any address, `f32` needs 4), the file is
/// little-endian whatever the host, the crate forbids `unsafe` (reinterpreting bytes as typed
/// slices needs it) and a fixed-size sample record carries 6 bytes of padding the view does not.
/// Bone names and metadata strings are copied into `String`s after their UTF-8 check.
pub fn load(bytes: &[u8]) -> Result<Proxy, Error> {
    spherebake_format::read(bytes).map(|file| Proxy { file })
}

/// The unit direction (model space) of geodesic direction `index`, `None` for `index >= 92`.
#[must_use]
pub fn direction(index: u8) -> Option<[f32; 3]> {
    GEODESIC_DIRECTIONS.get(usize::from(index)).copied()
}

impl Proxy {
    /// Validates an in-memory file by encoding and reading it back, giving the same checks as [`load`].
    ///
    /// # Errors
    ///
    /// The first rule the model breaks.
    pub fn from_file(file: &SphbFile) -> Result<Proxy, Error> {
        load(&spherebake_format::write(file))
    }

    /// Number of spheres (at least 1).
    #[must_use]
    pub fn sphere_count(&self) -> usize {
        self.file.spheres.len()
    }

    /// All spheres: centre and radius, model space.
    #[must_use]
    pub fn spheres(&self) -> &[Sphere] {
        &self.file.spheres
    }

    /// The sphere hierarchy, if the bake produced one.
    ///
    /// `nodes[root]` is the root; every node is reached from it once; leaves index [`Proxy::spheres`].
    #[must_use]
    pub fn hierarchy(&self) -> Option<&Hierarchy> {
        self.file.hierarchy.as_ref()
    }

    /// The refit / cut plan of the hierarchy ([`HierarchyPlan::new`]), `None` without one.
    /// Build it once after loading; it allocates.
    #[must_use]
    pub fn hierarchy_plan(&self) -> Option<HierarchyPlan> {
        HierarchyPlan::new(self.file.hierarchy.as_ref()?).ok()
    }

    /// The samples section, if present.
    #[must_use]
    pub fn samples(&self) -> Option<&Samples> {
        self.file.samples.as_ref()
    }

    /// All surface sample points, sphere after sphere (one flat array); empty without samples.
    #[must_use]
    pub fn sample_points(&self) -> &[SamplePoint] {
        self.file.samples.as_ref().map_or(&[], |s| s.points.as_slice())
    }

    /// Per-sphere ranges of [`Proxy::sample_points`]: sphere `i` owns `offsets[i] .. offsets[i + 1]`
    /// (`sphere_count + 1` entries); empty without samples.
    #[must_use]
    pub fn sample_offsets(&self) -> &[u32] {
        self.file.samples.as_ref().map_or(&[], |s| s.offsets.as_slice())
    }

    /// Surface sample points of sphere `sphere` in increasing direction order; empty if the file
    /// has no samples or `sphere` is out of range.
    #[must_use]
    pub fn samples_of(&self, sphere: usize) -> &[SamplePoint] {
        self.file.samples.as_ref().map_or(&[], |s| s.of(sphere))
    }

    /// The surface area each of sphere `sphere`'s samples stands for (model units², spec §7.2), parallel to
    /// [`Proxy::samples_of`]; `None` for files without the `sample_areas` section (format minor < 2).
    #[must_use]
    pub fn sample_areas_of(&self, sphere: usize) -> Option<&[f32]> {
        self.file.samples.as_ref()?.areas_of(sphere)
    }

    /// The albedo SH section, if present.
    #[must_use]
    pub fn albedo_sh(&self) -> Option<&AlbedoSh> {
        self.file.albedo_sh.as_ref()
    }

    /// The `order²` linear-RGB SH coefficients of sphere `sphere`.
    #[must_use]
    pub fn albedo_coefficients(&self, sphere: usize) -> Option<&[[f32; 3]]> {
        self.file.albedo_sh.as_ref()?.of(sphere)
    }

    /// Linear-RGB albedo of sphere `sphere` in unit direction `dir` (model space), evaluating
    /// its SH expansion; `None` without an SH section or for an out-of-range sphere.
    ///
    /// `dir` must be unit length (the SH basis is evaluated as a polynomial in x, y, z).
    #[must_use]
    pub fn albedo(&self, sphere: usize, dir: [f32; 3]) -> Option<[f32; 3]> {
        let sh = self.file.albedo_sh.as_ref()?;
        let coeffs = sh.of(sphere)?;
        let mut basis = [0.0f32; spherebake_sh::MAX_COEFFS];
        spherebake_sh::eval_sh(usize::from(sh.order), dir, &mut basis).ok()?;
        let mut out = [0.0f32; 3];
        for (c, y) in coeffs.iter().zip(basis.iter()) {
            for (o, v) in out.iter_mut().zip(c.iter()) {
                *o += v * y;
            }
        }
        Some(out)
    }

    /// The skinning section, if present.
    #[must_use]
    pub fn skin(&self) -> Option<&SkinTerms> {
        self.file.skin.as_ref()
    }

    /// The `bones_per_sphere` skin slots of sphere `sphere`; empty without skin or out of range.
    #[must_use]
    pub fn skin_slots(&self, sphere: usize) -> &[SkinEntry] {
        self.file.skin.as_ref().map_or(&[], |s| s.of(sphere))
    }

    /// The bone table (empty if absent): name, parent, column-major inverse bind matrix.
    #[must_use]
    pub fn bones(&self) -> &[BoneRecord] {
        self.file.bones.as_deref().unwrap_or(&[])
    }

    /// Metadata: tool version, settings, input hash, units, free pairs.
    #[must_use]
    pub fn metadata(&self) -> Option<&Metadata> {
        self.file.metadata.as_ref()
    }

    /// The whole validated file.
    #[must_use]
    pub fn file(&self) -> &SphbFile {
        &self.file
    }

    /// Gives up the proxy and returns the file data.
    #[must_use]
    pub fn into_file(self) -> SphbFile {
        self.file
    }

    /// Encodes the proxy again; deterministic, and equal to the loaded bytes when those came from
    /// `spherebake_format::write`.
    #[must_use]
    pub fn to_bytes(&self) -> Vec<u8> {
        spherebake_format::write(&self.file)
    }
}
