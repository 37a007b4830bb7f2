//! The C ABI of the spherebake runtime (`include/spherebake.h`, generated from this file by cbindgen).
//!
//! # Conventions
//!
//! - Every function returns an `int32_t` status: `SPHB_OK` (0) or one of the `SPHB_ERR_*` codes.
//!   When the last argument `err` is not NULL it receives the code, the specification's rule ID
//!   (for `SPHB_ERR_INVALID_FILE`, e.g. 3004; else 0) and a one-line NUL-terminated message.
//! - Every pointer is checked: NULL where data is needed gives `SPHB_ERR_NULL`; a misaligned
//!   pointer `SPHB_ERR_INVALID_ARGUMENT`; an output buffer shorter than needed
//!   `SPHB_ERR_BUFFER_TOO_SMALL` (nothing is written then; where a `*_len_out` exists it holds the
//!   required length). A NULL pointer with a length of 0 is an empty array.
//! - No output may overlap an input or another output of the same call (as with `memcpy`): the
//!   array arguments are checked, and an overlap gives `SPHB_ERR_INVALID_ARGUMENT` (an output's
//!   range is its declared capacity). Memory the library hands out (`sphb_proxy_views` and the
//!   like) is read-only.
//! - Floating-point arguments are checked where a NaN or an infinity would give a silent wrong
//!   answer (points, radii, angles, directions): `SPHB_ERR_INVALID_ARGUMENT`.
//! - No panic crosses the boundary: each call runs under `catch_unwind`; a caught panic gives
//!   `SPHB_ERR_INTERNAL`.
//! - Ownership: `sphb_load` copies the bytes (the caller may free them right away) and returns a
//!   proxy the caller frees with `sphb_proxy_free`. Pointers handed out by `sphb_proxy_views`,
//!   `sphb_proxy_bone` and `sphb_proxy_metadata` point into the proxy and live until it is freed.
//!   Every `*_new` object is freed by its `*_free`; freeing NULL does nothing.
//! - Memory: the library allocates with the system allocator (no allocator hooks). Running out
//!   of memory aborts the process, as Rust's global allocator does. A `*_new` without arguments
//!   returns NULL only on an internal error (a caught panic); `sphb_shadow_context_new` and
//!   `sphb_light_context_new` return a status and leave NULL in `*out` when they fail.
//! - Thread safety: a proxy and the shadow / light contexts are immutable after creation: any
//!   number of threads may use them at once. A `SphbShadowCluster` is mutated by its build (one
//!   thread at a time); once built, its queries (`sphb_accumulate_log_visibility`,
//!   `sphb_shade_point`) read it only and may run on many threads at once. A
//!   `SphbIndirectCluster` is mutated by its build and by `sphb_indirect_irradiance` (its own
//!   buffers): one thread at a time; once built, `sphb_indirect_irradiance_with` reads it only
//!   and may run on many threads at once, each with its own `SphbIndirectScratch`. A
//!   `SphbSphereLights` is mutated by its calls: one thread at a time per object. No call keeps
//!   global state.
//! - A failed build leaves its cluster empty and not built: its queries then fail with
//!   `SPHB_ERR_INVALID_ARGUMENT` ("not built") until a build succeeds, never answering from a
//!   half-built cluster.
//! - Arrays of pointers to const objects (`const SphbSphereLights *const *lights`): C does not
//!   convert `SphbSphereLights **` to that type implicitly; declare the array
//!   `const SphbSphereLights *lights[]` (C++ converts it implicitly).
//! - Units and conventions are the runtime's: model space, right-handed, lengths in the units
//!   of the `units` metadata (metres for glTF input), angles in radians, colours linear RGB, SH
//!   real orthonormal with the Condon–Shortley phase and index `l(l+1)+m` (order n = n² coefficients),
//!   matrices column-major 4×4 (glTF joint matrices: world(joint) × inverse bind).

#![allow(clippy::missing_safety_doc)] // Every function's safety contract is the module's "Conventions".

use core::ffi::c_char;
use core::mem::{align_of, offset_of, size_of};
use std::panic::{catch_unwind, AssertUnwindSafe};

use spherebake_format::{HierarchyNode, SamplePoint, SkinEntry, Sphere, ValidationError};
use spherebake_runtime::light::{
    clip_below_horizon, light_spheres, light_spheres_from_radiance, sphere_rotations, ClusterSpec, IndirectCluster,
    IndirectScratch, LightContext, LightError, LightSource, Pass1Settings, Pass1Stats, PosedProxy, SphereLights,
};
use spherebake_runtime::shadow::{accumulate_log_visibility, shade, ClusterBlockers, ExpMethod, ShadowContext};
use spherebake_runtime::{CutEntry, HierarchyPlan, Proxy};

/// Success.
pub const SPHB_OK: i32 = 0;
/// A required pointer argument is NULL.
pub const SPHB_ERR_NULL: i32 = 1;
/// An output buffer is shorter than needed (nothing written; see `*_len_out` where given).
pub const SPHB_ERR_BUFFER_TOO_SMALL: i32 = 2;
/// The bytes are not a valid `.sphb` file; `SphbError::rule_id` names the violated rule.
pub const SPHB_ERR_INVALID_FILE: i32 = 3;
/// An argument is out of range, misaligned, or does not fit the proxy (wrong count, order, index).
pub const SPHB_ERR_INVALID_ARGUMENT: i32 = 4;
/// The proxy lacks the data the call needs (no hierarchy, samples, albedo SH).
pub const SPHB_ERR_MISSING_DATA: i32 = 5;
/// A panic was caught inside the library (a bug; please report).
pub const SPHB_ERR_INTERNAL: i32 = 6;

/// Capacity of `SphbError::message` in bytes, NUL included.
pub const SPHB_MESSAGE_CAPACITY: usize = 256;

/// SH exponential of the shadow queries: Ren's PS* of degree 4 (the default).
pub const SPHB_EXP_PS_STAR_4: i32 = 0;
/// SH exponential: Ren's HYB with the default OL norm bound (about 2× faster, less accurate).
pub const SPHB_EXP_HYB: i32 = 1;
/// SH exponential: accurate exp(M_f)·1 (a reference; slower).
pub const SPHB_EXP_ACCURATE: i32 = 2;

/// Default cut threshold θmax of the hierarchy, radians (25°; Ren 2006 eq. 36).
pub const SPHB_DEFAULT_THETA_MAX_RAD: f32 = 0.436_332_3_f32;

/// Bone index of an unused skin slot (its terms are 0).
pub const SPHB_UNUSED_BONE: u32 = u32::MAX;
/// Parent index of a root bone.
pub const SPHB_NO_PARENT: u32 = u32::MAX;

/// Why a call failed. Caller-allocated; pass NULL to ignore.
#[repr(C)]
pub struct SphbError {
    /// `SPHB_OK` or an `SPHB_ERR_*` code (the call's return value).
    pub code: i32,
    /// The specification's validation rule ID (e.g. 1005 header checksum, 3004 sphere radius) for
    /// `SPHB_ERR_INVALID_FILE`; 0 otherwise.
    pub rule_id: u32,
    /// One-line UTF-8 message, NUL-terminated (truncated to fit).
    pub message: [c_char; SPHB_MESSAGE_CAPACITY],
}

/// One sphere: centre x, y, z and radius (model space / model units; radius > 0). 16 bytes, the
/// file's sphere record. A sphere the fit left empty (it found no use for it within its budget)
/// is stored as a point: radius `FLT_MIN` (the least positive normal float). It blocks and emits
/// nothing measurable; an engine may skip it, and every query treats it as the point it is.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SphbSphere {
    /// Centre x, y, z.
    pub center: [f32; 3],
    /// Radius.
    pub radius: f32,
}

/// One hierarchy node: its sphere and its ranges of `SphbViews::children` and `SphbViews::leaves`.
/// 32 bytes, the file's node record.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SphbNode {
    /// Centre x, y, z (rest pose).
    pub center: [f32; 3],
    /// Radius.
    pub radius: f32,
    /// Start of the node's child nodes in `children`.
    pub first_child: u32,
    /// Number of child nodes.
    pub child_count: u32,
    /// Start of the node's leaf spheres in `leaves`.
    pub first_leaf: u32,
    /// Number of leaf spheres.
    pub leaf_count: u32,
}

/// One surface sample point (28 bytes in memory; the file's record adds 6 bytes of padding).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SphbSample {
    /// Position on the surface x, y, z, model space.
    pub position: [f32; 3],
    /// Outward unit normal x, y, z.
    pub normal: [f32; 3],
    /// Index 0..91 of the geodesic direction whose ray produced the sample.
    pub direction: u8,
    /// Placement rule 1, 2 or 3.
    pub rule: u8,
}

/// One skin slot: the posed centre of a sphere is Σ_j M_j · (q_j, b_j) over its slots. 20 bytes,
/// the file's slot record.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SphbSkinSlot {
    /// Bone index, or `SPHB_UNUSED_BONE`.
    pub bone: u32,
    /// Homogeneous point, xyz part.
    pub q: [f32; 3],
    /// Homogeneous point, w part.
    pub b: f32,
}

/// One entry of a hierarchy cut.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SphbCutEntry {
    /// Node index (`is_leaf == 0`) or sphere index (`is_leaf == 1`).
    pub index: u32,
    /// 1 for a leaf sphere, 0 for a hierarchy node.
    pub is_leaf: u32,
}

const _: () = assert!(SPHB_DEFAULT_THETA_MAX_RAD == spherebake_runtime::DEFAULT_THETA_MAX_RAD);

// The view types are the runtime's records, so views are handed out without copying.
const _: () = {
    assert!(size_of::<SphbSphere>() == size_of::<Sphere>() && align_of::<SphbSphere>() == align_of::<Sphere>());
    assert!(offset_of!(SphbSphere, radius) == offset_of!(Sphere, radius));
    assert!(size_of::<SphbNode>() == size_of::<HierarchyNode>() && size_of::<SphbNode>() == 32);
    assert!(offset_of!(SphbNode, radius) == offset_of!(HierarchyNode, radius));
    assert!(offset_of!(SphbNode, first_child) == offset_of!(HierarchyNode, first_child));
    assert!(offset_of!(SphbNode, child_count) == offset_of!(HierarchyNode, child_count));
    assert!(offset_of!(SphbNode, first_leaf) == offset_of!(HierarchyNode, first_leaf));
    assert!(offset_of!(SphbNode, leaf_count) == offset_of!(HierarchyNode, leaf_count));
    assert!(size_of::<SphbSample>() == size_of::<SamplePoint>() && size_of::<SphbSample>() == 28);
    assert!(offset_of!(SphbSample, normal) == offset_of!(SamplePoint, normal));
    assert!(offset_of!(SphbSample, direction) == offset_of!(SamplePoint, direction));
    assert!(offset_of!(SphbSample, rule) == offset_of!(SamplePoint, rule));
    assert!(size_of::<SphbSkinSlot>() == size_of::<SkinEntry>() && size_of::<SphbSkinSlot>() == 20);
    assert!(offset_of!(SphbSkinSlot, q) == offset_of!(SkinEntry, q));
    assert!(offset_of!(SphbSkinSlot, b) == offset_of!(SkinEntry, b));
};

