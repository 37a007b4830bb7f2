//! Albedo cube maps per sphere, projected to spherical harmonics (Guerrero et al. 2008 §4.2,
//! seed 003 §6.2; issue 7).
//!
//! For each sphere S_i = (c_i, r_i):
//!
//! 1. **Segment triangles.** A surface point p belongs to segment P_i when i minimises
//!    |p − c_i| / r_i (math reference §8). A triangle is rendered for sphere i unless some other
//!    sphere j beats i on *every* point of the triangle; so a triangle partly closer to another
//!    sphere goes to both. The test per pair is exact: f(p) = |p−c_j|²/r_j² − |p−c_i|²/r_i² is
//!    an isotropic quadratic, whose maximum over the triangle is at a corner (convex or linear
//!    case, r_j ≤ r_i) or at the triangle point closest to its apex (concave case). It is
//!    conservative only where three or more segments meet inside one triangle (no single j
//!    dominates although the pieces all belong to others). A triangle rendered for two or more
//!    spheres keeps, in each sphere's map, only the fragments whose point lies in that sphere's
//!    segment (the smallest |p − c|/r among the spheres it is rendered for, which holds every
//!    point's owner; ties to the lowest index), as the samples test their hits (`samples`); its
//!    other fragments only count as back-facing surface for rule 2. Until 2026-12 whole triangles
//!    were drawn, so a map showed the part of a shared triangle that another sphere owns: on a
//!    near-black WebXR controller (`microsoft-mixed-reality`) a sphere beside the bright button
//!    icons baked a mean albedo 84× its segment's area-weighted mean (3.7e-3 against 4.4e-5);
//!    per sphere, the area-weighted mean |SH mean − segment mean| / mean albedo fell from
//!    0.38 / 0.12 / 0.12 / 0.026 / 0.029 / 0.021 / 0.0018 to 0.11 / 0.065 / 0.031 / 0.0052 /
//!    0.017 / 0.016 / 0.0007 (the controller, CesiumMilkTruck, BoxTextured, spot, Fox,
//!    CesiumMan, Duck at 64 spheres).
//! 2. **Rendering** into a cube map centred at c_i (`raster`, one sample per texel centre,
//!    OpenGL/Vulkan faces), with the sample-point rules of §8 per texel direction ω and outward
//!    normals (CCW, or reversed where `flip` says so):
//!    - rule 1: the farthest back-facing (n·ω > 0) surface among the segment's triangles;
//!    - rule 2: if back-facing surface exists along ω (any triangle) but none of the segment,
//!      the texel is 0 (another sphere covers that direction);
//!    - rule 3: if there is no back-facing surface along ω at all (centre outside the object),
//!      the nearest front-facing segment triangle along −ω (seen *through* the centre; no near
//!      clip).
//!
//!    **Uncovered texels** (rule 2, or nothing at all) take the solid-angle-weighted mean colour of
//!    the sphere's covered texels ([`AlbedoSettings::fill_uncovered`], default on; a sphere with no
//!    covered texel stays 0). The sphere emits nothing in those directions anyway — the samples'
//!    rule 2 carries that into the emission L, and the runtime multiplies L by this albedo — so the
//!    value there is free; 0 would leak into the covered directions through the order-n truncation
//!    (a one-colour sphere split between two spheres: worst error on each own half below 2e-3
//!    filled, above 10 % left 0, `tests/albedo_bake.rs`), darkening every segment's edge, the more
//!    so the more spheres share the surface (indirect light: runtime `light` module docs).
//!
//!    **One colour.** When every surface point has the same colour (no used material has a
//!    base-colour texture, the used materials' base colour factors agree and so do the COLOR_0
//!    values, if any) and uncovered texels are filled, a sphere's map is that colour at every
//!    texel as soon as one texel is covered. So once the segment's own triangles have covered
//!    a texel by rule 1 (back-facing segment surface: rule 1 wins over rules 2 and 3) the
//!    other triangles are not drawn at all; a sphere whose segment covers no texel by rule 1
//!    is rendered in full (it may have rule 3 texels or none). The coefficients are those of the
//!    full render (the same texels, up to the f32 rounding of the barycentric interpolation of
//!    COLOR_0), without the coverage pass: on the bunny subdivided to 1.1 M triangles (one
//!    colour, 64 spheres) the stage fell from 4.5–4.6 s to 1.2 s, byte-identical files
//!    (`docs/benchmarks.md`). Such maps are all the same, so their projection is computed once
//!    per bake (the same sums in the same order: the same coefficients).
//! 3. **Colour** = base colour factor × base-colour texture × COLOR_0, linear RGB. Alpha is
//!    ignored, except for an alpha-masked material (glTF `alphaMode` `MASK`): a fragment of the
//!    segment's own triangles whose alpha (factor × texture × COLOR_0, the texture at level 0) is
//!    below the cutoff is a hole ([`SurfaceAlbedo::is_hole`]) and takes no texel, so the surface
//!    behind a leaf card's cut-out shows (or the texel is filled); the colour of a masked texture
//!    is α-weighted at every level (Σ RGB·α / Σ α), so its cut-out texels' colour never bleeds into
//!    the opaque part. The rule-2 coverage pass and the sample points (`samples`) still take masked
//!    triangles as whole surfaces, and `BLEND` is opaque. The texture is sampled at the true
//!    (perspective-correct) barycentric point, with the material's UV set, KHR_texture_transform
//!    and wrap modes, trilinearly from a box-filtered mip chain (`spherebake_geom::texels`; its
//!    base at most 4096 texels a side, as the importers reduce larger textures); the level is log2
//!    of the texel footprint's side in texture texels: footprint = Ω_nominal · t² / |n·ω| (world
//!    area) × UV area per world area of the triangle × texture size, Ω_nominal =
//!    (2/N)²/(1+u²+v²)^{3/2} (see [`TextureLod`]).
//! 4. **Projection** onto real orthonormal SH with the Condon–Shortley phase, index
//!    i = l(l+1)+m (math reference §1), with exact texel solid angles (§4):
//!    f_i = (4π/Σw) Σ_t w_t f(d_t) y_i(d_t).
//!
//! Spheres are independent and run in parallel (rayon, ordered collect): the coefficients are
//! bit-identical for any thread count.
//!
//! **Cost.** Per sphere its segment's triangles are drawn, then the other triangles only mark
//! which texels have some back-facing surface (rule 2), until every texel has one. They are
//! visited in runs of 32 in Morton order, and a run whose bounding box can reach no unmarked
//! texel is skipped whole (`raster::CubeGrid::box_covered`, conservative, so the maps are
//! unchanged). A triangle whose corners lie in one face's pyramid is tested against that face
//! only. Segment assignment skips the exact dominance test where a bound already settles it,
//! and whole groups of nearby spheres where the bound settles it for all of them.
//! The bunny subdivided to 1.1 M triangles, 64 spheres: 7.8–8.0 s → 2.4–3.0 s for the stage,
//! byte-identical files. Memory ≈ 6N² × 90 bytes per thread.
//!
//! **Measured** (`examples/albedo_measure.rs`, 64 spheres from `spherebake_fit::fit`, order 4,
//! release build): CesiumMan 0.09 s on 1 thread, 0.18–0.19 s with `RAYON_NUM_THREADS=2` on a
//! loaded 2-core machine; spot 0.09 s / 0.14–0.18 s. RMS coefficient error against 512² faces
//! (reference RMS 0.564 for CesiumMan, 0.311 for spot):
//!
//! | face size | 8 | 16 | 32 | 64 | 128 |
//! |---|---|---|---|---|---|
//! | CesiumMan | 0.0197 | 0.0065 | 0.0024 | 0.00093 | 0.00034 |
//! | spot | 0.0145 | 0.0051 | 0.0020 | 0.00069 | 0.00026 |
//!
//! (about ×2.7 per doubling, between 1/N and 1/N²: segment boundaries and silhouettes are
//! discontinuities, the smooth part falls like 1/N², §4). [`TextureLod::Base`] gives the same
//! errors to 2 digits on these models: at order 4 the SH integral averages texture aliasing
//! away; the footprint level matters for the cube maps themselves (debug images, a far textured
//! surface shows its mean instead of aliased texels — see the tests).

use crate::raster::{CubeGrid, Fragment};
use glam::DVec3;
use rayon::prelude::*;
use spherebake_format::{AlbedoSh, ColourSpace, ShBasis};
use spherebake_geom::{texels, Mesh, WrapMode};
use spherebake_sh::{coeff_count, cube_texel_solid_angle, eval_sh_f64, CubeFace, CubeProjector, ShError};
use std::path::{Path, PathBuf};

/// How the texture level of detail is chosen per cube-map texel.
#[non_exhaustive]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum TextureLod {
    /// Trilinear from a box-filtered mip chain; level = ½·log2(footprint in texture texels)
    /// of the cube-map texel seen on the surface (isotropic, area-preserving). Default.
    #[default]
    Footprint,
    /// Bilinear from the full-resolution texture only (aliases when a cube-map texel covers
    /// many texture texels; kept for measurement).
    Base,
}

/// Settings of the albedo stage.
#[derive(Clone, Debug, PartialEq)]
pub struct AlbedoSettings {
    /// SH order n (bands 0..n−1, n² coefficients per sphere). Default 4, range 1..=8.
    pub sh_order: usize,
    /// Cube-map face size in texels. Default 32, range 1..=1024.
    pub cubemap_size: usize,
    /// When set, [`bake_albedo`] writes each sphere's cube map and its SH reconstruction as PNG
    /// crosses into this directory (see [`write_debug_cubemaps`]).
    pub debug_dir: Option<PathBuf>,
    /// Files the debug images must never replace (the model's inputs: a texture named
    /// `sphere_0000.png` in the debug directory is refused, not overwritten).
    pub debug_protect: Vec<PathBuf>,
    /// Texture level-of-detail choice. Default [`TextureLod::Footprint`].
    pub texture_lod: TextureLod,
    /// Texels where the sphere has no surface (rule 2, or nothing at all) take the solid-angle-weighted mean colour
    /// of its covered texels before the projection, instead of 0 (module docs, "Uncovered texels"). Default on.
    pub fill_uncovered: bool,
}

impl Default for AlbedoSettings {
    fn default() -> Self {
        Self {
            sh_order: 4,
            cubemap_size: 32,
            debug_dir: None,
            debug_protect: Vec::new(),
            texture_lod: TextureLod::Footprint,
            fill_uncovered: true,
        }
    }
}

