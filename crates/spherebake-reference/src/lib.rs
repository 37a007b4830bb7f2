//! Ground truth for the end-to-end light check (issue 14): Monte Carlo direct and one-bounce
//! indirect irradiance of a triangle mesh standing on a ground plane under an SH sky, ray traced
//! through [`spherebake_geom::bvh::TriangleBvh`] with the bake's own albedo lookup
//! ([`spherebake_bake::SurfaceAlbedo`]).
//!
//! # Scene
//! - The (possibly posed) mesh, +Y up, standing on the infinite ground plane y = y_min (the
//!   smallest y of any triangle corner). Units are the mesh's.
//! - **Ground receivers** ([`Scene::ground_receivers`]): a `res × res` grid of cell centres on a
//!   square of side 3 × the larger horizontal (x or z) extent of the mesh's bounding box, centred
//!   under it, normal +Y; index = row · res + column, row along z, column along x (the layout of
//!   `spherebake shadows`).
//! - **Model receivers** ([`Scene::model_receivers`]): `m` area-weighted points on the mesh,
//!   stratified along the triangle-area CDF and seeded, each with its triangle, barycentrics and
//!   outward shading normal.
//! - **Outward normals** as the sample placement does: the geometric normal of each triangle is
//!   oriented by the solid ([`spherebake_geom::orient::outward_orientation`] on the welded rest
//!   mesh; posing does not change which side is out), the shading normal is the interpolated
//!   vertex normal, negated when it points against the oriented geometric normal (the geometric
//!   normal when there is no usable vertex normal). A posed mesh's vertex normals are the rest
//!   normals turned by the rotation that takes each welded vertex's area-weighted rest normal to
//!   its posed one ([`posed_normals`]).
//!
//! # Light
//! - **Sky** ([`Sky`]): an SH environment (real orthonormal SH, Condon–Shortley phase, index
//!   l(l+1)+m, [`spherebake_sh::eval_sh_f64`]) evaluated pointwise and clamped at ≥ 0, grey
//!   (the same radiance in R, G and B). The ground is an infinite occluder: the sky radiance is 0
//!   for every direction with ω_y ≤ 0.
//! - **The ground reflects nothing**: its own bounce is excluded everywhere (it neither lights the
//!   model nor itself). The sphere proxy models the light the *model* reflects; an engine lights
//!   its ground's own bounce by other means, so the check compares exactly that part.
//! - **Direct irradiance** E_d(x) = ∫ sky(ω) · [ray x + tω does not hit the mesh] · max(0, n·ω) dω.
//! - **One-bounce indirect irradiance** E_i(x) = ∫ L1(y(ω)) max(0, n·ω) dω over the directions
//!   whose ray from x hits the mesh first at y, with the diffuse exit radiance
//!   L1(y) = albedo(y)/π · E_d(y) (albedo at the hit's triangle and barycentrics, level of detail 0;
//!   E_d(y) about the outward shading normal at y, estimated with a few shadow rays per hit).
//!   Rays that miss the mesh and go below the horizon hit the ground and contribute 0. Rays pass
//!   through the holes of alpha-masked materials (glTF `alphaMode` `MASK`: alpha below the cutoff
//!   at level 0, [`spherebake_bake::SurfaceAlbedo::is_hole`], as the albedo bake sees through
//!   them), for visibility and for the bounce alike, up to
//!   [`spherebake_bake::MAX_HOLES_PER_RAY`] holes per ray. Surfaces
//!   are two-sided: a ray that reaches a triangle from its inner side sees that side lit about
//!   the reversed normals (for a closed mesh and receivers outside it this never happens).
//!
//! All irradiances are linear RGB (direct: one grey value), E = ∫ L cos dω, so a uniform sky of
//! radiance 1 gives E_d = π on an unoccluded ground point.
//!
//! # Estimator
//! Cosine-weighted directions about the receiver's shading normal (Malley's method on stratified
//! (u₁, u₂) ∈ [0, 1)², `s × s` strata with s = ⌈√rays⌉), so E_d ≈ π/N Σ sky(ω_k)·V_k and
//! E_i ≈ 1/N Σ albedo(y_k)·E_d(y_k). Directions with n_geo·ω ≤ 0 (below the receiver's own
//! geometric surface, possible where the shading normal differs from it) contribute 0. Ray
//! origins are offset by 2ε along the geometric normal and casts start at t = ε, with
//! ε = 1e-5 × the bounding-box diagonal. Jitter comes from SplitMix64 seeded per receiver
//! (seed, receiver index) and per stratum; receivers run in parallel with rayon and collect in
//! order, so results are bit-identical for any thread count.
//!
//! # Analytic cases
//! [`analytic`]: a diffuse sphere above the ground ([`analytic::sphere_one_bounce`], by
//! deterministic quadrature) and a UV-sphere mesh builder to compare the Monte Carlo reference
//! against it.