/// Counts of a loaded proxy (0 for an absent section).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SphbCounts {
    /// Spheres (at least 1).
    pub sphere_count: u32,
    /// Hierarchy nodes (0 without a hierarchy).
    pub node_count: u32,
    /// Index of the root node (0 without a hierarchy).
    pub root: u32,
    /// Length of the child-index array.
    pub child_total: u32,
    /// Length of the leaf-index array.
    pub leaf_total: u32,
    /// Surface samples over all spheres.
    pub sample_count: u32,
    /// Albedo SH order n (n² coefficients per sphere; 0 without albedo SH).
    pub sh_order: u32,
    /// Colour space of the albedo SH: 0 = linear RGB (Rec. 709 primaries).
    pub sh_colour_space: u32,
    /// SH basis: 0 = real orthonormal, Condon–Shortley phase, index l(l+1)+m.
    pub sh_basis: u32,
    /// Skin slots per sphere (0 without skin).
    pub bones_per_sphere: u32,
    /// Bones in the bone table.
    pub bone_count: u32,
    /// Metadata entries (the four required keys first, then the free pairs; 0 without metadata).
    pub metadata_count: u32,
}

/// Borrowed views of a proxy's arrays; valid until `sphb_proxy_free`. NULL with a count of 0 for
/// an absent section.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct SphbViews {
    /// `sphere_count` spheres.
    pub spheres: *const SphbSphere,
    /// `sphere_count`.
    pub sphere_count: usize,
    /// `node_count` hierarchy nodes (rest pose).
    pub nodes: *const SphbNode,
    /// `node_count`.
    pub node_count: usize,
    /// Child node indices; node i owns `children[first_child .. first_child + child_count]`.
    pub children: *const u32,
    /// Length of `children`.
    pub child_total: usize,
    /// Leaf sphere indices; node i owns `leaves[first_leaf .. first_leaf + leaf_count]`.
    pub leaves: *const u32,
    /// Length of `leaves`.
    pub leaf_total: usize,
    /// All samples, sphere after sphere, each sphere's in increasing direction order.
    pub samples: *const SphbSample,
    /// Number of samples.
    pub sample_count: usize,
    /// `sphere_count + 1` offsets: sphere i owns `samples[sample_offsets[i] .. sample_offsets[i + 1]]`.
    pub sample_offsets: *const u32,
    /// `sphere_count + 1`, or 0 without samples.
    pub sample_offset_count: usize,
    /// Albedo SH: sphere s, coefficient i, channel c (R, G, B) at `sh[3 * (s * n² + i) + c]`.
    pub sh: *const f32,
    /// Number of floats in `sh` (sphere_count × n² × 3).
    pub sh_float_count: usize,
    /// Skin slots: sphere s owns `skin[s * bones_per_sphere .. (s + 1) * bones_per_sphere]`.
    pub skin: *const SphbSkinSlot,
    /// Number of slots (sphere_count × bones_per_sphere).
    pub skin_slot_count: usize,
}

/// One bone; `name` points into the proxy (UTF-8, not NUL-terminated, `name_len` bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct SphbBone {
    /// Parent bone index or `SPHB_NO_PARENT`.
    pub parent: u32,
    /// Name bytes (may be NULL when `name_len` is 0).
    pub name: *const u8,
    /// Name length in bytes.
    pub name_len: usize,
    /// Inverse bind matrix, 4×4 column-major.
    pub inverse_bind: [f32; 16],
}

/// One metadata pair; both strings point into the proxy (UTF-8, not NUL-terminated; never NULL,
/// also for an empty value).
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct SphbMetadataEntry {
    /// Key bytes (never NULL).
    pub key: *const u8,
    /// Key length.
    pub key_len: usize,
    /// Value bytes (never NULL, also when `value_len` is 0).
    pub value: *const u8,
    /// Value length.
    pub value_len: usize,
}

/// A posed proxy as the light passes see it: the proxy, its leaf spheres and (optionally) node
/// spheres in the current pose, and per-sphere rotations (all borrowed for the call).
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct SphbPosed {
    /// The proxy (samples, albedo, rest spheres).
    pub proxy: *const SphbProxy,
    /// `sphere_count` posed spheres (e.g. from `sphb_pose`).
    pub leaves: *const SphbSphere,
    /// Must equal the proxy's sphere count.
    pub leaf_count: usize,
    /// `node_count` refitted node spheres, or NULL: all leaves under one implicit root.
    pub nodes: *const SphbSphere,
    /// Must equal the proxy's node count when `nodes` is not NULL.
    pub node_count: usize,
    /// `sphere_count` column-major 3×3 rotations (9 floats each, `sphb_sphere_rotations`), or NULL = identity.
    pub rotations: *const f32,
}

/// Settings of pass 1 (`sphb_light_spheres`), the Rust `light::Pass1Settings`; start from
/// `sphb_pass1_settings_default()`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SphbPass1Settings {
    /// Cut threshold θmax (radians) of the hierarchy seen from each sphere (Ren 2006 eq. 36);
    /// default `SPHB_DEFAULT_THETA_MAX_RAD`.
    pub theta_max_rad: f32,
}

/// Counts of one `sphb_light_spheres` call (the Rust `light::Pass1Stats`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SphbPass1Stats {
    /// Sample points lit.
    pub samples: usize,
    /// Blockers accumulated over all samples (after the self-shadowing rules).
    pub blocker_accumulations: usize,
}

/// A receiver cluster of pass 2 (the Rust `light::ClusterSpec`): receivers sharing one hierarchy
/// cut, e.g. a tile of a ground grid or a patch of a character. Start from `sphb_cluster_spec_init`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SphbClusterSpec {
    /// Centre x, y, z of a ball around the cluster's receivers (the spheres' space).
    pub center: [f32; 3],
    /// Radius of that ball (model units).
    pub radius: f32,
    /// The receivers' mean normal, for the reflection ratios (taken at the centre and at four
    /// points on the disc of this normal through it); used when `has_normal` is 1 (scaled to unit
    /// length; zero or non-finite makes the build `SPHB_ERR_INVALID_ARGUMENT`).
    pub normal: [f32; 3],
    /// 1: `normal` is given; 0: no normal (reflection ratios are 1, no overlap correction).
    pub has_normal: u32,
    /// Cut threshold θmax, radians (Ren 2006 eq. 36); default `SPHB_DEFAULT_THETA_MAX_RAD`.
    pub theta_max_rad: f32,
    /// 1 (default): compute the reflection ratios of Guerrero 2008 eq. 25; 0 only to measure their effect.
    pub reflection_ratio: u32,
    /// 1: scale each source's blocker logs by the overlap correction at the cluster centre
    /// (`sphb_shadow_cluster_correct_overlap` with 256 directions; needs a normal; not in the
    /// papers). Default 0 (off): the correction makes results depend on the coordinate frame (its
    /// directions are fixed in the spheres' space, not turned with the receivers) and jump between
    /// neighbouring clusters and between frames of a moving proxy (its scale moves in steps of 0.05).
    pub overlap_correction: u32,
}

/// A loaded, validated proxy (opaque; owns its data).
pub struct SphbProxy {
    proxy: Proxy,
    plan: Option<HierarchyPlan>,
    metadata: Vec<(String, String)>,
}

/// SH order, exponential and triple-product tensor of the shadow queries (opaque, immutable).
pub struct SphbShadowContext {
    ctx: ShadowContext,
}

/// The blockers of one receiver cluster (opaque; reusable buffers). Built by one thread at a
/// time; once built, its queries may run on many threads at once.
pub struct SphbShadowCluster {
    cb: ClusterBlockers,
    cut: Vec<CutEntry>,
}

/// Order, exponential and tables of the indirect-light passes (opaque, immutable).
pub struct SphbLightContext {
    ctx: LightContext,
}

/// Pass 1's output for one proxy: its sphere lights (opaque; one thread at a time).
pub struct SphbSphereLights {
    lights: SphereLights,
}

/// Pass 2's lights of one receiver cluster (opaque; built by one thread at a time, then queried
/// by many with `sphb_indirect_irradiance_with`).
pub struct SphbIndirectCluster {
    ic: IndirectCluster,
}

/// Per-thread working space of `sphb_indirect_irradiance_with` (opaque; one thread at a time;
/// holds nothing between calls, so one scratch serves every cluster).
pub struct SphbIndirectScratch {
    scratch: IndirectScratch,
}

struct Fail {
    code: i32,
    rule: u32,
    message: String,
}

type Res<T> = Result<T, Fail>;

fn fail(code: i32, message: impl Into<String>) -> Fail {
    Fail { code, rule: 0, message: message.into() }
}

fn invalid(message: impl core::fmt::Display) -> Fail {
    fail(SPHB_ERR_INVALID_ARGUMENT, message.to_string())
}

fn from_validation(e: &ValidationError) -> Fail {
    Fail { code: SPHB_ERR_INVALID_FILE, rule: u32::from(e.rule.id()), message: e.to_string() }
}

fn write_error(err: *mut SphbError, code: i32, rule: u32, message: &str) {
    if err.is_null() || (err as usize) % align_of::<SphbError>() != 0 {
        return;
    }
    let mut buf = [0 as c_char; SPHB_MESSAGE_CAPACITY];
    let mut n = message.len().min(SPHB_MESSAGE_CAPACITY - 1);
    while !message.is_char_boundary(n) {
        n -= 1;
    }
    for (d, s) in buf.iter_mut().zip(message.as_bytes()[..n].iter()) {
        *d = *s as c_char;
    }
    // SAFETY: `err` is non-null and aligned; the caller promises it points to a writable SphbError.
    unsafe {
        err.write(SphbError { code, rule_id: rule, message: buf });
    }
}

/// Runs `f` with panics caught, fills `err`, returns the status.
fn run(err: *mut SphbError, f: impl FnOnce() -> Res<()>) -> i32 {
    let outcome = catch_unwind(AssertUnwindSafe(f));
    let failure = match outcome {
        Ok(Ok(())) => {
            write_error(err, SPHB_OK, 0, "");
            return SPHB_OK;
        }
        Ok(Err(f)) => f,
        Err(_) => fail(SPHB_ERR_INTERNAL, "internal error: a panic was caught inside spherebake"),
    };
    write_error(err, failure.code, failure.rule, &failure.message);
    failure.code
}

fn check_ptr<T>(ptr: *const T, what: &str) -> Res<()> {
    if ptr.is_null() {
        return Err(fail(SPHB_ERR_NULL, format!("{what} is NULL")));
    }
    if (ptr as usize) % align_of::<T>() != 0 {
        return Err(invalid(format!("{what} is not aligned to {} bytes", align_of::<T>())));
    }
    Ok(())
}

/// The byte range `[start, end)` of `len` values of `T` at `ptr` (empty for NULL or `len == 0`).
fn span<T>(ptr: *const T, len: usize) -> (usize, usize) {
    let start = ptr as usize;
    if ptr.is_null() || len == 0 {
        return (start, start);
    }
    (start, start.saturating_add(len.saturating_mul(size_of::<T>())))
}

