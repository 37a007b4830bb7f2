//! One-bounce indirect light from the sphere proxies: the spheres as *spherical lights* (Guerrero, Jeschke, Wimmer
//! 2008 §5–7, seed 000), built on the log-SH visibility of [`crate::shadow`] (Ren et al. 2006).
//!
//! # Per frame, in order
//!
//! 1. [`crate::pose()`] / [`crate::pose_and_refit`] the proxy (skinned models), and [`sphere_rotations`] for the soft
//!    deformation (§7.1).
//! 2. **Pass 1** ([`light_spheres`], per proxy): the diffuse exit radiance of every surface sample point p_j of every
//!    leaf sphere S_i, L_pj = V_p,env · L_env,ρn (eq. 3–8): V by log-SH accumulation over the hierarchy cut seen from
//!    S_i (the receiver cluster is S_i itself), the self-shadowing rules of `shadow` and any other proxies passed in;
//!    L_env,ρn = L_env ∗ H(n_j) with H the clamped cosine over π (so an unoccluded sample under uniform radiance 1
//!    has L_pj = 1: exit radiance per unit albedo). The values are projected onto S_i's SH with the Voronoi-cell
//!    basis sums (eq. 9–10, [`spherebake_sh::voronoi_cell_basis`]; directions without a sample emit nothing, seed
//!    rule 2) and multiplied by the baked albedo SH (eq. 11, the SH product through the triple-product tensor), per
//!    linear RGB channel. Interior hierarchy nodes get radiance from their leaves (below).
//! 3. **Pass 2** per receiver cluster ([`IndirectCluster::build`]: hierarchy cut, ratio vectors, reflection ratios)
//!    and per receiver ([`IndirectCluster::irradiance`]): E^I(p) = π Σ_i L̃_p,Si · Ṽ_p,Si · t_Si (eq. 14, 26), with
//!    the cosine-weighted average radiance and the visibility share below.
//! 4. Direct light: [`crate::shadow`] (`ShadowContext::shade_point`, whose shaded value is the direct irradiance
//!    over π); total = direct + indirect (eq. 12): E_total = π · shade + E^I, exit radiance ρ · E_total / π, both
//!    parts exposed: [`IndirectCluster::irradiance`] returns the indirect part only.
//!
//! # Readings taken (where the paper's text is ambiguous) and departures
//!
//! - **Units.** [`IndirectCluster::irradiance`] returns irradiance E = ∫ L_in cos dω (linear RGB); the receiver's
//!   exit radiance is albedo · E / π. The paper's ρ_n includes 1/π (Ṽ = V · ρ_n, eq. 24); we multiply back by π.
//! - **Voronoi gain (departure, eq. 10).** The piecewise-constant Voronoi function attenuates band l of a smooth
//!   emission by κ_l = (1/(2l+1)) Σ_m Σ_j y_lm(ω_j) Y_j,lm ([`voronoi_band_gains`]: 1, 0.989, 0.967, 0.935 for
//!   l = 0..3); pass 1 divides band l by κ_l. Without it the band-1 emission of a sky-lit sphere is 1.1 % low, which
//!   makes its dark underside glow (2.5 % ground error under a floating sphere; 0.00 % with it).
//! - **Average radiance with the cosine inside (departure, eq. 14–18).** Eq. 14–15 hold the receiver's cosine
//!   constant over a light and eq. 16 drops the Jacobian between the sphere's surface and p's solid angle. For a
//!   light near the receiver's horizon — a ground point seeing an object that stands on it — the cosine runs from 0
//!   to its maximum across the light and correlates with the light's sky-lit upper half: the paper's product is 18 %
//!   low for a unit sphere seen from 3 radii. We use the cosine-weighted average instead,
//!   L̃ρ = Φ / Ṽ₀ with Φ = (1/π) ∫_cap L (n·ω) dω ([`spherebake_sh::cosine_weighted_radiance_rgb_f32`]: zonal tables
//!   C_l(θ), D_l(θ) plus the light's gradient) and Ṽ₀ = (n·s) sin²θ the exact unoccluded cosine-weighted cap, so
//!   the contribution is E_i = π L̃ρ Ṽ_i t_i. The paper's uniform average (eq. 15) is tabulated too
//!   ([`spherebake_sh::average_radiance_rgb_f32`]).
//! - **Visibility as a share (eq. 23–24).** Ṽ_i = Ṽ₀ · clamp(((exp*(A) − exp*(A + G_i)) · H) / ((1 − exp*(G_i)) · H),
//!   0, 1): eq. 23's SH estimate of the visible part divided by the same estimate of the whole cap, times the exact
//!   whole cap. This removes the truncation error of a single cap at order n (large for a receiver under an
//!   object, where the cap is wide) and costs one exponential more where blockers exist; with no nearer blocker
//!   Ṽ_i = Ṽ₀ and no exponential is evaluated.
//! - **Blocker order (eq. 20–23).** "All SLs closer to p" is taken as the *power* of p with respect to each sphere,
//!   |p − c|² − r²: for two disjoint balls the radical plane separates them, so every ray from p that meets both
//!   meets the ball of smaller power first. Ties keep the cut order.
//! - **Cones that miss are no blockers (departure).** A nearer light whose cone from p does not overlap the light's
//!   cone (angle between the axes ≥ θ_i + θ_j) blocks none of it, but its band-limited log still darkens it by
//!   SH leakage (measured 4–10 % for two unit spheres 143° apart); such pairs are skipped.
//! - **Lights seen from very close (departure).** For a receiver inside or under a light (angular radius θ > 40°),
//!   the weights concentrate near the axis, where the order-n SH smears the light's empty directions (rule 2) and
//!   its sharp light/dark edges: the ground under the Duck glowed (rel RMSE 0.65 at 64 spheres). From θ = 40° to
//!   60° the light's SH is blended into a local band-0–1 least-squares fit of its Voronoi function (the 92 sampled
//!   values, empty directions as 0) within a cone about the axis, integrated with the same cosine weights; the fit
//!   is exact for band-1 emission, so the known-answer cases keep their exactness (Duck: 0.65 → 0.36).
//! - **Loose lights: area weights and the samples as small emitters (departure).** Where a bounding sphere stands
//!   away from the surface it bounds (a limb in a fat sphere), its surface is the wrong emitter: it has far more
//!   area than the surface it stands for (CesiumMan at 64 spheres: 2.35 vs the mesh's 1.46, so the ground was 44 %
//!   too bright), and up close light leaves the sphere's underside instead of the sides of the foot. A leaf's
//!   *fill* f = mean(t_j / r) over its samples (t_j the sample's distance from the centre) measures it.
//!   - *Far field, pass 1*: each sample's radiance enters the projection (eq. 9) weighted by
//!     1 + w_a ((t/r)² / max(|n·ω|, 0.2) − 1), the ratio of the surface area its Voronoi cell covers (t² Ω / |n·ω|)
//!     to the sphere's (r² Ω), so the light emits the power of its surface; w_a ramps from 0 at f = 0.85 to 1 at
//!     f = 0.70. Summed over all leaves the full weights reproduce the mesh area (Duck 6.87–7.10 vs 7.02, CesiumMan
//!     1.44–1.50 vs 1.46, spot 5.63–5.79 vs 5.6 at 16–256 spheres), but applied to tight leaves too they darken
//!     blob-like models (Duck 0.375 → 0.442, spot 0.176 → 0.323 at 64): there the bounding spheres' mutual
//!     blocking (they occlude more than the surface inside them) already removes light, and the sphere surface's
//!     excess area (9 % on the Duck) had balanced it. Tight leaves are therefore left unweighted.
//!   - *Near field, pass 2*: for a leaf with f < 0.98, or with samples in fewer than 95 % of the 92 directions
//!     (the rest belong to other spheres, rule 2, and the order-n SH smears the sharp edge between emitting and empty
//!     directions; full weight at 75 %, [`SPLAT_COVER_FULL`]), seen at an angular radius θ above 10° (or containing
//!     the receiver), its emission is blended into the *splat* of its own samples ([`splat_irradiance`]): each sample
//!     a planar *tile*, the central projection of its direction's Voronoi cell onto its tangent plane, with the
//!     pass-1 radiance L_pj c(ω_j) and its exact polygon irradiance (Lambert's formula, clipped to the receiver's
//!     horizon; [`crate::tile`]; scaled to the sample's surface area when the file has it, format minor 2), times
//!     the light's visible share; weight ramp(θ: 10° → 30°) ×
//!     max(ramp(f: 0.98 → 0.90), ramp(coverage: 0.95 → 0.75)) ([`SPLAT_THETA_START`], [`SPLAT_THETA_FULL`]). A
//!     tight, fully covered leaf keeps the SH light, which is exact for the known-answer spheres. Until 2026-12-02
//!     each sample was a disk facing the receiver, L A cos_e cos_r / (d² + A/π) with A = t² Ω / max(|n·ω|, 0.2): its
//!     cosines vanish for a receiver a hair under a surface (the ground under the Duck's belly, 0.003–0.05 below it,
//!     where half the ground error was), while the tiles above such a receiver fill its view as the surface does.
//!     Splat oracle (traced radiance and albedo, ray-cast visibility), ground at 64 spheres: disks 0.308 / 0.221
//!     (Duck / CesiumMan), tiles 0.231 / 0.156. The tiles' near-plane rule ([`crate::tile::TILE_MIN_HEIGHT`]) keeps
//!     a posed leaf's rigidly moved samples from flooding a receiver beside them. On the shared models every leaf
//!     of a 16–256-sphere proxy is below 75 % coverage.
//!   - *Tiles of the right size* (2026-12-02): the central projection misjudges a tile's area where a ray's
//!     farthest hit skips a fold, where rule 2 empties directions and where the surface curves away, so the
//!     tiles of a segment carried 0.56–2.8× the surface they stood for (Duck, 64 spheres, quartiles 0.96–1.07).
//!     The bake now stores each sample's true share of its segment's surface (spec §7.2) and the tile is scaled
//!     to it ([`crate::tile::scale_tile_to_area`]). With correctly sized tiles the splat is the better emitter
//!     from closer in, so the blend moved from 20°–40° to 10°–30°. Ground rel RMSE at 64 spheres (Duck / spot /
//!     CesiumMan): 0.255 / 0.128 / 0.259 → areas 0.211 / 0.125 / 0.246 → and 10°–30°: 0.191 / 0.112 / 0.239
//!     (sweep of the blend with a brute-force prototype of the areas, start–full: 5°–20° 0.190 / 0.126 / 0.239, 10°–20° 0.189 / 0.125 / 0.244,
//!     15°–30° 0.188 / 0.111 / 0.239, 30°–50° 0.286 / 0.155 / 0.262, 0°–10° 0.197 / 0.136 / 0.230).
//!   - *The surface's power in pass 1*: with the file's areas, a leaf's sample j is weighted by a_j / (r² Ω_j) (Ω_j
//!     its cell's solid angle, [`crate::tile::cell_solid_angle`]), blended in by the splat's weight (fill and
//!     coverage ramps above), so every leaf that is not a tight, fully covered sphere emits the power of the surface
//!     it bounds, not of its sphere. This replaces, when areas are present, the estimate (t/r)² / |n·ω| that was
//!     applied to loose leaves only: the estimate cannot see folds and empty directions, and applied to tight leaves
//!     it had darkened blobs. Ground at 64 spheres (Duck / spot / CesiumMan): 0.191 / 0.112 / 0.239 → 0.194 / 0.157 /
//!     0.205 (CesiumMan's far field overshot by +11 %, its tight leaves' spheres emitting more than their surface;
//!     spot's spheres over-block each other in pass 2, which the sphere's excess area had hidden). The loose ball of
//!     `tests/light_known.rs` given its true areas: 0.0069 against the analytic answer (0.0475 with the estimate).
//!   - *Contact*: spheres of one proxy that intersect do not block each other (§6.2), and a sphere that contains the
//!     receiver cannot occlude it, so the ground under a foot (the sole resting on it) was lit through the foot by
//!     the shin's light. Now the leaf that contains the receiver and whose front-facing tiles cover the largest
//!     share C of its cosine-weighted view (their polygon irradiance / π, without the near-plane rule) hides every
//!     other light by (1 − C) ([`tile_coverage`]; C is direction-blind, a share of the whole view). CesiumMan at 64
//!     spheres: the 10 receivers under its soles (reference 0) from 0.059 to 0.021, ground 0.205 → 0.194; Duck and
//!     spot unchanged (0.194 / 0.157). Costs one pass over the containing leaves' tiles per receiver (most ground
//!     receivers are in no sphere).
//!   - *Albedo without zeros*: the bake fills the albedo cube map's directions without surface with the segment's
//!     mean colour (`spherebake-bake` albedo docs); the emission is 0 there anyway (rule 2, carried by L), and the
//!     zeros had darkened every segment's edge through the order-4 truncation of c (L ∗ c, eq. 11) more the more
//!     spheres there are. Check: the splat of the samples with traced radiance, traced albedo and ray-cast
//!     visibility (`spherebake light --splat-oracle`, a hidden dev aid) gives the same ground error with the filled
//!     albedo SH as with the true albedo (Duck 0.308 vs 0.308, spot 0.085 vs 0.097, CesiumMan 0.220 vs 0.221 at 64
//!     spheres), against 0.394 / 0.202 / 0.283 with the zeros.
//!   - Measured (4096 rays, uniform sky; ground rel RMSE at 16 | 64 | 256 spheres): Duck 0.371 | 0.375 | 0.457 →
//!     0.307 | 0.338 | 0.437 (area weights and splat of loose leaves) → 0.314 | 0.335 | 0.290 (filled albedo,
//!     coverage splat), spot 0.394 | 0.176 | 0.291 → 0.209 | 0.146 | 0.291 → 0.310 | 0.129 | 0.184, CesiumMan
//!     1.751 | 0.761 | 0.530 → 0.421 | 0.265 | 0.332 → 0.481 | 0.270 | 0.317; model receivers at 64: 1.47 / 1.02 /
//!     0.53 → 0.955 / 0.776 / 0.441. A unit ball in a 1.4× bounding sphere: 0.93 → 0.047 (`tests/light_known.rs`).
//!   - Pass 1 is not what limits this: with the traced sample radiance instead of the log-SH pass 1
//!     (`--pass1-reference`, via [`light_spheres_from_radiance`]) the errors stay within 0.01–0.05 of these.
//! - **One radiance per direction.** Lights that contain the receiver all touch its tangent plane after the
//!   self-shadowing rules and intersect, so none blocks another; their cosine-weighted shares are scaled down to the
//!   union of their caps (24 fixed directions per cap) when they add up to more.
//! - **Intersecting spheres of the same proxy** (§6.2) are not blockers of each other (|c_i − c_j| < r_i + r_j on the
//!   posed, unadjusted spheres): their mutual occlusion is already in the emission (rule 2). Spheres of different
//!   proxies always block (the paper forbids them to intersect).
//! - **Receivers inside or straddling a sphere** use [`crate::shadow::self_shadow_sphere`] for both the light's
//!   geometry (its angular radius and direction) and its log vector; spheres entirely behind the tangent plane
//!   contribute nothing. The adjusted sphere keeps the original's intensity distribution.
//! - **Parents' radiance (§7.3).** A node N stands for its leaves j in the far field, where the power received from
//!   a sphere is its average radiance times its solid angle ∝ r²: L^c_N = Σ_j (r_j / r_N)² L^c_j (leaves below N, all
//!   coefficients in their rest frames), and N turns with the polar rotation of Σ_j r_j² R_j. Mutual occlusion of the
//!   leaves is what the reflection ratio corrects. A leaf under a millionth of N's radius ((r_j / r_N)² ≤ 10⁻¹²: the
//!   empty spheres a fit leaves, radius `f32::MIN_POSITIVE`) is not in N's sums, as pass 2 skips it among the
//!   leaves (Ṽ₀ ≤ 10⁻¹²); a node of such leaves only is dark.
//! - **Reflection ratio (eq. 25–26; taken over the cluster, departure).** Every accepted node N is evaluated twice
//!   with the same routine as the receivers: as one light among the cut, and replaced by its leaves (each occluded by
//!   the rest of the cut and by its non-intersecting siblings); t_N = Σ_q Σ_j (L̃Ṽ)_q,j / Σ_q (L̃Ṽ)_q,N per RGB
//!   channel, 1 where the node contributes nothing measurable, clamped to [0, 16]. The paper takes it at the cluster
//!   centre x_C alone; we sum over x_C and four points q on the cluster's disc (perpendicular to its normal, at
//!   [`RATIO_PROBE_RADIUS`] · radius), so t is the scale that gives the node's leaves' total over the cluster. At a
//!   centre where a node is hidden (the ground between a figure's feet, the head behind the body) its value is a
//!   poor denominator: CesiumMan's head nodes got t = 6–16 there and lit the whole tile 2× too bright (ground rel
//!   RMSE 0.502 at 24² receivers in 8² tiles, 0.434 at 40², against 0.22–0.26 at 16², 32², 48²); taken over the
//!   tile 0.292 and 0.242; at 64² receivers the ground moves by −2.2 % to +1 % in 8² tiles and by up to +3 % (the
//!   Duck) in 16² tiles on CesiumMan, the Duck and spot (`docs/benchmarks.md`).
//!   Costs five evaluations per accepted node instead of one, in the cluster build only. Without a cluster normal the
//!   ratio is 1.
//! - **Soft deformation (§7.1).** Each leaf turns with R_i = polar(Σ_j b_j M_j) · polar(Σ_j b_j M⁰_j)ᵀ: the polar
//!   rotation of its skin terms' weighted joint matrices in the pose, relative to the rest pose (the skin weights
//!   b_j are the sphere centre's mean-value-coordinate bone weights, so this averages the rotation of what the sphere
//!   bounds; no format change). Pass 1 moves samples rigidly with (R_i, posed centre); pass 2 rotates the *weight
//!   vector* into the light's rest frame (axis Rᵀa), never the light's coefficients.
//!
//! # Cost (order n, K cut entries per receiver, m samples per sphere)
//!
//! Pass 1: per sample one log accumulation over the cut (K · n² multiply-adds), one SH exponential and one triple
//! product (V ∗ L_env); per sphere three triple products (albedo). Pass 2 per receiver: K log vectors, a sort of
//! K powers, and for each light ≤ K log additions and three exponentials (none when no blocker precedes it). Measured
//! numbers: `docs/benchmarks.md`. Pass 2 is allocation-free per receiver; builds allocate only while buffers grow.

