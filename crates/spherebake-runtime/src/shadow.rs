//! Soft-shadow queries with log-SH visibility (Ren et al. 2006 §4–§7; math reference §2, §3, §9).
//!
//! The visibility of the blockers seen from a receiver point p is the SH product of the
//! visibilities of the single spheres, evaluated as exp*(Σ_i f_i) of their log vectors
//! (Ren eq. 8). One sphere (P, r) contributes f_lm = w_l F_l(θ) y_lm(s) with θ = asin(r/|P − p|),
//! s = (P − p)/|P − p| (eq. 34; F from the embedded table of `spherebake-sh`) and w its ratio
//! vector (eq. 37, 38; all ones for a leaf sphere).
//!
//! # Steps
//!
//! 1. **Per receiver cluster** (a ball (p_R, r_R) around receivers sharing a cut, e.g. a tile of
//!    a ground grid or a patch of a character): [`ClusterBlockers::build`] walks the hierarchy
//!    cut of eq. 36 ([`crate::cut::cut`]) and computes, at p* = p_R, the ratio vector w of every
//!    accepted interior node: the per-band least-squares scale of the node's log vector f_b onto
//!    the summed log vectors f_d of all leaves below it (eq. 37). Files without a hierarchy are
//!    treated as all spheres under one implicit root whose sphere is a bound of all leaves.
//!    Allocates only while its buffers grow.
//!    Optionally, [`ClusterBlockers::correct_overlap`] (not in the paper) then scales the
//!    cluster's logs so that the visibility DC at p* matches the union of the spheres: deeply
//!    overlapping sphere sets otherwise over-count in log space (measured in `docs/benchmarks.md`,
//!    "Shadows (issue 10)": without it the ground error *rises* past 64–128 spheres).
//!    `spherebake shadows` applies it by default (1024 directions), and the measured errors there
//!    are with it; its scale moves in steps of 0.05 over directions fixed in the spheres' space, so
//!    a moving proxy's shading can jump between frames and neighbouring clusters can differ.
//! 2. **Per receiver point** p with unit normal N: [`accumulate_log_visibility`] applies the
//!    self-shadowing rules ([`self_shadow_sphere`]) to every blocker of the cluster and sums its
//!    log vector. Allocation-free.
//! 3. [`ShadowContext::visibility`]: exp* of the sum, a visibility vector g (f64).
//! 4. [`ShadowContext::shading_vector`] builds T = L ∗ H(N) once per light and normal (Ren §7: L
//!    the lighting, H(N)_lm = (A_l/π) y_lm(N) the clamped cosine about N); the shaded value is
//!    T · g ([`shade`]). For uniform white light L = **1**, T · g is the cosine-weighted visible
//!    fraction: 1 without blockers.
//!
//! # Self-shadowing (Ren 2006 §6.2, Figure 5)
//!
//! With h = N · (P − p) the signed height of the centre over the tangent plane T_p:
//!
//! - h ≥ r (entirely in front): unchanged.
//! - h ≤ −r (entirely behind): removed.
//! - −r < h < r (straddling): replaced by a sphere tangent to T_p at q1 = P − hN, the foot of the
//!   centre on T_p, in front of T_p, of radius R(ρ), where ρ = |p − q1| is the receiver's
//!   distance from q1 along the plane and d = √(r² − h²) the radius of the circle where S meets T_p
//!   (p is inside S exactly when ρ < d):
//!   - ρ ≤ d (p inside S): R = max(h, 0) — the paper's "eliminate S if its centre is behind T_p,
//!     reduce its radius until it becomes tangent to T_p if its centre is in front" (a sphere
//!     about P of radius h touches T_p at q1);
//!   - ρ ≥ 2d: R = r′ = (r + h)/2 — the paper's S′, whose diameter is q0 = P + rN (the point of
//!     S farthest in front of T_p) to q1;
//!   - in between R = R_in + (r′ − R_in) · a with the smooth scale factor a = (ρ − d)/d.
//!
//!   The paper prints a = max(1, (|p − q1| − d)/d) and scales S′'s radius by it. Read literally
//!   that leaves S′ unscaled next to S, where the jump between the "inside" and the "outside"
//!   rules happens, and grows S′ without bound far away; the text says the factor exists to
//!   remove that jump by "gradually scaling up the radius of S′ as a function of p's distance to
//!   S along the tangent plane". We therefore use a = min(1, max(0, (ρ − d)/d)) as the blend from
//!   the inside rule at S's boundary to S′ one d further out: continuous in p everywhere.
//!
//! The rules are applied to every blocker of the cut, interior nodes included (Ren §8 applies
//! them per cut sphere in the shader). Ratio vectors are computed at p* without them (p* has no
//! normal), as in the paper.
//!
//! # Choice of SH exponential
//!
//! [`ExpMethod::PsStar`] of degree 4 is the default: at order 4 it costs about the same number of
//! SH products as HYB (3 + p against p squarings) but its measured error on sums of several
//! sphere logs is 10–20× lower (`spherebake-sh` exp module docs: ≤ 4e-3 against HYB's ≤ 9e-2 for
//! 4–8 spheres). End to end (bunny, 64 spheres, ground irradiance) PS*-4, HYB and the accurate
//! exp give 3.77%, 3.77% and 3.65% relative RMSE: the sphere approximation dominates. HYB is 2×
//! faster (1.0 µs against 2.0 µs per exp at order 4), so it is the choice when exp cost matters.
//!
//! # Units
//!
//! Positions and radii in one space (model or world, the same for receivers and spheres);
//! angles in radians; normals unit length.