/// What the albedo stage did (texel counts are summed over all spheres).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AlbedoStats {
    pub spheres: usize,
    pub face_size: usize,
    pub sh_order: usize,
    /// Texels coloured by rule 1 (farthest back-facing segment surface).
    pub texels_rule1: u64,
    /// Texels left 0 by rule 2 (back-facing surface exists, none of the segment).
    pub texels_rule2: u64,
    /// Texels coloured by rule 3 (no back-facing surface; nearest front-facing segment surface
    /// through the centre).
    pub texels_rule3: u64,
    /// Texels left 0 because no allowed surface covers them under rule 3.
    pub texels_empty: u64,
    /// Spheres whose map is the mesh's one colour (module docs, "One colour"): after their
    /// segment covered a texel by rule 1 no other triangle was drawn, so their texels other
    /// than rule 1 are counted in [`AlbedoStats::texels_unclassified`], not by rule.
    pub one_colour_spheres: usize,
    /// Texels of the one-colour spheres not coloured by rule 1 (rule 2, 3 or empty: the map is
    /// the one colour either way).
    pub texels_unclassified: u64,
    /// Texels of spheres whose segment holds no triangle (spheres the fit left empty): left 0
    /// without drawing any triangle, so not told apart by rule.
    pub texels_no_segment: u64,
    /// Σ over spheres of the number of triangles rendered for it.
    pub triangle_assignments: u64,
    /// Triangles rendered for two or more spheres.
    pub shared_triangles: usize,
    /// Triangles whose material has a texture but whose vertices lack that UV set (rendered
    /// with the factor and vertex colour only).
    pub textured_triangles_without_uvs: usize,
    /// Debug PNGs written.
    pub debug_files: Vec<PathBuf>,
}

/// One sphere's albedo cube map: linear RGB, `6·face_size²` texels, face-major (OpenGL/Vulkan
/// layer order), then row j, then column i.
#[derive(Clone, Debug, PartialEq)]
pub struct CubeMap {
    pub face_size: usize,
    pub texels_linear: Vec<[f32; 3]>,
}