//! # Example: one frame
//!
//! ```
//! use spherebake_runtime::light::{
//!     clip_below_horizon, light_spheres, ClusterSpec, IndirectCluster, LightContext, Pass1Settings, PosedProxy,
//!     SphereLights,
//! };
//! use spherebake_runtime::shadow::{uniform_light, ExpMethod};
//! # use spherebake_runtime::{AlbedoSh, SamplePoint, Samples, SphbFile, Sphere, GEODESIC_DIRECTIONS};
//! # // A one-sphere proxy standing on the ground: samples on its surface, a grey albedo.
//! # let s = Sphere { center: [0.0, 1.0, 0.0], radius: 1.0 };
//! # let pts: Vec<SamplePoint> = GEODESIC_DIRECTIONS.iter().enumerate().map(|(j, d)| SamplePoint {
//! #     position: [d[0], 1.0 + d[1], d[2]], normal: *d, direction: j as u8, rule: 1 }).collect();
//! # let mut coefficients = vec![[0.0f32; 3]; 16];
//! # coefficients[0] = [0.5 * 3.5449077; 3];
//! # let file = SphbFile { spheres: vec![s], samples: Some(Samples::from_per_sphere([pts])),
//! #     albedo_sh: Some(AlbedoSh { order: 4, coefficients, ..AlbedoSh::default() }), ..SphbFile::default() };
//! # let bytes = spherebake_runtime::Proxy::from_file(&file)?.to_bytes();
//! let proxy = spherebake_runtime::load(&bytes)?;
//! let ctx = LightContext::new(4, ExpMethod::default())?; // once
//!
//! // Per frame: the environment (here a uniform white sky over a ground plane), then pass 1 per proxy.
//! let mut sky = [0.0; 16];
//! uniform_light(4, &mut sky);
//! let mut env = [0.0; 16];
//! clip_below_horizon(&ctx, &sky, [0.0, 1.0, 0.0], &mut env)?;
//! let posed = PosedProxy::at_rest(&proxy); // or posed leaves, refitted nodes and `sphere_rotations`
//! let mut lights = SphereLights::new();
//! light_spheres(&ctx, &posed, &env, &[], &Pass1Settings::default(), &mut lights)?;
//!
//! // Pass 2: per receiver cluster (here one ground point), then per receiver.
//! let sources = [(posed, &lights)];
//! let p = [2.0, 0.0, 0.0];
//! let mut cluster = IndirectCluster::new();
//! cluster.build(&ctx, &sources, &ClusterSpec::new(p, 0.0, Some([0.0, 1.0, 0.0])))?;
//! let e = cluster.irradiance(&ctx, &sources, p, [0.0, 1.0, 0.0])?; // indirect irradiance, linear RGB
//! assert!(e[0] > 0.0 && (e[0] - e[2]).abs() < 1e-6); // grey light bounced onto the ground
//! # Ok::<(), Box<dyn core::error::Error>>(())
//! ```

// Index loops mirror the formulas (bands l, coefficients i, channels c).
#![allow(clippy::needless_range_loop)]

use crate::cut::CutEntry;
use crate::refit::{ChildRef, HierarchyPlan};
use crate::shadow::{
    accumulate_log_visibility, asin_f32, implicit_root, rsqrt_f32, self_shadow_sphere, Blocker, ClusterBlockers,
    ExpMethod, ShadowContext, ShadowError, IMPLICIT_ROOT,
};
use crate::{Proxy, SamplePoint, Sphere};
use alloc::vec::Vec;
use core::fmt;
use spherebake_sh::{
    accumulate_log_visibility_f32, cap_zh, clamped_cosine_convolution, coeff_count, cosine_weighted_radiance_rgb_f32,
    eval_sh_f64, voronoi_cell_basis, zh_rotate, GEODESIC_DIRECTIONS, GEODESIC_DIRECTION_COUNT, MAX_COEFFS, MAX_ORDER,
};

/// The SH order of the light passes unless told otherwise (Guerrero 2008 §7.4 works with n = 4 bands).
pub const DEFAULT_LIGHT_ORDER: usize = 4;

/// Largest reflection ratio applied (a guard against a node that is nearly dark over the whole cluster).
pub const MAX_REFLECTION_RATIO: f32 = 16.0;

/// Points of a receiver cluster at which its reflection ratios are taken ([`IndirectCluster::build`]): the centre
/// and, for a cluster of positive radius, four points on the disc through the centre perpendicular to the cluster
/// normal, at this share of the radius along two perpendicular tangents (for a square tile whose half-diagonal is
/// the radius and whose edges run along the tangents, as a ground tile's do with the normal +Y: the midpoints of
/// its edges).
pub const RATIO_PROBE_RADIUS: f32 = core::f32::consts::FRAC_1_SQRT_2;

/// The identity rotation, column-major 3×3.
pub const IDENTITY_ROTATION: [f32; 9] = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];

/// Why a light query could not run.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum LightError {
    /// A shadow-machinery call failed (order, slices, hierarchy).
    Shadow(ShadowError),
    /// The proxy has no sample section: nothing to light.
    NoSamples,
    /// The proxy has no albedo SH section.
    NoAlbedo,
    /// The light order exceeds the baked albedo order.
    AlbedoOrder {
        /// Requested light order.
        order: usize,
        /// Baked albedo order.
        albedo_order: usize,
    },
    /// A slice has the wrong length.
    SliceLength {
        /// Which argument.
        argument: &'static str,
        /// Required length.
        expected: usize,
        /// Given length.
        actual: usize,
    },
    /// The sphere lights were computed at another order, or for another proxy's sphere count.
    Mismatch {
        /// What does not match.
        what: &'static str,
    },
}

impl fmt::Display for LightError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LightError::Shadow(e) => write!(f, "{e}"),
            LightError::NoSamples => write!(f, "the proxy has no surface samples"),
            LightError::NoAlbedo => write!(f, "the proxy has no albedo SH"),
            LightError::AlbedoOrder { order, albedo_order } => {
                write!(f, "light order {order} exceeds the baked albedo order {albedo_order}")
            }
            LightError::SliceLength { argument, expected, actual } => {
                write!(f, "{argument} has length {actual}, expected {expected}")
            }
            LightError::Mismatch { what } => write!(f, "the sphere lights do not match: {what}"),
        }
    }
}

impl core::error::Error for LightError {}

impl From<ShadowError> for LightError {
    fn from(e: ShadowError) -> Self {
        LightError::Shadow(e)
    }
}

impl From<spherebake_sh::ShError> for LightError {
    fn from(e: spherebake_sh::ShError) -> Self {
        LightError::Shadow(ShadowError::Sh(e))
    }
}

impl From<crate::QueryError> for LightError {
    fn from(e: crate::QueryError) -> Self {
        LightError::Shadow(ShadowError::Query(e))
    }
}

/// Order, SH exponential, triple-product tensor and the clamped-cosine factors of the light passes: built once
/// (allocates).
#[derive(Clone, Debug)]
pub struct LightContext {
    shadow: ShadowContext,
    /// A_l / π: the clamped cosine over π, band factors.
    h_band: [f64; MAX_ORDER],
    /// κ_l of the Voronoi projection.
    cell_gain: [f64; MAX_ORDER],
    /// The Voronoi cells of the 92 directions (corner directions), for the surface tiles of the splat.
    cells: Vec<crate::tile::Cell>,
    /// Their solid angles (steradians), for the area weights of pass 1 ([`crate::tile::cell_solid_angle`]).
    cell_solid_angles: Vec<f64>,
}

