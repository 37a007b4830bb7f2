//! The spherebake pipeline: import → orient → voxelize → fit → skinning (and the pose margin, which
//! may grow radii) → hierarchy → samples → albedo SH → `.sphb` file bytes.
//!
//! Architecture invariant: no terminal, no JSON printing, no exit codes. [`bake_path`] returns
//! the file bytes and a [`BakeReport`]; the caller decides where they go (the CLI writes them
//! atomically).
//!
//! Units: lengths in the input's units (glTF: metres), model (scene) space; see
//! `docs/ARCHITECTURE.md` for the conventions of every stage.

mod albedo;
pub mod export;
mod incremental;
mod raster;
pub mod render;
pub mod samples;
mod settings;
pub mod skin;

pub use albedo::{
    bake_albedo, project_cubemaps, render_albedo_cubemaps, segment_triangles, write_debug_cubemaps, AlbedoError,
    AlbedoSettings, AlbedoStats, CubeMap, SurfaceAlbedo, TextureLod, MAX_HOLES_PER_RAY,
};
pub use incremental::{inputs_value, is_up_to_date, recorded_inputs, recorded_missing, INPUTS_KEY, MISSING_INPUTS_KEY};

pub use settings::{BakeSettings, Method, Preset};
pub use skin::{bake_skin, grow_for_animations, MarginResult, PoseMargin, SkinError, SkinSettings, SkinStats};

use serde::Serialize;
use spherebake_fit::hierarchy::{build_hierarchy, hierarchy_stats, HierarchySettings};
use spherebake_fit::{FitSettings, Method as FitMethod};
use spherebake_format::{Metadata, SphbFile, Sphere};
use spherebake_geom::bvh::TriangleBvh;
use spherebake_geom::orient::{outward_orientation, turned};
use spherebake_geom::winding::WindingNumber;
use spherebake_geom::TopologyReport;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The tool version recorded in every file (`metadata.tool_version`).
pub const TOOL_VERSION: &str = concat!("spherebake ", env!("CARGO_PKG_VERSION"));