/// Everything that can stop the albedo stage.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum AlbedoError {
    #[error("setting {name} = {value} is out of range (expected {expected})")]
    InvalidSetting { name: &'static str, value: usize, expected: &'static str },
    #[error("flip has {actual} entries, expected one per triangle ({expected})")]
    FlipLength { expected: usize, actual: usize },
    #[error("sphere {index} is invalid (centre and radius must be finite, radius ≥ 0): {sphere:?}")]
    InvalidSphere { index: usize, sphere: [f32; 4] },
    #[error("triangle {triangle} references vertex {index}, but there are {vertex_count} vertices")]
    VertexOutOfRange { triangle: usize, index: u32, vertex_count: usize },
    #[error("triangle_materials has {actual} entries, expected {expected} (one per triangle) or 0")]
    MaterialListLength { expected: usize, actual: usize },
    #[error("triangle {triangle} uses material {material}, but there are {material_count} materials")]
    MaterialOutOfRange { triangle: usize, material: u32, material_count: usize },
    #[error("material {material} uses texture {texture}, but there are {texture_count} textures")]
    TextureOutOfRange { material: usize, texture: usize, texture_count: usize },
    #[error("texture {texture} is {width}x{height} but holds {actual} texels")]
    TextureSize { texture: usize, width: u32, height: u32, actual: usize },
    #[error("vertex attribute {attribute} has {actual} entries, expected {expected} (one per vertex) or 0")]
    AttributeLength { attribute: &'static str, expected: usize, actual: usize },
    #[error("cube map {index} has {actual} texels, expected {expected}")]
    CubeMapSize { index: usize, expected: usize, actual: usize },
    #[error("SH projection: {0}")]
    Sh(#[from] ShError),
    #[error("writing debug cube maps to {path}: {source}")]
    DebugWrite { path: PathBuf, source: std::io::Error },
}

/// Renders the albedo cube maps and projects them to SH (see the module docs).
///
/// `flip[t]` reverses triangle t's CCW normal to make it outward (one entry per triangle of
/// `mesh.triangles`); `spheres` are `[x, y, z, r]`, model space. When `settings.debug_dir` is
/// set, the debug PNGs are written there too ([`write_debug_cubemaps`]).
///
/// # Errors
/// Invalid settings, spheres (non-finite, negative radius; radius 0 is accepted and owns no
/// surface, so its cube map is 0), or mesh indices/lengths; failure to write the debug images.
pub fn bake_albedo(
    mesh: &Mesh,
    flip: &[bool],
    spheres: &[[f32; 4]],
    settings: &AlbedoSettings,
) -> Result<(AlbedoSh, AlbedoStats), AlbedoError> {
    let ctx = Context::new(mesh, flip, spheres, settings)?;
    let projector = Projector::new(settings.sh_order, settings.cubemap_size)?;
    let keep = settings.debug_dir.is_some();
    // A one-colour sphere's map is that colour at every texel, all covered (module docs, "One
    // colour"): the fill leaves it as it is and its projection, the same sums in the same order
    // on the same texels, is this one, computed once instead of once per sphere.
    let one_colour_coeffs = ctx.one_colour.map(|c| projector.project(&vec![c; ctx.grid.texel_count()]));
    let per_sphere: Vec<(Vec<[f32; 3]>, Option<CubeMap>, SphereCounts)> = (0..spheres.len())
        .into_par_iter()
        .map(|s| {
            let (mut texels, counts, covered) = ctx.render_sphere(s);
            let coeffs = match &one_colour_coeffs {
                Some(c) if counts.one_colour => c.clone(),
                _ => {
                    if settings.fill_uncovered {
                        ctx.fill_uncovered(&mut texels, &covered);
                    }
                    projector.project(&texels)
                }
            };
            let map =
                if keep { Some(CubeMap { face_size: settings.cubemap_size, texels_linear: texels }) } else { None };
            (coeffs, map, counts)
        })
        .collect();
    let mut stats = ctx.base_stats();
    let mut coefficients = Vec::with_capacity(spheres.len() * coeff_count(settings.sh_order));
    let mut maps = Vec::new();
    for (c, m, counts) in per_sphere {
        coefficients.extend_from_slice(&c);
        counts.add_to(&mut stats);
        maps.extend(m);
    }
    let sh = AlbedoSh {
        order: settings.sh_order as u8,
        colour_space: ColourSpace::LinearRgb,
        basis: ShBasis::RealOrthonormalCs,
        coefficients,
    };
    if let Some(dir) = &settings.debug_dir {
        stats.debug_files = write_debug_cubemaps(dir, &maps, &sh, &settings.debug_protect)
            .map_err(|source| AlbedoError::DebugWrite { path: dir.clone(), source })?;
    }
    Ok((sh, stats))
}

/// Renders every sphere's albedo cube map (no projection); see [`bake_albedo`].
///
/// # Errors
/// As [`bake_albedo`], without the IO.
pub fn render_albedo_cubemaps(
    mesh: &Mesh,
    flip: &[bool],
    spheres: &[[f32; 4]],
    settings: &AlbedoSettings,
) -> Result<(Vec<CubeMap>, AlbedoStats), AlbedoError> {
    let ctx = Context::new(mesh, flip, spheres, settings)?;
    let per_sphere: Vec<(Vec<[f32; 3]>, SphereCounts)> =
        (0..spheres.len()).into_par_iter().map(|s| ctx.render_sphere(s)).map(|(t, c, _)| (t, c)).collect();
    let mut stats = ctx.base_stats();
    let mut maps = Vec::with_capacity(spheres.len());
    for (texels, counts) in per_sphere {
        counts.add_to(&mut stats);
        maps.push(CubeMap { face_size: settings.cubemap_size, texels_linear: texels });
    }
    Ok((maps, stats))
}

/// Projects cube maps (all of one face size) onto SH of `sh_order` with exact texel solid angles.
///
/// # Errors
/// Order outside 1..=8, face size 0 or mixed sizes.
pub fn project_cubemaps(maps: &[CubeMap], sh_order: usize) -> Result<AlbedoSh, AlbedoError> {
    check_setting("sh_order", sh_order, 1, 8, "1..=8")?;
    let n = maps.first().map_or(1, |m| m.face_size);
    check_setting("cubemap_size", n, 1, 1024, "1..=1024")?;
    for (index, m) in maps.iter().enumerate() {
        if m.face_size != n || m.texels_linear.len() != 6 * n * n {
            return Err(AlbedoError::CubeMapSize { index, expected: 6 * n * n, actual: m.texels_linear.len() });
        }
    }
    let projector = Projector::new(sh_order, n)?;
    let per: Vec<Vec<[f32; 3]>> = maps.par_iter().map(|m| projector.project(&m.texels_linear)).collect();
    Ok(AlbedoSh {
        order: sh_order as u8,
        colour_space: ColourSpace::LinearRgb,
        basis: ShBasis::RealOrthonormalCs,
        coefficients: per.concat(),
    })
}

/// For each sphere, the triangles (indices into `mesh.triangles`, increasing) rendered for it:
/// those not entirely beaten by a single other sphere under d(p, S) = |p − c|/r (module docs).
///
/// # Errors
/// Invalid spheres or vertex indices.
pub fn segment_triangles(mesh: &Mesh, spheres: &[[f32; 4]]) -> Result<Vec<Vec<u32>>, AlbedoError> {
    check_spheres(spheres)?;
    check_vertices(mesh)?;
    let pos: Vec<DVec3> = mesh.positions.iter().map(|p| p.as_dvec3()).collect();
    let sph = spheres_f64(spheres);
    Ok(assign(&pos, &mesh.triangles, &sph).0)
}

// ---------------------------------------------------------------------------------------------
// Validation

fn check_setting(
    name: &'static str,
    value: usize,
    lo: usize,
    hi: usize,
    expected: &'static str,
) -> Result<(), AlbedoError> {
    if value < lo || value > hi {
        return Err(AlbedoError::InvalidSetting { name, value, expected });
    }
    Ok(())
}

fn check_spheres(spheres: &[[f32; 4]]) -> Result<(), AlbedoError> {
    for (index, s) in spheres.iter().enumerate() {
        if !(s.iter().all(|v| v.is_finite()) && s[3] >= 0.0) {
            return Err(AlbedoError::InvalidSphere { index, sphere: *s });
        }
    }
    Ok(())
}

fn check_vertices(mesh: &Mesh) -> Result<(), AlbedoError> {
    let vertex_count = mesh.positions.len();
    for (triangle, t) in mesh.triangles.iter().enumerate() {
        for &index in t {
            if index as usize >= vertex_count {
                return Err(AlbedoError::VertexOutOfRange { triangle, index, vertex_count });
            }
        }
    }
    Ok(())
}

struct SphereF64 {
    c: DVec3,
    inv_r2: f64,
}

fn spheres_f64(spheres: &[[f32; 4]]) -> Vec<SphereF64> {
    spheres
        .iter()
        .map(|s| {
            let r = f64::from(s[3]);
            SphereF64 { c: DVec3::new(f64::from(s[0]), f64::from(s[1]), f64::from(s[2])), inv_r2: 1.0 / (r * r) }
        })
        .collect()
}

// ---------------------------------------------------------------------------------------------
// Segment assignment

impl SphereF64 {
    /// Squared normalised distance |p − c|²/r².
    fn d2(&self, p: DVec3) -> f64 {
        (p - self.c).length_squared() * self.inv_r2
    }
}

/// Whether sphere j beats sphere i on every point of triangle `t` (strictly).
fn dominates(j: &SphereF64, i: &SphereF64, t: &[DVec3; 3]) -> bool {
    let f = |p: DVec3| j.d2(p) - i.d2(p);
    let alpha = j.inv_r2 - i.inv_r2;
    let corners = t.iter().all(|&p| f(p) < 0.0);
    if !corners {
        return false;
    }
    if alpha >= 0.0 {
        // Convex (or linear) in p: the maximum over the triangle is at a corner.
        return true;
    }
    // Concave isotropic quadratic: f = α|p − q|² + const, maximal at the point of the
    // triangle nearest q = (c_j/r_j² − c_i/r_i²)/α (computed relative to corner 0).
    let o = t[0];
    let q = o + ((j.c - o) * j.inv_r2 - (i.c - o) * i.inv_r2) / alpha;
    f(spherebake_geom::triangle::closest_point_on_triangle(q, t)) < 0.0
}

/// Per sphere, the increasing list of triangles rendered for it; and the triangles rendered for
/// two or more spheres with their increasing sphere lists ([`SharedTriangles`]).
fn assign(pos: &[DVec3], triangles: &[[u32; 3]], spheres: &[SphereF64]) -> (Vec<Vec<u32>>, SharedTriangles) {
    // The owner of each vertex (ties → lowest index; 0 when no sphere has a finite distance),
    // once per vertex rather than once per corner.
    let vertex_owner: Vec<usize> = pos
        .par_iter()
        .map(|p| {
            let mut owner = 0;
            let mut best = f64::INFINITY;
            for (s, sp) in spheres.iter().enumerate().filter(|(_, sp)| sp.inv_r2.is_finite()) {
                let d = sp.d2(*p);
                if d < best {
                    best = d;
                    owner = s;
                }
            }
            owner
        })
        .collect();
    let groups = sphere_groups(spheres);
    let per_tri: Vec<Vec<u32>> = triangles
        .par_iter()
        .map_init(Vec::new, |candidates: &mut Vec<u32>, tri| {
            let t = tri.map(|v| pos[v as usize]);
            if !t.iter().all(|p| p.is_finite()) {
                return Vec::new();
            }
            // Owners of the corners: certainly in their segments.
            let owners = tri.map(|v| vertex_owner[v as usize]);
            // A quick sufficient test for an owner's dominance: d_o is convex, so it is largest
            // at a corner, and d_i is at least its value at the triangle's bounding box; when
            // some owner's largest corner value is clearly below sphere i's bound everywhere,
            // that owner dominates i (`dominates` would say so; skipping it saves its cost).
            // (No spheres, or a NaN anywhere: +∞, no skipping.)
            let owner_max = owner_max(spheres, &owners, &t);
            // Each sphere's d at the triangle's bounding box is a lower bound of d on the
            // triangle; where it is clearly above `owner_max`, an owner dominates the sphere
            // (`dominates` would say so). The others and the owners, in increasing order, are
            // the spheres to test.
            let limit = owner_max * (1.0 + 1e-9) + f64::MIN_POSITIVE;
            near_spheres(spheres, &groups, &t, limit, candidates);
            candidates.extend(owners.iter().filter(|&&o| o < spheres.len()).map(|&o| o as u32));
            candidates.sort_unstable();
            candidates.dedup();
            let mut out = Vec::new();
            for &i in candidates.iter() {
                let (i, si) = (i as usize, &spheres[i as usize]);
                if si.inv_r2.is_infinite() {
                    // Radius 0: |p − c|/r is infinite, the segment is empty.
                    continue;
                }
                if owners.contains(&i) {
                    out.push(i as u32);
                    continue;
                }
                if owners.iter().any(|&o| dominates(&spheres[o], si, &t)) {
                    continue;
                }
                if !spheres.iter().enumerate().any(|(j, sj)| j != i && sj.inv_r2.is_finite() && dominates(sj, si, &t)) {
                    out.push(i as u32);
                }
            }
            out
        })
        .collect();
    let mut per_sphere = vec![Vec::new(); spheres.len()];
    let mut shared = SharedTriangles { triangles: Vec::new(), offsets: vec![0], spheres: Vec::new() };
    for (t, list) in per_tri.iter().enumerate() {
        for &s in list {
            per_sphere[s as usize].push(t as u32);
        }
        if list.len() >= 2 {
            shared.triangles.push(t as u32);
            shared.spheres.extend_from_slice(list);
            shared.offsets.push(shared.spheres.len() as u32);
        }
    }
    (per_sphere, shared)
}

/// The least over the corners' owners (`owners`; an index past `spheres` is none) of the
/// owner's largest d² at the triangle's corners `t`: below it an owner holds the whole triangle
/// nearer than any sphere whose bound on the triangle is larger. +∞ without owners, or where
/// some d² is NaN.
fn owner_max(spheres: &[SphereF64], owners: &[usize; 3], t: &[DVec3; 3]) -> f64 {
    let mut owner_max = f64::INFINITY;
    for &o in owners.iter().filter(|&&o| o < spheres.len()) {
        let d =
            t.iter().map(|p| spheres[o].d2(*p)).fold(0.0f64, |a, d| if d.is_nan() { f64::INFINITY } else { a.max(d) });
        owner_max = owner_max.min(d);
    }
    owner_max
}

/// Spheres per [`SphereGroup`].
const SPHERE_GROUP: usize = 8;

/// Nearby spheres for [`assign`]'s bound: the box of their centres and their smallest 1/r².
struct SphereGroup {
    lo: DVec3,
    hi: DVec3,
    min_inv_r2: f64,
    members: Vec<u32>,
}

/// The spheres in groups of at most [`SPHERE_GROUP`] (median splits of the centres along the
/// longest axis of their box; ties by index, so the groups do not depend on the threads).
fn sphere_groups(spheres: &[SphereF64]) -> Vec<SphereGroup> {
    fn split(idx: &mut [u32], spheres: &[SphereF64], out: &mut Vec<SphereGroup>) {
        let (mut lo, mut hi, mut min_inv_r2) = (DVec3::INFINITY, DVec3::NEG_INFINITY, f64::INFINITY);
        for &i in idx.iter() {
            lo = lo.min(spheres[i as usize].c);
            hi = hi.max(spheres[i as usize].c);
            min_inv_r2 = min_inv_r2.min(spheres[i as usize].inv_r2);
        }
        if idx.len() <= SPHERE_GROUP {
            if !idx.is_empty() {
                out.push(SphereGroup { lo, hi, min_inv_r2, members: idx.to_vec() });
            }
            return;
        }
        let ext = hi - lo;
        let axis = if ext.x >= ext.y && ext.x >= ext.z {
            0
        } else if ext.y >= ext.z {
            1
        } else {
            2
        };
        idx.sort_unstable_by(|&a, &b| {
            spheres[a as usize].c[axis].total_cmp(&spheres[b as usize].c[axis]).then(a.cmp(&b))
        });
        let (l, r) = idx.split_at_mut(idx.len() / 2);
        split(l, spheres, out);
        split(r, spheres, out);
    }
    let mut idx: Vec<u32> = (0..spheres.len() as u32).collect();
    let mut out = Vec::new();
    split(&mut idx, spheres, &mut out);
    out
}

/// Writes to `out` (cleared first, in no particular order) every sphere whose bound on triangle
/// `t`, d at the point of the triangle's bounding box nearest its centre, |clamp(c) − c|² / r²
/// (glam's clamp: max, then min), is not above `limit` (a NaN bound is not above it);
/// [`assign`] skips the others. A group is skipped whole when the same bound for the box of its
/// centres and its smallest 1/r² is above `limit`: per axis that gap is at most each member's
/// and every operation rounds monotonically, so it is at most each member's bound, bit for bit,
/// and only spheres the per-sphere test would skip are skipped.
/// Cost: O(groups + members of the groups kept) per triangle, instead of O(spheres).
fn near_spheres(spheres: &[SphereF64], groups: &[SphereGroup], t: &[DVec3; 3], limit: f64, out: &mut Vec<u32>) {
    out.clear();
    let (lo, hi) = (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]));
    let gap = |c: f64, lo: f64, hi: f64| {
        let a = if c > lo { c } else { lo };
        (if a < hi { a } else { hi }) - c
    };
    // The least gap of a centre in [clo, chi] to [lo, hi] (≥ 0).
    let group_gap = |clo: f64, chi: f64, lo: f64, hi: f64| {
        if chi < lo {
            lo - chi
        } else if clo > hi {
            clo - hi
        } else {
            0.0
        }
    };
    for g in groups {
        let (dx, dy, dz) = (
            group_gap(g.lo.x, g.hi.x, lo.x, hi.x),
            group_gap(g.lo.y, g.hi.y, lo.y, hi.y),
            group_gap(g.lo.z, g.hi.z, lo.z, hi.z),
        );
        if (dx * dx + dy * dy + dz * dz) * g.min_inv_r2 > limit {
            continue;
        }
        for &i in &g.members {
            let s = &spheres[i as usize];
            let (dx, dy, dz) = (gap(s.c.x, lo.x, hi.x), gap(s.c.y, lo.y, hi.y), gap(s.c.z, lo.z, hi.z));
            let bound = (dx * dx + dy * dy + dz * dz) * s.inv_r2;
            if bound.partial_cmp(&limit) != Some(std::cmp::Ordering::Greater) {
                out.push(i);
            }
        }
    }
}