/// The per-band gain κ_l = (1/(2l + 1)) Σ_m Σ_j y_lm(ω_j) Y_j,lm of the Voronoi-cell projection (eq. 10) applied
/// to the band-l basis functions sampled at the 92 directions: the factor by which eq. 10 attenuates band l of a
/// smooth emission (cell averaging is a low-pass). 1 for l = 0; l < `order`.
#[must_use]
pub fn voronoi_band_gains(order: usize) -> [f64; MAX_ORDER] {
    let mut k = [0.0f64; MAX_ORDER];
    let order = order.min(MAX_ORDER);
    let mut y = [0.0f64; MAX_COEFFS];
    for (j, d) in spherebake_sh::GEODESIC_DIRECTIONS.iter().enumerate() {
        let Some(row) = voronoi_cell_basis(j, order) else { continue };
        if eval_sh_f64(order, [f64::from(d[0]), f64::from(d[1]), f64::from(d[2])], &mut y).is_err() {
            continue;
        }
        for l in 0..order {
            for i in l * l..(l + 1) * (l + 1) {
                k[l] += y[i] * f64::from(row[i]);
            }
        }
    }
    for l in 0..order {
        k[l] /= (2 * l + 1) as f64;
    }
    k
}

impl LightContext {
    /// A context of SH `order` (1..=8) with exponential `exp`.
    ///
    /// # Errors
    ///
    /// Order outside 1..=8, or the tensor could not be allocated.
    pub fn new(order: usize, exp: ExpMethod) -> Result<LightContext, LightError> {
        let shadow = ShadowContext::new(order, exp)?;
        let mut a = [0.0; MAX_ORDER];
        clamped_cosine_convolution(order, &mut a)?;
        for v in &mut a[..order] {
            *v /= core::f64::consts::PI;
        }
        let cells = crate::tile::voronoi_cells();
        let cell_solid_angles = cells.iter().enumerate().map(|(j, c)| crate::tile::cell_solid_angle(c, j)).collect();
        Ok(LightContext { shadow, h_band: a, cell_gain: voronoi_band_gains(order), cells, cell_solid_angles })
    }

    /// The per-band gains κ_l of the Voronoi projection (see [`voronoi_band_gains`]).
    #[must_use]
    pub fn voronoi_band_gains(&self) -> &[f64] {
        &self.cell_gain[..self.order()]
    }

    /// The SH order.
    #[must_use]
    pub fn order(&self) -> usize {
        self.shadow.order()
    }

    /// The shadow context inside (the same order and exponential), for the direct light.
    #[must_use]
    pub fn shadow(&self) -> &ShadowContext {
        &self.shadow
    }

    /// H(n)_lm = (A_l/π) y_lm(n) into `out[0..order²]`.
    fn cosine_lobe(&self, n: [f64; 3], out: &mut [f64; MAX_COEFFS]) {
        let order = self.order();
        if eval_sh_f64(order, n, out).is_err() {
            return;
        }
        for l in 0..order {
            for i in l * l..(l + 1) * (l + 1) {
                out[i] *= self.h_band[l];
            }
        }
    }
}

/// The environment `env` (order² radiance coefficients) with everything below the horizon of the `up` direction
/// (scaled to unit length) removed: the SH product env ∗ χ, χ the hemisphere {ω · up > 0} (exact for an infinite ground plane
/// under the scene, which hides the lower half of every point's sphere of directions). Into `out[0..order²]`.
///
/// # Errors
///
/// `env` or `out` shorter than order²; `up` zero or not finite.
pub fn clip_below_horizon(ctx: &LightContext, env: &[f64], up: [f64; 3], out: &mut [f64]) -> Result<(), LightError> {
    let order = ctx.order();
    let nc = coeff_count(order);
    check_len("env", nc, env.len())?;
    check_len("out", nc, out.len())?;
    let mut g = [0.0; MAX_ORDER];
    cap_zh(core::f64::consts::FRAC_PI_2, order, &mut g)?;
    let mut hemi = [0.0; MAX_COEFFS];
    zh_rotate(&g[..order], crate::shadow::unit_normal("up", up)?, &mut hemi)?;
    ctx.shadow.triple_product().product(&env[..nc], &hemi[..nc], out)?;
    Ok(())
}

fn check_len(argument: &'static str, expected: usize, actual: usize) -> Result<(), LightError> {
    if actual < expected {
        Err(LightError::SliceLength { argument, expected, actual })
    } else {
        Ok(())
    }
}

/// A posed proxy as the light passes see it.
#[derive(Clone, Copy, Debug)]
pub struct PosedProxy<'a> {
    /// The loaded file (samples, albedo, rest spheres).
    pub proxy: &'a Proxy,
    /// The leaf spheres in their current pose (`proxy.spheres()` at rest), one per proxy sphere.
    pub leaves: &'a [Sphere],
    /// The hierarchy plan and its (refitted) node spheres, or `None`: all leaves under one implicit root.
    pub nodes: Option<(&'a HierarchyPlan, &'a [Sphere])>,
    /// Per-leaf rotation from rest to the pose (column-major 3×3, [`sphere_rotations`]); `None` = identity.
    pub rotations: Option<&'a [[f32; 9]]>,
}

impl<'a> PosedProxy<'a> {
    /// The proxy at rest: its stored spheres, no hierarchy plan, no rotations.
    #[must_use]
    pub fn at_rest(proxy: &'a Proxy) -> PosedProxy<'a> {
        PosedProxy { proxy, leaves: proxy.spheres(), nodes: None, rotations: None }
    }

    fn rotation(&self, leaf: usize) -> [f32; 9] {
        self.rotations.and_then(|r| r.get(leaf)).copied().unwrap_or(IDENTITY_ROTATION)
    }

    fn check(&self) -> Result<(), LightError> {
        if self.leaves.len() != self.proxy.sphere_count() {
            return Err(LightError::SliceLength {
                argument: "leaves",
                expected: self.proxy.sphere_count(),
                actual: self.leaves.len(),
            });
        }
        if let Some(r) = self.rotations {
            if r.len() != self.leaves.len() {
                return Err(LightError::SliceLength {
                    argument: "rotations",
                    expected: self.leaves.len(),
                    actual: r.len(),
                });
            }
        }
        crate::shadow::check_spheres("leaves", self.leaves)?;
        if let Some((_, nodes)) = self.nodes {
            crate::shadow::check_spheres("nodes", nodes)?;
        }
        Ok(())
    }
}

/// Settings of pass 1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pass1Settings {
    /// Cut threshold θmax (radians) of the hierarchy seen from each sphere (Ren eq. 36).
    pub theta_max_rad: f32,
}

impl Default for Pass1Settings {
    fn default() -> Self {
        Pass1Settings { theta_max_rad: crate::cut::DEFAULT_THETA_MAX_RAD }
    }
}

/// Counts of one [`light_spheres`] call.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Pass1Stats {
    /// Sample points lit.
    pub samples: usize,
    /// Blockers accumulated over all samples (after the self-shadowing rules).
    pub blocker_accumulations: usize,
}

/// The sphere lights of one proxy for one frame (pass 1's output): linear RGB SH of order n per leaf and per
/// hierarchy node (L^c, eq. 11), each in its sphere's rest frame, with the node rotations.
#[derive(Clone, Debug, Default)]
pub struct SphereLights {
    order: usize,
    leaf: Vec<[f32; 3]>,
    node: Vec<[f32; 3]>,
    node_rotation: Vec<[f32; 9]>,
    root: Vec<[f32; 3]>,
    root_rotation: [f32; 9],
    sample_radiance: Vec<f32>,
    /// Per leaf and geodesic direction: L_pj · c(ω_j) (0 where no sample).
    leaf_cells: Vec<[f32; 3]>,
    /// Per leaf: its fill, mean t_j / r of its samples at rest ([`leaf_fill`]).
    leaf_fill: Vec<f32>,
    // Scratch of pass 1.
    cluster: ClusterBlockers,
    others: ClusterBlockers,
    blockers: Vec<Blocker>,
    stack: Vec<u32>,
}

impl SphereLights {
    /// Empty lights.
    #[must_use]
    pub fn new() -> SphereLights {
        SphereLights { root_rotation: IDENTITY_ROTATION, ..SphereLights::default() }
    }

    /// The SH order of the last [`light_spheres`] (0 before the first).
    #[must_use]
    pub fn order(&self) -> usize {
        self.order
    }

    /// Number of leaf lights.
    #[must_use]
    pub fn leaf_count(&self) -> usize {
        if self.order == 0 {
            0
        } else {
            self.leaf.len() / coeff_count(self.order)
        }
    }

    /// L^c of leaf `i`: order² RGB coefficients in the sphere's rest frame (empty when out of range).
    #[must_use]
    pub fn leaf(&self, i: usize) -> &[[f32; 3]] {
        let nc = coeff_count(self.order);
        self.leaf.get(i * nc..(i + 1) * nc).unwrap_or(&[])
    }

    /// L^c of hierarchy node `n` (empty when out of range or without a hierarchy).
    #[must_use]
    pub fn node(&self, n: usize) -> &[[f32; 3]] {
        let nc = coeff_count(self.order);
        self.node.get(n * nc..(n + 1) * nc).unwrap_or(&[])
    }

    /// The diffuse exit radiance per unit albedo L_pj of every sample, in the order of `Proxy::samples`.
    #[must_use]
    pub fn sample_radiance(&self) -> &[f32] {
        &self.sample_radiance
    }

    fn light_of(&self, entry: CutEntry) -> (&[[f32; 3]], [f32; 9]) {
        match entry {
            CutEntry::Leaf(i) => (self.leaf(i as usize), IDENTITY_ROTATION),
            CutEntry::Node(IMPLICIT_ROOT) => (&self.root, self.root_rotation),
            CutEntry::Node(n) => {
                (self.node(n as usize), self.node_rotation.get(n as usize).copied().unwrap_or(IDENTITY_ROTATION))
            }
        }
    }
}

fn rotate(m: &[f32; 9], v: [f32; 3]) -> [f32; 3] {
    [
        m[0] * v[0] + m[3] * v[1] + m[6] * v[2],
        m[1] * v[0] + m[4] * v[1] + m[7] * v[2],
        m[2] * v[0] + m[5] * v[1] + m[8] * v[2],
    ]
}

fn rotate_transposed(m: &[f32; 9], v: [f32; 3]) -> [f32; 3] {
    [
        m[0] * v[0] + m[1] * v[1] + m[2] * v[2],
        m[3] * v[0] + m[4] * v[1] + m[5] * v[2],
        m[6] * v[0] + m[7] * v[1] + m[8] * v[2],
    ]
}