pub mod analytic;

use glam::{DVec3, Quat, Vec3};
use rayon::prelude::*;
use spherebake_bake::{AlbedoError, SurfaceAlbedo};
use spherebake_geom::bvh::TriangleBvh;
use spherebake_geom::orient::{oriented_normal, outward_orientation};
use spherebake_geom::winding::WindingNumber;
use spherebake_geom::Mesh;
use spherebake_sh::{coeff_count, eval_sh_f64, ShError, MAX_COEFFS, MAX_ORDER};
use std::f64::consts::PI;

/// Everything that can stop a reference computation.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum ReferenceError {
    /// The mesh's materials, colours or textures are inconsistent.
    #[error("albedo: {0}")]
    Albedo(#[from] AlbedoError),
    /// The SH sky is invalid.
    #[error("SH sky: {0}")]
    Sh(#[from] ShError),
    /// The mesh has no triangle with finite corners.
    #[error("the mesh has no finite triangles")]
    EmptyMesh,
    /// The mesh's bounding box has no horizontal extent (the ground square would be empty).
    #[error("the mesh has no horizontal extent")]
    NoHorizontalExtent,
    /// Posed positions do not match the mesh's vertex count.
    #[error("{actual} posed positions given, the mesh has {expected} vertices")]
    PositionsLength { expected: usize, actual: usize },
    /// A setting is out of range.
    #[error("{name} = {value} is out of range (expected {expected})")]
    InvalidSetting { name: &'static str, value: f64, expected: &'static str },
    /// A sky coefficient is not finite.
    #[error("sky coefficient {index} is not finite")]
    NonFiniteSky { index: usize },
    /// A model receiver names a triangle the mesh does not have.
    #[error("receiver {receiver} names triangle {triangle}, the mesh has {triangle_count}")]
    ReceiverTriangle { receiver: usize, triangle: usize, triangle_count: usize },
}

// ---------------------------------------------------------------------------------------------
// Sky

/// A grey SH sky: radiance(ω) = max(0, Σ c_i y_i(ω)) for ω_y > 0, 0 below the horizon.
#[derive(Clone, Debug, PartialEq)]
pub struct Sky {
    order: usize,
    coeffs: Vec<f64>,
}

impl Sky {
    /// A sky from `order²` real orthonormal SH coefficients (order 1..=8).
    ///
    /// # Errors
    /// Order outside 1..=8, fewer than order² coefficients, non-finite coefficients.
    pub fn new(order: usize, coeffs: &[f64]) -> Result<Sky, ReferenceError> {
        if !(1..=MAX_ORDER).contains(&order) {
            return Err(ReferenceError::InvalidSetting { name: "sky order", value: order as f64, expected: "1..=8" });
        }
        let nc = coeff_count(order);
        if coeffs.len() < nc {
            return Err(ReferenceError::Sh(ShError::BufferTooShort {
                buffer: "sky coefficients",
                expected: nc,
                actual: coeffs.len(),
            }));
        }
        if let Some(index) = coeffs[..nc].iter().position(|c| !c.is_finite()) {
            return Err(ReferenceError::NonFiniteSky { index });
        }
        Ok(Sky { order, coeffs: coeffs[..nc].to_vec() })
    }

    /// The uniform sky of radiance `radiance` over the upper hemisphere (order 1).
    ///
    /// # Errors
    /// A non-finite radiance.
    pub fn uniform(radiance: f64) -> Result<Sky, ReferenceError> {
        Sky::new(1, &[radiance * (4.0 * PI).sqrt()])
    }

    /// SH order.
    pub fn order(&self) -> usize {
        self.order
    }

    /// The SH coefficients (order² of them).
    pub fn coefficients(&self) -> &[f64] {
        &self.coeffs
    }

    /// When only the constant term is non-zero: the constant radiance above the horizon (≥ 0).
    pub fn constant(&self) -> Option<f64> {
        if self.coeffs[1..].iter().all(|&c| c == 0.0) {
            Some((self.coeffs[0] * 0.5 / PI.sqrt()).max(0.0))
        } else {
            None
        }
    }

    /// Radiance arriving from unit direction `dir` (travelling towards −dir): 0 for dir_y ≤ 0,
    /// else the SH sum clamped at ≥ 0.
    pub fn radiance(&self, dir: [f64; 3]) -> f64 {
        if dir[1].is_nan() || dir[1] <= 0.0 {
            return 0.0;
        }
        let nc = self.coeffs.len();
        let mut y = [0.0f64; MAX_COEFFS];
        if eval_sh_f64(self.order, dir, &mut y[..nc]).is_err() {
            return 0.0;
        }
        let v: f64 = self.coeffs.iter().zip(&y[..nc]).map(|(c, y)| c * y).sum();
        if v > 0.0 {
            v
        } else {
            0.0
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Receivers and settings

/// A point where irradiance is measured.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Receiver {
    /// Position, model space.
    pub position: [f64; 3],
    /// Unit shading normal (outward for model receivers, +Y on the ground).
    pub normal: [f64; 3],
    /// For model receivers: the triangle (index into `mesh.triangles`) and the barycentric
    /// weights of its corners; `None` for free receivers (the ground, or any point whose normal
    /// stands for its surface: directions below the plane of `normal` contribute 0).
    pub surface: Option<(usize, [f64; 3])>,
}

/// Monte Carlo settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReferenceSettings {
    /// Rays per receiver, cosine-weighted over its hemisphere (rounded up to a square number of
    /// strata). Default 1024, range 1..=2²⁰.
    pub rays: usize,
    /// Shadow rays per indirect hit for E_d(y) (rounded up to a square). Default 4, range 1..=1024.
    pub shadow_rays: usize,
    /// Seed of the jitter.
    pub seed: u64,
}

impl Default for ReferenceSettings {
    fn default() -> Self {
        Self { rays: 1024, shadow_rays: 4, seed: 1 }
    }
}

impl ReferenceSettings {
    fn check(&self) -> Result<(), ReferenceError> {
        if !(1..=1 << 20).contains(&self.rays) {
            return Err(ReferenceError::InvalidSetting {
                name: "rays",
                value: self.rays as f64,
                expected: "1..=1048576",
            });
        }
        if !(1..=1024).contains(&self.shadow_rays) {
            return Err(ReferenceError::InvalidSetting {
                name: "shadow_rays",
                value: self.shadow_rays as f64,
                expected: "1..=1024",
            });
        }
        Ok(())
    }
}

/// A per-receiver estimate with its standard error (from the sample variance of the ray
/// contributions, which over-estimates the error of the stratified estimate: conservative).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimate {
    /// Linear RGB irradiance.
    pub value: [f64; 3],
    /// Standard error per channel.
    pub std_error: [f64; 3],
}

// ---------------------------------------------------------------------------------------------
// Scene

/// A mesh on the ground plane, ready for ray casts (see the crate docs).
pub struct Scene<'a> {
    mesh: &'a Mesh,
    albedo: SurfaceAlbedo<'a>,
    /// Per vertex, the (posed) positions the scene uses.
    positions: Vec<Vec3>,
    /// Per vertex, unit shading normals of the (posed) mesh; empty when the mesh has none.
    normals: Vec<DVec3>,
    /// Per triangle: outward unit geometric normal (None for degenerate triangles).
    geo: Vec<Option<DVec3>>,
    bvh: TriangleBvh,
    lo: DVec3,
    hi: DVec3,
    eps: f64,
}