/// `SPHB_ERR_INVALID_ARGUMENT` when the buffer `out` (an output, as declared: its capacity)
/// overlaps one of `others` (the call's inputs and other outputs): the library may not read and
/// write one buffer at once, and an overlap gave wrong values with `SPHB_OK`.
fn disjoint(out: (&str, (usize, usize)), others: &[(&str, (usize, usize))]) -> Res<()> {
    let (name, (a0, a1)) = out;
    for &(other, (b0, b1)) in others {
        if a0 < a1 && b0 < b1 && a0 < b1 && b0 < a1 {
            return Err(invalid(format!("{name} overlaps {other}: outputs must not share memory with inputs")));
        }
    }
    Ok(())
}

/// Runs the build `build` on `target` and, when it fails (an error, or a panic on its way to
/// `run`'s `catch_unwind`), replaces `target` by `empty()`: a failed build leaves its object empty
/// and not built, whichever check refused it (the module's conventions), never the previous
/// build's state.
fn build_or_empty<T>(target: &mut T, empty: fn() -> T, build: impl FnOnce(&mut T) -> Res<()>) -> Res<()> {
    struct Guard<'a, T> {
        target: &'a mut T,
        empty: fn() -> T,
        built: bool,
    }
    impl<T> Drop for Guard<'_, T> {
        fn drop(&mut self) {
            if !self.built {
                *self.target = (self.empty)();
            }
        }
    }
    let mut guard = Guard { target, empty, built: false };
    let result = build(guard.target);
    guard.built = result.is_ok();
    result
}

/// `SPHB_ERR_INVALID_ARGUMENT` unless `leaf_count` is the proxy's sphere count (one leaf per sphere).
fn check_leaf_count(p: &SphbProxy, leaf_count: usize) -> Res<()> {
    if leaf_count == p.proxy.sphere_count() {
        Ok(())
    } else {
        Err(invalid(format!("leaf_count {leaf_count} but the proxy has {} spheres", p.proxy.sphere_count())))
    }
}

/// `SPHB_ERR_INVALID_ARGUMENT` naming `what` unless every sphere has a finite centre and a finite
/// radius ≥ 0 (the rule of the shadow cluster's build).
fn check_spheres(spheres: &[SphbSphere], what: &str) -> Res<()> {
    match spherebake_runtime::shadow::first_unusable_sphere(spheres_of(spheres)) {
        None => Ok(()),
        Some(i) => Err(invalid(format!("{what}[{i}] has no finite centre and finite radius ≥ 0"))),
    }
}

/// `SPHB_ERR_INVALID_ARGUMENT` naming `what` unless every value of `values` is finite.
fn check_finite<T: Copy + Into<f64>>(values: &[T], what: &str) -> Res<()> {
    match values.iter().position(|&v| !v.into().is_finite()) {
        None => Ok(()),
        Some(i) => Err(invalid(format!("{what}[{i}] is not finite"))),
    }
}

/// A borrowed input array; NULL with `len == 0` is empty.
///
/// # Safety
/// `ptr` must point to `len` readable values (the C caller's contract).
unsafe fn input<'a, T>(ptr: *const T, len: usize, what: &str) -> Res<&'a [T]> {
    if len == 0 {
        return Ok(&[]);
    }
    check_ptr(ptr, what)?;
    if len.checked_mul(size_of::<T>()).is_none_or(|b| b > isize::MAX as usize) {
        return Err(invalid(format!("{what}: length {len} is too large")));
    }
    // SAFETY: non-null, aligned, size checked; validity of the memory is the caller's contract.
    Ok(unsafe { core::slice::from_raw_parts(ptr, len) })
}

/// A borrowed output array of capacity `len`, at least `need` long.
///
/// # Safety
/// `ptr` must point to `len` writable values.
unsafe fn output<'a, T>(ptr: *mut T, len: usize, need: usize, what: &str) -> Res<&'a mut [T]> {
    if len < need {
        return Err(fail(SPHB_ERR_BUFFER_TOO_SMALL, format!("{what} holds {len} values, {need} needed")));
    }
    if need == 0 {
        return Ok(&mut []);
    }
    check_ptr(ptr.cast_const(), what)?;
    if need.checked_mul(size_of::<T>()).is_none_or(|b| b > isize::MAX as usize) {
        return Err(invalid(format!("{what}: length {need} is too large")));
    }
    // SAFETY: as `input`, writable by the caller's contract.
    Ok(unsafe { core::slice::from_raw_parts_mut(ptr, need) })
}

/// # Safety
/// `ptr` must be NULL or point to a live object of type `T` made by this library.
unsafe fn object<'a, T>(ptr: *const T, what: &str) -> Res<&'a T> {
    check_ptr(ptr, what)?;
    // SAFETY: non-null and aligned; the caller passes an object this library created.
    Ok(unsafe { &*ptr })
}

/// # Safety
/// As [`object`], and not used by another thread during the call.
unsafe fn object_mut<'a, T>(ptr: *mut T, what: &str) -> Res<&'a mut T> {
    check_ptr(ptr.cast_const(), what)?;
    // SAFETY: as `object`; exclusive use is the caller's contract (documented per type).
    Ok(unsafe { &mut *ptr })
}

/// Writes `v` to `*ptr` unless `ptr` is NULL (an optional output).
///
/// # Safety
/// As [`object_mut`].
unsafe fn put_opt<T>(ptr: *mut T, v: T, what: &str) -> Res<()> {
    if !ptr.is_null() {
        *unsafe { object_mut(ptr, what)? } = v;
    }
    Ok(())
}

/// A borrowed input of at least `need` values: `len < need` is `SPHB_ERR_BUFFER_TOO_SMALL`; the
/// first `need` values are returned.
///
/// # Safety
/// As [`input`].
unsafe fn input_min<'a, T>(ptr: *const T, len: usize, need: usize, what: &str) -> Res<&'a [T]> {
    if len < need {
        return Err(fail(SPHB_ERR_BUFFER_TOO_SMALL, format!("{what} holds {len} values, {need} needed")));
    }
    unsafe { input(ptr, need, what) }
}

/// `count` column-major 4×4 matrices (16 floats each) at `ptr`.
///
/// # Safety
/// As [`input`].
unsafe fn matrices_in<'a>(ptr: *const f32, count: usize, what: &str) -> Res<&'a [[f32; 16]]> {
    let floats = count.checked_mul(16).ok_or_else(|| invalid(format!("{what}: count {count} is too large")))?;
    Ok(matrices(unsafe { input(ptr, floats, what)? }))
}

/// `Some` of the 3 floats at `ptr`, `None` for NULL (an optional vector).
///
/// # Safety
/// As [`input`].
unsafe fn opt_vec3(ptr: *const f32, what: &str) -> Res<Option<[f32; 3]>> {
    if ptr.is_null() {
        Ok(None)
    } else {
        unsafe { vec3(ptr, what) }.map(Some)
    }
}

/// The proxy's hierarchy plan with the `count` node spheres at `nodes`, or `None` when `nodes` is
/// NULL or the proxy has no hierarchy (all leaves under one implicit root).
///
/// # Safety
/// As [`input`].
unsafe fn hierarchy_of<'a>(
    p: &'a SphbProxy,
    nodes: *const SphbSphere,
    count: usize,
    what: &str,
) -> Res<Option<(&'a HierarchyPlan, &'a [Sphere])>> {
    match (&p.plan, nodes.is_null()) {
        (Some(plan), false) => Ok(Some((plan, spheres_of(unsafe { input(nodes, count, what)? })))),
        _ => Ok(None),
    }
}

/// The SH order as an index, refusing orders outside 1..=8.
fn sh_order(order: u32) -> Res<usize> {
    if (1..=8).contains(&order) {
        Ok(order as usize)
    } else {
        Err(invalid(format!("order {order} outside 1..=8")))
    }
}

/// Copies RGB SH coefficients into `out` (`out_len` floats, at least 3 per coefficient); an
/// empty `coefficients` (index out of range) is `SPHB_ERR_INVALID_ARGUMENT` naming `what`.
///
/// # Safety
/// As [`output`].
unsafe fn copy_rgb(coefficients: &[[f32; 3]], out: *mut f32, out_len: usize, what: &str) -> Res<()> {
    if coefficients.is_empty() {
        return Err(invalid(format!("{what} has no light")));
    }
    let o = unsafe { output(out, out_len, 3 * coefficients.len(), "out")? };
    for (d, v) in o.chunks_exact_mut(3).zip(coefficients) {
        d.copy_from_slice(v);
    }
    Ok(())
}

/// A new heap object for C (`*_new` without arguments): NULL if making it panicked.
fn new_object<T>(make: impl FnOnce() -> T) -> *mut T {
    catch_unwind(AssertUnwindSafe(|| Box::into_raw(Box::new(make())))).unwrap_or(core::ptr::null_mut())
}

/// Stores a new heap object in `*out` (NULL first, so a failure leaves NULL there).
///
/// # Safety
/// `out` as [`object_mut`].
unsafe fn new_object_into<T>(out: *mut *mut T, make: impl FnOnce() -> Res<T>) -> Res<()> {
    let o = unsafe { object_mut(out, "out")? };
    *o = core::ptr::null_mut();
    *o = Box::into_raw(Box::new(make()?));
    Ok(())
}

/// Frees an object of [`new_object`] / [`new_object_into`]; NULL does nothing.
///
/// # Safety
/// `ptr` is NULL or came from this library's `*_new` for `T` and is freed once.
unsafe fn free_object<T>(ptr: *mut T) {
    if !ptr.is_null() {
        // SAFETY: the caller's contract above.
        let _ = catch_unwind(AssertUnwindSafe(|| drop(unsafe { Box::from_raw(ptr) })));
    }
}

fn spheres_of(s: &[SphbSphere]) -> &[Sphere] {
    // SAFETY: identical repr(C) layout (asserted above).
    unsafe { core::slice::from_raw_parts(s.as_ptr().cast::<Sphere>(), s.len()) }
}

fn spheres_of_mut(s: &mut [SphbSphere]) -> &mut [Sphere] {
    // SAFETY: identical repr(C) layout (asserted above).
    unsafe { core::slice::from_raw_parts_mut(s.as_mut_ptr().cast::<Sphere>(), s.len()) }
}

fn matrices(m: &[f32]) -> &[[f32; 16]] {
    // SAFETY: [f32; 16] has the alignment of f32 and no padding; the length is rounded down.
    unsafe { core::slice::from_raw_parts(m.as_ptr().cast::<[f32; 16]>(), m.len() / 16) }
}

fn rotations_of(m: &[f32]) -> &[[f32; 9]] {
    // SAFETY: as `matrices`.
    unsafe { core::slice::from_raw_parts(m.as_ptr().cast::<[f32; 9]>(), m.len() / 9) }
}

/// # Safety
/// `ptr` is NULL or points to 3 floats.
unsafe fn vec3(ptr: *const f32, what: &str) -> Res<[f32; 3]> {
    let s = unsafe { input(ptr, 3, what)? };
    Ok([s[0], s[1], s[2]])
}