/// **Pass 1** (eq. 3–11): lights every sample of `posed` under the environment `env` (order² radiance
/// coefficients of one channel, monochrome, e.g. from [`clip_below_horizon`]; the lights are RGB through the albedo
/// SH, so a coloured sky takes one pass per channel), projects onto each leaf's SH with the Voronoi-cell basis sums,
/// multiplies by the albedo SH, and derives the hierarchy nodes' lights. `others` are further proxies whose spheres
/// block the environment (their own lights are not needed here). Results go to `out`.
///
/// Samples move rigidly with their sphere: p' = R_i (p − c_i,rest) + c_i,posed, n' = R_i n.
///
/// # Errors
///
/// The proxy has no samples or albedo; the light order exceeds the albedo order; `env` shorter than order²; slices
/// of `posed` or `others` that do not fit their proxies.
pub fn light_spheres(
    ctx: &LightContext,
    posed: &PosedProxy<'_>,
    env: &[f64],
    others: &[PosedProxy<'_>],
    settings: &Pass1Settings,
    out: &mut SphereLights,
) -> Result<Pass1Stats, LightError> {
    let order = ctx.order();
    let nc = coeff_count(order);
    check_len("env", nc, env.len())?;
    posed.check()?;
    for o in others {
        o.check()?;
    }
    let proxy = posed.proxy;
    let total = prepare_lights(ctx, posed, out)?;
    out.sample_radiance.clear();
    out.sample_radiance.resize(total, 0.0);
    let n_leaves = posed.leaves.len();

    let rest = proxy.spheres();
    let tp = ctx.shadow.triple_product();
    let mut stats = Pass1Stats::default();
    let mut sample_base = 0usize;
    for i in 0..n_leaves {
        let pts = proxy.samples_of(i);
        let first = sample_base;
        sample_base += pts.len();
        if pts.is_empty() {
            continue;
        }
        let s = posed.leaves[i];
        out.cluster.build(order, posed.leaves, posed.nodes, s.center, s.radius, settings.theta_max_rad)?;
        out.blockers.clear();
        out.blockers.extend_from_slice(out.cluster.blockers());
        for o in others {
            out.others.build(order, o.leaves, o.nodes, s.center, s.radius, settings.theta_max_rad)?;
            out.blockers.extend_from_slice(out.others.blockers());
        }
        let rot = posed.rotation(i);
        let c_rest = rest.get(i).map_or(s.center, |r| r.center);
        for (k, sp) in pts.iter().enumerate() {
            let rel = [sp.position[0] - c_rest[0], sp.position[1] - c_rest[1], sp.position[2] - c_rest[2]];
            let r = rotate(&rot, rel);
            let p = [r[0] + s.center[0], r[1] + s.center[1], r[2] + s.center[2]];
            let n = rotate(&rot, sp.normal);
            let mut log = [0.0f32; MAX_COEFFS];
            stats.blocker_accumulations += accumulate_log_visibility(&out.blockers, order, p, Some(n), &mut log[..nc])?;
            let mut g = [0.0f64; MAX_COEFFS];
            ctx.shadow.visibility(&log[..nc], &mut g[..nc])?;
            let mut h = [0.0f64; MAX_COEFFS];
            ctx.cosine_lobe([f64::from(n[0]), f64::from(n[1]), f64::from(n[2])], &mut h);
            // L_p = ∫ V L ρ = (V ∗ L) · H(n): one product per sample.
            let mut vl = [0.0f64; MAX_COEFFS];
            tp.product(&g[..nc], &env[..nc], &mut vl[..nc])?;
            let lp: f64 = (0..nc).map(|c| vl[c] * h[c]).sum::<f64>().max(0.0);
            if let Some(slot) = out.sample_radiance.get_mut(first + k) {
                *slot = lp as f32;
            }
            stats.samples += 1;
        }
    }
    project_sample_radiance(ctx, posed, out)?;
    Ok(stats)
}

/// Pass 1 with the samples' exit radiance given instead of computed: `radiance` holds L_pj per unit albedo for
/// every sample in the order of `Proxy::samples` (for example from an engine's own direct lighting, or a ray
/// tracer); projection, albedo product and node lights as in [`light_spheres`].
///
/// # Errors
///
/// As [`light_spheres`]; `radiance` of another length than the sample count.
pub fn light_spheres_from_radiance(
    ctx: &LightContext,
    posed: &PosedProxy<'_>,
    radiance: &[f32],
    out: &mut SphereLights,
) -> Result<(), LightError> {
    posed.check()?;
    let total = prepare_lights(ctx, posed, out)?;
    check_len("radiance", total, radiance.len())?;
    out.sample_radiance.clear();
    out.sample_radiance.extend(radiance.iter().map(|&v| v.max(0.0)));
    project_sample_radiance(ctx, posed, out)
}

/// Checks that the proxy has samples and albedo of at least the light order, sets `out`'s order and every leaf's
/// fill; returns the sample count.
fn prepare_lights(ctx: &LightContext, posed: &PosedProxy<'_>, out: &mut SphereLights) -> Result<usize, LightError> {
    let proxy = posed.proxy;
    let samples = proxy.samples().ok_or(LightError::NoSamples)?;
    let albedo = proxy.albedo_sh().ok_or(LightError::NoAlbedo)?;
    let order = ctx.order();
    let albedo_order = usize::from(albedo.order);
    if order > albedo_order {
        return Err(LightError::AlbedoOrder { order, albedo_order });
    }
    out.order = order;
    let rest = proxy.spheres();
    out.leaf_fill.clear();
    out.leaf_fill.extend(posed.leaves.iter().enumerate().map(|(i, s)| {
        let c_rest = rest.get(i).map_or(s.center, |r| r.center);
        let r_rest = f64::from(rest.get(i).map_or(s.radius, |r| r.radius)).max(1e-30);
        leaf_fill(proxy.samples_of(i), c_rest, r_rest) as f32
    }));
    Ok(samples.total())
}

/// Projects `out.sample_radiance` onto each leaf's SH (eq. 9–10, with the area weights of loose leaves), multiplies
/// by the albedo SH (eq. 11), stores the Voronoi functions and derives the node lights.
fn project_sample_radiance(
    ctx: &LightContext,
    posed: &PosedProxy<'_>,
    out: &mut SphereLights,
) -> Result<(), LightError> {
    let order = out.order;
    let nc = coeff_count(order);
    let proxy = posed.proxy;
    let n_leaves = posed.leaves.len();
    out.leaf.clear();
    out.leaf.resize(n_leaves * nc, [0.0; 3]);
    out.leaf_cells.clear();
    out.leaf_cells.resize(n_leaves * GEODESIC_DIRECTION_COUNT, [0.0; 3]);
    let rest = proxy.spheres();
    let tp = ctx.shadow.triple_product();
    let mut sample_base = 0usize;
    for i in 0..n_leaves {
        let pts = proxy.samples_of(i);
        let first = sample_base;
        sample_base += pts.len();
        if pts.is_empty() {
            continue;
        }
        let s = posed.leaves[i];
        let c_rest = rest.get(i).map_or(s.center, |r| r.center);
        let r_rest = f64::from(rest.get(i).map_or(s.radius, |r| r.radius)).max(1e-30);
        let fill = f64::from(out.leaf_fill.get(i).copied().unwrap_or(1.0));
        let loose = ((AREA_FILL_TIGHT - fill) / (AREA_FILL_TIGHT - AREA_FILL_LOOSE)).clamp(0.0, 1.0);
        let mut l_i = [0.0f64; MAX_COEFFS];
        let areas = proxy.sample_areas_of(i);
        let near_weight = splat_weight(fill, pts.len());
        for (k, sp) in pts.iter().enumerate() {
            let rel = [sp.position[0] - c_rest[0], sp.position[1] - c_rest[1], sp.position[2] - c_rest[2]];
            // With the file's sample areas (format 1.2): a leaf emits the power of its surface, area / (r² Ω), blended
            // in by the weight the splat uses (module docs, "Tiles of the right size"; 0 for a tight, fully covered
            // leaf, whose sphere is its surface).
            let stored = areas.and_then(|a| a.get(k)).zip(ctx.cell_solid_angles.get(usize::from(sp.direction)));
            let area_w = if let Some((&a, &omega)) = stored {
                1.0 + near_weight * (f64::from(a) / (r_rest * r_rest * omega.max(1e-12)) - 1.0)
            } else if loose > 0.0 {
                let t2 = f64::from(rel[0] * rel[0] + rel[1] * rel[1] + rel[2] * rel[2]);
                let t = spherebake_sh::sqrt_f64(t2).max(1e-30);
                let nd = (f64::from(rel[0] * sp.normal[0] + rel[1] * sp.normal[1] + rel[2] * sp.normal[2]) / t).abs();
                1.0 + loose * (t2 / (r_rest * r_rest) / nd.max(SPLAT_MIN_COS) - 1.0)
            } else {
                1.0
            };
            let lp = f64::from(out.sample_radiance.get(first + k).copied().unwrap_or(0.0));
            if let Some(y) = voronoi_cell_basis(usize::from(sp.direction), order) {
                for c in 0..nc {
                    l_i[c] += area_w * lp * f64::from(y[c]);
                }
            }
        }
        // Undo the cell averaging's band attenuation (module docs, "Voronoi gain").
        for l in 0..order {
            for c in l * l..(l + 1) * (l + 1) {
                l_i[c] /= ctx.cell_gain[l];
            }
        }
        // L^c = L ∗ c per channel (eq. 11).
        let a = proxy.albedo_coefficients(i).unwrap_or(&[]);
        if a.len() < nc {
            continue;
        }
        for ch in 0..3 {
            let mut c = [0.0f64; MAX_COEFFS];
            for k in 0..nc {
                c[k] = f64::from(a[k][ch]);
            }
            let mut prod = [0.0f64; MAX_COEFFS];
            tp.product(&l_i[..nc], &c[..nc], &mut prod[..nc])?;
            for k in 0..nc {
                out.leaf[i * nc + k][ch] = prod[k] as f32;
            }
        }
        // A light beyond f32 (a leaf of almost no radius whose samples stand for real surface: area / r²) is
        // dark: no path could weight it by a share that small ([`node_share`]; pass 2's Ṽ₀ cutoff).
        let light = &mut out.leaf[i * nc..(i + 1) * nc];
        if light.iter().flatten().any(|v| !v.is_finite()) {
            light.fill([0.0; 3]);
        }
        // The Voronoi function itself, L_pj · c(ω_j), for lights seen from very close (pass 2).
        let mut y = [0.0f64; MAX_COEFFS];
        for (k, sp) in pts.iter().enumerate() {
            let d = usize::from(sp.direction);
            let Some(dir) = GEODESIC_DIRECTIONS.get(d) else { continue };
            eval_sh_f64(order, [f64::from(dir[0]), f64::from(dir[1]), f64::from(dir[2])], &mut y)?;
            let lp = f64::from(out.sample_radiance.get(first + k).copied().unwrap_or(0.0));
            for ch in 0..3 {
                let c: f64 = (0..nc).map(|q| f64::from(a[q][ch]) * y[q]).sum::<f64>().max(0.0);
                out.leaf_cells[i * GEODESIC_DIRECTION_COUNT + d][ch] = (lp * c) as f32;
            }
        }
    }
    derive_node_lights(posed, out)
}

/// Mean t_j / r of a leaf's samples (t_j: distance from the rest centre), 1 without samples.
fn leaf_fill(pts: &[SamplePoint], c: [f32; 3], r: f64) -> f64 {
    if pts.is_empty() {
        return 1.0;
    }
    let sum: f64 = pts
        .iter()
        .map(|sp| {
            let rel = [sp.position[0] - c[0], sp.position[1] - c[1], sp.position[2] - c[2]];
            spherebake_sh::sqrt_f64(f64::from(rel[0] * rel[0] + rel[1] * rel[1] + rel[2] * rel[2])) / r
        })
        .sum();
    sum / pts.len() as f64
}

/// Fill at and above which pass 1 weights no sample by the surface area it stands for (module docs, "Loose lights").
const AREA_FILL_TIGHT: f64 = 0.85;
/// Fill at and below which every sample is weighted by its area ratio (t/r)² / |n·ω|.
const AREA_FILL_LOOSE: f64 = 0.70;

/// Irradiance (linear RGB) at `p` (unit normal `n`) from leaf `leaf`'s own samples as small Lambertian emitters
/// (module docs, "Loose lights"): sample j, radiance L_pj c(ω_j), as its surface tile
/// ([`crate::tile::SampleTile::irradiance`], built in the leaf's rest frame, into which the receiver is turned). No
/// visibility inside the leaf's own segment; the caller multiplies by the light's visible share. Allocation-free.
fn splat_irradiance(
    cells: &[crate::tile::Cell],
    posed: &PosedProxy<'_>,
    lights: &SphereLights,
    leaf: usize,
    p: [f32; 3],
    n: [f32; 3],
) -> [f64; 3] {
    let mut out = [0.0f64; 3];
    for_each_tile(cells, posed, leaf, p, n, |direction, tile| {
        let Some(v) = lights.leaf_cells.get(leaf * GEODESIC_DIRECTION_COUNT + direction) else { return };
        let f = tile.tile.irradiance(tile.p, tile.n);
        if f > 0.0 {
            for c in 0..3 {
                out[c] += f * f64::from(v[c]);
            }
        }
    });
    out
}

/// One sample's tile and the receiver (`p`, unit normal `n`), in its leaf's rest frame relative to the centre
/// ([`for_each_tile`]).
struct LeafTile<'c> {
    tile: crate::tile::SampleTile<'c>,
    p: [f64; 3],
    n: [f64; 3],
}

/// Calls `f(direction, tile)` for each sample of leaf `leaf`, with the receiver (`p`, unit normal `n`, world space)
/// turned into the leaf's rest frame relative to its centre, where tiles are built (the rotation is rigid).
fn for_each_tile<'c>(
    cells: &'c [crate::tile::Cell],
    posed: &PosedProxy<'_>,
    leaf: usize,
    p: [f32; 3],
    n: [f32; 3],
    mut f: impl FnMut(usize, &LeafTile<'c>),
) {
    let Some(s) = posed.leaves.get(leaf) else { return };
    let rot = posed.rotation(leaf);
    let (c_rest, r_rest) = posed.proxy.spheres().get(leaf).map_or((s.center, s.radius), |r| (r.center, r.radius));
    let pr = rotate_transposed(&rot, [p[0] - s.center[0], p[1] - s.center[1], p[2] - s.center[2]]).map(f64::from);
    let nr = rotate_transposed(&rot, n).map(f64::from);
    let areas = posed.proxy.sample_areas_of(leaf);
    for (q, sp) in posed.proxy.samples_of(leaf).iter().enumerate() {
        let direction = usize::from(sp.direction);
        let Some(cell) = cells.get(direction) else { continue };
        let tile = LeafTile {
            tile: crate::tile::SampleTile {
                cell,
                radius: f64::from(r_rest),
                x: [sp.position[0] - c_rest[0], sp.position[1] - c_rest[1], sp.position[2] - c_rest[2]].map(f64::from),
                normal: sp.normal.map(f64::from),
                area: areas.and_then(|a| a.get(q)).map(|&a| f64::from(a)),
            },
            p: pr,
            n: nr,
        };
        f(direction, &tile);
    }
}