/// The triangles rendered for two or more spheres (increasing), each with the increasing list of
/// those spheres: `spheres[offsets[k]..offsets[k + 1]]` for `triangles[k]`. Every sphere whose
/// segment holds a point of such a triangle is in its list (a sphere that owns a point is not
/// beaten on the whole triangle), so the segment test of its fragments compares these only.
struct SharedTriangles {
    triangles: Vec<u32>,
    offsets: Vec<u32>,
    spheres: Vec<u32>,
}

impl SharedTriangles {
    /// The spheres triangle `t` is rendered for, when they are two or more.
    fn spheres_of(&self, t: u32) -> Option<&[u32]> {
        let k = self.triangles.binary_search(&t).ok()?;
        Some(&self.spheres[self.offsets[k] as usize..self.offsets[k + 1] as usize])
    }
}

// ---------------------------------------------------------------------------------------------
// Textures

/// A texture as a mip chain of linear levels of `N` channels (RGB, or a masked material's
/// texture premultiplied, RGB·α and α; box filter, 2×2 → 1: [`texels::halve`]).
#[derive(Clone)]
struct MipChain<const N: usize> {
    levels: Vec<(usize, usize, Vec<[f32; N]>)>,
}

impl<const N: usize> MipChain<N> {
    /// The chain over `width × height` texels, each mapped by `channels`.
    fn new(width: usize, height: usize, texels: &[[f32; 4]], channels: impl Fn(&[f32; 4]) -> [f32; N]) -> Self {
        let base: Vec<[f32; N]> = texels.iter().map(channels).collect();
        let mut levels = vec![(width, height, base)];
        loop {
            let (w, h, ref src) = levels[levels.len() - 1];
            if w == 1 && h == 1 {
                break;
            }
            let next = texels::halve(w, h, src);
            levels.push(next);
        }
        Self { levels }
    }

    fn bilinear(&self, level: usize, uv: [f64; 2], wrap: [WrapMode; 2]) -> [f64; N] {
        let (w, h, ref tex) = self.levels[level];
        // Clamped so the integer texel coordinates below cannot overflow (far beyond any
        // texture, wrapping is unaffected in practice).
        let x = (uv[0] * w as f64 - 0.5).clamp(-1e15, 1e15);
        let y = (uv[1] * h as f64 - 0.5).clamp(-1e15, 1e15);
        let (xf, yf) = (x.floor(), y.floor());
        let (fx, fy) = (x - xf, y - yf);
        let (xi, yi) = (xf as i64, yf as i64);
        let xs = [wrap_index(xi, w, wrap[0]), wrap_index(xi + 1, w, wrap[0])];
        let ys = [wrap_index(yi, h, wrap[1]), wrap_index(yi + 1, h, wrap[1])];
        let mut out = [0.0f64; N];
        for (a, &yy) in ys.iter().enumerate() {
            let wy = if a == 0 { 1.0 - fy } else { fy };
            for (b, &xx) in xs.iter().enumerate() {
                let wx = if b == 0 { 1.0 - fx } else { fx };
                let t = tex[yy * w + xx];
                for c in 0..N {
                    out[c] += wx * wy * f64::from(t[c]);
                }
            }
        }
        out
    }

    /// Trilinear sample at fractional `lod` (clamped to the chain).
    fn sample(&self, uv: [f64; 2], lod: f64, wrap: [WrapMode; 2]) -> [f64; N] {
        let max = (self.levels.len() - 1) as f64;
        let lod = if lod.is_finite() { lod.clamp(0.0, max) } else { 0.0 };
        let l0 = lod.floor();
        let f = lod - l0;
        let a = self.bilinear(l0 as usize, uv, wrap);
        if f == 0.0 {
            return a;
        }
        let b = self.bilinear(l0 as usize + 1, uv, wrap);
        std::array::from_fn(|c| a[c] + f * (b[c] - a[c]))
    }
}

/// Per texture of `mesh`, its mip chain of `channels` where `wanted` says so (in parallel, ordered
/// collect).
fn build_chains<const N: usize>(
    mesh: &Mesh,
    wanted: &[bool],
    channels: impl Fn(&[f32; 4]) -> [f32; N] + Sync,
) -> Vec<Option<MipChain<N>>> {
    mesh.textures
        .par_iter()
        .zip(wanted.par_iter())
        .map(|(t, &w)| w.then(|| MipChain::new(t.width as usize, t.height as usize, &t.texels_linear, &channels)))
        .collect()
}

/// Texel index `i` wrapped into `0..n` (glTF sampler semantics on texel indices).
fn wrap_index(i: i64, n: usize, mode: WrapMode) -> usize {
    let n = n as i64;
    let r = match mode {
        WrapMode::Repeat => i.rem_euclid(n),
        WrapMode::ClampToEdge => i.clamp(0, n - 1),
        WrapMode::MirroredRepeat => {
            let m = i.rem_euclid(2 * n);
            if m >= n {
                2 * n - 1 - m
            } else {
                m
            }
        }
    };
    r as usize
}

// ---------------------------------------------------------------------------------------------
// Surface colour

/// The albedo of a mesh's surface points: base colour factor × COLOR_0 × base-colour texture,
/// linear RGB (alpha ignored), written once and shared by the albedo bake (its cube-map texels)
/// and the reference path tracer (`spherebake-reference`).
///
/// The texture is sampled with the material's UV set (skipped when the mesh lacks it, or when
/// a corner of the triangle holds [`spherebake_geom::NO_UV`]: its part has no such set),
/// KHR_texture_transform (in f64) and the sampler's wrap modes, trilinearly from a box-filtered
/// mip chain (2×2 → 1 per level, down to 1×1).
#[derive(Clone)]
pub struct SurfaceAlbedo<'a> {
    mesh: &'a Mesh,
    /// Per texture: its RGB mip chain when a material references it.
    chains: Vec<Option<MipChain<3>>>,
    /// Per texture: its premultiplied mip chain (RGB·α, α) when an alpha-masked material
    /// references it: a masked surface's colour is Σ RGB·α / Σ α over the footprint, so the
    /// colour of its cut-out texels never bleeds in, and its holes are tested on level 0's α.
    masked_chains: Vec<Option<MipChain<4>>>,
}

impl<'a> SurfaceAlbedo<'a> {
    /// Checks the mesh's indices and attribute lengths and builds one mip chain per referenced
    /// texture (in parallel, ordered collect).
    ///
    /// # Errors
    /// A triangle referencing a missing vertex, a per-triangle material list of the wrong length
    /// or a material index out of range, a COLOR_0 list of the wrong length, a material
    /// referencing a missing texture, or a texture whose texel count is not width × height
    /// (or is empty).
    pub fn new(mesh: &'a Mesh) -> Result<Self, AlbedoError> {
        check_vertices(mesh)?;
        let tcount = mesh.triangles.len();
        let vcount = mesh.positions.len();
        if !mesh.triangle_materials.is_empty() && mesh.triangle_materials.len() != tcount {
            return Err(AlbedoError::MaterialListLength { expected: tcount, actual: mesh.triangle_materials.len() });
        }
        for (triangle, &m) in mesh.triangle_materials.iter().enumerate() {
            if m as usize >= mesh.materials.len() {
                return Err(AlbedoError::MaterialOutOfRange {
                    triangle,
                    material: m,
                    material_count: mesh.materials.len(),
                });
            }
        }
        if !mesh.colors_linear.is_empty() && mesh.colors_linear.len() != vcount {
            return Err(AlbedoError::AttributeLength {
                attribute: "COLOR_0",
                expected: vcount,
                actual: mesh.colors_linear.len(),
            });
        }
        let mut referenced = vec![false; mesh.textures.len()];
        for (mi, m) in mesh.materials.iter().enumerate() {
            let Some(tr) = &m.base_color_texture else { continue };
            let Some(tex) = mesh.textures.get(tr.texture) else {
                return Err(AlbedoError::TextureOutOfRange {
                    material: mi,
                    texture: tr.texture,
                    texture_count: mesh.textures.len(),
                });
            };
            let (w, h) = (tex.width as usize, tex.height as usize);
            if w == 0 || h == 0 || tex.texels_linear.len() != w * h {
                return Err(AlbedoError::TextureSize {
                    texture: tr.texture,
                    width: tex.width,
                    height: tex.height,
                    actual: tex.texels_linear.len(),
                });
            }
            referenced[tr.texture] = true;
        }
        let chains = build_chains(mesh, &referenced, |t| [t[0], t[1], t[2]]);
        let mut masked = vec![false; mesh.textures.len()];
        for m in mesh.materials.iter().filter(|m| m.alpha_mask_cutoff.is_some()) {
            if let Some(tr) = &m.base_color_texture {
                masked[tr.texture] = true;
            }
        }
        let masked_chains = build_chains(mesh, &masked, |t| [t[0] * t[3], t[1] * t[3], t[2] * t[3], t[3]]);
        Ok(Self { mesh, chains, masked_chains })
    }