/// Everything that can stop a bake.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum BakeError {
    /// The input could not be imported.
    #[error(transparent)]
    Import(#[from] spherebake_io::IoError),
    /// The mesh has no usable triangles.
    #[error("{path}: mesh has no triangles")]
    EmptyMesh { path: PathBuf },
    /// A pipeline stage failed.
    #[error("{path}: {stage} stage failed: {message}")]
    Stage { path: PathBuf, stage: &'static str, message: String },
}

/// Wall time of one stage.
#[derive(Clone, Debug, Serialize)]
pub struct StageTime {
    pub stage: &'static str,
    pub seconds: f64,
}

/// What a bake did and measured.
#[derive(Clone, Debug, Serialize)]
pub struct BakeReport {
    /// The model file (in JSON as text; a name that is not UTF-8 shows U+FFFD where its bytes are not).
    #[serde(serialize_with = "json_path::path")]
    pub input: PathBuf,
    /// Every file read (model, buffers, .mtl, textures), for depfiles (in JSON as [`BakeReport::input`]).
    #[serde(serialize_with = "json_path::paths")]
    pub inputs: Vec<PathBuf>,
    /// Referenced files that did not exist (warned): depfiles list them too, so adding one re-bakes.
    #[serde(serialize_with = "json_path::paths")]
    pub missing: Vec<PathBuf>,
    /// FNV-1a 64 of every input byte, hex.
    pub input_hash: String,
    pub triangles: usize,
    pub vertices_welded: usize,
    pub closed: bool,
    pub sphere_count: usize,
    /// Spheres the fit left empty (radius 0, stored as `f32::MIN_POSITIVE`, a point): no
    /// split trial of the descent put them to use within its budget. Sometimes no sphere could
    /// lower E there (the capsule at 64 spheres uses 9 along its axis; each sphere off it would
    /// stick out), but not always: beetle-alt at `--preset fast` leaves 3 of 64 empty at
    /// E 1.033, where the default preset uses all 64 for E 0.862. They bound nothing and cost a
    /// reader little.
    pub empty_spheres: usize,
    /// Outside-volume ratio E = Σ V(S_i − T) / V(T) (Ren et al. 2006 eq. 35) of the spheres written
    /// (after `--pose-margin auto` grew them), when measured.
    pub outside_ratio_e: Option<f64>,
    /// V(∪S − T) / V(T), when measured.
    pub union_outside_ratio: Option<f64>,
    /// Skinning statistics, when the model is skinned.
    pub skin: Option<SkinSummary>,
    /// Sphere hierarchy statistics.
    pub hierarchy: HierarchySummary,
    /// Surface sample statistics.
    pub samples: SampleSummary,
    /// Per-stage wall times, in pipeline order (fit sub-stages are prefixed by the fitter).
    /// `topology` runs beside the winding-number build of `orient`: each reports its own time,
    /// so the sum can exceed the bake's wall time.
    pub timings: Vec<StageTime>,
    /// The fitter's own sub-stages (they add up to the `fit` stage, roughly).
    pub fit_stages: Vec<StageTime>,
    /// Every stage of every fit run in order, with the proxy E after it
    /// ([`spherebake_fit::FitStats::trace`]).
    pub fit_trace: Vec<FitTraceEntry>,
    /// Things the pipeline coped with (open mesh, missing texture, ...).
    pub warnings: Vec<String>,
    /// Size of the written file in bytes.
    pub file_bytes: usize,
}

/// One stage of one fit run ([`spherebake_fit::TraceEntry`]).
#[derive(Clone, Debug, Serialize)]
pub struct FitTraceEntry {
    /// The part (0-based; 0 unless the mesh splits into parts far apart).
    pub part: usize,
    /// The sphere count of the run (target mode runs several counts).
    pub spheres: usize,
    /// The seed of the run (restarts of the `best` preset run other seeds).
    pub seed: u64,
    /// The stage, as `spherebake_fit::TraceEntry::stage` lists them: `dense_points`, `lloyd`,
    /// `lattice_start`, `polish`, `descent_points`, `descent`, `seam`, `band`, `gap`, `bound`,
    /// `exact_e`, `start_kept`, `split_start`, `enclosing_ball` (baselines: `kmeans`, `octree`).
    pub stage: &'static str,
    /// Round (1, 2, ...) for `seam` and `gap`, else 0.
    pub round: usize,
    /// Proxy E after the stage (after `exact_e`: the exact E of the part); none for point stages.
    pub e: Option<f64>,
    /// Points built or worked on.
    pub points: usize,
    /// Lloyd iterations, polish rounds or descent sweeps; for the starts and `enclosing_ball`
    /// which one ran or was kept (`spherebake_fit::TraceEntry::iterations`).
    pub iterations: usize,
    /// Teleportation or split/delete trials tried; for `split_start` 1 when it cut along the
    /// cells' principal axes too.
    pub trials: usize,
    /// Descent work, voxel rows read.
    pub work: u64,
    /// Wall seconds (0 for a run a later restart of `best` reused).
    pub seconds: f64,
}

/// Skinning statistics (MVC of sphere centres folded into bones, Ren et al. 2006 §6.2).
#[derive(Clone, Debug, Serialize)]
pub struct SkinSummary {
    pub bones: usize,
    pub bones_per_sphere: usize,
    /// max |Σ w_v v − c| / bbox diagonal (0 up to rounding on closed meshes; open meshes lose linear precision).
    pub linear_residual_max_relative: f64,
    /// Largest |b| weight share dropped by keeping `bones_per_sphere` bones.
    pub dropped_weight_max: f64,
    /// Spheres none of whose kept bones has an invertible rest joint matrix: their terms do not
    /// sum to the rest centre (Σ b ≠ 1; warned). 0 in every other case.
    pub remainder_dropped: usize,
    /// Spheres whose centre's mean value coordinates could not be normalised, or only into
    /// weights that nearly cancel (a rest pose that folds the mesh onto itself), which follow
    /// the bones of their nearest surface point
    /// instead (warned). 0 in every other case.
    pub nearest_surface_centres: usize,
    /// What `--pose-margin auto` did ([`MarginResult`]).
    pub pose_margin: Option<MarginResult>,
}

/// Sphere hierarchy statistics (Ren et al. 2006 §6.3).
#[derive(Clone, Debug, Serialize)]
pub struct HierarchySummary {
    /// Levels above the leaves.
    pub levels: usize,
    pub mean_branching: f64,
    /// Parent radius / radius of the minimal ball enclosing its children (1 = tightest).
    pub tightness_mean: f64,
    pub tightness_max: f64,
}

/// Surface sample statistics of a bake (Guerrero et al. 2008 §4.2, 92 directions per sphere).
#[derive(Clone, Debug, Serialize)]
pub struct SampleSummary {
    pub per_sphere_mean: f64,
    pub per_sphere_min: u32,
    /// Share of (sphere, direction) pairs left empty by rule 2 (another sphere's segment covers it).
    pub share_rule2_empty: f64,
    /// Share left empty by rule 3 (no hit, and nothing in the segment along −ω).
    pub share_rule3_empty: f64,
    /// Sum of the sample areas (spec §7.2), model units².
    pub area_assigned: f64,
    /// Mesh area in segments of spheres without samples (carried by no sample), model units².
    pub area_unassigned: f64,
    /// Surface points (sub-triangle centroids) that measured the sample areas.
    pub area_points: u64,
}

/// The result of a bake: the file (as data and as bytes) and the report.
#[derive(Clone, Debug)]
pub struct BakeOutput {
    pub file: SphbFile,
    pub bytes: Vec<u8>,
    pub report: BakeReport,
    pub topology: TopologyReport,
}

/// Imports `path` and bakes it. `progress` receives the overall fraction done in [0, 1].
///
/// # Errors
/// [`BakeError::Import`] names the file and what is wrong with it; [`BakeError::EmptyMesh`] when
/// nothing is left to bake.
pub fn bake_path(
    path: &Path,
    settings: &BakeSettings,
    progress: &(dyn Fn(f32) + Sync),
) -> Result<BakeOutput, BakeError> {
    let t0 = Instant::now();
    let imported = spherebake_io::load_mesh(path)?;
    let import_s = t0.elapsed().as_secs_f64();
    let mut out = bake_imported(path, imported, settings, progress)?;
    out.report.timings.insert(0, StageTime { stage: "import", seconds: import_s });
    Ok(out)
}

/// Runs `f` and returns its result with its wall time in seconds.
fn timed<T>(f: impl FnOnce() -> T) -> (T, f64) {
    let t = Instant::now();
    let v = f();
    (v, t.elapsed().as_secs_f64())
}

/// The welded triangles of `mesh` split into those that bound the solid and its
/// [`surface_only`](spherebake_geom::Mesh::surface_only) ones, each list in mesh order. When
/// the mesh has none, the first list is all of them.
pub fn solid_and_surface_only(mesh: &spherebake_geom::Mesh) -> (Vec<[u32; 3]>, Vec<[u32; 3]>) {
    let all = mesh.welded_triangles();
    if mesh.surface_only.is_empty() {
        return (all, Vec::new());
    }
    let mut only = vec![false; all.len()];
    for &t in &mesh.surface_only {
        if let Some(o) = only.get_mut(t as usize) {
            *o = true;
        }
    }
    let (surface, solid): (Vec<_>, Vec<_>) = all.iter().zip(&only).partition(|(_, &o)| o);
    (solid.into_iter().map(|(t, _)| *t).collect(), surface.into_iter().map(|(t, _)| *t).collect())
}

/// The welded triangles of `mesh` that bound its solid, each turned outward by the solid
/// ([`spherebake_geom::orient::outward_orientation`]), and its surface-only triangles
/// ([`solid_and_surface_only`]): what the bake hands to the fit. Cost: one winding-number
/// build and the orientation.
pub fn outward_triangles(mesh: &spherebake_geom::Mesh) -> (Vec<[u32; 3]>, Vec<[u32; 3]>) {
    let (triangles, surface_only) = solid_and_surface_only(mesh);
    let winding = WindingNumber::new(&mesh.welded_positions, &triangles);
    (turned(&triangles, &outward_orientation(&mesh.welded_positions, &triangles, &winding).flip), surface_only)
}

/// [`spherebake_fit::evaluate`] of `spheres` against `mesh` as a bake measures them: on its
/// welded triangles turned outward ([`outward_triangles`]). The solid of an open mesh depends on
/// the triangles' winding, so evaluating the triangles as stored gave another E than the bake
/// printed when some faced inward (the Khronos sample BoxAnimated: 0.5409 against 0.4521).
///
/// # Errors
///
/// As [`spherebake_fit::evaluate`].
pub fn evaluate_mesh(
    mesh: &spherebake_geom::Mesh,
    spheres: &[[f32; 4]],
    settings: &spherebake_fit::EvalSettings,
) -> Result<spherebake_fit::Evaluation, spherebake_fit::FitError> {
    let (solid, surface_only) = outward_triangles(mesh);
    spherebake_fit::evaluate_with_surface(&mesh.welded_positions, &solid, &surface_only, spheres, settings)
}

/// Bakes an already imported mesh (see [`bake_path`]).
/// A warning when the mesh lies so far from the origin, for its size, that an f32 step there
/// is more than a sixteenth of a voxel cell: positions, sphere centres and radii are f32 (the
/// importers round to it, the file stores it), so the fit's resolution is lost (a unit cube
/// at 32 spheres: E 0.47 at the origin, 0.66 moved by 10⁶, 6.75 by 10⁷, where an f32 step is a
/// whole unit), and the spheres bound the positions as rounded, which differ from the file's
/// decimal text by up to half a step.
fn far_from_origin((lo, hi): (glam::Vec3, glam::Vec3), voxels: u32) -> Option<String> {
    let far = lo.abs().max(hi.abs()).max_element();
    let extent = f64::from((hi - lo).max_element());
    if !(far.is_finite() && extent > 0.0) {
        return None;
    }
    let step = f64::from(spherebake_format::quant::next_up_f32(far) - far);
    let cell = extent / f64::from(voxels.max(1));
    (step > cell / 16.0).then(|| {
        format!(
            "coordinates far from the origin for the model's size: at {far:.4e} an f32 step is {step:.3e}, {:.2} of a voxel cell ({cell:.3e}); positions and spheres are f32, so the fit loses resolution and bounds the positions as rounded: move the model near the origin (and place it in the engine) for a tighter fit",
            step / cell
        )
    })
}

pub fn bake_imported(
    path: &Path,
    imported: spherebake_io::Imported,
    settings: &BakeSettings,
    progress: &(dyn Fn(f32) + Sync),
) -> Result<BakeOutput, BakeError> {
    let mesh = &imported.mesh;
    let mut timings = Vec::new();
    let mut warnings: Vec<String> = imported.warnings.iter().map(|w| w.0.clone()).collect();

    if mesh.triangles.is_empty() {
        return Err(BakeError::EmptyMesh { path: path.to_path_buf() });
    }
    let positions = &mesh.welded_positions;
    if let Some(w) = mesh.bounds().and_then(|b| far_from_origin(b, settings.voxels)) {
        warnings.push(w);
    }
    // The surface-only triangles (`Mesh::surface_only`: double-sided faces, enclosing nothing)
    // are left out of the closed check, the orientation and the solid, and handed to the fit
    // beside the others to be covered.
    let (triangles, surface_only) = solid_and_surface_only(mesh);
    // Outward orientation by the solid (real meshes are not always consistently oriented),
    // shared by the fit, the sample points and the albedo. On the welded mesh, so UV/normal
    // seams do not split orientation patches; triangle indices are the same as in
    // `mesh.triangles` (but for the surface-only ones), so the flips apply there too. The
    // topology report (serial) is computed while the winding number's tree (serial) is built:
    // neither reads the other.
    let ((topology, topology_s), (winding, winding_s)) =
        rayon::join(|| timed(|| TopologyReport::compute(mesh)), || timed(|| WindingNumber::new(positions, &triangles)));
    timings.push(StageTime { stage: "topology", seconds: topology_s });
    let t = Instant::now();
    let mut orientation = outward_orientation(positions, &triangles, &winding);
    // Its tree is the sample points' BVH too: the welded triangles are `mesh.triangles` in the
    // same order with the same corners (the weld joins bit-identical positions, −0.0 as 0.0).
    // With surface-only triangles the samples get a tree over all of them, and the flips are
    // spread to mesh order (a surface-only face is not flipped: it faces both ways).
    let bvh = winding.into_bvh();
    let all_bvh = (!surface_only.is_empty()).then(|| TriangleBvh::new(positions, &mesh.welded_triangles()));
    // The fit sees the outward-oriented triangles: a mesh and its inside-out twin are the same
    // input to it (same solid, same spheres), and a mesh whose only defect was the winding of
    // some patches is closed again.
    let oriented = turned(&triangles, &orientation.flip);
    if !surface_only.is_empty() {
        let solid_flip = std::mem::take(&mut orientation.flip);
        let mut solid_flips = solid_flip.iter();
        let mut only = mesh.surface_only.iter().peekable();
        orientation.flip = (0..mesh.triangles.len() as u32)
            .map(|t| {
                if only.peek() == Some(&&t) {
                    only.next();
                    false
                } else {
                    solid_flips.next().copied().unwrap_or(false)
                }
            })
            .collect();
    }
    if orientation.flipped > 0 {
        warnings.push(format!("{} triangles face inward; oriented outward by the solid", orientation.flipped));
    }
    timings.push(StageTime { stage: "orient", seconds: winding_s + t.elapsed().as_secs_f64() });

    let t = Instant::now();
    let mut fitted = fit_spheres(path, positions, &oriented, &surface_only, &bvh, settings, progress)?;
    timings.push(StageTime { stage: "fit", seconds: t.elapsed().as_secs_f64() });
    let fit_stages: Vec<StageTime> =
        fitted.stage_timings.iter().map(|(stage, seconds)| StageTime { stage, seconds: *seconds }).collect();
    let fit_trace = fitted.trace;
    warnings.extend(fitted.warnings);
    let mut spheres = fitted.spheres;

    // Skinning terms of the sphere centres (MVC folded into bones); with `--pose-margin auto`
    // the radii grow so the model's own animations stay covered at every time (skin::margin).
    // Before the hierarchy, so the hierarchy bounds the final radii.
    let t = Instant::now();
    let skin_settings = SkinSettings {
        bones_per_sphere: settings.bones_per_sphere,
        pose_margin: settings.pose_margin,
        ..Default::default()
    };
    let stage_err = |stage: &'static str, e: String| BakeError::Stage { path: path.to_path_buf(), stage, message: e };
    let skin = bake_skin(mesh, &spheres, &skin_settings).map_err(|e| stage_err("skin", e.to_string()))?;
    let mut margin = None;
    if let Some((_, _, st)) = &skin {
        if st.remainder_dropped > 0 {
            warnings.push(format!(
                "skin: {} sphere(s) keep no bone with an invertible rest joint matrix, so their terms do not reproduce the rest centre (Σ b ≠ 1 there)",
                st.remainder_dropped
            ));
        }
        if st.nearest_surface > 0 {
            warnings.push(format!(
                "skin: the mean value coordinates of {} sphere centre(s) could not be normalised (does the stored pose fold the mesh onto itself?); they follow the bones of their nearest surface point instead",
                st.nearest_surface
            ));
        }
    }
    if skin.is_none() && settings.pose_margin == PoseMargin::Auto {
        warnings.push(
            "pose margin: the model has no skin, so nothing moves and no radius grew (--pose-margin auto applies to skinned models)"
                .into(),
        );
    }
    if let Some((terms, _, _)) = &skin {
        if settings.pose_margin == PoseMargin::Auto {
            let m = grow_for_animations(mesh, &spheres, terms, &skin_settings)
                .map_err(|e| stage_err("pose margin", e.to_string()))?;
            if mesh.skin.as_ref().is_some_and(|s| s.skeleton.animations.is_empty()) {
                warnings.push(
                    "pose margin: the model has no animations, so no radius grew; the spheres bound the rest pose only (poses from elsewhere, such as live hand tracking, are not covered)"
                        .into(),
                );
            }
            if m.unbounded_frames > 0 {
                warnings.push(format!(
                    "pose margin: {} animation frames have no finite motion bound or need a radius beyond f32 (non-finite or huge keys); their coverage is not guaranteed",
                    m.unbounded_frames
                ));
            }
            spheres.clone_from(&m.spheres);
            if m.grown_count > 0 {
                // E and the union ratio of the spheres written, not of the fit's.
                let es = spherebake_fit::EvalSettings {
                    voxel_resolution: settings.voxels,
                    surface_samples: 1,
                    ..Default::default()
                };
                if let Ok(ev) =
                    spherebake_fit::evaluate_with_surface(positions, &oriented, &surface_only, &spheres, &es)
                {
                    if let (Some(target), Some(before)) = (settings.max_outside_ratio, fitted.outside_ratio_e) {
                        if before <= target && ev.outside_ratio_e > target {
                            warnings.push(format!(
                                "the pose margin raised E from {before:.4} to {:.4}, above the target {target}",
                                ev.outside_ratio_e
                            ));
                        }
                    }
                    fitted.outside_ratio_e = Some(ev.outside_ratio_e);
                    fitted.union_outside_ratio = Some(ev.union_outside_ratio);
                }
            }
            margin = Some(m);
        }
    }
    timings.push(StageTime { stage: "skin", seconds: t.elapsed().as_secs_f64() });
    let spheres = &spheres;

    let t = Instant::now();
    let hierarchy = build_hierarchy(spheres, &HierarchySettings { branching: settings.branching, seed: settings.seed })
        .map_err(|e| BakeError::Stage { path: path.to_path_buf(), stage: "hierarchy", message: e.to_string() })?;
    let hstats = hierarchy_stats(&hierarchy, spheres);
    timings.push(StageTime { stage: "hierarchy", seconds: t.elapsed().as_secs_f64() });

    progress(0.85);

    let t = Instant::now();
    let (samples, sample_stats) =
        samples::place_samples(mesh, all_bvh.as_ref().unwrap_or(&bvh), &orientation.flip, spheres);
    timings.push(StageTime { stage: "samples", seconds: t.elapsed().as_secs_f64() });
    progress(0.9);

    let t = Instant::now();
    let albedo_settings = AlbedoSettings {
        sh_order: settings.sh_order,
        cubemap_size: settings.cubemap_size,
        debug_dir: settings.debug_cubemaps.clone(),
        debug_protect: imported.inputs.clone(),
        ..Default::default()
    };
    let (albedo_sh, albedo_stats) = bake_albedo(mesh, &orientation.flip, spheres, &albedo_settings)
        .map_err(|e| BakeError::Stage { path: path.to_path_buf(), stage: "albedo", message: e.to_string() })?;
    timings.push(StageTime { stage: "albedo", seconds: t.elapsed().as_secs_f64() });
    if albedo_stats.textured_triangles_without_uvs > 0 {
        warnings.push(format!(
            "{} textured triangles have no usable UVs (none, or not finite): their base colour factor is used",
            albedo_stats.textured_triangles_without_uvs
        ));
    }
    progress(0.95);

    let input_hash = format!("{:016x}", imported.content_hash);
    let file = SphbFile {
        spheres: spheres.iter().map(|s| Sphere { center: [s[0], s[1], s[2]], radius: s[3] }).collect(),
        hierarchy: Some(hierarchy),
        skin: skin.as_ref().map(|(terms, _, _)| terms.clone()),
        bones: skin.as_ref().map(|(_, bones, _)| bones.clone()),
        samples: Some(samples),
        albedo_sh: Some(albedo_sh),
        metadata: Some(Metadata {
            tool_version: TOOL_VERSION.to_string(),
            settings: settings.to_json(),
            input_hash: input_hash.clone(),
            units: units_of(path).to_string(),
            extra: {
                let mut extra = vec![
                    ("input_name".to_string(), file_name(path)),
                    (INPUTS_KEY.to_string(), inputs_value(path, &imported.inputs)),
                ];
                if !imported.missing.is_empty() {
                    extra.push((MISSING_INPUTS_KEY.to_string(), inputs_value(path, &imported.missing)));
                }
                extra
            },
        }),
    };
    let t = Instant::now();
    let bytes = if settings.compact {
        spherebake_format::write_compact(&file).map_err(|e| BakeError::Stage {
            path: path.to_path_buf(),
            stage: "write",
            message: e.to_string(),
        })?
    } else {
        file.to_bytes()
    };
    // Never hand out a file the reader would refuse: a violated rule here is a bug in a stage,
    // reported as an error rather than written.
    let file = match spherebake_format::read(&bytes) {
        // A compact file is returned as it reads back (dequantised), so `file` and `bytes` agree.
        Ok(back) if settings.compact => back,
        Ok(_) => file,
        Err(e) => {
            return Err(BakeError::Stage {
                path: path.to_path_buf(),
                stage: "write",
                message: format!("internal error, invalid output: {e}"),
            })
        }
    };
    timings.push(StageTime { stage: "write", seconds: t.elapsed().as_secs_f64() });
    progress(1.0);

    let report = BakeReport {
        input: path.to_path_buf(),
        inputs: imported.inputs.clone(),
        missing: imported.missing.clone(),
        input_hash,
        triangles: mesh.triangles.len(),
        vertices_welded: topology.welded_vertex_count,
        closed: topology.closed,
        sphere_count: file.spheres.len(),
        empty_spheres: file.spheres.iter().filter(|s| s.radius <= f32::MIN_POSITIVE).count(),
        outside_ratio_e: fitted.outside_ratio_e,
        union_outside_ratio: fitted.union_outside_ratio,
        skin: skin.as_ref().map(|(_, _, st)| SkinSummary {
            bones: st.bone_count,
            bones_per_sphere: st.bones_per_sphere,
            linear_residual_max_relative: st.linear_residual_max_relative,
            dropped_weight_max: st.dropped_weight_max,
            remainder_dropped: st.remainder_dropped,
            nearest_surface_centres: st.nearest_surface,
            pose_margin: margin,
        }),
        hierarchy: HierarchySummary {
            levels: hstats.levels,
            mean_branching: hstats.mean_branching,
            tightness_mean: hstats.tightness_mean,
            tightness_max: hstats.tightness_max,
        },
        samples: SampleSummary {
            per_sphere_mean: sample_stats.samples_per_sphere_mean,
            per_sphere_min: sample_stats.samples_per_sphere_min,
            share_rule2_empty: sample_stats.share_rule2_empty,
            share_rule3_empty: sample_stats.share_rule3_empty,
            area_assigned: sample_stats.area_assigned,
            area_unassigned: sample_stats.area_unassigned,
            area_points: sample_stats.area_points,
        },
        timings,
        fit_stages,
        fit_trace,
        warnings,
        file_bytes: bytes.len(),
    };
    Ok(BakeOutput { file, bytes, report, topology })
}

struct Fitted {
    spheres: Vec<[f32; 4]>,
    outside_ratio_e: Option<f64>,
    union_outside_ratio: Option<f64>,
    stage_timings: Vec<(&'static str, f64)>,
    trace: Vec<FitTraceEntry>,
    warnings: Vec<String>,
}

/// `tree`: the winding number's tree over the same triangles (file winding), which the fit
/// reuses for its own (`spherebake_fit::fit_reusing`).
fn fit_spheres(
    path: &Path,
    positions: &[glam::Vec3],
    triangles: &[[u32; 3]],
    surface_only: &[[u32; 3]],
    tree: &spherebake_geom::bvh::TriangleBvh,
    settings: &BakeSettings,
    progress: &(dyn Fn(f32) + Sync),
) -> Result<Fitted, BakeError> {
    let fit_settings = FitSettings {
        method: match settings.method {
            Method::Variational => FitMethod::Variational,
            Method::Kmeans => FitMethod::Kmeans,
            Method::Octree => FitMethod::Octree,
        },
        spheres: settings.spheres,
        max_outside_ratio: settings.max_outside_ratio,
        voxel_resolution: settings.voxels,
        seed: settings.seed,
        plan: settings.preset.plan(),
    };
    let fit_progress = |f: f32| progress(0.8 * f);
    let r =
        spherebake_fit::fit_with_surface(positions, triangles, surface_only, Some(tree), &fit_settings, &fit_progress)
            .map_err(|e| BakeError::Stage { path: path.to_path_buf(), stage: "fit", message: e.to_string() })?;
    // Target mode's result is among the fit's warnings once ("target mode: k spheres give E =
    // ..." when the target is reached, else "target E ≤ ... not reached: the best is E = ...").
    let warnings = r.warnings;
    // A sphere of radius 0 bounds a single point; store the smallest positive radius instead so
    // the file stays valid (rule 3004) and the point stays inside.
    let spheres =
        r.spheres.iter().map(|s| if s[3] > 0.0 { *s } else { [s[0], s[1], s[2], f32::MIN_POSITIVE] }).collect();
    Ok(Fitted {
        spheres,
        outside_ratio_e: Some(r.stats.outside_ratio_e),
        union_outside_ratio: Some(r.stats.union_outside_ratio),
        stage_timings: r.stats.timings.iter().map(|(s, t)| (*s, *t)).collect(),
        trace: r
            .stats
            .trace
            .iter()
            .map(|e| FitTraceEntry {
                part: e.part,
                spheres: e.spheres,
                seed: e.seed,
                stage: e.stage,
                round: e.round,
                e: e.e,
                points: e.points,
                iterations: e.iterations,
                trials: e.trials,
                work: e.work,
                seconds: e.seconds,
            })
            .collect(),
        warnings,
    })
}

fn units_of(path: &Path) -> &'static str {
    match path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
        Some("gltf" | "glb") => "metres",
        _ => "file units",
    }
}

fn file_name(path: &Path) -> String {
    path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default()
}

/// Paths in JSON reports: as text, lossily. serde's own `Path` serializer fails on a name that is
/// not UTF-8 (possible on Unix), which would turn a finished bake into a failed report.
pub mod json_path {
    use serde::Serializer;
    use std::path::{Path, PathBuf};

    /// One path, as `Path::to_string_lossy`.
    pub fn path<S: Serializer>(p: &Path, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&p.to_string_lossy())
    }

    /// A list of paths, each as [`path`].
    pub fn paths<S: Serializer>(v: &[PathBuf], s: S) -> Result<S::Ok, S::Error> {
        s.collect_seq(v.iter().map(|p| p.to_string_lossy()))
    }
}
