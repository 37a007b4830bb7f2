//! Per-asset settings from an optional `spherebake.toml`, overridable on the command line.
//!
//! ```toml
//! # spherebake.toml (looked up in the current directory, or given with --config)
//! [defaults]
//! spheres = 64
//!
//! [[asset]]
//! glob = "characters/**/*.glb"   # matched against the input path as given, '/'-separated
//! spheres = 128
//! method = "variational"
//! preset = "best"                # fast | default | best: how much work the fit spends
//! ```
//!
//! Precedence: command-line flag > the last `[[asset]]` rule whose glob matches > `[defaults]` >
//! built-in defaults. Unknown keys are an error (a typo should not silently do nothing).

use anyhow::{Context, Result};
use serde::Deserialize;
use std::path::Path;

/// Settings a config rule or the command line may set; `None` = not set at this level.
#[derive(Clone, Debug, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Overrides {
    pub spheres: Option<usize>,
    pub method: Option<String>,
    pub preset: Option<String>,
    pub max_outside_ratio: Option<f64>,
    pub voxels: Option<u32>,
    pub seed: Option<u64>,
    pub sh_order: Option<usize>,
    pub cubemap_size: Option<usize>,
    pub branching: Option<f64>,
    pub bones_per_sphere: Option<usize>,
    pub pose_margin: Option<String>,
    pub compact: Option<bool>,
}

impl Overrides {
    /// Fields set in `over` replace those of `self`.
    pub fn merged(&self, over: &Overrides) -> Overrides {
        Overrides {
            spheres: over.spheres.or(self.spheres),
            method: over.method.clone().or_else(|| self.method.clone()),
            preset: over.preset.clone().or_else(|| self.preset.clone()),
            max_outside_ratio: over.max_outside_ratio.or(self.max_outside_ratio),
            voxels: over.voxels.or(self.voxels),
            seed: over.seed.or(self.seed),
            sh_order: over.sh_order.or(self.sh_order),
            cubemap_size: over.cubemap_size.or(self.cubemap_size),
            branching: over.branching.or(self.branching),
            bones_per_sphere: over.bones_per_sphere.or(self.bones_per_sphere),
            pose_margin: over.pose_margin.clone().or_else(|| self.pose_margin.clone()),
            compact: over.compact.or(self.compact),
        }
    }
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct AssetRule {
    glob: String,
    #[serde(flatten)]
    settings: Overrides,
}

/// A parsed `spherebake.toml`.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Config {
    #[serde(default)]
    defaults: Overrides,
    #[serde(default)]
    asset: Vec<AssetRule>,
}

impl Config {
    /// Reads and parses a config file.
    pub fn load(path: &Path) -> Result<Config> {
        let text = std::fs::read_to_string(path).with_context(|| format!("{}: reading config", path.display()))?;
        toml::from_str(&text).with_context(|| format!("{}: invalid config", path.display()))
    }

    /// The settings for `input`: defaults, then every matching rule in file order.
    pub fn for_input(&self, input: &Path) -> Overrides {
        let name = input.to_string_lossy().replace('\\', "/");
        let name = name.trim_start_matches("./");
        self.asset
            .iter()
            .filter(|r| glob_match(&r.glob, name))
            .fold(self.defaults.clone(), |acc, r| acc.merged(&r.settings))
    }
}

/// Glob matching: `*` matches within a path segment, `**` across segments, `?` one character.
/// A pattern without `/` matches the file name alone (like .gitignore).
pub fn glob_match(pattern: &str, path: &str) -> bool {
    if !pattern.contains('/') {
        let file = path.rsplit('/').next().unwrap_or(path);
        return match_here(pattern.as_bytes(), file.as_bytes());
    }
    match_here(pattern.as_bytes(), path.as_bytes())
}

fn match_here(p: &[u8], s: &[u8]) -> bool {
    match p.first() {
        None => s.is_empty(),
        Some(b'*') if p.get(1) == Some(&b'*') => {
            // `**/` also matches zero segments.
            let rest = if p.get(2) == Some(&b'/') { &p[3..] } else { &p[2..] };
            (0..=s.len()).any(|i| match_here(rest, &s[i..]))
        }
        Some(b'*') => {
            let mut i = 0;
            loop {
                if match_here(&p[1..], &s[i..]) {
                    return true;
                }
                if i == s.len() || s[i] == b'/' {
                    return false;
                }
                i += 1;
            }
        }
        Some(b'?') => !s.is_empty() && s[0] != b'/' && match_here(&p[1..], &s[1..]),
        Some(&c) => s.first() == Some(&c) && match_here(&p[1..], &s[1..]),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn globs() {
        assert!(glob_match("*.glb", "a/b/fox.glb"));
        assert!(!glob_match("*.glb", "a/b/fox.gltf"));
        assert!(glob_match("chars/**/*.glb", "chars/a/b/fox.glb"));
        assert!(glob_match("chars/**/*.glb", "chars/fox.glb"));
        assert!(!glob_match("chars/*.glb", "chars/a/fox.glb"));
        assert!(glob_match("props/?ox.obj", "props/box.obj"));
        assert!(!glob_match("props/?ox.obj", "props/bbox.obj"));
    }

    #[test]
    fn precedence_is_last_matching_rule_over_defaults() {
        let c: Config = toml::from_str(
            "[defaults]\nspheres = 32\nseed = 5\n[[asset]]\nglob = \"*.glb\"\nspheres = 128\n[[asset]]\nglob = \"hero*.glb\"\nspheres = 256\n",
        )
        .unwrap();
        assert_eq!(c.for_input(Path::new("x/prop.glb")).spheres, Some(128));
        assert_eq!(c.for_input(Path::new("x/hero1.glb")).spheres, Some(256));
        assert_eq!(c.for_input(Path::new("x/hero1.glb")).seed, Some(5));
        assert_eq!(c.for_input(Path::new("x/a.obj")).spheres, Some(32));
        let cli = Overrides { spheres: Some(8), ..Default::default() };
        assert_eq!(c.for_input(Path::new("x/hero1.glb")).merged(&cli).spheres, Some(8));
    }

    #[test]
    fn unknown_keys_are_errors() {
        assert!(toml::from_str::<Config>("[defaults]\nsphere = 3\n").is_err());
    }
}