    /// The mesh this lookup reads.
    pub fn mesh(&self) -> &'a Mesh {
        self.mesh
    }

    /// Linear RGB albedo of triangle `triangle` (index into `mesh.triangles`) at barycentric
    /// weights `bary` (of its corners 0, 1, 2; not renormalised), texture level of detail `lod`
    /// (0 = full resolution, fractional levels blend two mip levels; clamped to the chain,
    /// non-finite → 0).
    ///
    /// A triangle index out of range gives black. Non-finite inputs (NaN vertex colours or
    /// texels) may give non-finite channels; callers map them as they need (the bake makes them 0).
    pub fn albedo(&self, triangle: usize, bary: [f64; 3], lod: f64) -> [f64; 3] {
        let Some(&tri) = self.mesh.triangles.get(triangle) else { return [0.0; 3] };
        let mi = self.mesh.triangle_materials.get(triangle).map_or(usize::MAX, |&m| m as usize);
        let material = self.mesh.materials.get(mi);
        let factor = material.map_or([1.0f32; 4], |m| m.base_color_factor_linear);
        let mut col = [f64::from(factor[0]), f64::from(factor[1]), f64::from(factor[2])];
        let interp = |v: [[f32; 4]; 3], k: usize| -> f64 {
            bary[0] * f64::from(v[0][k]) + bary[1] * f64::from(v[1][k]) + bary[2] * f64::from(v[2][k])
        };
        if !self.mesh.colors_linear.is_empty() {
            let vc = tri.map(|v| self.mesh.colors_linear[v as usize]);
            for (k, c) in col.iter_mut().enumerate() {
                *c *= interp(vc, k);
            }
        }
        if let Some(tr) = material.and_then(|m| m.base_color_texture.as_ref()) {
            let vcount = self.mesh.positions.len();
            if let (Some(uvs), Some(chain)) = (
                self.mesh.uvs.get(tr.uv_set as usize).filter(|u| u.len() == vcount && tri_has_uvs(u, tri)),
                self.chains.get(tr.texture).and_then(Option::as_ref),
            ) {
                let uv = texture_uv(uvs, tri, bary, &tr.transform);
                let wrap = [tr.wrap_s, tr.wrap_t];
                // A masked material: the α-weighted colour (its cut-out texels' colour left out);
                // where the footprint holds no opaque texel at all, the plain colour.
                let s = match self.masked_chains.get(tr.texture).and_then(Option::as_ref) {
                    Some(m) if material.is_some_and(|m| m.alpha_mask_cutoff.is_some()) => {
                        let p = m.sample(uv, lod, wrap);
                        if p[3] > 0.0 {
                            [p[0] / p[3], p[1] / p[3], p[2] / p[3]]
                        } else {
                            chain.sample(uv, lod, wrap)
                        }
                    }
                    _ => chain.sample(uv, lod, wrap),
                };
                for k in 0..3 {
                    col[k] *= s[k];
                }
            }
        }
        col
    }

    /// Whether triangle `triangle` is a hole at `bary` and `lod` (as in [`Self::albedo`]): its
    /// material is alpha-masked (glTF `alphaMode` `MASK`) and the base colour's alpha there —
    /// factor × COLOR_0 × texture, the texture only where the triangle has UVs — is below the
    /// cutoff (glTF: "rendered fully transparent"). NaN alpha is not a hole.
    pub fn is_hole(&self, triangle: usize, bary: [f64; 3], lod: f64) -> bool {
        let Some(&tri) = self.mesh.triangles.get(triangle) else { return false };
        let mi = self.mesh.triangle_materials.get(triangle).map_or(usize::MAX, |&m| m as usize);
        let Some(material) = self.mesh.materials.get(mi) else { return false };
        let Some(cutoff) = material.alpha_mask_cutoff else { return false };
        let mut alpha = f64::from(material.base_color_factor_linear[3]);
        if !self.mesh.colors_linear.is_empty() {
            let vc = tri.map(|v| f64::from(self.mesh.colors_linear[v as usize][3]));
            alpha *= bary[0] * vc[0] + bary[1] * vc[1] + bary[2] * vc[2];
        }
        if let Some(tr) = &material.base_color_texture {
            let vcount = self.mesh.positions.len();
            if let (Some(uvs), Some(chain)) = (
                self.mesh.uvs.get(tr.uv_set as usize).filter(|u| u.len() == vcount && tri_has_uvs(u, tri)),
                self.masked_chains.get(tr.texture).and_then(Option::as_ref),
            ) {
                alpha *= chain.sample(texture_uv(uvs, tri, bary, &tr.transform), lod, [tr.wrap_s, tr.wrap_t])[3];
            }
        }
        alpha < f64::from(cutoff)
    }

    /// The first hit of the ray `origin + t·dir`, t in (`t_min`, `t_max`), on `bvh` (built over
    /// this mesh's triangles, in order) that is not a hole ([`Self::is_hole`] at level 0): a ray
    /// passes through a leaf card's cut-out as the albedo bake sees through it. Each hole moves
    /// the search past its t by at least `step` (and one float); after [`MAX_HOLES_PER_RAY`]
    /// holes the next hit counts as opaque (bounded work on stacks of cards). Without masked
    /// materials this is `bvh.closest_hit`.
    pub fn first_opaque_hit(
        &self,
        bvh: &spherebake_geom::bvh::TriangleBvh,
        origin: glam::Vec3,
        dir: glam::Vec3,
        t_min: f32,
        t_max: f32,
        step: f32,
    ) -> Option<spherebake_geom::bvh::Hit> {
        let mut t0 = t_min;
        for _ in 0..MAX_HOLES_PER_RAY {
            let hit = bvh.closest_hit(origin, dir, t0, t_max)?;
            let (u, v) = (f64::from(hit.u), f64::from(hit.v));
            if !self.is_hole(hit.triangle as usize, [1.0 - u - v, u, v], 0.0) {
                return Some(hit);
            }
            t0 = f32::max(f32::from_bits(hit.t.to_bits() + 1), hit.t + step);
        }
        bvh.closest_hit(origin, dir, t0, t_max)
    }
}

/// Holes of alpha-masked materials a ray passes through at most in
/// [`SurfaceAlbedo::first_opaque_hit`].
pub const MAX_HOLES_PER_RAY: usize = 64;

// ---------------------------------------------------------------------------------------------
// Rendering

/// Per-triangle shading data.
struct TriShade {
    /// Unit outward normal.
    normal: DVec3,
    /// Texture texels per unit world area (UV area per world area × transform scale × size),
    /// 0 without a usable texture.
    texels_per_area: f64,
}

struct Context<'a> {
    mesh: &'a Mesh,
    pos: Vec<DVec3>,
    /// ±1: outward = sign · CCW normal.
    orient: Vec<f64>,
    spheres: Vec<SphereF64>,
    assigned: Vec<Vec<u32>>,
    /// The triangles rendered for several spheres: their fragments are kept only where the point
    /// seen lies in the sphere's own segment (module docs, step 1).
    shared: SharedTriangles,
    /// Triangles in Morton order of their centroids, in runs of [`CLUSTER_SIZE`] with their
    /// bounding boxes: the coverage pass skips a run whose texels are all covered already.
    clusters: Vec<Cluster>,
    cluster_tris: Vec<u32>,
    shade: Vec<TriShade>,
    /// The colour lookup (shared with the reference path tracer).
    surface: SurfaceAlbedo<'a>,
    grid: CubeGrid,
    lod: TextureLod,
    shared_triangles: usize,
    textured_without_uvs: usize,
    sh_order: usize,
    /// The surface's one colour (module docs, "One colour"), when it has one and the uncovered
    /// texels are filled.
    one_colour: Option<[f32; 3]>,
    /// Per triangle: its material is alpha-masked, so a segment fragment may be a hole
    /// ([`SurfaceAlbedo::is_hole`]); empty when no material is.
    masked: Vec<bool>,
}

#[derive(Default, Clone, Copy)]
struct SphereCounts {
    rule1: u64,
    rule2: u64,
    rule3: u64,
    empty: u64,
    unclassified: u64,
    no_segment: u64,
    one_colour: bool,
    triangles: u64,
}

impl SphereCounts {
    fn add_to(&self, s: &mut AlbedoStats) {
        s.texels_rule1 += self.rule1;
        s.texels_rule2 += self.rule2;
        s.texels_rule3 += self.rule3;
        s.texels_empty += self.empty;
        s.texels_unclassified += self.unclassified;
        s.texels_no_segment += self.no_segment;
        s.one_colour_spheres += usize::from(self.one_colour);
        s.triangle_assignments += self.triangles;
    }
}

/// One sphere's render targets: the farthest back-facing and nearest front-facing segment
/// surface per texel, whether any back-facing surface covers it, and how many do not.
struct Canvas {
    back: Vec<Hit>,
    front: Vec<Hit>,
    any_back: Vec<bool>,
    uncovered: usize,
}

/// A stored candidate surface for one texel.
#[derive(Clone, Copy)]
struct Hit {
    dist: f64,
    tri: u32,
    bary: [f64; 3],
}

/// Triangles per coverage run ([`Context::clusters`]).
const CLUSTER_SIZE: usize = 32;

/// A run of triangles in Morton order and the bounding box of their corners (model space).
struct Cluster {
    lo: DVec3,
    hi: DVec3,
    start: u32,
    end: u32,
}

/// The triangles sorted by the 30-bit Morton code of their centroids in the mesh's bounding
/// box (ties by index; non-finite centroids code 0), cut into runs of [`CLUSTER_SIZE`].
fn clusters(pos: &[DVec3], triangles: &[[u32; 3]]) -> (Vec<Cluster>, Vec<u32>) {
    let finite = pos.iter().filter(|p| p.is_finite());
    let lo = finite.clone().fold(DVec3::INFINITY, |a, &p| a.min(p));
    let hi = finite.fold(DVec3::NEG_INFINITY, |a, &p| a.max(p));
    let extent = (hi - lo).max(DVec3::splat(f64::MIN_POSITIVE));
    let code = |t: &[u32; 3]| -> u32 {
        let c = (pos[t[0] as usize] + pos[t[1] as usize] + pos[t[2] as usize]) / 3.0;
        let q =
            ((c - lo) / extent * 1023.0)
                .to_array()
                .map(|v| if v.is_finite() { v.clamp(0.0, 1023.0) as u32 } else { 0 });
        let mut m = 0u32;
        for bit in 0..10 {
            for (k, v) in q.iter().enumerate() {
                m |= ((v >> bit) & 1) << (3 * bit + k as u32);
            }
        }
        m
    };
    // (code, index) pairs are distinct: the parallel sort is the same whatever the threads.
    let mut keyed: Vec<(u32, u32)> = triangles.par_iter().enumerate().map(|(i, t)| (code(t), i as u32)).collect();
    keyed.par_sort_unstable();
    let order: Vec<u32> = keyed.into_iter().map(|(_, i)| i).collect();
    let runs = order
        .par_chunks(CLUSTER_SIZE)
        .enumerate()
        .map(|(k, run)| {
            let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
            // (A triangle with a non-finite corner draws nothing, so the box may leave it out.)
            for &v in run.iter().flat_map(|&t| &triangles[t as usize]) {
                lo = lo.min(pos[v as usize]);
                hi = hi.max(pos[v as usize]);
            }
            let start = (k * CLUSTER_SIZE) as u32;
            Cluster { lo, hi, start, end: start + run.len() as u32 }
        })
        .collect();
    (runs, order)
}