fn exp_of(code: i32) -> Res<ExpMethod> {
    match code {
        SPHB_EXP_PS_STAR_4 => Ok(ExpMethod::PsStar { degree: 4 }),
        SPHB_EXP_HYB => Ok(ExpMethod::Hyb { ol_norm_bound: 0.0 }),
        SPHB_EXP_ACCURATE => Ok(ExpMethod::Accurate),
        other => Err(invalid(format!("exp method {other} is not one of SPHB_EXP_*"))),
    }
}

fn count_u32(n: usize) -> u32 {
    u32::try_from(n).unwrap_or(u32::MAX)
}

/// Version of this ABI: raised whenever a function, struct or constant of this header changes
/// incompatibly. Compare it with `sphb_abi_version()` at start-up: a library built from another
/// header answers another number.
pub const SPHB_ABI_VERSION: u32 = 1;

/// The `SPHB_ABI_VERSION` the library was built with. Thread-safe.
#[no_mangle]
pub extern "C" fn sphb_abi_version() -> u32 {
    SPHB_ABI_VERSION
}

/// Returns the library version as a NUL-terminated string (static; never NULL). Thread-safe.
#[no_mangle]
pub extern "C" fn sphb_version() -> *const c_char {
    concat!(env!("CARGO_PKG_VERSION"), "\0").as_ptr().cast()
}

/// Validates `len` bytes of a `.sphb` file and copies them into a new proxy (`*out`; NULL on
/// failure). The bytes are not referenced after the call. Free the proxy with `sphb_proxy_free`.
/// Thread-safe.
///
/// Errors: `SPHB_ERR_NULL` (`bytes` with `len > 0`, or `out`), `SPHB_ERR_INVALID_FILE` with the
/// violated rule ID.
#[no_mangle]
pub unsafe extern "C" fn sphb_load(bytes: *const u8, len: usize, out: *mut *mut SphbProxy, err: *mut SphbError) -> i32 {
    run(err, || unsafe {
        new_object_into(out, || {
            let data = input(bytes, len, "bytes")?;
            let proxy = spherebake_runtime::load(data).map_err(|e| from_validation(&e))?;
            let plan = proxy.hierarchy_plan();
            let metadata = proxy.metadata().map_or_else(Vec::new, |m| {
                let mut v = vec![
                    ("tool_version".to_string(), m.tool_version.clone()),
                    ("settings".to_string(), m.settings.clone()),
                    ("input_hash".to_string(), m.input_hash.clone()),
                    ("units".to_string(), m.units.clone()),
                ];
                v.extend(m.extra.iter().cloned());
                v
            });
            Ok(SphbProxy { proxy, plan, metadata })
        })
    })
}

/// Frees a proxy from `sphb_load`; NULL does nothing. No other thread may use it during or after.
#[no_mangle]
pub unsafe extern "C" fn sphb_proxy_free(proxy: *mut SphbProxy) {
    // SAFETY: the pointer came from `sphb_load` (the caller's contract) and is freed once.
    unsafe { free_object(proxy) }
}

/// The counts of `proxy` into `*out`. Thread-safe.
#[no_mangle]
pub unsafe extern "C" fn sphb_proxy_counts(proxy: *const SphbProxy, out: *mut SphbCounts, err: *mut SphbError) -> i32 {
    run(err, || {
        let p = unsafe { object(proxy, "proxy")? };
        let o = unsafe { object_mut(out, "out")? };
        let pr = &p.proxy;
        let h = pr.hierarchy();
        let sh = pr.albedo_sh();
        *o = SphbCounts {
            sphere_count: count_u32(pr.sphere_count()),
            node_count: h.map_or(0, |h| count_u32(h.nodes.len())),
            root: h.map_or(0, |h| h.root),
            child_total: h.map_or(0, |h| count_u32(h.children.len())),
            leaf_total: h.map_or(0, |h| count_u32(h.leaves.len())),
            sample_count: count_u32(pr.sample_points().len()),
            sh_order: sh.map_or(0, |s| u32::from(s.order)),
            sh_colour_space: sh.map_or(0, |s| u32::from(s.colour_space.code())),
            sh_basis: sh.map_or(0, |s| u32::from(s.basis.code())),
            bones_per_sphere: pr.skin().map_or(0, |k| k.bones_per_sphere),
            bone_count: count_u32(pr.bones().len()),
            metadata_count: count_u32(p.metadata.len()),
        };
        Ok(())
    })
}

fn ptr_or_null<T, U>(s: &[T]) -> *const U {
    if s.is_empty() {
        core::ptr::null()
    } else {
        s.as_ptr().cast()
    }
}

/// The first byte of `s`, or of a static empty string when `s` is empty: never NULL (C's `memcpy`
/// and the like need a valid pointer even for 0 bytes).
fn str_ptr(s: &str) -> *const u8 {
    static EMPTY: u8 = 0;
    if s.is_empty() {
        &EMPTY
    } else {
        s.as_ptr()
    }
}

/// Pointers to the proxy's arrays into `*out` (no copy; valid until `sphb_proxy_free`). Thread-safe.
#[no_mangle]
pub unsafe extern "C" fn sphb_proxy_views(proxy: *const SphbProxy, out: *mut SphbViews, err: *mut SphbError) -> i32 {
    run(err, || {
        let p = unsafe { object(proxy, "proxy")? };
        let o = unsafe { object_mut(out, "out")? };
        let pr = &p.proxy;
        let (nodes, children, leaves): (&[HierarchyNode], &[u32], &[u32]) =
            pr.hierarchy().map_or((&[], &[], &[]), |h| (&h.nodes, &h.children, &h.leaves));
        let sh: &[[f32; 3]] = pr.albedo_sh().map_or(&[], |s| &s.coefficients);
        let skin: &[SkinEntry] = pr.skin().map_or(&[], |k| &k.entries);
        *o = SphbViews {
            spheres: ptr_or_null(pr.spheres()),
            sphere_count: pr.sphere_count(),
            nodes: ptr_or_null(nodes),
            node_count: nodes.len(),
            children: ptr_or_null(children),
            child_total: children.len(),
            leaves: ptr_or_null(leaves),
            leaf_total: leaves.len(),
            samples: ptr_or_null(pr.sample_points()),
            sample_count: pr.sample_points().len(),
            sample_offsets: ptr_or_null(pr.sample_offsets()),
            sample_offset_count: pr.sample_offsets().len(),
            sh: ptr_or_null(sh),
            sh_float_count: sh.len() * 3,
            skin: ptr_or_null(skin),
            skin_slot_count: skin.len(),
        };
        Ok(())
    })
}

/// Bone `index` into `*out` (`SPHB_ERR_INVALID_ARGUMENT` when `index >= bone_count`). Thread-safe.
#[no_mangle]
pub unsafe extern "C" fn sphb_proxy_bone(
    proxy: *const SphbProxy,
    index: u32,
    out: *mut SphbBone,
    err: *mut SphbError,
) -> i32 {
    run(err, || {
        let p = unsafe { object(proxy, "proxy")? };
        let o = unsafe { object_mut(out, "out")? };
        let bones = p.proxy.bones();
        let b = bones.get(index as usize).ok_or_else(|| invalid(format!("bone {index} of {}", bones.len())))?;
        *o = SphbBone {
            parent: b.parent.unwrap_or(SPHB_NO_PARENT),
            name: ptr_or_null(b.name.as_bytes()),
            name_len: b.name.len(),
            inverse_bind: b.inverse_bind,
        };
        Ok(())
    })
}

/// Metadata entry `index` into `*out`: 0 `tool_version`, 1 `settings`, 2 `input_hash`, 3 `units`,
/// then the free pairs in file order. Thread-safe.
#[no_mangle]
pub unsafe extern "C" fn sphb_proxy_metadata(
    proxy: *const SphbProxy,
    index: u32,
    out: *mut SphbMetadataEntry,
    err: *mut SphbError,
) -> i32 {
    run(err, || {
        let p = unsafe { object(proxy, "proxy")? };
        let o = unsafe { object_mut(out, "out")? };
        let (k, v) = p
            .metadata
            .get(index as usize)
            .ok_or_else(|| invalid(format!("metadata entry {index} of {}", p.metadata.len())))?;
        *o = SphbMetadataEntry { key: str_ptr(k), key_len: k.len(), value: str_ptr(v), value_len: v.len() };
        Ok(())
    })
}

/// Poses the spheres: `out[s]` = Σ_j M_j · (q_j, b_j) over sphere s's skin slots, radius kept;
/// `joints` holds `joint_count` column-major 4×4 joint matrices (16 floats each, glTF convention).
/// The palette is indexed by the file's bone table: matrix j belongs to bone j
/// (`sphb_proxy_bone(proxy, j, ...)`, j < `SphbCounts::bone_count`; extra matrices are ignored).
/// The bone table holds the joints of all the asset's skins in order of first use, a joint two
/// skins share with the same inverse bind being one bone (formats/spherebake-v1.md §10): for a
/// model with one skin that is glTF `skin.joints` order, otherwise not necessarily the order of
/// an engine's skin, so map each bone to the engine's joint by its name (`SphbBone::name`; names
/// need not be unique, so check the inverse bind too where they repeat).
/// Without skin the rest spheres are copied. `out_len` must be at least the sphere count. A NaN or
/// an infinity in a matrix the bone table uses is `SPHB_ERR_INVALID_ARGUMENT`.
/// Allocation-free; thread-safe (distinct `out`).
#[no_mangle]
pub unsafe extern "C" fn sphb_pose(
    proxy: *const SphbProxy,
    joints: *const f32,
    joint_count: usize,
    out: *mut SphbSphere,
    out_len: usize,
    err: *mut SphbError,
) -> i32 {
    run(err, || {
        let p = unsafe { object(proxy, "proxy")? };
        disjoint(("out", span(out, out_len)), &[("joints", span(joints, joint_count.saturating_mul(16)))])?;
        let m = unsafe { matrices_in(joints, joint_count, "joints")? };
        let o = unsafe { output(out, out_len, p.proxy.sphere_count(), "out")? };
        spherebake_runtime::pose(&p.proxy, m, spheres_of_mut(o)).map_err(invalid)
    })
}

/// The stored (rest) node spheres into `out` (`out_len` at least the node count); the starting
/// point for `sphb_refit`. Thread-safe.
#[no_mangle]
pub unsafe extern "C" fn sphb_rest_nodes(
    proxy: *const SphbProxy,
    out: *mut SphbSphere,
    out_len: usize,
    err: *mut SphbError,
) -> i32 {
    run(err, || {
        let p = unsafe { object(proxy, "proxy")? };
        let h = p.proxy.hierarchy().ok_or_else(|| fail(SPHB_ERR_MISSING_DATA, "the proxy has no hierarchy"))?;
        let o = unsafe { output(out, out_len, h.nodes.len(), "out")? };
        for (d, n) in o.iter_mut().zip(&h.nodes) {
            *d = SphbSphere { center: n.center, radius: n.radius };
        }
        Ok(())
    })
}

fn plan_of(p: &SphbProxy) -> Res<&HierarchyPlan> {
    p.plan.as_ref().ok_or_else(|| fail(SPHB_ERR_MISSING_DATA, "the proxy has no hierarchy"))
}