/// How much a leaf's own surface replaces its sphere, 0..=1: max(ramp(fill: 0.98 → 0.90), ramp(directions with a
/// sample: 95 % → 75 %)) ([`SPLAT_FILL_TIGHT`] …). 0 for a tight, fully covered leaf (the sphere is its surface, and
/// the SH light is exact for it); the weight of the splat up close and of the sample areas in pass 1.
fn splat_weight(fill: f64, samples: usize) -> f64 {
    let fw_fill = ((SPLAT_FILL_TIGHT - fill) / (SPLAT_FILL_TIGHT - SPLAT_FILL_LOOSE)).clamp(0.0, 1.0);
    let cover = samples as f64 / GEODESIC_DIRECTION_COUNT as f64;
    let fw_cover = ((SPLAT_COVER_FULL - cover) / (SPLAT_COVER_FULL - SPLAT_COVER_PARTIAL)).clamp(0.0, 1.0);
    fw_fill.max(fw_cover)
}

/// Share of the receiver's cosine-weighted hemisphere (0..=1) covered by leaf `leaf`'s surface tiles that face it
/// (module docs, "Contact"): Σ polygon irradiance / π of the tiles, scaled to their stored areas, with the receiver
/// where it is (no near-plane rule: a receiver against a tile is covered by it). Allocation-free.
fn tile_coverage(cells: &[crate::tile::Cell], posed: &PosedProxy<'_>, leaf: usize, p: [f32; 3], n: [f32; 3]) -> f64 {
    let mut cover = 0.0f64;
    for_each_tile(cells, posed, leaf, p, n, |_, t| {
        cover += t.tile.cover(t.p, t.n);
    });
    cover.clamp(0.0, 1.0)
}

/// Node lights from their leaves: L^c_N = Σ_j (r_j / r_N)² L^c_j, rotation polar(Σ_j r_j² R_j) (module docs).
fn derive_node_lights(posed: &PosedProxy<'_>, out: &mut SphereLights) -> Result<(), LightError> {
    let nc = coeff_count(out.order);
    out.node.clear();
    out.node_rotation.clear();
    out.root.clear();
    out.root.resize(nc, [0.0; 3]);
    out.root_rotation = IDENTITY_ROTATION;
    match posed.nodes {
        Some((plan, nodes)) => {
            if nodes.len() != plan.node_count() {
                return Err(LightError::SliceLength {
                    argument: "nodes",
                    expected: plan.node_count(),
                    actual: nodes.len(),
                });
            }
            out.node.resize(plan.node_count() * nc, [0.0; 3]);
            out.node_rotation.resize(plan.node_count(), IDENTITY_ROTATION);
            for n in 0..plan.node_count() {
                let rn = f64::from(nodes[n].radius);
                let mut acc = [[0.0f64; 3]; MAX_COEFFS];
                let mut rot = [0.0f64; 9];
                out.stack.clear();
                out.stack.push(n as u32);
                while let Some(k) = out.stack.pop() {
                    for c in plan.refs_of(k) {
                        match c {
                            ChildRef::Node(c) => out.stack.push(c),
                            ChildRef::Leaf(l) => {
                                let l = l as usize;
                                let Some(s) = posed.leaves.get(l) else { continue };
                                let w = node_share(s.radius, rn);
                                if w == 0.0 {
                                    continue;
                                }
                                let src = out.leaf.get(l * nc..(l + 1) * nc).unwrap_or(&[]);
                                for (a, v) in acc.iter_mut().zip(src) {
                                    for ch in 0..3 {
                                        a[ch] += w * f64::from(v[ch]);
                                    }
                                }
                                let r = posed.rotation(l);
                                for q in 0..9 {
                                    rot[q] += w * f64::from(r[q]);
                                }
                            }
                        }
                    }
                }
                for k in 0..nc {
                    out.node[n * nc + k] = acc[k].map(|v| v as f32);
                }
                out.node_rotation[n] = polar_rotation(&rot).map_or(IDENTITY_ROTATION, |m| m.map(|v| v as f32));
            }
        }
        None => {
            let Some(root) = implicit_root(posed.leaves) else { return Ok(()) };
            let rn = f64::from(root.radius);
            let mut rot = [0.0f64; 9];
            for (l, s) in posed.leaves.iter().enumerate() {
                let w = node_share(s.radius, rn);
                if w == 0.0 {
                    continue;
                }
                let src = out.leaf.get(l * nc..(l + 1) * nc).unwrap_or(&[]);
                for (a, v) in out.root.iter_mut().zip(src) {
                    for ch in 0..3 {
                        a[ch] += (w * f64::from(v[ch])) as f32;
                    }
                }
                let r = posed.rotation(l);
                for q in 0..9 {
                    rot[q] += w * f64::from(r[q]);
                }
            }
            out.root_rotation = polar_rotation(&rot).map_or(IDENTITY_ROTATION, |m| m.map(|v| v as f32));
        }
    }
    Ok(())
}

fn sq(x: f64) -> f64 {
    x * x
}

/// Below this share (r_j / r_N)² a leaf stands for nothing in its node ([`node_share`]).
const NEGLIGIBLE_NODE_SHARE: f64 = 1e-12;

/// A leaf's weight (r_j / r_N)² in its node's light, or 0 when it is at most [`NEGLIGIBLE_NODE_SHARE`] (a leaf
/// under a millionth of the node's radius), when the node has no positive radius, or when either is not finite.
/// Wherever a cut takes the node, such a leaf subtends less than the leaves-only path's cutoff (Ṽ₀ ≤ 10⁻¹², which
/// skips it there too), so both paths drop it alike. Without the cutoff a node holding only empty spheres (radius
/// `f32::MIN_POSITIVE`) that own samples got a light of 10⁻⁷⁵ × theirs (0 in f32, or NaN where a leaf's light,
/// area / r² for loose samples, overflowed f32) and a rotation from Σ w_j R_j ≈ 10⁻⁷⁵ I, which the polar
/// iteration did not bring back to a rotation in its steps; pass 2 then read NaN from it and the receiver's sum
/// was clamped to 0: the capsule at 64 spheres (53 left empty) lit the ground with 0 through the hierarchy.
fn node_share(leaf_radius: f32, node_radius: f64) -> f64 {
    let w = sq(f64::from(leaf_radius) / node_radius);
    if node_radius > 0.0 && w.is_finite() && w > NEGLIGIBLE_NODE_SHARE {
        w
    } else {
        0.0
    }
}

/// The rotation of the polar decomposition M = R S (column-major 3×3) by Higham's iteration
/// X ← (X + X⁻ᵀ)/2 (quadratic convergence; at most 30 steps); `None` when det M ≤ 0 or M is not finite. R of s M
/// is R of M for s > 0, so a matrix of Frobenius norm outside [1/16, 16] is first scaled by a power of two (exact)
/// to a norm in [1, 2): from s I the iteration needs about |log₂ s| steps before it converges.
#[must_use]
pub fn polar_rotation(m: &[f64; 9]) -> Option<[f64; 9]> {
    let mut x = *m;
    let f = frob2(&x);
    if f.is_finite() && f > 0.0 && !(0.0625..=16.0).contains(&f) {
        // 2^−e with 2^e ≤ f < 2^(e+1) (f normal: its exponent field; subnormal norms stay as they are).
        let e = ((f.to_bits() >> 52) & 0x7ff) as i64 - 1023;
        if (-1022..=1022).contains(&e) {
            let scale = f64::from_bits(((1023 - e) as u64) << 52);
            x = x.map(|v| v * scale);
        }
    }
    let det0 = det3(&x);
    if !det0.is_finite()
        || det0
            <= 1e-30 * {
                let f = frob2(&x);
                f * f * f
            }
    {
        return None;
    }
    for _ in 0..30 {
        let d = det3(&x);
        if !(d.is_finite() && d > 0.0) {
            return None;
        }
        // X⁻ᵀ = cof(X) / det (cofactor matrix), in column-major order.
        let c = cofactor(&x);
        let mut next = [0.0; 9];
        let mut change = 0.0;
        for k in 0..9 {
            next[k] = 0.5 * (x[k] + c[k] / d);
            change += (next[k] - x[k]).abs();
        }
        x = next;
        if change < 1e-14 {
            break;
        }
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

fn frob2(m: &[f64; 9]) -> f64 {
    crate::refit::sqrt(m.iter().map(|v| v * v).sum::<f64>())
}

/// det of a column-major 3×3.
fn det3(m: &[f64; 9]) -> f64 {
    let (a, b, c) = ([m[0], m[1], m[2]], [m[3], m[4], m[5]], [m[6], m[7], m[8]]);
    a[0] * (b[1] * c[2] - b[2] * c[1]) - b[0] * (a[1] * c[2] - a[2] * c[1]) + c[0] * (a[1] * b[2] - a[2] * b[1])
}

/// Cofactor matrix of a column-major 3×3 (cof(M) = det(M) · M⁻ᵀ), column-major.
fn cofactor(m: &[f64; 9]) -> [f64; 9] {
    // Columns a, b, c: the cofactor columns are b×c, c×a, a×b.
    let (a, b, c) = ([m[0], m[1], m[2]], [m[3], m[4], m[5]], [m[6], m[7], m[8]]);
    let cross =
        |u: [f64; 3], v: [f64; 3]| [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]];
    let (x, y, z) = (cross(b, c), cross(c, a), cross(a, b));
    [x[0], x[1], x[2], y[0], y[1], y[2], z[0], z[1], z[2]]
}

/// Soft-deformation rotations (§7.1): for every sphere, R = polar(Σ_j b_j M_j) · polar(Σ_j b_j M⁰_j)ᵀ over its skin
/// slots, M_j = `joint_matrices[bone]` (the pose) and M⁰_j = `rest_joint_matrices[bone]` (the rest pose the file's
/// model space shows), glTF convention, column-major 4×4 (upper 3×3 used). Identity for a proxy without skin and
/// where a weighted matrix is singular. `out[s]` is column-major 3×3. The rest matrices are world(joint) × inverse
/// bind of the glTF scene with no animation applied (each node's own TRS), not the identity (that is the bind
/// pose); the file does not store them, so compute them once per model as the joint matrices are computed.
///
/// # Errors
///
/// Fewer matrices than bones; `out.len() != proxy.sphere_count()`.
pub fn sphere_rotations(
    proxy: &Proxy,
    joint_matrices: &[[f32; 16]],
    rest_joint_matrices: &[[f32; 16]],
    out: &mut [[f32; 9]],
) -> Result<(), LightError> {
    if out.len() != proxy.sphere_count() {
        return Err(LightError::SliceLength { argument: "out", expected: proxy.sphere_count(), actual: out.len() });
    }
    out.fill(IDENTITY_ROTATION);
    if proxy.skin().is_none() {
        return Ok(());
    }
    let bones = proxy.bones().len();
    check_len("joint_matrices", bones, joint_matrices.len())?;
    check_len("rest_joint_matrices", bones, rest_joint_matrices.len())?;
    for (s, o) in out.iter_mut().enumerate() {
        let mut m = [0.0f64; 9];
        let mut m0 = [0.0f64; 9];
        for e in proxy.skin_slots(s) {
            let (Some(j), Some(j0)) = (joint_matrices.get(e.bone as usize), rest_joint_matrices.get(e.bone as usize))
            else {
                continue;
            };
            let b = f64::from(e.b);
            for col in 0..3 {
                for row in 0..3 {
                    m[3 * col + row] += b * f64::from(j[4 * col + row]);
                    m0[3 * col + row] += b * f64::from(j0[4 * col + row]);
                }
            }
        }
        let (Some(r), Some(r0)) = (polar_rotation(&m), polar_rotation(&m0)) else { continue };
        // R r0ᵀ, column-major: (R r0ᵀ)[row, col] = Σ_k R[row, k] r0[col, k].
        let mut q = [0.0f32; 9];
        for col in 0..3 {
            for row in 0..3 {
                let v: f64 = (0..3).map(|k| r[3 * k + row] * r0[3 * k + col]).sum();
                q[3 * col + row] = v as f32;
            }
        }
        *o = q;
    }
    Ok(())
}

/// One sphere light of a receiver cluster's cut.
#[derive(Clone, Copy, Debug)]
struct LightEntry {
    blocker: Blocker,
    /// Which source (proxy) it belongs to.
    source: u32,
    /// Reflection ratio per channel (1 for leaves).
    ratio: [f32; 3],
    /// Rotation of the light's coefficients (rest → pose).
    rotation: [f32; 9],
}

/// Per-receiver working data of one entry.
#[derive(Clone, Copy, Debug)]
struct Active {
    entry: u32,
    power: f32,
    theta: f32,
    sin_theta: f32,
    /// The receiver is inside the original sphere (the self-shadowing rules shrank it to touch the tangent plane).
    adjusted: bool,
    /// Unit direction from the (adjusted) centre to the receiver.
    axis: [f32; 3],
    log: [f32; MAX_COEFFS],
}

/// The sphere lights of one receiver cluster: the hierarchy cut of every source, its ratio vectors (eq. 37) and
/// reflection ratios (eq. 25); reusable buffers. Build once per cluster and frame, then query per receiver: with
/// [`IndirectCluster::irradiance`] on one thread, or from many threads at once with
/// [`IndirectCluster::irradiance_with`] and one [`IndirectScratch`] per thread.
#[derive(Clone, Debug, Default)]
pub struct IndirectCluster {
    order: usize,
    entries: Vec<LightEntry>,
    scratch_entries: Vec<LightEntry>,
    scratch: IndirectScratch,
    cb: ClusterBlockers,
    lights: Vec<(usize, usize)>,
    stack: Vec<u32>,
    /// Per source of the last build: its spheres, samples, and its lights' spheres and order,
    /// which the queries check.
    built_for: Vec<[usize; 4]>,
}

/// Per-query working data of [`IndirectCluster::irradiance_with`] (one per thread that queries; it holds nothing
/// between queries, so one scratch serves every cluster).
#[derive(Clone, Debug, Default)]
pub struct IndirectScratch {
    active: Vec<Active>,
}

impl IndirectScratch {
    /// Empty buffers; they grow to the largest cluster queried.
    #[must_use]
    pub fn new() -> IndirectScratch {
        IndirectScratch::default()
    }
}

/// A receiver cluster of pass 2: receivers sharing one hierarchy cut (a tile of a ground grid, a patch of a
/// character).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClusterSpec {
    /// Centre x_C of a ball around the cluster's receivers (same space as the spheres).
    pub center: [f32; 3],
    /// Radius of that ball.
    pub radius: f32,
    /// The receivers' mean unit normal, for the reflection ratios (taken at the centre and at four points on the
    /// disc of this normal through it; `None`: ratios are 1).
    pub normal: Option<[f32; 3]>,
    /// Cut threshold θmax in radians (Ren eq. 36).
    pub theta_max_rad: f32,
    /// Compute the reflection ratios of eq. 25 (the default; off only to measure their effect).
    pub reflection_ratio: bool,
    /// Scale each source's blocker logs by [`ClusterBlockers::correct_overlap`] at the cluster centre, with 256
    /// directions (needs `normal`; not in the papers). Off by default: its directions, fixed in the spheres' space,
    /// and its scale's steps of 0.05 make results depend on the coordinate frame and jump between neighbouring
    /// clusters and between frames of a moving proxy.
    pub overlap_correction: bool,
}