/// The colour of every surface point when the mesh has one (module docs, "One colour"): no
/// used material has a base-colour texture, the used materials' base colour factors agree (RGB)
/// and so do the COLOR_0 values (or there are none); `None` otherwise, or when it is not finite.
/// The value is [`SurfaceAlbedo::albedo`] at a corner of the first triangle, rounded to f32
/// as a rendered texel is.
fn one_colour(mesh: &Mesh, surface: &SurfaceAlbedo<'_>) -> Option<[f32; 3]> {
    if mesh.triangles.is_empty() {
        return None;
    }
    let material = |t: usize| mesh.triangle_materials.get(t).and_then(|&m| mesh.materials.get(m as usize));
    let factor = |t: usize| {
        let f = material(t).map_or([1.0f32; 4], |m| m.base_color_factor_linear);
        [f[0], f[1], f[2]].map(f32::to_bits)
    };
    let first = factor(0);
    for t in 0..mesh.triangles.len() {
        if material(t).is_some_and(|m| m.base_color_texture.is_some()) || factor(t) != first {
            return None;
        }
    }
    if let Some(c0) = mesh.colors_linear.first() {
        let rgb = |c: &[f32; 4]| [c[0], c[1], c[2]].map(f32::to_bits);
        if mesh.colors_linear.iter().any(|c| rgb(c) != rgb(c0)) {
            return None;
        }
    }
    let c = surface.albedo(0, [1.0, 0.0, 0.0], 0.0);
    c.iter().all(|v| v.is_finite()).then(|| c.map(|v| v as f32))
}

impl<'a> Context<'a> {
    fn new(
        mesh: &'a Mesh,
        flip: &[bool],
        spheres: &[[f32; 4]],
        settings: &AlbedoSettings,
    ) -> Result<Self, AlbedoError> {
        check_setting("sh_order", settings.sh_order, 1, 8, "1..=8")?;
        check_setting("cubemap_size", settings.cubemap_size, 1, 1024, "1..=1024")?;
        let tcount = mesh.triangles.len();
        if flip.len() != tcount {
            return Err(AlbedoError::FlipLength { expected: tcount, actual: flip.len() });
        }
        check_spheres(spheres)?;
        let surface = SurfaceAlbedo::new(mesh)?;
        let vcount = mesh.positions.len();
        let texture_of_material: Vec<Option<usize>> =
            mesh.materials.iter().map(|m| m.base_color_texture.as_ref().map(|t| t.texture)).collect();

        let pos: Vec<DVec3> = mesh.positions.iter().map(|p| p.as_dvec3()).collect();
        let orient: Vec<f64> = flip.iter().map(|&f| if f { -1.0 } else { 1.0 }).collect();
        let sph = spheres_f64(spheres);
        let (assigned, shared) = assign(&pos, &mesh.triangles, &sph);
        let shared_triangles = shared.triangles.len();

        // Per triangle, in parallel (an ordered collect): its shading terms, and whether it is
        // textured without UVs.
        let shaded: Vec<(TriShade, bool)> = mesh
            .triangles
            .par_iter()
            .enumerate()
            .map(|(t, tri)| {
                let [a, b, c] = tri.map(|v| pos[v as usize]);
                let n = (b - a).cross(c - a);
                let area2 = n.length();
                let normal = if area2 > 0.0 { n / area2 * orient[t] } else { DVec3::ZERO };
                let (mut texels_per_area, mut without_uvs) = (0.0, false);
                let mi = mesh.triangle_materials.get(t).map_or(usize::MAX, |&m| m as usize);
                if let (Some(m), Some(Some(ti))) = (mesh.materials.get(mi), texture_of_material.get(mi)) {
                    let tr = m.base_color_texture.as_ref().expect("texture_of_material is Some");
                    match mesh.uvs.get(tr.uv_set as usize).filter(|u| u.len() == vcount && tri_has_uvs(u, *tri)) {
                        Some(uvs) => {
                            let [ua, ub, uc] = tri.map(|v| uvs[v as usize]);
                            let uv_area2 = ((f64::from(ub[0]) - f64::from(ua[0]))
                                * (f64::from(uc[1]) - f64::from(ua[1]))
                                - (f64::from(ub[1]) - f64::from(ua[1])) * (f64::from(uc[0]) - f64::from(ua[0])))
                            .abs();
                            let tex = &mesh.textures[*ti];
                            let scale = (f64::from(tr.transform.scale[0]) * f64::from(tr.transform.scale[1])).abs();
                            if area2 > 0.0 {
                                texels_per_area =
                                    uv_area2 / area2 * scale * f64::from(tex.width) * f64::from(tex.height);
                            }
                        }
                        None => without_uvs = true,
                    }
                }
                (TriShade { normal, texels_per_area }, without_uvs)
            })
            .collect();
        let textured_without_uvs = shaded.iter().filter(|x| x.1).count();
        let shade: Vec<TriShade> = shaded.into_iter().map(|x| x.0).collect();
        let (clusters, cluster_tris) = clusters(&pos, &mesh.triangles);
        let one_colour = if settings.fill_uncovered { one_colour(mesh, &surface) } else { None };
        let masked = if mesh.materials.iter().any(|m| m.alpha_mask_cutoff.is_some()) {
            (0..tcount)
                .map(|t| {
                    let m = mesh.triangle_materials.get(t).and_then(|&m| mesh.materials.get(m as usize));
                    m.is_some_and(|m| m.alpha_mask_cutoff.is_some())
                })
                .collect()
        } else {
            Vec::new()
        };
        Ok(Self {
            mesh,
            pos,
            orient,
            spheres: sph,
            assigned,
            shared,
            clusters,
            cluster_tris,
            shade,
            surface,
            grid: CubeGrid::new(settings.cubemap_size),
            lod: settings.texture_lod,
            shared_triangles,
            textured_without_uvs,
            sh_order: settings.sh_order,
            one_colour,
            masked,
        })
    }

    fn base_stats(&self) -> AlbedoStats {
        AlbedoStats {
            spheres: self.spheres.len(),
            face_size: self.grid.face_size(),
            sh_order: self.sh_order,
            shared_triangles: self.shared_triangles,
            textured_triangles_without_uvs: self.textured_without_uvs,
            ..Default::default()
        }
    }

    /// Sets every texel of sphere `s`'s map where the sphere has no surface (rule 2, or nothing at all) to the
    /// solid-angle-weighted mean colour of its covered texels (rules 1 and 3); a map with no covered texel stays 0.
    fn fill_uncovered(&self, texels: &mut [[f32; 3]], covered: &[bool]) {
        let (mut sum, mut w) = ([0.0f64; 3], 0.0f64);
        for (t, (v, &c)) in texels.iter().zip(covered).enumerate() {
            if c {
                let a = self.grid.nominal_solid_angle(t);
                for k in 0..3 {
                    sum[k] += a * f64::from(v[k]);
                }
                w += a;
            }
        }
        if w <= 0.0 {
            return;
        }
        let mean = sum.map(|x| (x / w) as f32);
        for (v, &c) in texels.iter_mut().zip(covered) {
            if !c {
                *v = mean;
            }
        }
    }

    /// The sphere of `list` (increasing indices) whose segment holds the point at `bary` of
    /// triangle `t`: the smallest |p − c|/r, ties to the lowest index; `None` when no distance
    /// is a number.
    fn owner_among(&self, t: usize, bary: [f64; 3], list: &[u32]) -> Option<u32> {
        let [a, b, c] = self.mesh.triangles[t].map(|v| self.pos[v as usize]);
        let p = a * bary[0] + b * bary[1] + c * bary[2];
        let mut best = (f64::INFINITY, None);
        for &j in list {
            let d = self.spheres[j as usize].d2(p);
            if d < best.0 {
                best = (d, Some(j));
            }
        }
        best.1
    }

    /// Draws triangle `t` for the sphere `s` centred at `centre`: back-facing from the centre it
    /// marks the texels that have some back surface (rule 2), and in the sphere's own segment
    /// (`mine`) it is a rule 1 (back) or rule 3 (front, seen through the centre) candidate —
    /// where the point seen lies in the segment: a triangle rendered for several spheres
    /// (`self.shared`) is tested per fragment, as the samples test their hits.
    fn draw(&self, cv: &mut Canvas, t: usize, mine: bool, s: usize, centre: DVec3) {
        let [a, b, c] = self.mesh.triangles[t].map(|v| self.pos[v as usize] - centre);
        // det(a, b, c) = CCW normal · (a − centre): > 0 when the CCW side faces away.
        let det = a.dot(b.cross(c)) * self.orient[t];
        // An alpha-masked segment fragment below the cutoff is a hole: it takes no texel, so
        // the surface behind it (or the fill) shows. It still counts as back surface for rule 2,
        // which the other triangles mark without reading their texture.
        let masked = mine && self.masked.get(t).copied().unwrap_or(false);
        // The hole test reads level 0 (a coarse level's mean α would drop a sparse card whole or
        // keep a dense one's cut-outs), as the light reference does.
        let hole = |f: &Fragment| masked && self.surface.is_hole(t, f.bary, 0.0);
        // Only a shared triangle has points outside the segment of a sphere it is drawn for.
        let shared = if mine { self.shared.spheres_of(t as u32) } else { None };
        let in_segment = |f: &Fragment| shared.is_none_or(|list| self.owner_among(t, f.bary, list) == Some(s as u32));
        if det > 0.0 {
            // Back-facing from the centre: seen along +ω.
            self.grid.rasterize(a, b, c, |f: Fragment| {
                if !cv.any_back[f.texel] {
                    cv.any_back[f.texel] = true;
                    cv.uncovered -= 1;
                }
                if mine {
                    let h = &mut cv.back[f.texel];
                    if f.dist > h.dist && in_segment(&f) && !hole(&f) {
                        *h = Hit { dist: f.dist, tri: t as u32, bary: f.bary };
                    }
                }
            });
        } else if det < 0.0 && mine {
            // Front-facing: seen through the centre (direction −(p − c)).
            self.grid.rasterize(-a, -b, -c, |f: Fragment| {
                let h = &mut cv.front[f.texel];
                if f.dist < h.dist && in_segment(&f) && !hole(&f) {
                    *h = Hit { dist: f.dist, tri: t as u32, bary: f.bary };
                }
            });
        }
    }