// Index loops mirror the formulas (bands l, coefficients i).
#![allow(clippy::needless_range_loop)]

use crate::cut::{cut, cut_accepts, CutEntry};
use crate::refit::{ChildRef, HierarchyPlan, QueryError};
use crate::Sphere;
use alloc::vec::Vec;
use core::fmt;
use spherebake_sh::{
    accumulate_log_visibility_f32, cap_zh, clamped_cosine_convolution, log_visibility_f, ratio_vector, ren_window,
    sh_exp_accurate, sh_exp_hyb, sh_exp_ps_star, zh_rotate, ShError, TripleProduct,
};

pub use spherebake_sh::{coeff_count, eval_sh_f64, MAX_COEFFS, MAX_ORDER};

/// The SH order of the shadow queries unless told otherwise (Ren 2006 uses order 4: 16 coefficients).
pub const DEFAULT_SHADOW_ORDER: usize = 4;

/// √(4π): the DC coefficient of the SH unit **1** (uniform white light, no occlusion).
pub const SQRT_4PI: f64 = 3.544_907_701_811_032;

/// Why a shadow query could not run.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum ShadowError {
    /// The SH order is outside 1..=8.
    Order {
        /// The requested order.
        order: usize,
    },
    /// The hierarchy plan and the node or leaf slices do not fit together.
    Query(QueryError),
    /// An SH routine rejected its buffers.
    Sh(ShError),
    /// A slice has the wrong length.
    SliceLength {
        /// Which argument.
        argument: &'static str,
        /// Required length (at least).
        expected: usize,
        /// Given length.
        actual: usize,
    },
    /// A scalar or point argument is outside its range (NaN or infinite included).
    Argument {
        /// Which argument.
        argument: &'static str,
        /// What it must be.
        expected: &'static str,
    },
    /// The cluster has no blockers to query: it was never built, or its last build failed.
    NotBuilt,
    /// The cluster was built at another SH order than the context's.
    OrderMismatch {
        /// The order of the cluster's build.
        built: usize,
        /// The context's order.
        context: usize,
    },
}

impl fmt::Display for ShadowError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ShadowError::Order { order } => write!(f, "SH order {order} is outside 1..=8"),
            ShadowError::Query(e) => write!(f, "hierarchy query: {e}"),
            ShadowError::Sh(e) => write!(f, "SH: {e}"),
            ShadowError::SliceLength { argument, expected, actual } => {
                write!(f, "{argument} has length {actual}, expected at least {expected}")
            }
            ShadowError::Argument { argument, expected } => write!(f, "{argument} must be {expected}"),
            ShadowError::NotBuilt => write!(f, "the cluster was not built (or its last build failed)"),
            ShadowError::OrderMismatch { built, context } => {
                write!(f, "the cluster was built at SH order {built}, the context's order is {context}")
            }
        }
    }
}

impl core::error::Error for ShadowError {}

impl From<QueryError> for ShadowError {
    fn from(e: QueryError) -> Self {
        ShadowError::Query(e)
    }
}

impl From<ShError> for ShadowError {
    fn from(e: ShError) -> Self {
        ShadowError::Sh(e)
    }
}

fn check_order(order: usize) -> Result<(), ShadowError> {
    if (1..=MAX_ORDER).contains(&order) {
        Ok(())
    } else {
        Err(ShadowError::Order { order })
    }
}

fn check_len(argument: &'static str, expected: usize, actual: usize) -> Result<(), ShadowError> {
    if actual < expected {
        Err(ShadowError::SliceLength { argument, expected, actual })
    } else {
        Ok(())
    }
}

/// The SH exponential used to turn the summed log vector into a visibility vector.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub enum ExpMethod {
    /// Ren's PS*-`degree` ([`spherebake_sh::sh_exp_ps_star`]); the default with degree 4.
    PsStar {
        /// Series degree, 1..=20.
        degree: u8,
    },
    /// Ren's HYB ([`spherebake_sh::sh_exp_hyb`]) with the given OL norm bound
    /// ([`spherebake_sh::HYB_DEFAULT_NORM_BOUND`] when ≤ 0).
    Hyb {
        /// Largest ‖f̂‖ handed to the OL table.
        ol_norm_bound: f32,
    },
    /// exp(M_f)·1 to rounding ([`spherebake_sh::sh_exp_accurate`]): a reference, slower for large
    /// logs.
    Accurate,
}

impl Default for ExpMethod {
    fn default() -> Self {
        ExpMethod::PsStar { degree: 4 }
    }
}

/// One blocker of a receiver cluster's cut: a sphere (leaf or hierarchy node) and its per-band
/// ratio weights (eq. 37; all ones for leaves; entries past the order are 0).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Blocker {
    /// Centre, same space as the receivers.
    pub center: [f32; 3],
    /// Radius, same units.
    pub radius: f32,
    /// w_l for bands l < order.
    pub band_weights: [f32; MAX_ORDER],
    /// Where it came from.
    pub source: CutEntry,
}

/// The blockers of one receiver cluster with their ratio vectors; reusable scratch buffers.
#[derive(Clone, Debug, Default)]
pub struct ClusterBlockers {
    blockers: Vec<Blocker>,
    cut: Vec<CutEntry>,
    stack: Vec<u32>,
    order: usize,
}