impl ClusterSpec {
    /// A cluster ball with normal `normal`, the default θmax and reflection ratios on.
    #[must_use]
    pub fn new(center: [f32; 3], radius: f32, normal: Option<[f32; 3]>) -> ClusterSpec {
        ClusterSpec {
            center,
            radius,
            normal,
            theta_max_rad: crate::cut::DEFAULT_THETA_MAX_RAD,
            reflection_ratio: true,
            overlap_correction: false,
        }
    }
}

/// The points at which [`IndirectCluster::build`] takes a cluster's reflection ratios, and how many there are: its
/// centre, then (a finite radius > 0 and a finite normal of positive length) the centre ± [`RATIO_PROBE_RADIUS`] ·
/// radius along two unit tangents u, v with u × v = n̂ (the orthonormal basis of Duff et al. 2017, so the same
/// cluster always gets the same points; for n̂ = +Y, u = +X and v = −Z).
fn ratio_probes(center: [f32; 3], radius: f32, n: [f32; 3]) -> ([[f32; 3]; 5], usize) {
    let mut out = [center; 5];
    // Scaled by its largest component first, so a huge finite normal does not overflow.
    let m = n[0].abs().max(n[1].abs()).max(n[2].abs());
    let n = if m > 0.0 && m.is_finite() { n.map(|x| x / m) } else { n };
    let len2 = n[0] * n[0] + n[1] * n[1] + n[2] * n[2];
    if !(radius > 0.0 && radius.is_finite() && len2 > 0.0 && len2.is_finite()) {
        return (out, 1);
    }
    let inv = rsqrt_f32(len2);
    let n = n.map(|x| x * inv);
    let sign = if n[2] >= 0.0 { 1.0f32 } else { -1.0 };
    let a = -1.0 / (sign + n[2]);
    let b = n[0] * n[1] * a;
    let u = [1.0 + sign * n[0] * n[0] * a, sign * b, -sign * n[0]];
    let v = [b, sign + n[1] * n[1] * a, -n[1]];
    let d = RATIO_PROBE_RADIUS * radius;
    for (k, (t, s)) in [(u, d), (v, d), (u, -d), (v, -d)].into_iter().enumerate() {
        out[k + 1] = core::array::from_fn(|c| center[c] + s * t[c]);
    }
    (out, 5)
}

/// The light sources of pass 2: each posed proxy with the lights pass 1 computed for it this frame.
pub type LightSource<'a, 'b> = (PosedProxy<'a>, &'b SphereLights);

/// What [`IndirectCluster::irradiance`] checks of each source against the build's: its spheres and samples, and
/// its lights' spheres and order.
fn source_key((posed, lights): &LightSource<'_, '_>) -> [usize; 4] {
    [posed.leaves.len(), posed.proxy.sample_points().len(), lights.leaf_count(), lights.order]
}

impl IndirectCluster {
    /// Empty buffers.
    #[must_use]
    pub fn new() -> IndirectCluster {
        IndirectCluster::default()
    }

    /// Number of sphere lights in the cluster's cut.
    #[must_use]
    pub fn light_count(&self) -> usize {
        self.entries.len()
    }

    /// Assembles the lights of the receiver cluster `cluster`: per source, the hierarchy cut at its θmax (eq. 36)
    /// with ratio vectors (eq. 37), and — when `cluster.reflection_ratio` is set and `cluster.normal` is given —
    /// the reflection ratio t of every accepted node over the cluster (eq. 25 summed over its centre and four points
    /// on its disc, [`RATIO_PROBE_RADIUS`]).
    ///
    /// # Errors
    ///
    /// The lights of a source were computed at another order or for another sphere count; slices that do not fit;
    /// the cluster ball or θmax out of range (as [`ClusterBlockers::build`]). After an error the cluster is empty
    /// and not built (its queries return [`ShadowError::NotBuilt`]), never half-built.
    pub fn build(
        &mut self,
        ctx: &LightContext,
        sources: &[LightSource<'_, '_>],
        cluster: &ClusterSpec,
    ) -> Result<(), LightError> {
        let built = self.build_entries(ctx, sources, cluster);
        self.built_for.clear();
        match built {
            Ok(()) => self.built_for.extend(sources.iter().map(source_key)),
            Err(_) => {
                self.order = 0;
                self.entries.clear();
            }
        }
        built
    }

    fn build_entries(
        &mut self,
        ctx: &LightContext,
        sources: &[LightSource<'_, '_>],
        cluster: &ClusterSpec,
    ) -> Result<(), LightError> {
        let ClusterSpec { center, radius, normal, theta_max_rad, reflection_ratio, overlap_correction } = *cluster;
        let normal = normal.map(|n| crate::shadow::unit_normal_f32("cluster normal", n)).transpose()?;
        let order = ctx.order();
        self.order = order;
        self.entries.clear();
        for (si, (posed, lights)) in sources.iter().enumerate() {
            posed.check()?;
            if lights.order != order {
                return Err(LightError::Mismatch { what: "order" });
            }
            if lights.leaf_count() != posed.leaves.len() {
                return Err(LightError::Mismatch { what: "sphere count" });
            }
            self.cb.build(order, posed.leaves, posed.nodes, center, radius, theta_max_rad)?;
            if let (true, Some(n)) = (overlap_correction, normal) {
                self.cb.correct_overlap(&ctx.shadow, center, n, 256)?;
            }
            for b in self.cb.blockers() {
                let rotation = match b.source {
                    CutEntry::Leaf(l) => posed.rotation(l as usize),
                    other => lights.light_of(other).1,
                };
                self.entries.push(LightEntry { blocker: *b, source: si as u32, ratio: [1.0; 3], rotation });
            }
        }
        let Some(n) = normal.filter(|_| reflection_ratio) else { return Ok(()) };
        // Reflection ratios of the accepted nodes.
        let (probes, probe_count) = ratio_probes(center, radius, n);
        for e in 0..self.entries.len() {
            let entry = self.entries[e];
            let CutEntry::Node(node) = entry.blocker.source else { continue };
            let (posed, _) = &sources[entry.source as usize];
            // Eq. 25 summed over the cluster's probe points (see `ratio_probes`).
            let mut den = [0.0f64; 3];
            for &q in &probes[..probe_count] {
                let d = contribution(order, &self.entries, &mut self.scratch.active, ctx, sources, q, n, |k| k == e)?;
                (0..3).for_each(|c| den[c] += d[c]);
            }
            // The same cut with the node replaced by its leaves.
            self.scratch_entries.clear();
            self.scratch_entries.extend(self.entries.iter().enumerate().filter(|&(k, _)| k != e).map(|(_, x)| *x));
            let first_leaf = self.scratch_entries.len();
            self.lights.clear();
            collect_leaves(posed, node, &mut self.stack, &mut self.lights);
            for &(leaf, _) in &self.lights {
                let s = posed.leaves[leaf];
                let mut w = [0.0f32; MAX_ORDER];
                w[..order].fill(1.0);
                self.scratch_entries.push(LightEntry {
                    blocker: Blocker {
                        center: s.center,
                        radius: s.radius,
                        band_weights: w,
                        source: CutEntry::Leaf(leaf as u32),
                    },
                    source: entry.source,
                    ratio: [1.0; 3],
                    rotation: posed.rotation(leaf),
                });
            }
            let mut num = [0.0f64; 3];
            for &q in &probes[..probe_count] {
                let d =
                    contribution(order, &self.scratch_entries, &mut self.scratch.active, ctx, sources, q, n, |k| {
                        k >= first_leaf
                    })?;
                (0..3).for_each(|c| num[c] += d[c]);
            }
            let mut t = [1.0f32; 3];
            for c in 0..3 {
                if den[c] > 1e-12 * (1.0 + num[c].abs()) && num[c].is_finite() {
                    t[c] = ((num[c] / den[c]) as f32).clamp(0.0, MAX_REFLECTION_RATIO);
                }
            }
            self.entries[e].ratio = t;
        }
        Ok(())
    }

    /// The indirect irradiance E^I (linear RGB, ∫ L_in cos dω) at receiver `p` with unit normal `normal` from the
    /// cluster's lights (eq. 14 with the reflection ratios of eq. 26). Allocation-free once the buffers have grown
    /// to the cluster's size (the first call after a larger build may allocate). Each channel is at least 0:
    /// irradiance cannot be negative, but SH lights can dip below 0 (ringing of a band-limited albedo or radiance,
    /// or an albedo SH that is negative where a hostile file put it), and an engine adds this to its lighting.
    ///
    /// # Errors
    ///
    /// The cluster was not built, or its last build failed; it was built at another order than `ctx`'s;
    /// `sources` is not the slice the cluster was built from (checked by their number, each one's sphere and sample
    /// counts, and its lights' sphere count and order); `p` or `normal` not finite.
    pub fn irradiance(
        &mut self,
        ctx: &LightContext,
        sources: &[LightSource<'_, '_>],
        p: [f32; 3],
        normal: [f32; 3],
    ) -> Result<[f64; 3], LightError> {
        let mut scratch = core::mem::take(&mut self.scratch);
        let e = self.irradiance_with(&mut scratch, ctx, sources, p, normal);
        self.scratch = scratch;
        e
    }

    /// [`IndirectCluster::irradiance`] on a shared cluster: the same value, bit for bit, with the per-query working
    /// data in `scratch` instead of the cluster's own buffers. A built cluster is only read, so any number of threads
    /// may query it at once, each with its own scratch (`IndirectCluster` is `Sync`); a build needs it exclusively.
    /// One scratch serves any cluster; allocation-free once it has grown to the largest cluster's light count.
    ///
    /// # Errors
    ///
    /// As [`IndirectCluster::irradiance`].
    pub fn irradiance_with(
        &self,
        scratch: &mut IndirectScratch,
        ctx: &LightContext,
        sources: &[LightSource<'_, '_>],
        p: [f32; 3],
        normal: [f32; 3],
    ) -> Result<[f64; 3], LightError> {
        if self.order == 0 {
            return Err(ShadowError::NotBuilt.into());
        }
        if self.order != ctx.order() {
            return Err(LightError::Mismatch { what: "order" });
        }
        if sources.len() != self.built_for.len()
            || sources.iter().zip(&self.built_for).any(|(s, b)| source_key(s) != *b)
        {
            return Err(LightError::Mismatch { what: "sources (not the ones the cluster was built from)" });
        }
        crate::shadow::check_point("p", p)?;
        let normal = crate::shadow::unit_normal_f32("normal", normal)?;
        let e = contribution(self.order, &self.entries, &mut scratch.active, ctx, sources, p, normal, |_| true)?;
        Ok(e.map(|v| v.max(0.0)))
    }
}