    /// Renders sphere `s`'s cube map (linear RGB, face-major), with per texel whether a surface point covers it
    /// (rule 1 or rule 3).
    fn render_sphere(&self, s: usize) -> (Vec<[f32; 3]>, SphereCounts, Vec<bool>) {
        let centre = self.spheres[s].c;
        let n_texels = self.grid.texel_count();
        // Empty entries: back at distance −∞ (any hit is farther), front at +∞ (any is nearer).
        let mut cv = Canvas {
            back: vec![Hit { dist: f64::NEG_INFINITY, tri: u32::MAX, bary: [0.0; 3] }; n_texels],
            front: vec![Hit { dist: f64::INFINITY, tri: u32::MAX, bary: [0.0; 3] }; n_texels],
            any_back: vec![false; n_texels],
            uncovered: n_texels,
        };
        let assigned = &self.assigned[s];
        if assigned.is_empty() {
            // No triangle of its own (a sphere the fit left empty): rules 1 and 3 read only the
            // segment's triangles, so every texel stays 0 and uncovered, whatever the others
            // would mark. Drawing them only told rule 2 from empty, at up to every triangle of
            // the mesh per sphere (the bunny at 4096 spheres, 2459 left empty: 6.6 s).
            let counts = SphereCounts { no_segment: n_texels as u64, ..Default::default() };
            return (vec![[0.0; 3]; n_texels], counts, vec![false; n_texels]);
        }
        // The segment's own triangles in increasing order (ties in distance keep the first).
        for &t in assigned {
            self.draw(&mut cv, t as usize, true, s, centre);
        }
        if let Some(colour) = self.one_colour {
            // A rule 1 texel is covered, so every texel ends the one colour (module docs).
            let rule1 = cv.back.iter().filter(|h| h.tri != u32::MAX).count() as u64;
            if rule1 > 0 {
                let counts = SphereCounts {
                    rule1,
                    unclassified: n_texels as u64 - rule1,
                    one_colour: true,
                    triangles: assigned.len() as u64,
                    ..Default::default()
                };
                return (vec![colour; n_texels], counts, vec![true; n_texels]);
            }
        }
        // The other triangles only mark the texels that have some back surface, until every
        // texel has: a run of them whose box covers only marked texels changes nothing.
        for cl in &self.clusters {
            if cv.uncovered == 0 {
                break;
            }
            if self.grid.box_covered(cl.lo - centre, cl.hi - centre, &cv.any_back) {
                continue;
            }
            for &t in &self.cluster_tris[cl.start as usize..cl.end as usize] {
                if cv.uncovered == 0 {
                    break;
                }
                if assigned.binary_search(&t).is_err() {
                    self.draw(&mut cv, t as usize, false, s, centre);
                }
            }
        }
        let Canvas { back, front, any_back, .. } = cv;
        let mut counts = SphereCounts { triangles: assigned.len() as u64, ..Default::default() };
        let mut out = vec![[0.0f32; 3]; n_texels];
        let mut covered = vec![false; n_texels];
        for (texel, o) in out.iter_mut().enumerate() {
            let hit = if back[texel].tri != u32::MAX {
                counts.rule1 += 1;
                Some((back[texel], 1.0))
            } else if any_back[texel] {
                counts.rule2 += 1;
                None
            } else if front[texel].tri != u32::MAX {
                counts.rule3 += 1;
                Some((front[texel], -1.0))
            } else {
                counts.empty += 1;
                None
            };
            if let Some((h, sgn)) = hit {
                covered[texel] = true;
                let c = self.shade(texel, h, sgn);
                // Non-finite input colours (NaN vertex colours, texels) become 0, never NaN SH.
                *o = c.map(|v| if v.is_finite() { v as f32 } else { 0.0 });
            }
        }
        (out, counts, covered)
    }

    /// Colour of the surface point `h` seen in texel `texel` (`sgn` −1 when seen through the
    /// centre): [`SurfaceAlbedo::albedo`] at the texel footprint's level of detail.
    fn shade(&self, texel: usize, h: Hit, sgn: f64) -> [f64; 3] {
        let t = h.tri as usize;
        self.surface.albedo(t, h.bary, self.lod_at(texel, t, h.dist, sgn))
    }

    /// The texture level of detail of triangle `t` seen in `texel` at distance `dist` (`sgn` −1
    /// when seen through the centre): see [`TextureLod`].
    fn lod_at(&self, texel: usize, t: usize, dist: f64, sgn: f64) -> f64 {
        match self.lod {
            TextureLod::Base => 0.0,
            TextureLod::Footprint => {
                let d = self.grid.direction(texel) * sgn;
                let cos = self.shade[t].normal.dot(d).abs().max(1e-3);
                let area = self.grid.nominal_solid_angle(texel) * dist * dist / cos;
                let texels = area * self.shade[t].texels_per_area;
                if texels > 1.0 {
                    0.5 * texels.log2()
                } else {
                    0.0
                }
            }
        }
    }
}

/// Whether every corner of `tri` has a usable UV in `uvs` ([`spherebake_geom::has_uv`]: not
/// [`spherebake_geom::NO_UV`], where its part lacks the set, nor otherwise non-finite). A
/// triangle without reads its base colour factor, never the texel at (0, 0).
fn tri_has_uvs(uvs: &[[f32; 2]], tri: [u32; 3]) -> bool {
    tri.iter().all(|&v| uvs.get(v as usize).is_some_and(|&uv| spherebake_geom::has_uv(uv)))
}

/// The texture coordinate of triangle `tri` at barycentric `bary`: its corners' UVs
/// interpolated in f64, then KHR_texture_transform.
fn texture_uv(uvs: &[[f32; 2]], tri: [u32; 3], bary: [f64; 3], transform: &spherebake_geom::UvTransform) -> [f64; 2] {
    let uv3 = tri.map(|v| uvs[v as usize]);
    let uv = [0, 1]
        .map(|k| bary[0] * f64::from(uv3[0][k]) + bary[1] * f64::from(uv3[1][k]) + bary[2] * f64::from(uv3[2][k]));
    apply_transform(transform, uv)
}

/// KHR_texture_transform in f64 (same formula as `UvTransform::apply`).
fn apply_transform(t: &spherebake_geom::UvTransform, uv: [f64; 2]) -> [f64; 2] {
    let r = f64::from(t.rotation_rad);
    let (s, c) = r.sin_cos();
    let x = uv[0] * f64::from(t.scale[0]);
    let y = uv[1] * f64::from(t.scale[1]);
    let out = [c * x + s * y + f64::from(t.offset[0]), -s * x + c * y + f64::from(t.offset[1])];
    if out[0].is_finite() && out[1].is_finite() {
        out
    } else {
        [0.0, 0.0]
    }
}

// ---------------------------------------------------------------------------------------------
// Projection

/// SH projection with exact texel solid angles: a precomputed table when it is small
/// (≤ 2²³ entries), otherwise evaluated per texel (same formula, for reference resolutions).
enum Projector {
    Table(CubeProjector),
    Stream { order: usize, n: usize, norm: f64 },
}

impl Projector {
    fn new(order: usize, n: usize) -> Result<Self, AlbedoError> {
        let entries = 6 * n * n * coeff_count(order);
        if entries <= 1 << 23 {
            return Ok(Projector::Table(CubeProjector::new(order, n)?));
        }
        let mut total = 0.0;
        for _ in 0..6 {
            for j in 0..n {
                for i in 0..n {
                    total += cube_texel_solid_angle(i, j, n);
                }
            }
        }
        Ok(Projector::Stream { order, n, norm: 4.0 * std::f64::consts::PI / total })
    }