/// The implicit-root "node index" used in [`Blocker::source`] when a file has no hierarchy.
pub const IMPLICIT_ROOT: u32 = u32::MAX;

/// Log vector of one sphere seen from `p` (f64; eq. 34), added to `out` with weight `scale`.
fn add_log_f64(order: usize, sphere: &Sphere, p: [f64; 3], scale: f64, out: &mut [f64; MAX_COEFFS]) {
    let d =
        [f64::from(sphere.center[0]) - p[0], f64::from(sphere.center[1]) - p[1], f64::from(sphere.center[2]) - p[2]];
    let dist = crate::refit::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    if dist.is_nan() || dist <= 0.0 {
        return;
    }
    let x = f64::from(sphere.radius) / dist;
    let theta = f64::from(asin_f32(x as f32));
    let mut f = [0.0; MAX_ORDER];
    let mut y = [0.0; MAX_COEFFS];
    // Orders are checked by the callers; the calls cannot fail.
    if log_visibility_f(theta, order, &mut f).is_err()
        || eval_sh_f64(order, [d[0] / dist, d[1] / dist, d[2] / dist], &mut y).is_err()
    {
        return;
    }
    for l in 0..order {
        for i in l * l..(l + 1) * (l + 1) {
            out[i] += scale * f[l] * y[i];
        }
    }
}

impl ClusterBlockers {
    /// Empty buffers.
    #[must_use]
    pub fn new() -> ClusterBlockers {
        ClusterBlockers::default()
    }

    /// The blockers of the last [`ClusterBlockers::build`].
    #[must_use]
    pub fn blockers(&self) -> &[Blocker] {
        &self.blockers
    }

    /// The SH order of the last build (0 before the first).
    #[must_use]
    pub fn order(&self) -> usize {
        self.order
    }

    /// Assembles the blockers of the receiver cluster bounded by (`receiver_center`,
    /// `receiver_radius`): the hierarchy cut at angular threshold `theta_max_rad` (eq. 36) and the
    /// ratio vector of every accepted interior node at p* = `receiver_center` (eq. 37).
    ///
    /// `leaves` are the (posed) sphere set; `hierarchy` the plan and its node spheres (stored or
    /// refitted), or `None` for a file without a hierarchy: then the leaves hang under one
    /// implicit root bounding them all, used as a single blocker when eq. 36 accepts it.
    ///
    /// # Errors
    ///
    /// Order outside 1..=8; `leaves` shorter than the plan's leaf bound; `nodes` not one per node;
    /// a centre that is not finite, a radius that is not finite and ≥ 0, θmax outside [0, π]. After
    /// an error the cluster is empty and not built ([`ShadowError::NotBuilt`] from its queries),
    /// never half-built.
    pub fn build(
        &mut self,
        order: usize,
        leaves: &[Sphere],
        hierarchy: Option<(&HierarchyPlan, &[Sphere])>,
        receiver_center: [f32; 3],
        receiver_radius: f32,
        theta_max_rad: f32,
    ) -> Result<(), ShadowError> {
        // One pass in a closure, so a failure anywhere empties the cluster below.
        let built = (|| -> Result<(), ShadowError> {
            check_order(order)?;
            check_receiver(receiver_center, receiver_radius, theta_max_rad)?;
            check_spheres("leaves", leaves)?;
            if let Some((_, nodes)) = hierarchy {
                check_spheres("nodes", nodes)?;
            }
            self.order = order;
            self.blockers.clear();
            let p_star = receiver_center.map(f64::from);
            let ones = {
                let mut w = [0.0f32; MAX_ORDER];
                w[..order].fill(1.0);
                w
            };
            let Some((plan, nodes)) = hierarchy else {
                let root = implicit_root(leaves);
                if let Some(root) = root.filter(|r| cut_accepts(r, receiver_center, receiver_radius, theta_max_rad)) {
                    let w = ratio_weights(order, &root, leaves.iter(), p_star)?;
                    self.blockers.push(Blocker {
                        center: root.center,
                        radius: root.radius,
                        band_weights: w,
                        source: CutEntry::Node(IMPLICIT_ROOT),
                    });
                } else {
                    self.blockers.extend(leaves.iter().enumerate().map(|(i, s)| Blocker {
                        center: s.center,
                        radius: s.radius,
                        band_weights: ones,
                        source: CutEntry::Leaf(i as u32),
                    }));
                }
                return Ok(());
            };
            check_len("leaves", plan.leaf_bound(), leaves.len())?;
            cut(plan, nodes, receiver_center, receiver_radius, theta_max_rad, &mut self.cut)?;
            for &entry in &self.cut {
                match entry {
                    CutEntry::Leaf(l) => {
                        let s = &leaves[l as usize]; // l < leaf_bound ≤ leaves.len()
                        self.blockers.push(Blocker {
                            center: s.center,
                            radius: s.radius,
                            band_weights: ones,
                            source: entry,
                        });
                    }
                    CutEntry::Node(n) => {
                        let node = nodes[n as usize]; // checked by `cut`
                                                      // Leaves below n, depth-first.
                        self.stack.clear();
                        self.stack.push(n);
                        let mut f_d = [0.0; MAX_COEFFS];
                        while let Some(k) = self.stack.pop() {
                            for c in plan.refs_of(k) {
                                match c {
                                    ChildRef::Node(c) => self.stack.push(c),
                                    ChildRef::Leaf(l) => add_log_f64(order, &leaves[l as usize], p_star, 1.0, &mut f_d),
                                }
                            }
                        }
                        let w = weights_from(order, &node, &f_d, p_star)?;
                        self.blockers.push(Blocker {
                            center: node.center,
                            radius: node.radius,
                            band_weights: w,
                            source: entry,
                        });
                    }
                }
            }
            Ok(())
        })();
        if built.is_err() {
            self.order = 0;
            self.blockers.clear();
        }
        built
    }
}