/// Σ over the entries with `include(k)` of π L̃ Ṽ t at receiver `p`, the blockers being all of `entries` (a
/// cluster's lights at SH order `order`); `active` is per-query working space (cleared first).
#[allow(clippy::too_many_arguments)]
fn contribution(
    order: usize,
    entries: &[LightEntry],
    active: &mut Vec<Active>,
    ctx: &LightContext,
    sources: &[LightSource<'_, '_>],
    p: [f32; 3],
    normal: [f32; 3],
    include: impl Fn(usize) -> bool,
) -> Result<[f64; 3], LightError> {
    let nc = coeff_count(order);
    // Per entry: the adjusted sphere, its log vector and power.
    active.clear();
    for (k, e) in entries.iter().enumerate() {
        let Some((c, r)) = self_shadow_sphere(e.blocker.center, e.blocker.radius, p, normal) else { continue };
        let d = [c[0] - p[0], c[1] - p[1], c[2] - p[2]];
        let d2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        if !(d2.is_finite() && d2 > 0.0) {
            continue;
        }
        let inv = rsqrt_f32(d2);
        let theta = asin_f32(r * inv);
        let s = [d[0] * inv, d[1] * inv, d[2] * inv];
        let mut a = Active {
            entry: k as u32,
            power: d2 - r * r,
            theta,
            sin_theta: (r * inv).min(1.0),
            adjusted: {
                let o = [e.blocker.center[0] - p[0], e.blocker.center[1] - p[1], e.blocker.center[2] - p[2]];
                o[0] * o[0] + o[1] * o[1] + o[2] * o[2] < e.blocker.radius * e.blocker.radius
            },
            axis: [-s[0], -s[1], -s[2]],
            log: [0.0; MAX_COEFFS],
        };
        accumulate_log_visibility_f32(theta, s, &e.blocker.band_weights[..order], &mut a.log[..nc])?;
        active.push(a);
    }
    // Nearest first by power (insertion sort: stable, allocation-free, K is small).
    for i in 1..active.len() {
        let mut j = i;
        while j > 0 && active[j - 1].power > active[j].power {
            active.swap(j - 1, j);
            j -= 1;
        }
    }
    // Contact (module docs): the leaf that contains the receiver and whose facing tiles cover most of its view
    // hides the other lights by that share.
    let mut contact = (0.0f64, usize::MAX);
    for ai in active.iter() {
        let k = ai.entry as usize;
        let e = &entries[k];
        let CutEntry::Leaf(leaf) = e.blocker.source else { continue };
        let d = [e.blocker.center[0] - p[0], e.blocker.center[1] - p[1], e.blocker.center[2] - p[2]];
        if d[0] * d[0] + d[1] * d[1] + d[2] * d[2] > e.blocker.radius * e.blocker.radius {
            continue;
        }
        let Some((posed_src, _)) = sources.get(e.source as usize) else { continue };
        let c = tile_coverage(&ctx.cells, posed_src, leaf as usize, p, normal);
        if c > contact.0 {
            contact = (c, k);
        }
    }
    let mut h = [0.0f64; MAX_COEFFS];
    ctx.cosine_lobe([f64::from(normal[0]), f64::from(normal[1]), f64::from(normal[2])], &mut h);
    let mut total = [0.0f64; 3];
    let mut adjusted = [0.0f64; 3];
    let mut adjusted_share = 0.0f64;
    for i in 0..active.len() {
        let ai = &active[i];
        let k = ai.entry as usize;
        if !include(k) {
            continue;
        }
        let e = &entries[k];
        let Some((posed_src, lights)) = sources.get(e.source as usize) else {
            return Err(LightError::Mismatch { what: "sources" });
        };
        let (coeffs, _) = lights.light_of(e.blocker.source);
        if coeffs.len() < nc {
            continue;
        }
        // Cosine-weighted average radiance Φ / Ṽ₀ (spherebake_sh light module), in the light's rest frame.
        let axis = rotate_transposed(&e.rotation, ai.axis);
        let n_local = rotate_transposed(&e.rotation, normal);
        let phi = cosine_weighted_radiance_rgb_f32(ai.theta, axis, n_local, coeffs, order)?;
        let ns = -(ai.axis[0] * normal[0] + ai.axis[1] * normal[1] + ai.axis[2] * normal[2]);
        let st = ai.sin_theta;
        let v0 = ns * st * st;
        if v0.partial_cmp(&1e-12) != Some(core::cmp::Ordering::Greater) || phi.iter().all(|&v| v.abs() <= 0.0) {
            continue;
        }
        let mut lt = phi.map(|v| v / v0);
        // Splat weight: seen from close, the leaf's own samples as small emitters (module docs).
        let mut splat_t = 0.0f32;
        let mut splat = [0.0f64; 3];
        if let CutEntry::Leaf(leaf) = e.blocker.source {
            let (lo, hi) = (SPLAT_THETA_START, SPLAT_THETA_FULL);
            let d = [e.blocker.center[0] - p[0], e.blocker.center[1] - p[1], e.blocker.center[2] - p[2]];
            let d2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
            let r = e.blocker.radius;
            let theta_raw = if d2 <= r * r { core::f32::consts::FRAC_PI_2 } else { asin_f32(r * rsqrt_f32(d2)) };
            if theta_raw > lo {
                let fill = f64::from(lights.leaf_fill.get(leaf as usize).copied().unwrap_or(1.0));
                let fw = splat_weight(fill, posed_src.proxy.samples_of(leaf as usize).len()) as f32;
                splat_t = fw * ((theta_raw - lo) / (hi - lo)).clamp(0.0, 1.0);
                if splat_t > 0.0 {
                    splat = splat_irradiance(&ctx.cells, posed_src, lights, leaf as usize, p, normal);
                }
            }
        }
        // Seen from very close (wide caps: the receiver is inside or under the light), the weights concentrate
        // near the axis, where the order-n smearing of the light's empty directions (rule 2) and of its sharp
        // light/dark edges would glow: blend towards a local fit of the Voronoi function itself.
        if let (CutEntry::Leaf(leaf), true) = (e.blocker.source, ai.theta > CLOSE_THETA_START) {
            let range = leaf as usize * GEODESIC_DIRECTION_COUNT..(leaf as usize + 1) * GEODESIC_DIRECTION_COUNT;
            if let Some(fit) = lights.leaf_cells.get(range).and_then(|cells| close_fit(cells, axis, ai.theta)) {
                let phi_fit = cosine_weighted_radiance_rgb_f32(ai.theta, axis, n_local, &fit, 2)?;
                let t = ((ai.theta - CLOSE_THETA_START) / (CLOSE_THETA_FULL - CLOSE_THETA_START)).clamp(0.0, 1.0);
                for c in 0..3 {
                    lt[c] = (1.0 - t) * lt[c] + t * (phi_fit[c] / v0).max(0.0);
                }
            }
        }
        // A = Σ of the logs of the nearer lights that do not intersect this one (same source).
        let mut acc = [0.0f32; MAX_COEFFS];
        let mut any = false;
        let cos_i = crate::shadow::sqrt_f32((1.0 - ai.sin_theta * ai.sin_theta).max(0.0));
        for aj in &active[..i] {
            let ej = &entries[aj.entry as usize];
            if ej.source == e.source && intersect(&ej.blocker, &e.blocker) {
                continue;
            }
            // A nearer light whose cone misses this one's blocks nothing of it; its band-limited log would
            // still darken it (SH leakage), so it is left out: the cones overlap iff the angle between their
            // axes is below θ_i + θ_j, i.e. cos∠ > cos θ_i cos θ_j − sin θ_i sin θ_j.
            let cos_j = crate::shadow::sqrt_f32((1.0 - aj.sin_theta * aj.sin_theta).max(0.0));
            let dot_axes = ai.axis[0] * aj.axis[0] + ai.axis[1] * aj.axis[1] + ai.axis[2] * aj.axis[2];
            if dot_axes <= cos_i * cos_j - ai.sin_theta * aj.sin_theta {
                continue;
            }
            any = true;
            for c in 0..nc {
                acc[c] += aj.log[c];
            }
        }
        // Ṽ = Ṽ₀ · (visible share of the light's cap): the share from eq. 23 as
        // (exp*(A) − exp*(A + G)) · H / ((1 − exp*(G)) · H), Ṽ₀ = (n·s) sin²θ exact. Without a nearer
        // blocker the share is 1 and no exponential is needed.
        let v = if any {
            let mut g = [0.0f64; MAX_COEFFS];
            ctx.shadow.visibility(&acc[..nc], &mut g[..nc])?;
            let v_near = dot(&g[..nc], &h[..nc]);
            for c in 0..nc {
                acc[c] += ai.log[c];
            }
            ctx.shadow.visibility(&acc[..nc], &mut g[..nc])?;
            let v_far = dot(&g[..nc], &h[..nc]);
            ctx.shadow.visibility(&ai.log[..nc], &mut g[..nc])?;
            let own = 1.0 - dot(&g[..nc], &h[..nc]);
            let share = if own > 1e-4 { ((v_near - v_far) / own).clamp(0.0, 1.0) } else { 1.0 };
            f64::from(v0) * share
        } else {
            f64::from(v0)
        };
        let v = if contact.1 != usize::MAX && contact.1 != k { v * (1.0 - contact.0) } else { v };
        let keep = 1.0 - f64::from(splat_t);
        if splat_t > 0.0 {
            let vis = if v0 > 0.0 { v / f64::from(v0) } else { 0.0 };
            for c in 0..3 {
                total[c] += f64::from(splat_t) * splat[c] * vis * f64::from(e.ratio[c]);
            }
        }
        let (sum, share) = if ai.adjusted { (&mut adjusted, &mut adjusted_share) } else { (&mut total, &mut 0.0) };
        *share += v * keep;
        for c in 0..3 {
            sum[c] += keep * core::f64::consts::PI * f64::from(lt[c]) * v * f64::from(e.ratio[c]);
        }
    }
    // One radiance per direction: the lights the self-shadowing rules moved next to the receiver (it was
    // inside or under them) all touch its tangent plane and intersect, so none blocks another; their
    // cosine-weighted shares cannot add up to more than the union of their caps covers.
    if adjusted_share > 0.0 {
        let union = union_of_adjusted(active, &include, normal);
        if adjusted_share > union {
            let s = union / adjusted_share;
            for c in 0..3 {
                total[c] += adjusted[c] * s;
            }
        } else {
            for c in 0..3 {
                total[c] += adjusted[c];
            }
        }
    }
    Ok(total)
}

/// Angular radius (radians) from which pass 2 starts blending a leaf light's SH towards its Voronoi function (40°).
pub const CLOSE_THETA_START: f32 = 0.698_131_7;
/// Angular radius (radians) from which only the Voronoi function is used (60°).
pub const CLOSE_THETA_FULL: f32 = core::f32::consts::FRAC_PI_3;
/// Smallest half-angle of the cone of [`close_fit`] over the 92 directions (25°: four to eight directions inside).
const CLOSE_KERNEL_MIN_RAD: f32 = 0.436_332_3;

/// The light's Voronoi function near `axis` (unit, the light's frame) as seen from a receiver at angular radius
/// `theta`, as a local band-0–1 model: the weighted least-squares fit L ≈ A + B·ω over the directions within a cone
/// about the axis (half-angle max(π/2 − θ, 25°), weights falling linearly to the cone's edge; empty cells count as
/// 0), returned as order-2 SH coefficients (RGB) for the same cosine-weighted integral as the light itself. Exact for
/// band-1 emission (a sky-lit sphere); ill-conditioned fits drop terms down to the weighted mean. `None` when no
/// cell is inside.
fn close_fit(cells: &[[f32; 3]], axis: [f32; 3], theta: f32) -> Option<[[f32; 3]; 4]> {
    let half = (core::f32::consts::FRAC_PI_2 - theta).max(CLOSE_KERNEL_MIN_RAD);
    let cos_half = crate::shadow::sqrt_f32(1.0 - sin_sq(half));
    let t = if axis[0].abs() < 0.9 { [1.0f32, 0.0, 0.0] } else { [0.0, 1.0, 0.0] };
    let mut e1 = [t[1] * axis[2] - t[2] * axis[1], t[2] * axis[0] - t[0] * axis[2], t[0] * axis[1] - t[1] * axis[0]];
    let inv = crate::shadow::rsqrt_f32(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]);
    e1 = e1.map(|x| x * inv);
    let e2 = [axis[1] * e1[2] - axis[2] * e1[1], axis[2] * e1[0] - axis[0] * e1[2], axis[0] * e1[1] - axis[1] * e1[0]];
    // Weighted least squares L ≈ a + b₁u + b₂v + c(u² + v²) (the curvature term makes band-1 emission exact: a
    // linear function of ω is a + b·axis·√(1 − u² − v²) + …); ill-conditioned systems (cells on a ring) drop the
    // curvature term, then the slopes, down to the weighted mean.
    let mut rows: [[f64; 4]; GEODESIC_DIRECTION_COUNT] = [[0.0; 4]; GEODESIC_DIRECTION_COUNT];
    let mut vals: [[f64; 3]; GEODESIC_DIRECTION_COUNT] = [[0.0; 3]; GEODESIC_DIRECTION_COUNT];
    let mut ws = [0.0f64; GEODESIC_DIRECTION_COUNT];
    let mut count = 0;
    for (d, cell) in GEODESIC_DIRECTIONS.iter().zip(cells) {
        let w = f64::from((d[0] * axis[0] + d[1] * axis[1] + d[2] * axis[2] - cos_half).max(0.0));
        if w <= 0.0 {
            continue;
        }
        let u = f64::from(d[0] * e1[0] + d[1] * e1[1] + d[2] * e1[2]);
        let v = f64::from(d[0] * e2[0] + d[1] * e2[1] + d[2] * e2[2]);
        let w_ax = f64::from(d[0] * axis[0] + d[1] * axis[1] + d[2] * axis[2]);
        rows[count] = [1.0, u, v, w_ax - 1.0];
        vals[count] = cell.map(f64::from);
        ws[count] = w;
        count += 1;
    }
    if count == 0 {
        return None;
    }
    // L ≈ a + b₁u + b₂v + b₃(ω·axis − 1) = (a − b₃) + (b₁e₁ + b₂e₂ + b₃ axis)·ω: band 0–1 SH coefficients.
    let c1 = crate::refit::sqrt(3.0 / (4.0 * core::f64::consts::PI));
    let dc = crate::refit::sqrt(4.0 * core::f64::consts::PI);
    for params in [4usize, 3, 1] {
        if let Some(b) = weighted_fit(&rows[..count], &vals[..count], &ws[..count], params) {
            let mut out = [[0.0f32; 3]; 4];
            for ch in 0..3 {
                let k = |i: usize| if i < params { b[i][ch] } else { 0.0 };
                let konst = k(0) - k(3);
                let vec =
                    [0, 1, 2].map(|q| k(1) * f64::from(e1[q]) + k(2) * f64::from(e2[q]) + k(3) * f64::from(axis[q]));
                // y_00 = 1/√(4π); y_1,−1 = −c₁y, y_1,0 = c₁z, y_1,1 = −c₁x (Condon–Shortley).
                out[0][ch] = (konst * dc) as f32;
                out[1][ch] = (-vec[1] / c1) as f32;
                out[2][ch] = (vec[2] / c1) as f32;
                out[3][ch] = (-vec[0] / c1) as f32;
            }
            return Some(out);
        }
    }
    None
}

