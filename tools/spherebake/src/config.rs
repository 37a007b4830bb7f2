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
    /// Only a regular file of at most [`MAX_CONFIG_BYTES`] is read (`--config /dev/zero` or a FIFO
    /// is refused before it is opened); a parse error is one line with its line and column.
    pub fn load(path: &Path) -> Result<Config> {
        use std::io::Read as _;
        let meta = std::fs::metadata(path).with_context(|| format!("{}: reading config", path.display()))?;
        anyhow::ensure!(meta.is_file(), "{}: reading config: not a regular file", path.display());
        let mut bytes = Vec::new();
        std::fs::File::open(path)
            .and_then(|f| f.take(MAX_CONFIG_BYTES + 1).read_to_end(&mut bytes))
            .with_context(|| format!("{}: reading config", path.display()))?;
        anyhow::ensure!(
            bytes.len() as u64 <= MAX_CONFIG_BYTES,
            "{}: reading config: larger than {} bytes",
            path.display(),
            MAX_CONFIG_BYTES
        );
        let text =
            String::from_utf8(bytes).map_err(|_| anyhow::anyhow!("{}: invalid config: not UTF-8", path.display()))?;
        let config: Config = toml::from_str(&text).map_err(|e| {
            // `get`, not indexing: a span that were not on a character boundary gives no
            // position rather than a panic.
            let at = e.span().and_then(|r| text.get(..r.start)).map(|before| {
                let line = before.matches('\n').count() + 1;
                let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
                format!(" at line {line}, column {column}")
            });
            let message = e.message().split_whitespace().collect::<Vec<_>>().join(" ");
            anyhow::anyhow!("{}: invalid config{}: {message}", path.display(), at.unwrap_or_default())
        })?;
        if let Some(r) = config.asset.iter().find(|r| r.glob.chars().count() > MAX_GLOB_CHARS) {
            anyhow::bail!(
                "{}: invalid config: a glob of {} characters (at most {MAX_GLOB_CHARS})",
                path.display(),
                r.glob.chars().count()
            );
        }
        Ok(config)
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

/// Largest config file read, bytes.
pub const MAX_CONFIG_BYTES: u64 = 1 << 20;

/// Longest glob of a rule, characters.
pub const MAX_GLOB_CHARS: usize = 4096;

/// Glob matching: `*` matches within a path segment, `**` across segments, `?` one character
/// (not one byte: `?x.obj` matches `öx.obj`). A pattern without `/` matches the file name alone
/// (like .gitignore). Dynamic programming over (pattern, path) positions: O(pattern × path) time,
/// whatever the stars (a backtracking matcher is exponential in them).
pub fn glob_match(pattern: &str, path: &str) -> bool {
    let p: Vec<char> = pattern.chars().collect();
    let s: Vec<char> = if pattern.contains('/') {
        path.chars().collect()
    } else {
        path.rsplit('/').next().unwrap_or(path).chars().collect()
    };
    // next[j]: p[i + 1..] matches s[j..]; cur[j]: p[i..] matches s[j..]; rows for i from the end.
    // `**` (with a following `/` taken as part of it) reads the row of the pattern after it.
    let n = s.len();
    let mut rows: Vec<Vec<bool>> = vec![Vec::new(); p.len() + 1];
    rows[p.len()] = (0..=n).map(|j| j == n).collect();
    for i in (0..p.len()).rev() {
        let mut cur = vec![false; n + 1];
        for j in (0..=n).rev() {
            cur[j] = match p[i] {
                '*' if p.get(i + 1) == Some(&'*') => {
                    let rest = if p.get(i + 2) == Some(&'/') { i + 3 } else { i + 2 };
                    rows[rest][j] || (j < n && cur[j + 1])
                }
                '*' => rows[i + 1][j] || (j < n && s[j] != '/' && cur[j + 1]),
                '?' => j < n && s[j] != '/' && rows[i + 1][j + 1],
                c => j < n && s[j] == c && rows[i + 1][j + 1],
            };
        }
        rows[i] = cur;
    }
    rows[0][0]
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
        // `?` is one character, not one byte.
        assert!(glob_match("?x.obj", "öx.obj"));
        assert!(!glob_match("?x.obj", "x.obj"));
        // `**/` matches zero or more whole segments; `*` never crosses a `/`.
        assert!(glob_match("a/**/b/*.glb", "a/b/c.glb"));
        assert!(glob_match("a/**/b/*.glb", "a/x/y/b/c.glb"));
        assert!(!glob_match("a/*/c.glb", "a/x/y/c.glb"));
        assert!(glob_match("**", "a/b/c"));
        assert!(glob_match("", "") && !glob_match("", "a"));
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

    /// Many stars against a long name that almost matches: a backtracking matcher took minutes
    /// (exponential in the stars); the table takes (pattern × name) steps. Checked against a
    /// brute-force reading of the rules on short random cases.
    #[test]
    fn many_stars_match_in_polynomial_time_and_agree_with_brute_force() {
        let name = format!("{}.obj", "a".repeat(60));
        let t0 = std::time::Instant::now();
        assert!(!glob_match("*a*a*a*a*a*a*a*a*a*a*b.obj", &name));
        assert!(glob_match("*a*a*a*a*a*a*a*a*a*a*.obj", &name));
        assert!(t0.elapsed().as_secs() < 5, "{:?}", t0.elapsed());
        // Brute force: try every way to split the name among the pattern's tokens.
        fn brute(p: &[char], s: &[char]) -> bool {
            match p.first() {
                None => s.is_empty(),
                Some('*') if p.get(1) == Some(&'*') => {
                    let rest = if p.get(2) == Some(&'/') { &p[3..] } else { &p[2..] };
                    (0..=s.len()).any(|i| brute(rest, &s[i..]))
                }
                Some('*') => (0..=s.len()).take_while(|&i| i == 0 || s[i - 1] != '/').any(|i| brute(&p[1..], &s[i..])),
                Some('?') => !s.is_empty() && s[0] != '/' && brute(&p[1..], &s[1..]),
                Some(c) => s.first() == Some(c) && brute(&p[1..], &s[1..]),
            }
        }
        let alphabet = ['a', 'b', '/', '*', '?'];
        let mut state = 12345u64;
        let mut pick = |n: usize| {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 33) as usize % n
        };
        for _ in 0..3000 {
            let p: String = (0..pick(7)).map(|_| alphabet[pick(5)]).collect();
            let s: String = (0..pick(7)).map(|_| alphabet[pick(3)]).collect();
            // A pattern without `/` reads the last segment only.
            let against = if p.contains('/') { s.as_str() } else { s.rsplit('/').next().unwrap() };
            let expected = brute(&p.chars().collect::<Vec<_>>(), &against.chars().collect::<Vec<_>>());
            assert_eq!(glob_match(&p, &s), expected, "pattern {p:?} name {s:?}");
        }
    }
}