impl ClusterBlockers {
    /// **Not in Ren 2006; optional.** Damps the over-counting of overlapping blockers in the
    /// log-space sum: finds one scale s in {1, 0.95, …, 0.05} for all log vectors of the cluster
    /// such that the DC of exp*(s Σ f) at the cluster point `p_star` (normal `normal`,
    /// self-shadowing rules applied) best matches the visible fraction of the *union* of the
    /// (rule-adjusted) blocker spheres there, measured with `directions` Fibonacci-sphere rays;
    /// then multiplies every blocker's band weights by s and returns s (1 when nothing improves).
    ///
    /// Overlapping spheres multiply binary visibilities harmlessly, but their band-limited logs
    /// add: deep overlaps drive ‖f̂‖ far past the range where exp* behaves and can make the
    /// visibility *brighter* than no blocker (see `docs/benchmarks.md`, "Shadows (issue 10)").
    /// [`ClusterBlockers::build`] does not apply it; `spherebake shadows` and `spherebake light` call
    /// it with 1024 directions, [`crate::light::ClusterSpec::overlap_correction`] with 256. The
    /// scale's steps of 0.05 and the fixed directions make the result depend on the coordinate
    /// frame and jump between neighbouring clusters and between frames of a moving proxy.
    /// Allocation-free.
    ///
    /// # Errors
    ///
    /// The order of `ctx` differs from the build's; `normal` zero or not finite (any other length
    /// is scaled to unit); `p_star` not finite; `directions` above [`MAX_OVERLAP_DIRECTIONS`].
    pub fn correct_overlap(
        &mut self,
        ctx: &ShadowContext,
        p_star: [f32; 3],
        normal: [f32; 3],
        directions: usize,
    ) -> Result<f32, ShadowError> {
        if self.order == 0 {
            return Err(ShadowError::NotBuilt);
        }
        if self.order != ctx.order {
            return Err(ShadowError::OrderMismatch { built: self.order, context: ctx.order });
        }
        check_point("p_star", p_star)?;
        let normal = unit_normal_f32("normal", normal)?;
        if directions > MAX_OVERLAP_DIRECTIONS {
            return Err(ShadowError::Argument { argument: "directions", expected: "at most 65536" });
        }
        let n = self.order;
        let nc = coeff_count(n);
        // Union visible fraction by Fibonacci directions.
        let dirs = directions.max(1);
        let golden = core::f64::consts::PI * (3.0 - crate::refit::sqrt(5.0));
        let mut visible = 0usize;
        for k in 0..dirs {
            let z = 1.0 - (2.0 * k as f64 + 1.0) / dirs as f64;
            let rxy = crate::refit::sqrt((1.0 - z * z).max(0.0));
            let (sn, cs) = sin_cos(golden * k as f64);
            let d = [(rxy * cs) as f32, (rxy * sn) as f32, z as f32];
            let blocked = self.blockers.iter().any(|b| {
                let Some((c, r)) = self_shadow_sphere(b.center, b.radius, p_star, normal) else {
                    return false;
                };
                let o = [c[0] - p_star[0], c[1] - p_star[1], c[2] - p_star[2]];
                let o2 = o[0] * o[0] + o[1] * o[1] + o[2] * o[2];
                let tc = o[0] * d[0] + o[1] * d[1] + o[2] * d[2];
                o2 < r * r || (tc > 0.0 && o2 - tc * tc < r * r)
            });
            if !blocked {
                visible += 1;
            }
        }
        let target = SQRT_4PI * visible as f64 / dirs as f64;
        let mut log = [0.0f32; MAX_COEFFS];
        accumulate_log_visibility(&self.blockers, n, p_star, Some(normal), &mut log[..nc])?;
        let mut best = (f64::INFINITY, 1.0f32);
        let mut scaled = [0.0f32; MAX_COEFFS];
        let mut g = [0.0f64; MAX_COEFFS];
        for step in (1..=20).rev() {
            let s = step as f32 / 20.0;
            for i in 0..nc {
                scaled[i] = s * log[i];
            }
            ctx.visibility(&scaled[..nc], &mut g[..nc])?;
            let err = (g[0] - target).abs();
            if err < best.0 - 1e-9 {
                best = (err, s);
            }
        }
        let s = best.1;
        if s < 1.0 {
            for b in &mut self.blockers {
                for w in &mut b.band_weights[..n] {
                    *w *= s;
                }
            }
        }
        Ok(s)
    }
}