    fn project(&self, texels: &[[f32; 3]]) -> Vec<[f32; 3]> {
        match self {
            Projector::Table(p) => {
                let mut out = vec![[0.0f32; 3]; coeff_count(p.order())];
                // Lengths match by construction (6n² texels, order² outputs).
                if p.project(texels, &mut out).is_err() {
                    out.fill([f32::NAN; 3]);
                }
                out
            }
            Projector::Stream { order, n, norm } => {
                let nc = coeff_count(*order);
                let mut acc = vec![[0.0f64; 3]; nc];
                let mut y = vec![0.0f64; nc];
                for face in CubeFace::ALL {
                    for j in 0..*n {
                        for i in 0..*n {
                            let v = texels[(face.index() * n + j) * n + i];
                            if v == [0.0; 3] {
                                continue;
                            }
                            let d = spherebake_sh::cube_texel_direction(face, i, j, *n);
                            let w = cube_texel_solid_angle(i, j, *n) * norm;
                            if eval_sh_f64(*order, d, &mut y).is_err() {
                                continue;
                            }
                            for (a, &yi) in acc.iter_mut().zip(&y) {
                                for c in 0..3 {
                                    a[c] += w * yi * f64::from(v[c]);
                                }
                            }
                        }
                    }
                }
                acc.iter().map(|a| [a[0] as f32, a[1] as f32, a[2] as f32]).collect()
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Debug images

/// Writes, per sphere, `sphere_NNNN.png`: the cube map as a horizontal cross (+Y on top; −X, +Z,
/// +X, −Z across; −Y below; faces as stored, column i → right, row j → down) and, to its right,
/// the same cross of the SH reconstruction evaluated at the texel centres. Linear colour is
/// clamped to [0, 1] and sRGB-encoded; the area outside the crosses is grey. Faces smaller than
/// 64 texels are enlarged by an integer factor. Returns the files written.
///
/// # Errors
/// Directory creation or PNG encoding/writing failures; an image whose path is one of `protect`
/// (by canonical path: the model's inputs), checked for every image before any is written.
pub fn write_debug_cubemaps(
    dir: &Path,
    maps: &[CubeMap],
    sh: &AlbedoSh,
    protect: &[PathBuf],
) -> std::io::Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir)?;
    let protected: Vec<PathBuf> = protect.iter().filter_map(|p| std::fs::canonicalize(p).ok()).collect();
    for s in 0..maps.len() {
        let path = dir.join(format!("sphere_{s:04}.png"));
        if std::fs::canonicalize(&path).is_ok_and(|c| protected.contains(&c)) {
            return Err(std::io::Error::other(format!(
                "{} is a file the model reads; not overwritten",
                path.display()
            )));
        }
    }
    let order = usize::from(sh.order);
    let nc = order * order;
    let mut files = Vec::with_capacity(maps.len());
    for (s, map) in maps.iter().enumerate() {
        let n = map.face_size;
        if n == 0 || map.texels_linear.len() != 6 * n * n {
            return Err(std::io::Error::other(format!("cube map {s} has the wrong texel count")));
        }
        let coeffs = sh.of(s).unwrap_or(&[]);
        let mut recon = vec![[0.0f32; 3]; 6 * n * n];
        if coeffs.len() == nc && nc > 0 {
            let mut y = vec![0.0f64; nc];
            for face in CubeFace::ALL {
                for j in 0..n {
                    for i in 0..n {
                        let d = spherebake_sh::cube_texel_direction(face, i, j, n);
                        if eval_sh_f64(order, d, &mut y).is_ok() {
                            let mut c = [0.0f64; 3];
                            for (yi, k) in y.iter().zip(coeffs) {
                                for ch in 0..3 {
                                    c[ch] += yi * f64::from(k[ch]);
                                }
                            }
                            recon[(face.index() * n + j) * n + i] = [c[0] as f32, c[1] as f32, c[2] as f32];
                        }
                    }
                }
            }
        }
        let scale = (64 / n).max(1);
        let fw = n * scale;
        let gap = fw / 4;
        let (w, h) = (8 * fw + gap, 3 * fw);
        let mut img = image::RgbImage::from_pixel(w as u32, h as u32, image::Rgb([96, 96, 96]));
        // (face, cross column, cross row)
        const LAYOUT: [(usize, usize, usize); 6] = [(2, 1, 0), (1, 0, 1), (4, 1, 1), (0, 2, 1), (5, 3, 1), (3, 1, 2)];
        for (k, texels) in [&map.texels_linear, &recon].into_iter().enumerate() {
            let x0 = k * (4 * fw + gap);
            for &(face, cx, cy) in &LAYOUT {
                for y in 0..fw {
                    for x in 0..fw {
                        let t = texels[(face * n + y / scale) * n + x / scale];
                        let px = image::Rgb(t.map(linear_to_srgb8));
                        img.put_pixel((x0 + cx * fw + x) as u32, (cy * fw + y) as u32, px);
                    }
                }
            }
        }
        let path = dir.join(format!("sphere_{s:04}.png"));
        img.save(&path).map_err(std::io::Error::other)?;
        files.push(path);
    }
    Ok(files)
}

fn linear_to_srgb8(c: f32) -> u8 {
    let c = f64::from(c);
    let c = if c.is_finite() { c.clamp(0.0, 1.0) } else { 0.0 };
    let s = if c <= 0.0031308 { 12.92 * c } else { 1.055 * c.powf(1.0 / 2.4) - 0.055 };
    (s * 255.0 + 0.5).floor().clamp(0.0, 255.0) as u8
}

#[cfg(test)]
mod tests {
    use super::*;

    /// [`assign`]'s per-triangle lists as they were computed before the sphere groups: every
    /// sphere's bound, one by one.
    fn assign_reference(pos: &[DVec3], triangles: &[[u32; 3]], spheres: &[SphereF64]) -> Vec<Vec<u32>> {
        let vertex_owner: Vec<usize> = pos
            .iter()
            .map(|p| {
                let (mut owner, mut best) = (0, f64::INFINITY);
                for (s, sp) in spheres.iter().enumerate().filter(|(_, sp)| sp.inv_r2.is_finite()) {
                    let d = sp.d2(*p);
                    if d < best {
                        (best, owner) = (d, s);
                    }
                }
                owner
            })
            .collect();
        let mut per_sphere = vec![Vec::new(); spheres.len()];
        for (ti, tri) in triangles.iter().enumerate() {
            let t = tri.map(|v| pos[v as usize]);
            if !t.iter().all(|p| p.is_finite()) {
                continue;
            }
            let owners = tri.map(|v| vertex_owner[v as usize]);
            let owner_max = owner_max(spheres, &owners, &t);
            let (lo, hi) = (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]));
            for (i, si) in spheres.iter().enumerate() {
                if si.inv_r2.is_infinite() {
                    continue;
                }
                if owners.contains(&i) {
                    per_sphere[i].push(ti as u32);
                    continue;
                }
                let d = si.c.clamp(lo, hi) - si.c;
                let bound = (d.x * d.x + d.y * d.y + d.z * d.z) * si.inv_r2;
                if bound > owner_max * (1.0 + 1e-9) + f64::MIN_POSITIVE {
                    continue;
                }
                if owners.iter().any(|&o| dominates(&spheres[o], si, &t)) {
                    continue;
                }
                if !spheres.iter().enumerate().any(|(j, sj)| j != i && sj.inv_r2.is_finite() && dominates(sj, si, &t)) {
                    per_sphere[i].push(ti as u32);
                }
            }
        }
        per_sphere
    }

    /// The sphere groups skip only spheres the per-sphere bound skips: [`assign`] gives the
    /// reference's lists on random triangles of all sizes, with radius-0, duplicate and
    /// coincident spheres among up to 70 (several groups).
    #[test]
    fn assign_with_sphere_groups_matches_the_per_sphere_bound() {
        let mut rng = spherebake_geom::rng::SplitMix64::new(0x2545_F491_4F6C_DD1D);
        let mut next = move || rng.next_f64();
        let mut checked = 0;
        for case in 0..24 {
            let n = [1, 3, 8, 9, 17, 40, 70][case % 7];
            let mut spheres: Vec<[f32; 4]> = (0..n)
                .map(|_| [next() * 4.0 - 2.0, next() * 4.0 - 2.0, next() * 4.0 - 2.0, 0.05 + next()].map(|v| v as f32))
                .collect();
            if n > 3 {
                spheres[n - 1] = spheres[0];
                spheres[1][3] = 0.0;
                spheres[2] = [spheres[3][0], spheres[3][1], spheres[3][2], spheres[3][3] * 0.5];
            }
            let scale = [0.01, 0.2, 1.5][case % 3];
            let mut pos = Vec::new();
            let mut triangles = Vec::new();
            for k in 0..400u32 {
                let c = DVec3::new(next(), next(), next()) * 5.0 - 2.5;
                for _ in 0..3 {
                    pos.push(c + (DVec3::new(next(), next(), next()) - 0.5) * scale);
                }
                triangles.push([3 * k, 3 * k + 1, 3 * k + 2]);
            }
            // Shared corners too (vertex owners carry over between triangles).
            triangles.extend((0..200u32).map(|k| [k, k + 401, (7 * k + 3) % 1200]));
            let sph = spheres_f64(&spheres);
            let (per_sphere, _) = assign(&pos, &triangles, &sph);
            assert_eq!(per_sphere, assign_reference(&pos, &triangles, &sph), "case {case}");
            checked += per_sphere.iter().map(Vec::len).sum::<usize>();
        }
        assert!(checked > 10_000, "{checked}");
    }

    #[test]
    fn wrap_modes_follow_gltf() {
        let n = 4;
        let r: Vec<usize> = (-5..9).map(|i| wrap_index(i, n, WrapMode::Repeat)).collect();
        assert_eq!(r, [3, 0, 1, 2, 3, 0, 1, 2, 3, 0, 1, 2, 3, 0]);
        let m: Vec<usize> = (-5..9).map(|i| wrap_index(i, n, WrapMode::MirroredRepeat)).collect();
        assert_eq!(m, [3, 3, 2, 1, 0, 0, 1, 2, 3, 3, 2, 1, 0, 0]);
        let c: Vec<usize> = (-2..6).map(|i| wrap_index(i, n, WrapMode::ClampToEdge)).collect();
        assert_eq!(c, [0, 0, 0, 1, 2, 3, 3, 3]);
    }

    #[test]
    fn surface_albedo_multiplies_factor_vertex_colour_and_texture() {
        use spherebake_geom::{Material, Texture, TextureRef, UvTransform};
        // 2×1 texture: left texel (0.2, 0.4, 0.6), right (1, 1, 1); one triangle whose UVs all
        // sit in the left texel's centre under ClampToEdge: bilinear there is exact.
        let texture = Texture {
            name: "t".into(),
            width: 2,
            height: 1,
            texels_linear: vec![[0.2, 0.4, 0.6, 1.0], [1.0, 1.0, 1.0, 1.0]],
        };
        let tr = TextureRef {
            texture: 0,
            uv_set: 0,
            wrap_s: WrapMode::ClampToEdge,
            wrap_t: WrapMode::ClampToEdge,
            mag_filter: Default::default(),
            transform: UvTransform::default(),
        };
        let mesh = Mesh {
            positions: vec![glam::Vec3::ZERO, glam::Vec3::X, glam::Vec3::Y],
            uvs: vec![vec![[0.25, 0.5]; 3]],
            colors_linear: vec![[1.0, 0.5, 0.25, 1.0], [0.5, 0.5, 0.5, 1.0], [0.0, 1.0, 1.0, 1.0]],
            triangles: vec![[0, 1, 2]],
            triangle_materials: vec![0],
            materials: vec![Material {
                base_color_factor_linear: [0.5, 1.0, 2.0, 1.0],
                base_color_texture: Some(tr),
                ..Default::default()
            }],
            textures: vec![texture],
            ..Default::default()
        };
        let s = SurfaceAlbedo::new(&mesh).unwrap();
        let w = [0.5, 0.25, 0.25];
        // Vertex colour at w: R 0.5·1 + 0.25·0.5 + 0 = 0.625, G 0.25 + 0.125 + 0.25 = 0.625,
        // B 0.125 + 0.125 + 0.25 = 0.5.
        let expect = [0.5 * 0.625 * 0.2, 1.0 * 0.625 * 0.4, 2.0 * 0.5 * 0.6];
        let got = s.albedo(0, w, 0.0);
        for k in 0..3 {
            assert!((got[k] - expect[k]).abs() < 1e-6, "{got:?} vs {expect:?}");
        }
        // Level 1 is the 1×1 mean (0.6, 0.7, 0.8).
        let mean = [0.6, 0.7, 0.8];
        let got = s.albedo(0, w, 5.0);
        for k in 0..3 {
            let e = [0.5 * 0.625, 0.625, 1.0][k] * mean[k];
            assert!((got[k] - e).abs() < 1e-6, "{got:?}");
        }
        assert_eq!(s.albedo(7, w, 0.0), [0.0; 3]);
        // A material pointing at a missing texture is an error, not a panic.
        let mut bad = mesh.clone();
        bad.textures.clear();
        assert!(matches!(SurfaceAlbedo::new(&bad), Err(AlbedoError::TextureOutOfRange { .. })));
    }
}