/// Recomputes every node sphere bottom-up from `leaf_count` posed leaves (sphere-pair merges,
/// allocation-free) into `nodes_out` (`node_len` at least the node count). `leaf_count` must
/// equal the proxy's sphere count, and a leaf without a finite centre and a finite radius ≥ 0 is
/// `SPHB_ERR_INVALID_ARGUMENT` (as for the shadow cluster's build). Thread-safe.
#[no_mangle]
pub unsafe extern "C" fn sphb_refit(
    proxy: *const SphbProxy,
    leaves: *const SphbSphere,
    leaf_count: usize,
    nodes_out: *mut SphbSphere,
    node_len: usize,
    err: *mut SphbError,
) -> i32 {
    run(err, || {
        let p = unsafe { object(proxy, "proxy")? };
        let plan = plan_of(p)?;
        disjoint(("nodes_out", span(nodes_out, node_len)), &[("leaves", span(leaves, leaf_count))])?;
        let l = unsafe { input(leaves, leaf_count, "leaves")? };
        check_leaf_count(p, l.len())?;
        check_spheres(l, "leaves")?;
        let o = unsafe { output(nodes_out, node_len, plan.node_count(), "nodes_out")? };
        spherebake_runtime::refit(plan, spheres_of(l), spheres_of_mut(o)).map_err(invalid)
    })
}

/// `sphb_pose` then `sphb_refit`: posed leaves into `leaves_out`, refitted nodes into `nodes_out`;
/// `joints` indexed by the file's bone table, as for `sphb_pose`. Allocation-free; thread-safe
/// (distinct outputs).
#[no_mangle]
pub unsafe extern "C" fn sphb_pose_and_refit(
    proxy: *const SphbProxy,
    joints: *const f32,
    joint_count: usize,
    leaves_out: *mut SphbSphere,
    leaf_len: usize,
    nodes_out: *mut SphbSphere,
    node_len: usize,
    err: *mut SphbError,
) -> i32 {
    run(err, || {
        let p = unsafe { object(proxy, "proxy")? };
        let plan = plan_of(p)?;
        let joints_span = ("joints", span(joints, joint_count.saturating_mul(16)));
        disjoint(("leaves_out", span(leaves_out, leaf_len)), &[joints_span])?;
        disjoint(("nodes_out", span(nodes_out, node_len)), &[joints_span, ("leaves_out", span(leaves_out, leaf_len))])?;
        let m = unsafe { matrices_in(joints, joint_count, "joints")? };
        let l = unsafe { output(leaves_out, leaf_len, p.proxy.sphere_count(), "leaves_out")? };
        let o = unsafe { output(nodes_out, node_len, plan.node_count(), "nodes_out")? };
        spherebake_runtime::pose_and_refit(&p.proxy, plan, m, spheres_of_mut(l), spheres_of_mut(o)).map_err(invalid)
    })
}

/// The hierarchy cut for the receiver ball (`receiver_center` 3 floats, `receiver_radius`): nodes
/// subtending less than `theta_max_rad` and leaves (Ren 2006 eq. 36), over the node spheres `nodes`
/// (refitted or rest, `node_count` = the proxy's; a node without a finite centre and a finite
/// radius ≥ 0 is `SPHB_ERR_INVALID_ARGUMENT`). Writes `*len_out` entries into `out`
/// (capacity `out_cap`); when too small returns `SPHB_ERR_BUFFER_TOO_SMALL` with `*len_out` = the
/// needed count. A centre that is not finite, a radius that is not finite and ≥ 0, or a θmax
/// outside [0, π] is `SPHB_ERR_INVALID_ARGUMENT` (as for the shadow cluster's build; above π/2 the
/// cut is the root's). Allocates its scratch; thread-safe.
#[no_mangle]
pub unsafe extern "C" fn sphb_cut(
    proxy: *const SphbProxy,
    nodes: *const SphbSphere,
    node_count: usize,
    receiver_center: *const f32,
    receiver_radius: f32,
    theta_max_rad: f32,
    out: *mut SphbCutEntry,
    out_cap: usize,
    len_out: *mut usize,
    err: *mut SphbError,
) -> i32 {
    run(err, || {
        let p = unsafe { object(proxy, "proxy")? };
        let plan = plan_of(p)?;
        let inputs = [("nodes", span(nodes, node_count)), ("receiver_center", span(receiver_center, 3))];
        disjoint(("out", span(out, out_cap)), &inputs)?;
        disjoint(("len_out", span(len_out, 1)), &[inputs[0], inputs[1], ("out", span(out, out_cap))])?;
        let n = unsafe { input(nodes, node_count, "nodes")? };
        check_spheres(n, "nodes")?;
        let c = unsafe { vec3(receiver_center, "receiver_center")? };
        // The receiver ball and θmax under the rules of the shadow cluster's build.
        spherebake_runtime::shadow::check_receiver(c, receiver_radius, theta_max_rad).map_err(invalid)?;
        let len = unsafe { object_mut(len_out, "len_out")? };
        let mut cut = Vec::new();
        spherebake_runtime::cut(plan, spheres_of(n), c, receiver_radius, theta_max_rad, &mut cut).map_err(invalid)?;
        *len = cut.len();
        let o = unsafe { output(out, out_cap, cut.len(), "out")? };
        for (d, e) in o.iter_mut().zip(&cut) {
            *d = match *e {
                CutEntry::Leaf(i) => SphbCutEntry { index: i, is_leaf: 1 },
                CutEntry::Node(i) => SphbCutEntry { index: i, is_leaf: 0 },
                _ => SphbCutEntry { index: u32::MAX, is_leaf: 0 },
            };
        }
        Ok(())
    })
}

/// A shadow context of SH `order` (1..=8; 4 is the default) and exponential `exp_method`
/// (`SPHB_EXP_*`) into `*out`. Allocates the triple-product tensor. Free with
/// `sphb_shadow_context_free`. The context is immutable: share it between threads.
#[no_mangle]
pub unsafe extern "C" fn sphb_shadow_context_new(
    order: u32,
    exp_method: i32,
    out: *mut *mut SphbShadowContext,
    err: *mut SphbError,
) -> i32 {
    run(err, || unsafe {
        new_object_into(out, || {
            let ctx = ShadowContext::new(order as usize, exp_of(exp_method)?).map_err(invalid)?;
            Ok(SphbShadowContext { ctx })
        })
    })
}

/// Frees a shadow context; NULL does nothing.
#[no_mangle]
pub unsafe extern "C" fn sphb_shadow_context_free(ctx: *mut SphbShadowContext) {
    // SAFETY: made by `sphb_shadow_context_new`, freed once (the caller's contract).
    unsafe { free_object(ctx) }
}

/// A new, empty receiver cluster (NULL only on an internal error, a caught panic). Free with
/// `sphb_shadow_cluster_free`.
#[no_mangle]
pub extern "C" fn sphb_shadow_cluster_new() -> *mut SphbShadowCluster {
    new_object(empty_shadow_cluster)
}

fn empty_shadow_cluster() -> SphbShadowCluster {
    SphbShadowCluster { cb: ClusterBlockers::new(), cut: Vec::new() }
}

/// Frees a cluster; NULL does nothing.
#[no_mangle]
pub unsafe extern "C" fn sphb_shadow_cluster_free(cluster: *mut SphbShadowCluster) {
    // SAFETY: made by `sphb_shadow_cluster_new`, freed once (the caller's contract).
    unsafe { free_object(cluster) }
}

/// Builds the blockers of the receiver cluster bounded by (`receiver_center`, `receiver_radius`):
/// the hierarchy cut at `theta_max_rad` and the ratio vectors of the accepted nodes at the centre
/// (Ren 2006 eq. 36, 37), at SH `order`. `leaves` are the posed spheres (`leaf_count` = the
/// proxy's); `nodes` the node spheres (`node_count` = the proxy's), or NULL (or a proxy without
/// hierarchy): all leaves under one implicit root. `proxy` provides the hierarchy plan.
/// Writes the number of blockers to `*blocker_count_out` when not NULL. A sphere (leaf or node)
/// without a finite centre and a finite radius ≥ 0 is `SPHB_ERR_INVALID_ARGUMENT`. Reuses the
/// cluster's buffers; one thread at a time per cluster.
#[no_mangle]
pub unsafe extern "C" fn sphb_shadow_cluster_build(
    cluster: *mut SphbShadowCluster,
    proxy: *const SphbProxy,
    order: u32,
    leaves: *const SphbSphere,
    leaf_count: usize,
    nodes: *const SphbSphere,
    node_count: usize,
    receiver_center: *const f32,
    receiver_radius: f32,
    theta_max_rad: f32,
    blocker_count_out: *mut usize,
    err: *mut SphbError,
) -> i32 {
    run(err, || {
        let cl = unsafe { object_mut(cluster, "cluster")? };
        build_or_empty(cl, empty_shadow_cluster, |cl| {
            let p = unsafe { object(proxy, "proxy")? };
            let inputs = [
                ("leaves", span(leaves, leaf_count)),
                ("nodes", span(nodes, node_count)),
                ("receiver_center", span(receiver_center, 3)),
            ];
            disjoint(("blocker_count_out", span(blocker_count_out, 1)), &inputs)?;
            let l = unsafe { input(leaves, leaf_count, "leaves")? };
            check_leaf_count(p, l.len())?;
            let c = unsafe { vec3(receiver_center, "receiver_center")? };
            let hierarchy = unsafe { hierarchy_of(p, nodes, node_count, "nodes")? };
            cl.cut.clear();
            cl.cb
                .build(order as usize, spheres_of(l), hierarchy, c, receiver_radius, theta_max_rad)
                .map_err(invalid)?;
            unsafe { put_opt(blocker_count_out, cl.cb.blockers().len(), "blocker_count_out") }
        })
    })
}

/// **Optional, not in Ren 2006.** Damps the over-counting of overlapping blockers: finds one
/// scale s in {1, 0.95, …, 0.05} for all log vectors of the built cluster such that the DC of the
/// visibility at the cluster point `p_star` (3 floats, `normal` 3 floats scaled to unit length, self-shadowing
/// rules applied) best matches the visible fraction of the union of the blocker spheres there,
/// measured with `directions` Fibonacci rays (at most 65536; cost: `directions` × blockers ray
/// tests); multiplies every blocker's band weights by s and writes s to `*scale_out` (optional; 1
/// when nothing improves). `sphb_shadow_cluster_build` does not apply it: call it after each build.
/// `spherebake shadows` (by default) and `spherebake light` apply it with 1024 directions, and the
/// shadow errors in docs/benchmarks.md are measured so unless a table says otherwise;
/// `SphbClusterSpec::overlap_correction` uses 256. Its cost in stability: s moves in steps of 0.05 and the directions are fixed in the
/// spheres' space, so the shading of a moving proxy can jump between frames and neighbouring
/// clusters can differ by a step. `ctx` must have the build's order. Allocation-free; one thread
/// at a time per cluster.
#[no_mangle]
pub unsafe extern "C" fn sphb_shadow_cluster_correct_overlap(
    cluster: *mut SphbShadowCluster,
    ctx: *const SphbShadowContext,
    p_star: *const f32,
    normal: *const f32,
    directions: usize,
    scale_out: *mut f32,
    err: *mut SphbError,
) -> i32 {
    run(err, || {
        let cl = unsafe { object_mut(cluster, "cluster")? };
        let c = unsafe { object(ctx, "ctx")? };
        disjoint(("scale_out", span(scale_out, 1)), &[("p_star", span(p_star, 3)), ("normal", span(normal, 3))])?;
        let p = unsafe { vec3(p_star, "p_star")? };
        let n = unsafe { vec3(normal, "normal")? };
        if cl.cb.order() == 0 {
            return Err(invalid("the cluster was not built"));
        }
        let s = cl.cb.correct_overlap(&c.ctx, p, n, directions).map_err(invalid)?;
        unsafe { put_opt(scale_out, s, "scale_out") }
    })
}