/// (sin x, cos x) for any finite x: reduced to [−π, π], then Taylor series to x¹⁹ / x¹⁸.
fn sin_cos(x: f64) -> (f64, f64) {
    let tau = 2.0 * core::f64::consts::PI;
    let mut t = x - tau * spherebake_format::quant::round_ties_away(x / tau);
    if t.is_nan() {
        t = 0.0;
    }
    let t2 = t * t;
    let (mut s, mut c) = (0.0, 0.0);
    for k in (0..10u32).rev() {
        s = 1.0 - t2 / (f64::from(2 * k + 2) * f64::from(2 * k + 3)) * s;
        c = 1.0 - t2 / (f64::from(2 * k + 1) * f64::from(2 * k + 2)) * c;
    }
    (t * s, c)
}

/// A bound of all leaves: centre = mean of the centres, radius = max(|c − centre| + r), rounded up.
pub(crate) fn implicit_root(leaves: &[Sphere]) -> Option<Sphere> {
    if leaves.is_empty() {
        return None;
    }
    let n = leaves.len() as f64;
    let mut c = [0.0f64; 3];
    for s in leaves {
        for k in 0..3 {
            c[k] += f64::from(s.center[k]) / n;
        }
    }
    let mut r = 0.0f64;
    for s in leaves {
        let d2: f64 = (0..3).map(|k| sq(f64::from(s.center[k]) - c[k])).sum();
        r = r.max(crate::refit::sqrt_upper(d2) + f64::from(s.radius));
    }
    let center = c.map(|v| v as f32);
    // Re-measure from the rounded centre and round the radius up.
    let mut rr = 0.0f64;
    for s in leaves {
        let d2: f64 = (0..3).map(|k| sq(f64::from(s.center[k]) - f64::from(center[k]))).sum();
        rr = rr.max(crate::refit::sqrt_upper(d2) + f64::from(s.radius));
    }
    let radius = (rr.max(r) * (1.0 + 1e-6)) as f32;
    Some(Sphere { center, radius })
}

fn sq(x: f64) -> f64 {
    x * x
}

fn ratio_weights<'a>(
    order: usize,
    node: &Sphere,
    leaves: impl Iterator<Item = &'a Sphere>,
    p_star: [f64; 3],
) -> Result<[f32; MAX_ORDER], ShadowError> {
    let mut f_d = [0.0; MAX_COEFFS];
    for s in leaves {
        add_log_f64(order, s, p_star, 1.0, &mut f_d);
    }
    weights_from(order, node, &f_d, p_star)
}

fn weights_from(
    order: usize,
    node: &Sphere,
    f_d: &[f64; MAX_COEFFS],
    p_star: [f64; 3],
) -> Result<[f32; MAX_ORDER], ShadowError> {
    let mut f_b = [0.0; MAX_COEFFS];
    add_log_f64(order, node, p_star, 1.0, &mut f_b);
    let mut w = [0.0f64; MAX_ORDER];
    ratio_vector(&f_b, f_d, order, &mut w)?;
    let mut out = [0.0f32; MAX_ORDER];
    for l in 0..order {
        out[l] = w[l] as f32;
    }
    Ok(out)
}

/// The blocker sphere that stands in for (`center`, `radius`) at receiver `p` with unit normal
/// `normal` under the self-shadowing rules (see the module docs): `None` when removed, the sphere
/// itself when entirely in front of the tangent plane, a tangent sphere when straddling it.
#[must_use]
pub fn self_shadow_sphere(center: [f32; 3], radius: f32, p: [f32; 3], normal: [f32; 3]) -> Option<([f32; 3], f32)> {
    let d = [center[0] - p[0], center[1] - p[1], center[2] - p[2]];
    let h = d[0] * normal[0] + d[1] * normal[1] + d[2] * normal[2];
    // NaN fails every comparison below and is removed.
    if h >= radius {
        return Some((center, radius));
    }
    if h.is_nan() || h <= -radius {
        return None;
    }
    // Straddling. q1 = P − hN; ρ² = |d|² − h² (d − hN is q1 − p, orthogonal to N).
    let rho = sqrt_f32((d[0] * d[0] + d[1] * d[1] + d[2] * d[2] - h * h).max(0.0));
    let disc = sqrt_f32((radius * radius - h * h).max(0.0));
    let r_in = h.max(0.0);
    let r_out = 0.5 * (radius + h);
    let a = if disc > 0.0 { ((rho - disc) / disc).clamp(0.0, 1.0) } else { 1.0 };
    let r_new = r_in + (r_out - r_in) * a;
    if r_new.is_nan() || r_new <= 0.0 {
        return None;
    }
    // Centre q1 + R N = P + (R − h) N.
    let k = r_new - h;
    Some(([center[0] + k * normal[0], center[1] + k * normal[1], center[2] + k * normal[2]], r_new))
}

/// Adds the log-visibility vectors of `blockers` seen from receiver `p` with normal `normal`
/// (scaled to unit length; self-shadowing rules applied, eq. 38) to `out[0..order²]`; returns how many blockers were
/// accumulated (the rest were removed as entirely behind the tangent plane or degenerate).
///
/// Allocation-free. Pass `normal = None` to skip the self-shadowing rules (a receiver that is not
/// on a surface).
///
/// # Errors
///
/// Order outside 1..=8, `out` shorter than order², `normal` zero or not finite.
pub fn accumulate_log_visibility(
    blockers: &[Blocker],
    order: usize,
    p: [f32; 3],
    normal: Option<[f32; 3]>,
    out: &mut [f32],
) -> Result<usize, ShadowError> {
    check_order(order)?;
    let normal = normal.map(|n| unit_normal_f32("normal", n)).transpose()?;
    check_len("out", coeff_count(order), out.len())?;
    let mut used = 0;
    for b in blockers {
        let (c, r) = match normal {
            Some(n) => match self_shadow_sphere(b.center, b.radius, p, n) {
                Some(s) => s,
                None => continue,
            },
            None => (b.center, b.radius),
        };
        let d = [c[0] - p[0], c[1] - p[1], c[2] - p[2]];
        let d2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        if d2.is_nan() || d2 <= 0.0 || !d2.is_finite() {
            continue;
        }
        let inv = rsqrt_f32(d2);
        let theta = asin_f32(r * inv);
        accumulate_log_visibility_f32(theta, [d[0] * inv, d[1] * inv, d[2] * inv], &b.band_weights[..order], out)?;
        used += 1;
    }
    Ok(used)
}