/// The weighted least-squares coefficients (`[param][channel]`) of `vals` on the first `params` columns of `rows`,
/// by Gauss–Jordan elimination with partial pivoting on the normal equations; `None` when a pivot falls below 1e-9
/// of the diagonal's scale (ill-conditioned).
fn weighted_fit(rows: &[[f64; 4]], vals: &[[f64; 3]], ws: &[f64], params: usize) -> Option<[[f64; 3]; 4]> {
    let n = params.min(4);
    let mut m = [[0.0f64; 7]; 4];
    for ((x, y), &w) in rows.iter().zip(vals).zip(ws) {
        for r in 0..n {
            for c in 0..n {
                m[r][c] += w * x[r] * x[c];
            }
            for ch in 0..3 {
                m[r][n + ch] += w * x[r] * y[ch];
            }
        }
    }
    let scale = (0..n).map(|k| m[k][k]).fold(0.0f64, f64::max);
    if scale <= 0.0 {
        return None;
    }
    for col in 0..n {
        let piv = (col..n).max_by(|&a, &b| m[a][col].abs().total_cmp(&m[b][col].abs()))?;
        if m[piv][col].abs() < 1e-9 * scale {
            return None;
        }
        m.swap(col, piv);
        for r in 0..n {
            if r != col {
                let f = m[r][col] / m[col][col];
                for c in col..n + 3 {
                    m[r][c] -= f * m[col][c];
                }
            }
        }
    }
    let mut out = [[0.0f64; 3]; 4];
    for r in 0..n {
        for ch in 0..3 {
            out[r][ch] = m[r][n + ch] / m[r][r];
        }
    }
    Some(out)
}

/// sin²x for x in [0, π/2] (f32, Taylor to x⁹ of sin; enough for a kernel width).
fn sin_sq(x: f32) -> f32 {
    let x2 = x * x;
    let s = x * (1.0 - x2 / 6.0 * (1.0 - x2 / 20.0 * (1.0 - x2 / 42.0 * (1.0 - x2 / 72.0))));
    s * s
}

/// Angular radius (radians, 10°) of a leaf light seen from the receiver from which pass 2 starts blending its
/// SH emission towards the splat of its own samples ([`splat_irradiance`], module docs "Close lights").
pub const SPLAT_THETA_START: f32 = 0.174_532_93;
/// Angular radius (radians, 30°) from which only the splat is used (and for receivers inside the leaf sphere).
pub const SPLAT_THETA_FULL: f32 = core::f32::consts::FRAC_PI_6;
/// Fill (mean sample distance / radius) of a leaf at and above which its splat is not used: the sphere's surface
/// is the surface it bounds, and the SH light is exact there.
const SPLAT_FILL_TIGHT: f64 = 0.98;
/// Fill at and below which the splat gets its full weight: the bounding sphere stands away from its surface.
const SPLAT_FILL_LOOSE: f64 = 0.90;
/// Share of the 92 directions with a sample at and above which a leaf's splat is not used for its coverage: its
/// emission is smooth over the whole sphere, which the order-n SH light represents (the known-answer spheres).
const SPLAT_COVER_FULL: f64 = 0.95;
/// Share of directions with a sample at and below which the splat gets its full weight: the rest are other spheres'
/// directions (rule 2), and the order-n SH smears the sharp edge between emitting and empty directions.
const SPLAT_COVER_PARTIAL: f64 = 0.75;
/// Smallest |n·ω| of a sample's area element t² Ω_cell / |n·ω| (grazing samples: area at most 5× the cell's).
const SPLAT_MIN_COS: f64 = 0.2;

/// Rings × azimuths of the per-cap sample pattern of [`union_of_adjusted`].
const CAP_RINGS: usize = 3;
const CAP_AZIMUTHS: usize = 8;

/// The cosine-weighted share (hemisphere = 1) of the union of the included adjusted lights' caps: each cap's exact
/// share (n·s) sin²θ times the cosine-weighted fraction of a fixed pattern of 24 directions inside it (equal-area
/// rings) that no nearer adjusted cap contains.
fn union_of_adjusted(active: &[Active], include: &impl Fn(usize) -> bool, normal: [f32; 3]) -> f64 {
    let mut union = 0.0f64;
    for (i, a) in active.iter().enumerate() {
        if !a.adjusted || !include(a.entry as usize) {
            continue;
        }
        let s = [-a.axis[0], -a.axis[1], -a.axis[2]];
        let v0 = f64::from((s[0] * normal[0] + s[1] * normal[1] + s[2] * normal[2]) * a.sin_theta * a.sin_theta);
        if v0 <= 0.0 {
            continue;
        }
        // Does any nearer included adjusted cap overlap this one at all?
        let cos_i = crate::shadow::sqrt_f32((1.0 - a.sin_theta * a.sin_theta).max(0.0));
        let overlaps = active[..i].iter().any(|b| b.adjusted && include(b.entry as usize));
        if !overlaps {
            union += v0;
            continue;
        }
        // Frame (u, v, s).
        let t = if s[0].abs() < 0.9 { [1.0f32, 0.0, 0.0] } else { [0.0, 1.0, 0.0] };
        let mut u = [t[1] * s[2] - t[2] * s[1], t[2] * s[0] - t[0] * s[2], t[0] * s[1] - t[1] * s[0]];
        let un = crate::shadow::rsqrt_f32(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
        u = u.map(|x| x * un);
        let v = [s[1] * u[2] - s[2] * u[1], s[2] * u[0] - s[0] * u[2], s[0] * u[1] - s[1] * u[0]];
        let (mut free, mut all) = (0.0f64, 0.0f64);
        for ring in 0..CAP_RINGS {
            let cz = 1.0 - (1.0 - cos_i) * (ring as f32 + 0.5) / CAP_RINGS as f32;
            let sz = crate::shadow::sqrt_f32((1.0 - cz * cz).max(0.0));
            for k in 0..CAP_AZIMUTHS {
                let (sn, cs) = CAP_TRIG[(k + ring) % CAP_AZIMUTHS];
                let d = [0, 1, 2].map(|q| cz * s[q] + sz * (cs * u[q] + sn * v[q]));
                let c = (d[0] * normal[0] + d[1] * normal[1] + d[2] * normal[2]).max(0.0);
                all += f64::from(c);
                let covered = active[..i].iter().any(|b| {
                    if !b.adjusted || !include(b.entry as usize) {
                        return false;
                    }
                    // Inside b's cap: the angle to b's centre direction is below b's angular radius.
                    let sb = [-b.axis[0], -b.axis[1], -b.axis[2]];
                    let cb = crate::shadow::sqrt_f32((1.0 - b.sin_theta * b.sin_theta).max(0.0));
                    d[0] * sb[0] + d[1] * sb[1] + d[2] * sb[2] > cb
                });
                if !covered {
                    free += f64::from(c);
                }
            }
        }
        if all > 0.0 {
            union += v0 * free / all;
        }
    }
    union
}

/// (sin, cos) of the azimuths 2πk/8 of the cap pattern.
const CAP_TRIG: [(f32, f32); CAP_AZIMUTHS] = [
    (0.0, 1.0),
    (core::f32::consts::FRAC_1_SQRT_2, core::f32::consts::FRAC_1_SQRT_2),
    (1.0, 0.0),
    (core::f32::consts::FRAC_1_SQRT_2, -core::f32::consts::FRAC_1_SQRT_2),
    (0.0, -1.0),
    (-core::f32::consts::FRAC_1_SQRT_2, -core::f32::consts::FRAC_1_SQRT_2),
    (-1.0, 0.0),
    (-core::f32::consts::FRAC_1_SQRT_2, core::f32::consts::FRAC_1_SQRT_2),
];

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn intersect(a: &Blocker, b: &Blocker) -> bool {
    let d = [a.center[0] - b.center[0], a.center[1] - b.center[1], a.center[2] - b.center[2]];
    let d2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    let r = a.radius + b.radius;
    d2 < r * r
}

/// The leaves below `node` (or all leaves for the implicit root) as (leaf, depth-first position).
fn collect_leaves(posed: &PosedProxy<'_>, node: u32, stack: &mut Vec<u32>, out: &mut Vec<(usize, usize)>) {
    match posed.nodes {
        Some((plan, _)) if node != IMPLICIT_ROOT => {
            stack.clear();
            stack.push(node);
            while let Some(k) = stack.pop() {
                for c in plan.refs_of(k) {
                    match c {
                        ChildRef::Node(c) => stack.push(c),
                        ChildRef::Leaf(l) if (l as usize) < posed.leaves.len() => out.push((l as usize, out.len())),
                        ChildRef::Leaf(_) => {}
                    }
                }
            }
        }
        _ => out.extend((0..posed.leaves.len()).map(|l| (l, l))),
    }
}

#[cfg(test)]
mod tests {
    use super::{ratio_probes, RATIO_PROBE_RADIUS};
    use alloc::vec::Vec;

    fn sub(a: [f32; 3], b: [f32; 3]) -> [f64; 3] {
        core::array::from_fn(|c| f64::from(a[c]) - f64::from(b[c]))
    }
    fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
        a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
    }

    #[test]
    fn ratio_probes_are_the_centre_and_four_points_on_the_cluster_disc() {
        let c = [0.5f32, -2.0, 3.0];
        let r = 0.8f32;
        // Normals of every sign pattern, the axes (n_z = ±1; the basis switches its sign at n_z = 0), unnormalised
        // ones and a huge finite one.
        let normals: [[f32; 3]; 10] = [
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0],
            [1.0, 0.0, 0.0],
            [0.3, -0.5, 0.81],
            [-0.6, 0.2, -0.77],
            [2.0, 2.0, 2.0],
            [-1e-3, 5.0, -2.0],
            [0.0, -3.0, -1e-4],
            [3e30, -1e30, 2e30],
        ];
        for n in normals {
            let len = dot(n.map(f64::from), n.map(f64::from)).sqrt(); // in f64: no overflow
            let unit = n.map(|x| f64::from(x) / len);
            let (p, count) = ratio_probes(c, r, n);
            assert_eq!(count, 5, "{n:?}");
            assert_eq!(p[0], c);
            let want = f64::from(RATIO_PROBE_RADIUS * r);
            let offsets: Vec<[f64; 3]> = p[1..].iter().map(|&q| sub(q, c)).collect();
            for (k, o) in offsets.iter().enumerate() {
                assert!((dot(*o, *o).sqrt() - want).abs() < 1e-5, "{n:?} probe {k}: distance");
                assert!(dot(*o, unit).abs() < 1e-5, "{n:?} probe {k}: off the disc");
            }
            // Two perpendicular tangents, each with its opposite.
            assert!(dot(offsets[0], offsets[1]).abs() < 1e-5, "{n:?}: tangents not perpendicular");
            for k in 0..2 {
                let s: [f64; 3] = core::array::from_fn(|a| offsets[k][a] + offsets[k + 2][a]);
                assert!(dot(s, s).sqrt() < 1e-5, "{n:?}: probe {} is not opposite probe {}", k + 3, k + 1);
            }
        }
        // A point cluster, or no usable normal: the centre alone.
        for (r, n) in
            [(0.0, [0.0, 1.0, 0.0]), (1.0, [0.0; 3]), (f32::NAN, [0.0, 1.0, 0.0]), (1.0, [f32::INFINITY, 0.0, 0.0])]
        {
            let (p, count) = ratio_probes(c, r, n);
            assert_eq!((count, p[0]), (1, c), "{r} {n:?}");
        }
    }
}