/// Adds the log-SH visibility of the cluster's blockers seen from receiver `p` (3 floats) to
/// `log_inout[0..order²]` (f32; zero it first), with the self-shadowing rules about `normal` (3
/// floats, scaled to unit length; NULL skips them). `*used_out` (optional) = blockers accumulated.
/// A `p` that is not finite is `SPHB_ERR_INVALID_ARGUMENT` (as for `sphb_shade_point`).
/// Allocation-free; does not modify the cluster: concurrent calls on one cluster are safe.
#[no_mangle]
pub unsafe extern "C" fn sphb_accumulate_log_visibility(
    cluster: *const SphbShadowCluster,
    p: *const f32,
    normal: *const f32,
    log_inout: *mut f32,
    log_len: usize,
    used_out: *mut usize,
    err: *mut SphbError,
) -> i32 {
    run(err, || {
        let cl = unsafe { object(cluster, "cluster")? };
        let order = cl.cb.order();
        if order == 0 {
            return Err(invalid("the cluster was not built"));
        }
        let inputs = [("p", span(p, 3)), ("normal", span(normal, 3))];
        disjoint(("log_inout", span(log_inout, log_len)), &inputs)?;
        disjoint(("used_out", span(used_out, 1)), &[inputs[0], inputs[1], ("log_inout", span(log_inout, log_len))])?;
        let pt = unsafe { vec3(p, "p")? };
        check_finite(&pt, "p")?;
        let n = unsafe { opt_vec3(normal, "normal")? };
        let log = unsafe { output(log_inout, log_len, order * order, "log_inout")? };
        let used = accumulate_log_visibility(cl.cb.blockers(), order, pt, n, log).map_err(invalid)?;
        unsafe { put_opt(used_out, used, "used_out") }
    })
}

/// Visibility vector g = exp*(log) (f64, `order²` values) from a summed log vector (f32); a log
/// with a NaN or an infinity is `SPHB_ERR_INVALID_ARGUMENT`. Allocation-free; thread-safe.
#[no_mangle]
pub unsafe extern "C" fn sphb_visibility(
    ctx: *const SphbShadowContext,
    log: *const f32,
    log_len: usize,
    out: *mut f64,
    out_len: usize,
    err: *mut SphbError,
) -> i32 {
    run(err, || {
        let c = unsafe { object(ctx, "ctx")? };
        let nc = c.ctx.order() * c.ctx.order();
        disjoint(("out", span(out, out_len)), &[("log", span(log, log_len))])?;
        let l = unsafe { input_min(log, log_len, nc, "log")? };
        if !l[..nc].iter().all(|v| v.is_finite()) {
            return Err(invalid("log must be finite"));
        }
        let o = unsafe { output(out, out_len, nc, "out")? };
        c.ctx.visibility(l, o).map_err(invalid)
    })
}

/// The shading vector T = L ∗ H(N) (Ren 2006 §7) for lighting `light` (order² SH radiance
/// coefficients, f64, one channel: monochrome radiance; T is linear in it, so a coloured light
/// takes one shading vector per channel; a NaN or an infinity in it is `SPHB_ERR_INVALID_ARGUMENT`)
/// and normal `normal` (3 doubles; scaled to unit length, zero or non-finite is
/// `SPHB_ERR_INVALID_ARGUMENT`) into `out[0..order²]`; the shaded value
/// is `sphb_shade(T, g)`. For uniform white light (`sphb_uniform_light`) and g = 1 it is 1.
/// Thread-safe.
#[no_mangle]
pub unsafe extern "C" fn sphb_shading_vector(
    ctx: *const SphbShadowContext,
    light: *const f64,
    light_len: usize,
    normal: *const f64,
    out: *mut f64,
    out_len: usize,
    err: *mut SphbError,
) -> i32 {
    run(err, || {
        let c = unsafe { object(ctx, "ctx")? };
        let nc = c.ctx.order() * c.ctx.order();
        disjoint(("out", span(out, out_len)), &[("light", span(light, light_len)), ("normal", span(normal, 3))])?;
        let l = unsafe { input_min(light, light_len, nc, "light")? };
        check_finite(l, "light")?;
        let nv = unsafe { input(normal, 3, "normal")? };
        let o = unsafe { output(out, out_len, nc, "out")? };
        c.ctx.shading_vector(l, [nv[0], nv[1], nv[2]], o).map_err(invalid)
    })
}

/// T · g over `count` coefficients (0 when either pointer is NULL). Thread-safe.
#[no_mangle]
pub unsafe extern "C" fn sphb_shade(shading_vector: *const f64, visibility: *const f64, count: usize) -> f64 {
    catch_unwind(AssertUnwindSafe(|| {
        let (Ok(t), Ok(g)) = (unsafe { input(shading_vector, count, "t") }, unsafe { input(visibility, count, "g") })
        else {
            return 0.0;
        };
        shade(t, g)
    }))
    .unwrap_or(0.0)
}

/// The shaded value at receiver `p` (3 floats) with normal `normal` (3 floats; scaled to unit
/// length, zero or non-finite is `SPHB_ERR_INVALID_ARGUMENT`) for the
/// cluster's blockers: accumulate, exponentiate, dot with `shading_vector` (order² doubles), into
/// `*out`. Allocation-free; does not modify the cluster (concurrent calls are safe).
#[no_mangle]
pub unsafe extern "C" fn sphb_shade_point(
    ctx: *const SphbShadowContext,
    cluster: *const SphbShadowCluster,
    p: *const f32,
    normal: *const f32,
    shading_vector: *const f64,
    shading_len: usize,
    out: *mut f64,
    err: *mut SphbError,
) -> i32 {
    run(err, || {
        let c = unsafe { object(ctx, "ctx")? };
        let cl = unsafe { object(cluster, "cluster")? };
        let inputs =
            [("p", span(p, 3)), ("normal", span(normal, 3)), ("shading_vector", span(shading_vector, shading_len))];
        disjoint(("out", span(out, 1)), &inputs)?;
        let pt = unsafe { vec3(p, "p")? };
        let n = unsafe { vec3(normal, "normal")? };
        let t = unsafe { input(shading_vector, shading_len, "shading_vector")? };
        let o = unsafe { object_mut(out, "out")? };
        *o = c.ctx.shade_point(&cl.cb, pt, n, t).map_err(invalid)?;
        Ok(())
    })
}

/// Uniform white light of unit radiance, **1** = (√(4π), 0, …), into `out[0..order²]`.
/// Thread-safe.
#[no_mangle]
pub unsafe extern "C" fn sphb_uniform_light(order: u32, out: *mut f64, out_len: usize, err: *mut SphbError) -> i32 {
    run(err, || {
        let order = sh_order(order)?;
        let o = unsafe { output(out, out_len, order * order, "out")? };
        spherebake_runtime::shadow::uniform_light(order, o);
        Ok(())
    })
}

/// A lobe of light: radiance 1 inside the cone of half-angle `half_angle_rad` about the unit
/// `direction` (3 doubles), projected to SH `order` (1..=8) and windowed against ringing
/// (Ren's a_l = cos(πl/(4·order))), into `out[0..order²]`. Thread-safe.
#[no_mangle]
pub unsafe extern "C" fn sphb_lobe_light(
    order: u32,
    direction: *const f64,
    half_angle_rad: f64,
    out: *mut f64,
    out_len: usize,
    err: *mut SphbError,
) -> i32 {
    run(err, || {
        let order = sh_order(order)?;
        disjoint(("out", span(out, out_len)), &[("direction", span(direction, 3))])?;
        let d = unsafe { input(direction, 3, "direction")? };
        let o = unsafe { output(out, out_len, order * order, "out")? };
        spherebake_runtime::shadow::lobe_light(order, [d[0], d[1], d[2]], half_angle_rad, o).map_err(invalid)
    })
}

/// A light context of SH `order` (1..=8, at most the albedo order of the proxies it lights) and
/// exponential `exp_method` into `*out`. Immutable: share between threads.
#[no_mangle]
pub unsafe extern "C" fn sphb_light_context_new(
    order: u32,
    exp_method: i32,
    out: *mut *mut SphbLightContext,
    err: *mut SphbError,
) -> i32 {
    run(err, || unsafe {
        new_object_into(out, || {
            let ctx = LightContext::new(order as usize, exp_of(exp_method)?).map_err(invalid)?;
            Ok(SphbLightContext { ctx })
        })
    })
}

/// Frees a light context; NULL does nothing.
#[no_mangle]
pub unsafe extern "C" fn sphb_light_context_free(ctx: *mut SphbLightContext) {
    // SAFETY: made by `sphb_light_context_new`, freed once (the caller's contract).
    unsafe { free_object(ctx) }
}

/// New, empty sphere lights (pass 1's output; NULL only on an internal error, a caught panic).
/// Free with `sphb_sphere_lights_free`.
#[no_mangle]
pub extern "C" fn sphb_sphere_lights_new() -> *mut SphbSphereLights {
    new_object(|| SphbSphereLights { lights: SphereLights::new() })
}

/// Frees sphere lights; NULL does nothing.
#[no_mangle]
pub unsafe extern "C" fn sphb_sphere_lights_free(lights: *mut SphbSphereLights) {
    // SAFETY: made by `sphb_sphere_lights_new`, freed once (the caller's contract).
    unsafe { free_object(lights) }
}

/// The leaf light L^c of sphere `sphere` after pass 1: `order²` linear-RGB SH coefficients
/// (3 floats each, the sphere's rest frame) into `out` (`out_len` floats, at least 3·order²).
#[no_mangle]
pub unsafe extern "C" fn sphb_sphere_lights_leaf(
    lights: *const SphbSphereLights,
    sphere: u32,
    out: *mut f32,
    out_len: usize,
    err: *mut SphbError,
) -> i32 {
    run(err, || {
        let l = unsafe { object(lights, "lights")? };
        let what = format!("sphere {sphere} (of {})", l.lights.leaf_count());
        unsafe { copy_rgb(l.lights.leaf(sphere as usize), out, out_len, &what) }
    })
}