/// Shading with a visibility vector: T · g over the first order² coefficients.
#[must_use]
pub fn shade(shading_vector: &[f64], visibility: &[f64]) -> f64 {
    shading_vector.iter().zip(visibility).map(|(a, b)| a * b).sum()
}

/// Order, SH exponential and the triple-product tensor of the queries: built once (allocates).
#[derive(Clone, Debug)]
pub struct ShadowContext {
    order: usize,
    exp: ExpMethod,
    tp: TripleProduct,
}

impl ShadowContext {
    /// A context of SH `order` (1..=8) with exponential `exp`.
    ///
    /// # Errors
    ///
    /// Order outside 1..=8, or the tensor could not be allocated.
    pub fn new(order: usize, exp: ExpMethod) -> Result<ShadowContext, ShadowError> {
        check_order(order)?;
        Ok(ShadowContext { order, exp, tp: TripleProduct::new(order)? })
    }

    /// The SH order.
    #[must_use]
    pub fn order(&self) -> usize {
        self.order
    }

    /// The exponential method.
    #[must_use]
    pub fn exp_method(&self) -> ExpMethod {
        self.exp
    }

    /// The triple-product tensor of the order.
    #[must_use]
    pub fn triple_product(&self) -> &TripleProduct {
        &self.tp
    }

    /// Visibility vector g = exp*(log) (f64) into `out[0..order²]`. Allocation-free.
    ///
    /// A log vector longer than [`MAX_LOG_NORM`] (its whole Euclidean norm, the DC term included)
    /// is first scaled down to that length: see there.
    ///
    /// # Errors
    ///
    /// `log` or `out` shorter than order².
    pub fn visibility(&self, log: &[f32], out: &mut [f64]) -> Result<(), ShadowError> {
        let nc = coeff_count(self.order);
        check_len("log", nc, log.len())?;
        check_len("out", nc, out.len())?;
        let mut f = [0.0f64; MAX_COEFFS];
        for (d, s) in f.iter_mut().zip(&log[..nc]) {
            *d = f64::from(*s);
        }
        let norm = crate::refit::sqrt(f[..nc].iter().map(|v| v * v).sum());
        if norm > MAX_LOG_NORM {
            let s = MAX_LOG_NORM / norm;
            for v in &mut f[..nc] {
                *v *= s;
            }
        }
        match self.exp {
            ExpMethod::PsStar { degree } => sh_exp_ps_star(&self.tp, &f[..nc], usize::from(degree), out)?,
            ExpMethod::Hyb { ol_norm_bound } => sh_exp_hyb(&self.tp, &f[..nc], f64::from(ol_norm_bound), out)?,
            ExpMethod::Accurate => sh_exp_accurate(&self.tp, &f[..nc], out)?,
        }
        Ok(())
    }

    /// The shading vector T = L ∗ H(N) (Ren §7) for lighting `light` (order² radiance
    /// coefficients) and normal `normal` (scaled to unit length), with H(N)_lm = (A_l/π) y_lm(N) the clamped cosine
    /// about N (Ramamoorthi–Hanrahan A_l), into `out[0..order²]`. Shaded value = T · g
    /// ([`shade`]); for `light` = **1** (uniform white, [`uniform_light`]) and g = **1** it is 1.
    ///
    /// # Errors
    ///
    /// `light` or `out` shorter than order²; `normal` zero or not finite.
    pub fn shading_vector(&self, light: &[f64], normal: [f64; 3], out: &mut [f64]) -> Result<(), ShadowError> {
        let normal = unit_normal("normal", normal)?;
        let n = self.order;
        let nc = coeff_count(n);
        check_len("light", nc, light.len())?;
        check_len("out", nc, out.len())?;
        let mut h = [0.0; MAX_COEFFS];
        let mut a = [0.0; MAX_ORDER];
        clamped_cosine_convolution(n, &mut a)?;
        eval_sh_f64(n, normal, &mut h)?;
        for l in 0..n {
            for i in l * l..(l + 1) * (l + 1) {
                h[i] *= a[l] / core::f64::consts::PI;
            }
        }
        self.tp.product(&light[..nc], &h[..nc], out)?;
        Ok(())
    }