impl<'a> Scene<'a> {
    /// The mesh in its rest pose (`mesh.positions`).
    ///
    /// # Errors
    /// See [`Scene::with_positions`].
    pub fn new(mesh: &'a Mesh) -> Result<Scene<'a>, ReferenceError> {
        Scene::with_positions(mesh, mesh.positions.clone())
    }

    /// The mesh with its vertices moved to `positions` (one per `mesh.positions` entry, e.g. from
    /// `spherebake_geom::anim::skin_vertices`); shading normals follow by [`posed_normals`].
    ///
    /// # Errors
    /// Wrong position count, inconsistent materials/textures/colours, vertex indices out of range,
    /// no finite triangle, no horizontal extent.
    pub fn with_positions(mesh: &'a Mesh, positions: Vec<Vec3>) -> Result<Scene<'a>, ReferenceError> {
        if positions.len() != mesh.positions.len() {
            return Err(ReferenceError::PositionsLength { expected: mesh.positions.len(), actual: positions.len() });
        }
        // Checks vertex indices, materials, colours and textures.
        let albedo = SurfaceAlbedo::new(mesh)?;
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for t in &mesh.triangles {
            let c = t.map(|v| positions[v as usize].as_dvec3());
            if c.iter().all(|p| p.is_finite()) {
                for p in c {
                    lo = lo.min(p);
                    hi = hi.max(p);
                }
            }
        }
        if !(lo.is_finite() && hi.is_finite()) {
            return Err(ReferenceError::EmptyMesh);
        }
        if (hi.x - lo.x).max(hi.z - lo.z) <= 0.0 {
            return Err(ReferenceError::NoHorizontalExtent);
        }
        let flip = rest_orientation(mesh);
        let geo: Vec<Option<DVec3>> = mesh
            .triangles
            .iter()
            .enumerate()
            .map(|(t, tri)| {
                let c = tri.map(|v| positions[v as usize].as_dvec3());
                if !c.iter().all(|p| p.is_finite()) {
                    return None;
                }
                oriented_normal(c, flip.get(t).copied().unwrap_or(false))
            })
            .collect();
        let normals = if mesh.normals.len() == mesh.positions.len() {
            let n = if positions == mesh.positions { mesh.normals.clone() } else { posed_normals(mesh, &positions) };
            n.iter().map(|v| v.as_dvec3()).collect()
        } else {
            Vec::new()
        };
        let bvh = TriangleBvh::new(&positions, &mesh.triangles);
        let eps = 1e-5 * (hi - lo).length();
        Ok(Scene { mesh, albedo, positions, normals, geo, bvh, lo, hi, eps })
    }

    /// The mesh.
    pub fn mesh(&self) -> &'a Mesh {
        self.mesh
    }

    /// The per-vertex positions the scene uses (posed or rest).
    pub fn positions(&self) -> &[Vec3] {
        &self.positions
    }

    /// Bounding box of the (posed) triangles, model space.
    pub fn bounds(&self) -> ([f64; 3], [f64; 3]) {
        (self.lo.to_array(), self.hi.to_array())
    }

    /// Height of the ground plane (the smallest y of the mesh).
    pub fn ground_y(&self) -> f64 {
        self.lo.y
    }

    /// Side of the ground square: 3 × the larger horizontal extent.
    pub fn ground_side(&self) -> f64 {
        3.0 * (self.hi.x - self.lo.x).max(self.hi.z - self.lo.z)
    }

    /// Position of ground receiver (column i along x, row j along z) of a `res × res` grid.
    pub fn ground_point(&self, res: usize, i: usize, j: usize) -> [f64; 3] {
        let side = self.ground_side();
        let cell = side / res as f64;
        let (cx, cz) = (0.5 * (self.lo.x + self.hi.x), 0.5 * (self.lo.z + self.hi.z));
        [cx - 0.5 * side + (i as f64 + 0.5) * cell, self.lo.y, cz - 0.5 * side + (j as f64 + 0.5) * cell]
    }

    /// The `res × res` ground receivers (index j · res + i; see the crate docs).
    ///
    /// # Errors
    /// `res` outside 1..=4096.
    pub fn ground_receivers(&self, res: usize) -> Result<Vec<Receiver>, ReferenceError> {
        if !(1..=4096).contains(&res) {
            return Err(ReferenceError::InvalidSetting { name: "resolution", value: res as f64, expected: "1..=4096" });
        }
        Ok((0..res * res)
            .map(|k| Receiver {
                position: self.ground_point(res, k % res, k / res),
                normal: [0.0, 1.0, 0.0],
                surface: None,
            })
            .collect())
    }

    /// `m` receivers on the mesh: receiver k picks the triangle where the area CDF reaches
    /// (k + u)/m (u jittered per k), then a uniform point in it; normal = outward shading normal.
    ///
    /// # Errors
    /// `m` above 2²⁴; a mesh with zero total area gives no receivers (not an error).
    pub fn model_receivers(&self, m: usize, seed: u64) -> Result<Vec<Receiver>, ReferenceError> {
        if m > 1 << 24 {
            return Err(ReferenceError::InvalidSetting {
                name: "model receivers",
                value: m as f64,
                expected: "0..=16777216",
            });
        }
        let mut cdf = Vec::with_capacity(self.mesh.triangles.len());
        let mut total = 0.0;
        for (t, tri) in self.mesh.triangles.iter().enumerate() {
            if self.geo[t].is_some() {
                let [a, b, c] = tri.map(|v| self.positions[v as usize].as_dvec3());
                total += 0.5 * (b - a).cross(c - a).length();
            }
            cdf.push(total);
        }
        if !(total > 0.0 && total.is_finite()) {
            return Ok(Vec::new());
        }
        let mut out = Vec::with_capacity(m);
        for k in 0..m {
            let h = mix(seed ^ mix(0x5EED_0000_0000_0000 ^ k as u64));
            let target = (k as f64 + unit(h)) / m as f64 * total;
            let t = cdf.partition_point(|&c| c <= target).min(cdf.len() - 1);
            // First triangle with positive area at or after the CDF step.
            let t = (t..cdf.len()).find(|&t| self.geo[t].is_some()).unwrap_or(t);
            let (r1, r2) = (unit(mix(h ^ 1)), unit(mix(h ^ 2)));
            let s = r1.sqrt();
            let bary = [1.0 - s, s * (1.0 - r2), s * r2];
            let Some((p, _g, n)) = self.surface_point(t, bary) else { continue };
            out.push(Receiver { position: p.to_array(), normal: n.to_array(), surface: Some((t, bary)) });
        }
        Ok(out)
    }

    /// Linear RGB albedo at a surface point (level of detail 0; non-finite channels → 0).
    pub fn albedo(&self, triangle: usize, bary: [f64; 3]) -> [f64; 3] {
        self.albedo.albedo(triangle, bary, 0.0).map(|v| if v.is_finite() { v } else { 0.0 })
    }

    /// Position, outward geometric normal and outward shading normal of a surface point.
    fn surface_point(&self, t: usize, w: [f64; 3]) -> Option<(DVec3, DVec3, DVec3)> {
        let g = (*self.geo.get(t)?)?;
        let tri = self.mesh.triangles[t];
        let c = tri.map(|v| self.positions[v as usize].as_dvec3());
        let p = c[0] * w[0] + c[1] * w[1] + c[2] * w[2];
        let mut n = g;
        if !self.normals.is_empty() {
            let s: DVec3 = (0..3).map(|k| self.normals[tri[k] as usize] * w[k]).sum();
            if let Some(s) = s.try_normalize() {
                n = if s.dot(g) < 0.0 { -s } else { s };
            }
        }
        Some((p, g, n))
    }

    /// Direct irradiance E_d at every receiver (grey; see the crate docs).
    ///
    /// # Errors
    /// Settings out of range, a receiver naming a missing triangle.
    pub fn direct(
        &self,
        sky: &Sky,
        receivers: &[Receiver],
        settings: &ReferenceSettings,
    ) -> Result<Vec<f64>, ReferenceError> {
        Ok(self.estimate(sky, receivers, settings, false)?.into_iter().map(|e| e.value[0]).collect())
    }

    /// Direct irradiance with standard errors (all three channels equal).
    ///
    /// # Errors
    /// As [`Scene::direct`].
    pub fn direct_with_error(
        &self,
        sky: &Sky,
        receivers: &[Receiver],
        settings: &ReferenceSettings,
    ) -> Result<Vec<Estimate>, ReferenceError> {
        self.estimate(sky, receivers, settings, false)
    }

    /// One-bounce indirect irradiance E_i at every receiver, linear RGB (see the crate docs).
    ///
    /// # Errors
    /// As [`Scene::direct`].
    pub fn indirect(
        &self,
        sky: &Sky,
        receivers: &[Receiver],
        settings: &ReferenceSettings,
    ) -> Result<Vec<[f64; 3]>, ReferenceError> {
        Ok(self.estimate(sky, receivers, settings, true)?.into_iter().map(|e| e.value).collect())
    }

    /// One-bounce indirect irradiance with standard errors.
    ///
    /// # Errors
    /// As [`Scene::direct`].
    pub fn indirect_with_error(
        &self,
        sky: &Sky,
        receivers: &[Receiver],
        settings: &ReferenceSettings,
    ) -> Result<Vec<Estimate>, ReferenceError> {
        self.estimate(sky, receivers, settings, true)
    }

    fn estimate(
        &self,
        sky: &Sky,
        receivers: &[Receiver],
        settings: &ReferenceSettings,
        indirect: bool,
    ) -> Result<Vec<Estimate>, ReferenceError> {
        settings.check()?;
        let tc = self.mesh.triangles.len();
        // Geometric frame of each receiver: (origin, geometric normal, shading normal).
        let mut frames = Vec::with_capacity(receivers.len());
        for (k, r) in receivers.iter().enumerate() {
            let n = DVec3::from(r.normal).try_normalize().unwrap_or(DVec3::Y);
            let g = match r.surface {
                // A free receiver (the ground, or any point with a normal): its own plane is the
                // one its normal spans.
                None => n,
                Some((t, _)) if t >= tc => {
                    return Err(ReferenceError::ReceiverTriangle { receiver: k, triangle: t, triangle_count: tc })
                }
                // A degenerate triangle has no geometric normal: use the shading normal.
                Some((t, _)) => self.geo[t].unwrap_or(n),
            };
            frames.push((DVec3::from(r.position), g, n));
        }
        let ns = strata(settings.rays);
        let ks = strata(settings.shadow_rays);
        let seed = settings.seed;
        Ok(frames
            .par_iter()
            .enumerate()
            .map(|(idx, &(x, g, n))| {
                let base = mix(seed ^ mix(idx as u64));
                let mut sum = [0.0f64; 3];
                let mut sum2 = [0.0f64; 3];
                let count = (ns * ns) as f64;
                for sa in 0..ns {
                    for sb in 0..ns {
                        let h = mix(base ^ ((sa * ns + sb) as u64));
                        let u1 = (sa as f64 + unit(h)) / ns as f64;
                        let u2 = (sb as f64 + unit(mix(h))) / ns as f64;
                        let w = cosine_direction(n, u1, u2);
                        let c = if indirect {
                            self.bounce(sky, x, g, w, h, ks)
                        } else {
                            let e = PI * self.sky_if_unblocked(sky, x, g, w);
                            [e; 3]
                        };
                        for k in 0..3 {
                            sum[k] += c[k];
                            sum2[k] += c[k] * c[k];
                        }
                    }
                }
                let mut value = [0.0; 3];
                let mut std_error = [0.0; 3];
                for k in 0..3 {
                    value[k] = sum[k] / count;
                    let var = (sum2[k] / count - value[k] * value[k]).max(0.0);
                    std_error[k] = if count > 1.0 { (var / (count - 1.0)).sqrt() } else { f64::INFINITY };
                }
                Estimate { value, std_error }
            })
            .collect())
    }

    /// Whether the open segment from `a` to `b` (model space) misses the mesh, both ends pulled in by
    /// a small tolerance (development aid: point-to-point visibility).
    #[must_use]
    pub fn segment_clear(&self, a: [f64; 3], b: [f64; 3]) -> bool {
        let (a, b) = (DVec3::from(a), DVec3::from(b));
        let d = b - a;
        let len = d.length();
        if len.is_nan() || len <= 4.0 * self.eps {
            return true;
        }
        let w = d / len;
        let o = (a + w * (2.0 * self.eps)).as_vec3();
        self.first_hit(o, w.as_vec3(), self.eps as f32, (len - 4.0 * self.eps) as f32).is_none()
    }

    /// The textured albedo of the surface just under the point `p` along its normal `n` (development aid: the
    /// first hit of a ray from p + δn along −n, δ a small multiple of the scene tolerance), or `None` on a miss.
    #[must_use]
    pub fn albedo_near(&self, p: [f64; 3], n: [f64; 3]) -> Option<[f64; 3]> {
        let (p, n) = (DVec3::from(p), DVec3::from(n).try_normalize()?);
        let o = (p + n * (50.0 * self.eps)).as_vec3();
        let hit = self.bvh.closest_hit(o, (-n).as_vec3(), 0.0, (200.0 * self.eps) as f32)?;
        let (u, v) = (f64::from(hit.u), f64::from(hit.v));
        Some(self.albedo(hit.triangle as usize, [1.0 - u - v, u, v]))
    }

    /// The first hit in (t_min, t_max) that is not a hole of an alpha-masked material
    /// ([`SurfaceAlbedo::first_opaque_hit`], holes passed by at least the scene tolerance).
    fn first_hit(&self, o: Vec3, w: Vec3, t_min: f32, t_max: f32) -> Option<spherebake_geom::bvh::Hit> {
        self.albedo.first_opaque_hit(&self.bvh, o, w, t_min, t_max, self.eps as f32)
    }

    /// sky(ω) when the ray from x (geometric normal g) along ω is not blocked by the mesh and
    /// leaves above x's own surface, else 0.
    fn sky_if_unblocked(&self, sky: &Sky, x: DVec3, g: DVec3, w: DVec3) -> f64 {
        if g.dot(w) <= 0.0 || w.y <= 0.0 {
            return 0.0;
        }
        let o = (x + g * (2.0 * self.eps)).as_vec3();
        if self.first_hit(o, w.as_vec3(), self.eps as f32, f32::INFINITY).is_some() {
            return 0.0;
        }
        sky.radiance(w.to_array())
    }

    /// albedo(y)·E_d(y) for the first mesh hit y of the ray from x along ω (0 on a miss).
    fn bounce(&self, sky: &Sky, x: DVec3, g: DVec3, w: DVec3, h: u64, ks: usize) -> [f64; 3] {
        if g.dot(w) <= 0.0 {
            return [0.0; 3];
        }
        let o = (x + g * (2.0 * self.eps)).as_vec3();
        let Some(hit) = self.first_hit(o, w.as_vec3(), self.eps as f32, f32::INFINITY) else {
            return [0.0; 3];
        };
        let t = hit.triangle as usize;
        let (u, v) = (f64::from(hit.u), f64::from(hit.v));
        let bary = [1.0 - u - v, u, v];
        let Some((y, mut gy, mut ny)) = self.surface_point(t, bary) else { return [0.0; 3] };
        if gy.dot(w) > 0.0 {
            // Reached from the inner side: that side is lit about the reversed normals.
            gy = -gy;
            ny = -ny;
        }
        let hs = mix(h ^ 0xD1B5_4A32_D192_ED03);
        let mut e = 0.0;
        for a in 0..ks {
            for b in 0..ks {
                let z = mix(hs ^ ((a * ks + b) as u64));
                let u1 = (a as f64 + unit(z)) / ks as f64;
                let u2 = (b as f64 + unit(mix(z))) / ks as f64;
                let d = cosine_direction(ny, u1, u2);
                e += self.sky_if_unblocked(sky, y, gy, d);
            }
        }
        let e = PI * e / (ks * ks) as f64;
        let alb = self.albedo(t, bary);
        [alb[0] * e, alb[1] * e, alb[2] * e]
    }
}

/// Outward orientation of the welded rest mesh (per triangle: flip the CCW normal).
fn rest_orientation(mesh: &Mesh) -> Vec<bool> {
    let welded_ok = mesh.weld.len() == mesh.positions.len()
        && mesh.weld.iter().all(|&w| (w as usize) < mesh.welded_positions.len());
    if welded_ok {
        let tris = mesh.welded_triangles();
        let winding = WindingNumber::new(&mesh.welded_positions, &tris);
        outward_orientation(&mesh.welded_positions, &tris, &winding).flip
    } else {
        let winding = WindingNumber::new(&mesh.positions, &mesh.triangles);
        outward_orientation(&mesh.positions, &mesh.triangles, &winding).flip
    }
}

/// Vertex shading normals of a posed mesh: each rest normal turned by the shortest-arc rotation
/// taking its welded vertex's area-weighted (counter-clockwise) rest normal to the posed one.
/// Vertices without a usable rest normal or neighbourhood keep their rest normal. Returns one
/// normal per vertex (`mesh.normals` is used as the rest normals; missing entries → +Y).
pub fn posed_normals(mesh: &Mesh, posed: &[Vec3]) -> Vec<Vec3> {
    let nv = mesh.positions.len();
    let key = |v: usize| -> usize {
        match mesh.weld.get(v) {
            Some(&w) if mesh.weld.len() == nv => w as usize,
            _ => v,
        }
    };
    let nk = if mesh.weld.len() == nv {
        mesh.welded_positions.len().max(1 + mesh.weld.iter().copied().max().unwrap_or(0) as usize)
    } else {
        nv
    };
    let mut rest = vec![DVec3::ZERO; nk];
    let mut pose = vec![DVec3::ZERO; nk];
    for t in &mesh.triangles {
        let idx = t.map(|v| v as usize);
        if idx.iter().any(|&v| v >= nv || v >= posed.len()) {
            continue;
        }
        let r = idx.map(|v| mesh.positions[v].as_dvec3());
        let p = idx.map(|v| posed[v].as_dvec3());
        let nr = (r[1] - r[0]).cross(r[2] - r[0]);
        let np = (p[1] - p[0]).cross(p[2] - p[0]);
        if !(nr.is_finite() && np.is_finite()) {
            continue;
        }
        for &v in &idx {
            rest[key(v)] += nr;
            pose[key(v)] += np;
        }
    }
    (0..nv)
        .map(|v| {
            let n = mesh.normals.get(v).copied().unwrap_or(Vec3::Y);
            let (Some(a), Some(b)) = (rest[key(v)].try_normalize(), pose[key(v)].try_normalize()) else {
                return n;
            };
            let q = Quat::from_rotation_arc(a.as_vec3(), b.as_vec3());
            let m = q * n;
            if m.is_finite() {
                m
            } else {
                n
            }
        })
        .collect()
}

/// ⌈√n⌉.
fn strata(n: usize) -> usize {
    let mut s = 1;
    while s * s < n {
        s += 1;
    }
    s
}

/// Cosine-weighted unit direction about unit `n` from (u1, u2) ∈ [0, 1)² (Malley).
fn cosine_direction(n: DVec3, u1: f64, u2: f64) -> DVec3 {
    let r = u1.sqrt();
    let phi = 2.0 * PI * u2;
    let (s, c) = phi.sin_cos();
    let z = (1.0 - u1).max(0.0).sqrt();
    let (t, b) = basis(n);
    t * (r * c) + b * (r * s) + n * z
}

/// An orthonormal pair perpendicular to unit `n` (Duff et al. 2017).
fn basis(n: DVec3) -> (DVec3, DVec3) {
    let sign = 1.0f64.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (DVec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x), DVec3::new(b, sign + n.y * n.y * a, -n.y))
}