/// Borrowed runtime view of a `SphbPosed`.
///
/// # Safety
/// The pointers in `posed` follow the module's conventions.
unsafe fn posed_of<'a>(posed: &'a SphbPosed) -> Res<PosedProxy<'a>> {
    let p: &'a SphbProxy = unsafe { object(posed.proxy, "posed.proxy")? };
    let leaves = spheres_of(unsafe { input(posed.leaves, posed.leaf_count, "posed.leaves")? });
    let nodes = unsafe { hierarchy_of(p, posed.nodes, posed.node_count, "posed.nodes")? };
    let rotations = if posed.rotations.is_null() {
        None
    } else {
        let floats = leaves.len().checked_mul(9).ok_or_else(|| invalid("leaf_count is too large"))?;
        Some(rotations_of(unsafe { input(posed.rotations, floats, "posed.rotations")? }))
    };
    Ok(PosedProxy { proxy: &p.proxy, leaves, nodes, rotations })
}

/// Soft-deformation rotations (Guerrero 2008 §7.1) of every sphere: R = polar(Σ b_j M_j) ·
/// polar(Σ b_j M⁰_j)ᵀ over its skin slots, from `joints` (pose) and `rest_joints` (the rest pose
/// of the file's model space), `joint_count` column-major 4×4 matrices each, indexed by the
/// file's bone table as for `sphb_pose`; into `out`
/// (9 floats per sphere, column-major 3×3, `out_len` floats). Thread-safe.
/// `rest_joints` are the joint matrices world(joint) × inverse bind of the glTF scene with no
/// animation applied (each node's own TRS), computed as the engine computes `joints`; they are
/// not the identity, which is the bind pose (CesiumMan's bind and rest poses differ by a
/// rotation). The file does not store them: compute them once per model from its glTF. A NaN or
/// an infinity in a matrix (of `joints` or `rest_joints`) the bone table uses is
/// `SPHB_ERR_INVALID_ARGUMENT`.
#[no_mangle]
pub unsafe extern "C" fn sphb_sphere_rotations(
    proxy: *const SphbProxy,
    joints: *const f32,
    rest_joints: *const f32,
    joint_count: usize,
    out: *mut f32,
    out_len: usize,
    err: *mut SphbError,
) -> i32 {
    run(err, || {
        let p = unsafe { object(proxy, "proxy")? };
        let floats = joint_count.saturating_mul(16);
        let inputs = [("joints", span(joints, floats)), ("rest_joints", span(rest_joints, floats))];
        disjoint(("out", span(out, out_len)), &inputs)?;
        let m = unsafe { matrices_in(joints, joint_count, "joints")? };
        let r = unsafe { matrices_in(rest_joints, joint_count, "rest_joints")? };
        if p.proxy.skin().is_some() {
            // As `sphb_pose`: the matrices the bone table uses must be finite (a short palette is
            // left to the count check below).
            let bones = p.proxy.bones().len();
            for (what, palette) in [("joints", m), ("rest_joints", r)] {
                let used = palette.get(..bones).unwrap_or(&[]);
                if let Some(j) = used.iter().position(|mat| !mat.iter().all(|v| v.is_finite())) {
                    return Err(invalid(format!("{what}: matrix {j} holds a NaN or an infinity")));
                }
            }
        }
        let n = p.proxy.sphere_count();
        let o = unsafe { output(out, out_len, n * 9, "out")? };
        // SAFETY: [f32; 9] has f32's alignment and no padding; `o` has exactly n·9 floats.
        let rot = unsafe { core::slice::from_raw_parts_mut(o.as_mut_ptr().cast::<[f32; 9]>(), n) };
        sphere_rotations(&p.proxy, m, r, rot).map_err(invalid)
    })
}

fn light_fail(e: &LightError) -> Fail {
    let code = match e {
        LightError::NoSamples | LightError::NoAlbedo => SPHB_ERR_MISSING_DATA,
        _ => SPHB_ERR_INVALID_ARGUMENT,
    };
    fail(code, e.to_string())
}

fn flag(v: u32, what: &str) -> Res<bool> {
    match v {
        0 => Ok(false),
        1 => Ok(true),
        other => Err(invalid(format!("{what} is {other}, not 0 or 1"))),
    }
}

/// The defaults of pass 1 (θmax = `SPHB_DEFAULT_THETA_MAX_RAD`). Thread-safe.
#[no_mangle]
pub extern "C" fn sphb_pass1_settings_default() -> SphbPass1Settings {
    // Every field listed: a new Rust setting fails to compile here until the C ABI mirrors it.
    let Pass1Settings { theta_max_rad } = Pass1Settings::default();
    SphbPass1Settings { theta_max_rad }
}

/// **Pass 1**: lights every sample of `posed` under the environment `env` (`env_len` ≥ order² SH
/// radiance coefficients, f64, one channel: monochrome radiance; e.g. from
/// `sphb_clip_below_horizon`), projects it onto each sphere's light and derives the hierarchy
/// nodes' lights; results into `lights`. The lights are RGB through the albedo SH; a coloured sky
/// takes one pass 1 (and pass 2) per channel, keeping that channel of each result (pass 1 is
/// linear in `env`, but for clamping each sample's radiance at 0). `others` (`other_count`
/// posed proxies, NULL with 0 for none) are further proxies whose spheres block the environment
/// (their lights are not needed). `settings` NULL means `sphb_pass1_settings_default()`.
/// `*stats_out` (optional) receives the counts. A NaN or an infinity in `env[0..order²]` is
/// `SPHB_ERR_INVALID_ARGUMENT`. The proxy needs samples and albedo SH (`SPHB_ERR_MISSING_DATA`).
/// A call that fails leaves `lights` empty (as new), never the previous pass 1's lights.
/// One thread at a time per `lights`.
#[no_mangle]
pub unsafe extern "C" fn sphb_light_spheres(
    ctx: *const SphbLightContext,
    posed: *const SphbPosed,
    env: *const f64,
    env_len: usize,
    others: *const SphbPosed,
    other_count: usize,
    settings: *const SphbPass1Settings,
    lights: *mut SphbSphereLights,
    stats_out: *mut SphbPass1Stats,
    err: *mut SphbError,
) -> i32 {
    run(err, || {
        let l = unsafe { object_mut(lights, "lights")? };
        build_or_empty(&mut l.lights, SphereLights::new, |out| {
            let c = unsafe { object(ctx, "ctx")? };
            let inputs = [
                ("posed", span(posed, 1)),
                ("env", span(env, env_len)),
                ("others", span(others, other_count)),
                ("settings", span(settings, 1)),
            ];
            disjoint(("stats_out", span(stats_out, 1)), &inputs)?;
            let pd = unsafe { object(posed, "posed")? };
            let pp = unsafe { posed_of(pd)? };
            let e = unsafe { input(env, env_len, "env")? };
            let nc = c.ctx.order() * c.ctx.order();
            check_finite(e.get(..nc).unwrap_or(e), "env")?;
            let o = unsafe { input(others, other_count, "others")? };
            let others: Vec<PosedProxy<'_>> = o.iter().map(|x| unsafe { posed_of(x) }).collect::<Res<_>>()?;
            let SphbPass1Settings { theta_max_rad } = if settings.is_null() {
                sphb_pass1_settings_default()
            } else {
                *unsafe { object(settings, "settings")? }
            };
            let Pass1Stats { samples, blocker_accumulations } =
                light_spheres(&c.ctx, &pp, e, &others, &Pass1Settings { theta_max_rad }, out)
                    .map_err(|e| light_fail(&e))?;
            unsafe { put_opt(stats_out, SphbPass1Stats { samples, blocker_accumulations }, "stats_out") }
        })
    })
}

/// **Pass 1 with given sample radiance** (e.g. an engine's own direct lighting or a ray tracer):
/// `radiance` holds L_pj per unit albedo for each of the proxy's samples (`radiance_len` = the
/// sample count, in the order of `SphbViews::samples`; negative values count as 0, a NaN or an
/// infinity is `SPHB_ERR_INVALID_ARGUMENT`); the projection, albedo product and node lights are
/// those of `sphb_light_spheres`; a call that fails leaves `lights` empty, as there. One thread
/// at a time per `lights`.
#[no_mangle]
pub unsafe extern "C" fn sphb_light_spheres_from_radiance(
    ctx: *const SphbLightContext,
    posed: *const SphbPosed,
    radiance: *const f32,
    radiance_len: usize,
    lights: *mut SphbSphereLights,
    err: *mut SphbError,
) -> i32 {
    run(err, || {
        let l = unsafe { object_mut(lights, "lights")? };
        build_or_empty(&mut l.lights, SphereLights::new, |out| {
            let c = unsafe { object(ctx, "ctx")? };
            let pp = unsafe { posed_of(object(posed, "posed")?)? };
            let r = unsafe { input(radiance, radiance_len, "radiance")? };
            check_finite(r, "radiance")?;
            light_spheres_from_radiance(&c.ctx, &pp, r, out).map_err(|e| light_fail(&e))
        })
    })
}

/// The environment `env` (order² SH radiance coefficients of `ctx`'s order, f64, one channel) with everything
/// below the horizon of the `up` direction (3 doubles; scaled to unit length, zero or non-finite is
/// `SPHB_ERR_INVALID_ARGUMENT`) removed (exact for an infinite ground
/// plane under the scene), into `out[0..order²]`. Thread-safe.
#[no_mangle]
pub unsafe extern "C" fn sphb_clip_below_horizon(
    ctx: *const SphbLightContext,
    env: *const f64,
    env_len: usize,
    up: *const f64,
    out: *mut f64,
    out_len: usize,
    err: *mut SphbError,
) -> i32 {
    run(err, || {
        let c = unsafe { object(ctx, "ctx")? };
        let nc = c.ctx.order() * c.ctx.order();
        disjoint(("out", span(out, out_len)), &[("env", span(env, env_len)), ("up", span(up, 3))])?;
        let e = unsafe { input(env, env_len, "env")? };
        let u = unsafe { input(up, 3, "up")? };
        let o = unsafe { output(out, out_len, nc, "out")? };
        clip_below_horizon(&c.ctx, e, [u[0], u[1], u[2]], o).map_err(|e| light_fail(&e))
    })
}

/// The L^c of hierarchy node `node` after pass 1: `order²` linear-RGB SH coefficients (3 floats
/// each, the node's rest frame) into `out` (`out_len` floats, at least 3·order²).
/// `SPHB_ERR_INVALID_ARGUMENT` for a node index out of range (or lights of a proxy without hierarchy).
#[no_mangle]
pub unsafe extern "C" fn sphb_sphere_lights_node(
    lights: *const SphbSphereLights,
    node: u32,
    out: *mut f32,
    out_len: usize,
    err: *mut SphbError,
) -> i32 {
    run(err, || {
        let l = unsafe { object(lights, "lights")? };
        unsafe { copy_rgb(l.lights.node(node as usize), out, out_len, &format!("node {node}")) }
    })
}