    /// The shaded value at receiver `p` (normal `normal`, scaled to unit length) for the cluster's
    /// blockers and a shading vector from [`ShadowContext::shading_vector`]: accumulate,
    /// exponentiate, dot. Allocation-free.
    ///
    /// # Errors
    ///
    /// The cluster was built for another order; `shading_vector` shorter than order²; `p` not
    /// finite; `normal` zero or not finite.
    pub fn shade_point(
        &self,
        blockers: &ClusterBlockers,
        p: [f32; 3],
        normal: [f32; 3],
        shading_vector: &[f64],
    ) -> Result<f64, ShadowError> {
        if blockers.order == 0 {
            return Err(ShadowError::NotBuilt);
        }
        if blockers.order != self.order {
            return Err(ShadowError::OrderMismatch { built: blockers.order, context: self.order });
        }
        check_point("p", p)?;
        let normal = unit_normal_f32("normal", normal)?;
        let nc = coeff_count(self.order);
        check_len("shading_vector", nc, shading_vector.len())?;
        let mut log = [0.0f32; MAX_COEFFS];
        accumulate_log_visibility(&blockers.blockers, self.order, p, Some(normal), &mut log[..nc])?;
        let mut g = [0.0f64; MAX_COEFFS];
        self.visibility(&log[..nc], &mut g[..nc])?;
        Ok(shade(&shading_vector[..nc], &g[..nc]))
    }
}

/// The longest log-visibility vector [`ShadowContext::visibility`] exponentiates (Euclidean norm
/// of its order² coefficients, the DC term included); a longer one is scaled down to this length
/// first. The SH exponentials square a truncated series p ≈ log₂‖f̂‖ times, and past a few hundred
/// the truncation error grows with every squaring: for n copies of one sphere seen at 41.8°
/// (order 4) PS*-4's shaded value falls with n as it should up to a norm of about 300 (n = 128)
/// and then rises again, to 330 (against at most 1) at n = 1000 and NaN at n = 4096; HYB is NaN
/// there too. Logs that long only come from many spheres blocking the same directions, where the
/// visibility is already about 0, so a shorter vector of the same shape gives that answer. The
/// longest seen in real bakes (the receivers of `spherebake shadows` and `spherebake light` on the
/// bunny, the armadillo, spot, the teapot, CesiumMan, the Duck, the Fox, the milk truck and the
/// Stanford dragon at 64 and 256 spheres) is 204 (the Duck's ground at 256), so they are not scaled.
pub const MAX_LOG_NORM: f64 = 256.0;

/// Directions of [`ClusterBlockers::correct_overlap`] at most (its cost is directions × blockers).
pub const MAX_OVERLAP_DIRECTIONS: usize = 65_536;

/// `Err(Argument)` unless every coordinate of `p` is finite.
pub(crate) fn check_point(argument: &'static str, p: [f32; 3]) -> Result<(), ShadowError> {
    if p.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(ShadowError::Argument { argument, expected: "finite" })
    }
}

/// `Err(Argument)` unless the receiver ball and the cut threshold of a cluster build (or of a cut,
/// `crate::cut::cut`) are usable: a finite centre, a radius finite and ≥ 0, 0 ≤ θmax ≤ π radians.
pub fn check_receiver(center: [f32; 3], radius: f32, theta_max_rad: f32) -> Result<(), ShadowError> {
    check_point("receiver_center", center)?;
    if !(radius >= 0.0 && radius.is_finite()) {
        return Err(ShadowError::Argument { argument: "receiver_radius", expected: "finite and ≥ 0" });
    }
    check_angle("theta_max_rad", f64::from(theta_max_rad))
}

/// `Err(Argument)` unless every sphere has a finite centre and a finite radius ≥ 0 (a posed proxy from a joint
/// matrix with a NaN, or a caller's own spheres, would otherwise give plausible-looking values).
pub(crate) fn check_spheres(argument: &'static str, spheres: &[Sphere]) -> Result<(), ShadowError> {
    match first_unusable_sphere(spheres) {
        None => Ok(()),
        Some(_) => {
            Err(ShadowError::Argument { argument, expected: "spheres with finite centres and finite radii ≥ 0" })
        }
    }
}

/// The index of the first sphere without a finite centre and a finite radius ≥ 0 (the rule every
/// cluster build, refit and cut applies to its spheres), or `None` when all are usable.
#[must_use]
pub fn first_unusable_sphere(spheres: &[Sphere]) -> Option<usize> {
    spheres.iter().position(|s| !(s.center.iter().all(|v| v.is_finite()) && s.radius.is_finite() && s.radius >= 0.0))
}

/// `n` at unit length: as it is when |n|² is within 10⁻⁶ of 1 (so unit normals keep their bits), else divided by
/// |n|. `Err(Argument)` unless `n` is finite and not zero: a normal need not be unit (interpolated vertex normals
/// are not), but it must have a direction.
pub(crate) fn unit_normal(argument: &'static str, n: [f64; 3]) -> Result<[f64; 3], ShadowError> {
    let len2 = n[0] * n[0] + n[1] * n[1] + n[2] * n[2];
    if !(len2.is_finite() && len2 > 0.0) {
        return Err(ShadowError::Argument { argument, expected: "a finite, non-zero vector" });
    }
    if (len2 - 1.0).abs() <= 1e-6 {
        return Ok(n);
    }
    let len = crate::refit::sqrt(len2);
    Ok(n.map(|v| v / len))
}

/// [`unit_normal`] of an f32 vector (the same rule; the result rounded to f32).
pub(crate) fn unit_normal_f32(argument: &'static str, n: [f32; 3]) -> Result<[f32; 3], ShadowError> {
    let len2 = n.iter().map(|&v| f64::from(v) * f64::from(v)).sum::<f64>();
    if len2.is_finite() && (len2 - 1.0).abs() <= 1e-6 {
        return Ok(n);
    }
    Ok(unit_normal(argument, n.map(f64::from))?.map(|v| v as f32))
}