/// SplitMix64's finaliser and its unit interval map (the seeded jitter of every Monte Carlo reference here and in
/// the CLI's checks), from the baker's one generator.
pub use spherebake_geom::rng::{mix, unit};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cosine_directions_are_unit_and_in_the_hemisphere() {
        for n in [DVec3::Y, -DVec3::Z, DVec3::new(0.3, -0.5, 0.81).normalize(), DVec3::Z] {
            let (t, b) = basis(n);
            assert!(t.dot(n).abs() < 1e-12 && b.dot(n).abs() < 1e-12 && t.dot(b).abs() < 1e-12);
            for k in 0..64 {
                let d = cosine_direction(n, (k % 8) as f64 / 8.0 + 0.01, (k / 8) as f64 / 8.0 + 0.02);
                assert!((d.length() - 1.0).abs() < 1e-12);
                assert!(d.dot(n) >= 0.0);
            }
        }
    }

    #[test]
    fn cosine_sampling_has_mean_cosine_two_thirds() {
        // E[n·ω] under pdf cos/π is ∫cos² dω / π = 2/3.
        let n = DVec3::new(0.2, 0.9, -0.1).normalize();
        let s = 64;
        let mut acc = 0.0;
        for a in 0..s {
            for b in 0..s {
                let h = mix((a * s + b) as u64);
                acc +=
                    cosine_direction(n, (a as f64 + unit(h)) / s as f64, (b as f64 + unit(mix(h))) / s as f64).dot(n);
            }
        }
        assert!((acc / (s * s) as f64 - 2.0 / 3.0).abs() < 1e-4);
    }

    #[test]
    fn sky_is_zero_below_the_horizon_and_clamped() {
        let u = Sky::uniform(2.0).unwrap();
        assert!((u.radiance([0.0, 1.0, 0.0]) - 2.0).abs() < 1e-12);
        assert_eq!(u.radiance([0.0, -1.0, 0.0]), 0.0);
        assert_eq!(u.constant(), Some(2.0));
        // y_1,0 = √(3/4π)·z: a sky of coefficient −1 on it is negative for z > 0 → clamped.
        let mut c = [0.0; 4];
        c[2] = -1.0;
        let s = Sky::new(2, &c).unwrap();
        assert_eq!(s.radiance([0.0, 0.6, 0.8]), 0.0);
        assert!((s.radiance([0.0, 0.6, -0.8]) - 0.8 * (3.0 / (4.0 * PI)).sqrt()).abs() < 1e-12);
        assert!(Sky::new(9, &[0.0; 81]).is_err());
        assert!(Sky::new(2, &[0.0; 3]).is_err());
        assert!(Sky::new(1, &[f64::NAN]).is_err());
    }
}