/// The diffuse exit radiance per unit albedo L_pj of every sample after pass 1 (in the order of
/// `SphbViews::samples`) into `out` (capacity `out_cap`); `*len_out` = the sample count (also when
/// `out` is too short: `SPHB_ERR_BUFFER_TOO_SMALL`).
#[no_mangle]
pub unsafe extern "C" fn sphb_sphere_lights_sample_radiance(
    lights: *const SphbSphereLights,
    out: *mut f32,
    out_cap: usize,
    len_out: *mut usize,
    err: *mut SphbError,
) -> i32 {
    run(err, || {
        let l = unsafe { object(lights, "lights")? };
        let r = l.lights.sample_radiance();
        disjoint(("len_out", span(len_out, 1)), &[("out", span(out, out_cap))])?;
        *unsafe { object_mut(len_out, "len_out")? } = r.len();
        unsafe { output(out, out_cap, r.len(), "out")? }.copy_from_slice(r);
        Ok(())
    })
}

/// A new, empty indirect-light cluster (NULL only on an internal error, a caught panic). Free with
/// `sphb_indirect_cluster_free`.
#[no_mangle]
pub extern "C" fn sphb_indirect_cluster_new() -> *mut SphbIndirectCluster {
    new_object(empty_indirect_cluster)
}

fn empty_indirect_cluster() -> SphbIndirectCluster {
    SphbIndirectCluster { ic: IndirectCluster::new() }
}

/// Frees an indirect-light cluster; NULL does nothing.
#[no_mangle]
pub unsafe extern "C" fn sphb_indirect_cluster_free(cluster: *mut SphbIndirectCluster) {
    // SAFETY: made by `sphb_indirect_cluster_new`, freed once (the caller's contract).
    unsafe { free_object(cluster) }
}

/// A new, empty scratch for `sphb_indirect_irradiance_with` (one per querying thread; NULL only on
/// an internal error, a caught panic). Free with `sphb_indirect_scratch_free`.
#[no_mangle]
pub extern "C" fn sphb_indirect_scratch_new() -> *mut SphbIndirectScratch {
    new_object(|| SphbIndirectScratch { scratch: IndirectScratch::new() })
}

/// Frees a scratch; NULL does nothing.
#[no_mangle]
pub unsafe extern "C" fn sphb_indirect_scratch_free(scratch: *mut SphbIndirectScratch) {
    // SAFETY: made by `sphb_indirect_scratch_new`, freed once (the caller's contract).
    unsafe { free_object(scratch) }
}

/// A cluster spec with centre `center` (3 floats), `radius`, the receivers' mean unit `normal`
/// (3 floats, or NULL: none) and the defaults: θmax = `SPHB_DEFAULT_THETA_MAX_RAD`, reflection
/// ratios on, overlap correction off. Thread-safe.
#[no_mangle]
pub unsafe extern "C" fn sphb_cluster_spec_init(
    center: *const f32,
    radius: f32,
    normal: *const f32,
    out: *mut SphbClusterSpec,
    err: *mut SphbError,
) -> i32 {
    run(err, || {
        let c = unsafe { vec3(center, "center")? };
        let n = unsafe { opt_vec3(normal, "normal")? };
        let o = unsafe { object_mut(out, "out")? };
        // Every field listed: a new Rust field fails to compile here until the C ABI mirrors it.
        let ClusterSpec { center, radius, normal, theta_max_rad, reflection_ratio, overlap_correction } =
            ClusterSpec::new(c, radius, n);
        *o = SphbClusterSpec {
            center,
            radius,
            normal: normal.unwrap_or([0.0; 3]),
            has_normal: u32::from(normal.is_some()),
            theta_max_rad,
            reflection_ratio: u32::from(reflection_ratio),
            overlap_correction: u32::from(overlap_correction),
        };
        Ok(())
    })
}

fn cluster_spec_of(s: &SphbClusterSpec) -> Res<ClusterSpec> {
    let SphbClusterSpec { center, radius, normal, has_normal, theta_max_rad, reflection_ratio, overlap_correction } =
        *s;
    Ok(ClusterSpec {
        center,
        radius,
        normal: flag(has_normal, "spec.has_normal")?.then_some(normal),
        theta_max_rad,
        reflection_ratio: flag(reflection_ratio, "spec.reflection_ratio")?,
        overlap_correction: flag(overlap_correction, "spec.overlap_correction")?,
    })
}

/// **Pass 2, per cluster**: the sphere lights of `source_count` sources (`sources[i]` posed with
/// `lights[i]` from pass 1) seen by the receiver cluster `spec` (ball, mean normal, θmax,
/// reflection ratios, overlap correction; see `SphbClusterSpec`). One thread at a time per cluster.
#[no_mangle]
pub unsafe extern "C" fn sphb_indirect_cluster_build(
    cluster: *mut SphbIndirectCluster,
    ctx: *const SphbLightContext,
    sources: *const SphbPosed,
    lights: *const *const SphbSphereLights,
    source_count: usize,
    spec: *const SphbClusterSpec,
    err: *mut SphbError,
) -> i32 {
    run(err, || {
        let cl = unsafe { object_mut(cluster, "cluster")? };
        build_or_empty(cl, empty_indirect_cluster, |cl| {
            let c = unsafe { object(ctx, "ctx")? };
            let spec = cluster_spec_of(unsafe { object(spec, "spec")? })?;
            unsafe {
                with_sources(sources, lights, source_count, |srcs| {
                    cl.ic.build(&c.ctx, srcs, &spec).map_err(|e| light_fail(&e))
                })
            }
        })
    })
}

/// The number of sphere lights in the cluster's cut (0 before the first build) into `*out`.
/// Thread-safe with other readers; not during a build or query of the same cluster.
#[no_mangle]
pub unsafe extern "C" fn sphb_indirect_cluster_light_count(
    cluster: *const SphbIndirectCluster,
    out: *mut usize,
    err: *mut SphbError,
) -> i32 {
    run(err, || {
        let cl = unsafe { object(cluster, "cluster")? };
        *unsafe { object_mut(out, "out")? } = cl.ic.light_count();
        Ok(())
    })
}

/// Sources a pass-2 call holds on the stack (more go to a heap array): a query per receiver
/// allocates nothing for up to this many.
const STACK_SOURCES: usize = 8;

/// Calls `f` with the `count` sources (`sources[i]` posed, lit by `lights[i]`), held on the
/// stack up to [`STACK_SOURCES`].
///
/// # Safety
/// Module conventions for the arrays.
unsafe fn with_sources<'a, R>(
    sources: *const SphbPosed,
    lights: *const *const SphbSphereLights,
    count: usize,
    f: impl FnOnce(&[(PosedProxy<'a>, &'a SphereLights)]) -> Res<R>,
) -> Res<R> {
    let s: &'a [SphbPosed] = unsafe { input(sources, count, "sources")? };
    let l: &'a [*const SphbSphereLights] = unsafe { input(lights, count, "lights")? };
    let get = |i: usize| -> Res<(PosedProxy<'a>, &'a SphereLights)> {
        let lights: &'a SphbSphereLights = unsafe { object(l[i], "lights[i]")? };
        Ok((unsafe { posed_of(&s[i])? }, &lights.lights))
    };
    if count == 0 {
        return f(&[]);
    }
    if count <= STACK_SOURCES {
        let mut held = [get(0)?; STACK_SOURCES];
        for (i, slot) in held.iter_mut().enumerate().take(count).skip(1) {
            *slot = get(i)?;
        }
        return f(&held[..count]);
    }
    let all = (0..count).map(get).collect::<Res<Vec<_>>>()?;
    f(&all)
}

/// **Pass 2, per receiver**: the indirect irradiance E (linear RGB, ∫ L_in cos dω; 3 doubles
/// into `out`) at receiver `p` (3 floats) with `normal` (3 floats; scaled to unit length, zero or
/// non-finite is `SPHB_ERR_INVALID_ARGUMENT`) from the cluster's lights.
/// `sources` / `lights` must be the arrays the cluster was built from. Reuses the cluster's
/// buffers: one thread at a time per cluster (to query one cluster from many threads, use
/// `sphb_indirect_irradiance_with`); allocation-free once they have grown (up to 8 sources).
/// Each channel is at least 0 (SH lights can dip below 0; irradiance cannot).
#[no_mangle]
pub unsafe extern "C" fn sphb_indirect_irradiance(
    cluster: *mut SphbIndirectCluster,
    ctx: *const SphbLightContext,
    sources: *const SphbPosed,
    lights: *const *const SphbSphereLights,
    source_count: usize,
    p: *const f32,
    normal: *const f32,
    out: *mut f64,
    err: *mut SphbError,
) -> i32 {
    run(err, || {
        let cl = unsafe { object_mut(cluster, "cluster")? };
        unsafe {
            irradiance_call(ctx, sources, lights, source_count, p, normal, out, |c, srcs, pt, n| {
                cl.ic.irradiance(c, srcs, pt, n)
            })
        }
    })
}

/// The shared part of the two per-receiver queries: checks and reads `ctx`, the sources, `p`,
/// `normal` and `out` (disjoint from both), runs `query` and writes its value to `out`.
///
/// # Safety
/// Module conventions for every pointer.
#[allow(clippy::too_many_arguments)]
unsafe fn irradiance_call(
    ctx: *const SphbLightContext,
    sources: *const SphbPosed,
    lights: *const *const SphbSphereLights,
    source_count: usize,
    p: *const f32,
    normal: *const f32,
    out: *mut f64,
    query: impl FnOnce(&LightContext, &[LightSource<'_, '_>], [f32; 3], [f32; 3]) -> Result<[f64; 3], LightError>,
) -> Res<()> {
    let c = unsafe { object(ctx, "ctx")? };
    disjoint(("out", span(out, 3)), &[("p", span(p, 3)), ("normal", span(normal, 3))])?;
    let pt = unsafe { vec3(p, "p")? };
    let n = unsafe { vec3(normal, "normal")? };
    let o = unsafe { output(out, 3, 3, "out")? };
    let e = unsafe {
        with_sources(sources, lights, source_count, |srcs| query(&c.ctx, srcs, pt, n).map_err(|e| light_fail(&e)))?
    };
    o.copy_from_slice(&e);
    Ok(())
}

/// `sphb_indirect_irradiance` on a shared cluster: the same value, bit for bit, with the
/// per-query working data in `scratch` (from `sphb_indirect_scratch_new`) instead of the
/// cluster's buffers. The cluster is only read: any number of threads may query one built
/// cluster at once, each with its own scratch, while no thread builds it. One scratch serves
/// every cluster; allocation-free once it has grown to the largest cluster's lights (up to 8
/// sources). `out` must not overlap `p` or `normal`.
#[no_mangle]
pub unsafe extern "C" fn sphb_indirect_irradiance_with(
    cluster: *const SphbIndirectCluster,
    scratch: *mut SphbIndirectScratch,
    ctx: *const SphbLightContext,
    sources: *const SphbPosed,
    lights: *const *const SphbSphereLights,
    source_count: usize,
    p: *const f32,
    normal: *const f32,
    out: *mut f64,
    err: *mut SphbError,
) -> i32 {
    run(err, || {
        let cl = unsafe { object(cluster, "cluster")? };
        let sc = unsafe { object_mut(scratch, "scratch")? };
        unsafe {
            irradiance_call(ctx, sources, lights, source_count, p, normal, out, |c, srcs, pt, n| {
                cl.ic.irradiance_with(&mut sc.scratch, c, srcs, pt, n)
            })
        }
    })
}