/// `Err(Argument)` unless 0 ≤ `a` ≤ π (radians).
fn check_angle(argument: &'static str, a: f64) -> Result<(), ShadowError> {
    // An f32 π rounds above the f64 one.
    if (0.0..=core::f64::consts::PI + 1e-6).contains(&a) {
        Ok(())
    } else {
        Err(ShadowError::Argument { argument, expected: "in [0, π] radians" })
    }
}

/// Uniform white light of unit radiance: **1** = (√(4π), 0, …) into `out[0..order²]`.
pub fn uniform_light(order: usize, out: &mut [f64]) {
    let nc = coeff_count(order.min(MAX_ORDER)).min(out.len());
    out[..nc].fill(0.0);
    if let Some(o) = out.first_mut() {
        if nc > 0 {
            *o = SQRT_4PI;
        }
    }
}

/// A directional-ish lobe of light: radiance 1 inside the cone of half-angle `half_angle_rad`
/// about the unit `direction`, projected to SH `order` (zonal cap coefficients rotated to the
/// direction, math reference §2) and windowed by Ren's a_l = cos(πl/(4·order)) against ringing,
/// into `out[0..order²]`.
///
/// # Errors
///
/// Order outside 1..=8, `out` shorter than order².
pub fn lobe_light(order: usize, direction: [f64; 3], half_angle_rad: f64, out: &mut [f64]) -> Result<(), ShadowError> {
    check_order(order)?;
    check_len("out", coeff_count(order), out.len())?;
    let len2 = direction.iter().map(|x| x * x).sum::<f64>();
    if !(len2 > 0.0 && len2.is_finite()) {
        return Err(ShadowError::Argument { argument: "direction", expected: "finite and not zero" });
    }
    check_angle("half_angle_rad", half_angle_rad)?;
    let mut g = [0.0; MAX_ORDER];
    let mut w = [0.0; MAX_ORDER];
    cap_zh(half_angle_rad, order, &mut g)?;
    ren_window(order, &mut w)?;
    for l in 0..order {
        g[l] *= w[l];
    }
    zh_rotate(&g[..order], direction, out)?;
    Ok(())
}

/// √x in f32 without a math library: reciprocal square root by bit guess and three Newton steps
/// (relative error ≲ 2e-7). Negative or NaN → NaN, 0 → 0, ∞ → ∞.
#[must_use]
pub fn sqrt_f32(x: f32) -> f32 {
    if x == 0.0 || x == f32::INFINITY {
        return x;
    }
    x * rsqrt_f32(x)
}

/// 1/√x in f32 (x > 0 finite; relative error ≲ 2e-7); NaN for x < 0 or NaN, ∞ for 0.
#[must_use]
pub fn rsqrt_f32(x: f32) -> f32 {
    if x.is_nan() || x < 0.0 {
        return f32::NAN;
    }
    if x == 0.0 {
        return f32::INFINITY;
    }
    if x < 1e-30 {
        // Keep the bit guess away from subnormals: 1/√(x·2⁶⁴) · 2³².
        return rsqrt_f32(x * 18_446_744_073_709_551_616.0) * 4_294_967_296.0;
    }
    let mut y = f32::from_bits(0x5F37_59DF - (x.to_bits() >> 1));
    let hx = 0.5 * x;
    for _ in 0..3 {
        y *= 1.5 - hx * y * y;
    }
    y
}

/// asin(x) in radians for x in [0, 1] (clamped; NaN → 0), f32, absolute error ≲ 5e-7:
/// Cephes' `asinf` polynomial, with asin x = π/2 − 2 asin √((1 − x)/2) above 1/2.
#[must_use]
pub fn asin_f32(x: f32) -> f32 {
    let x = if x > 0.0 { x.min(1.0) } else { 0.0 };
    let poly =
        |z: f32| (((4.216_32e-2 * z + 2.418_131e-2) * z + 4.547_002_6e-2) * z + 7.495_300_3e-2) * z + 1.666_675_2e-1;
    if x > 0.5 {
        let z = 0.5 * (1.0 - x);
        let s = sqrt_f32(z);
        core::f32::consts::FRAC_PI_2 - 2.0 * (s + s * z * poly(z))
    } else {
        let z = x * x;
        x + x * z * poly(z)
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;

    #[test]
    fn asin_and_sqrt_match_std() {
        for k in 0..=20000 {
            let x = k as f32 / 20000.0;
            let e = (x as f64).asin();
            assert!((asin_f32(x) as f64 - e).abs() < 5e-7, "asin {x}: {} vs {e}", asin_f32(x));
        }
        assert_eq!(asin_f32(f32::NAN), 0.0);
        assert_eq!(asin_f32(-0.5), 0.0);
        assert!((asin_f32(3.0) - core::f32::consts::FRAC_PI_2).abs() < 1e-6);
        let mut x = 1e-38f32;
        while x < 1e38 {
            let e = (x as f64).sqrt();
            assert!(((sqrt_f32(x) as f64) - e).abs() < 3e-7 * e, "sqrt {x}");
            x *= 1.37;
        }
        assert!(sqrt_f32(-1.0).is_nan() && sqrt_f32(f32::NAN).is_nan());
        assert_eq!(sqrt_f32(0.0), 0.0);
    }
}
