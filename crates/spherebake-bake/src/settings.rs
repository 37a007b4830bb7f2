//! [`BakeSettings`]: every knob of a bake, with unit, default and valid range.

use serde::Serialize;

/// How the sphere set is fitted.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// Variational fit of minimal outside volume (Ren et al. 2006 §6.2): Lloyd + Powell + teleportation.
    #[default]
    Variational,
    /// Baseline: k-means of surface points, each sphere the bounding ball of its cluster.
    Kmeans,
    /// Baseline: bounding spheres of the leaf cubes of an adaptive octree.
    Octree,
}

/// How much work the fit spends: the fit's own presets ([`spherebake_fit::FitPlan`]), serialised by name.
pub use spherebake_fit::Preset;

/// Settings of one bake. Field docs give unit, default and valid range; the CLI repeats them.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BakeSettings {
    /// Number of spheres in the set. Default 64, range 1..=4096.
    pub spheres: usize,
    /// Fitting method. Default [`Method::Variational`].
    pub method: Method,
    /// How much work the variational fit spends (`fast`, `default`, `best`). Default
    /// [`Preset::Default`]. Recorded in the settings only when not the default, so files baked
    /// with the default keep their bytes; a change re-bakes (the up-to-date check compares the
    /// recorded settings).
    #[serde(skip_serializing_if = "is_default_preset", serialize_with = "serialize_preset")]
    pub preset: Preset,
    /// Target mode: find the smallest sphere count whose outside-volume ratio E is at most this.
    /// Default none (use `spheres`), range (0, ∞).
    pub max_outside_ratio: Option<f64>,
    /// Voxel cells along the longest bounding-box axis, for the fit's proxy and an open mesh's
    /// solid. Default 128 (`Preset::voxels` of the default preset; the CLI takes the chosen
    /// preset's, 96 for `fast`, when `--voxels` is not given), range 16..=1024.
    pub voxels: u32,
    /// Seed of the random start. Default 1. Same seed + input + settings → byte-identical output.
    pub seed: u64,
    /// Average branching ratio of the sphere hierarchy. Default 4, range 2..=16.
    pub branching: f64,
    /// Bones kept per sphere for skinning (the k largest |b_j|). Default 4, range 1..=64; more
    /// than the model's bone count keeps every bone.
    pub bones_per_sphere: usize,
    /// Grow radii so the model's own animations stay covered. Default none.
    pub pose_margin: crate::PoseMargin,
    /// SH order n of the albedo (bands 0..n−1, n² coefficients per sphere). Default 4, range 1..=8.
    pub sh_order: usize,
    /// Albedo cube-map face size in texels. Default 32, range 4..=512.
    pub cubemap_size: usize,
    /// Write the compact encoding (format 1.1: samples quantised to 12 bytes, albedo SH as f16;
    /// `spherebake_format::write_compact`) instead of the lossless one. Default false. Recorded
    /// in the settings only when set, so lossless files keep their bytes.
    #[serde(skip_serializing_if = "is_false")]
    pub compact: bool,
    /// When set, each sphere's albedo cube map and its SH reconstruction are written here as PNG
    /// crosses. Not part of the recorded settings (it does not change the file).
    #[serde(skip)]
    pub debug_cubemaps: Option<std::path::PathBuf>,
}

impl Default for BakeSettings {
    fn default() -> Self {
        Self {
            spheres: 64,
            method: Method::Variational,
            preset: Preset::Default,
            max_outside_ratio: None,
            voxels: Preset::Default.voxels(),
            seed: 1,
            branching: 4.0,
            bones_per_sphere: 4,
            pose_margin: crate::PoseMargin::None,
            sh_order: 4,
            cubemap_size: 32,
            compact: false,
            debug_cubemaps: None,
        }
    }
}

#[allow(clippy::trivially_copy_pass_by_ref)] // serde's skip_serializing_if passes a reference
fn is_false(b: &bool) -> bool {
    !*b
}

#[allow(clippy::trivially_copy_pass_by_ref)] // serde's skip_serializing_if passes a reference
fn is_default_preset(p: &Preset) -> bool {
    *p == Preset::Default
}

/// The preset as its lowercase name (`fast`, `best`), as the settings record it.
#[allow(clippy::trivially_copy_pass_by_ref)] // serde's serialize_with passes a reference
fn serialize_preset<S: serde::Serializer>(p: &Preset, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(p.name())
}

impl BakeSettings {
    /// The settings as one-line JSON (stored in the file's metadata).
    pub fn to_json(&self) -> String {
        serde_json::to_string(self).unwrap_or_default()
    }

    /// Checks ranges; returns a message naming the setting when one is out of range.
    pub fn validate(&self) -> Result<(), String> {
        if !(1..=4096).contains(&self.spheres) {
            return Err(format!("--spheres must be in 1..=4096, got {}", self.spheres));
        }
        if !(16..=1024).contains(&self.voxels) {
            return Err(format!("--voxels must be in 16..=1024, got {}", self.voxels));
        }
        if !(self.branching.is_finite() && (2.0..=16.0).contains(&self.branching)) {
            return Err(format!("--branching must be in 2..=16, got {}", self.branching));
        }
        if !(1..=64).contains(&self.bones_per_sphere) {
            return Err(format!("--bones-per-sphere must be in 1..=64, got {}", self.bones_per_sphere));
        }
        if !(1..=8).contains(&self.sh_order) {
            return Err(format!("--sh-order must be in 1..=8, got {}", self.sh_order));
        }
        if !(4..=512).contains(&self.cubemap_size) {
            return Err(format!("--cubemap-size must be in 4..=512, got {}", self.cubemap_size));
        }
        if let Some(e) = self.max_outside_ratio {
            if !(e.is_finite() && e > 0.0) {
                return Err(format!("--max-outside-ratio must be a positive number, got {e}"));
            }
        }
        Ok(())
    }
}
