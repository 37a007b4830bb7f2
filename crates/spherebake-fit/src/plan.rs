//! [`FitPlan`]: every knob of the variational fit that trades time for quality, in one place,
//! with the presets [`FitPlan::fast`], [`FitPlan::default`] and [`FitPlan::best`].
//!
//! The stages these knobs drive, in order (see `run_once` in the crate root): dense points,
//! Lloyd (+ teleportation), lattice start, polish, descent points, exclusive descent, seam
//! rounds, band, bound, exact E, start kept (at a near tie of the two starts, `start_tie`,
//! the stages from the polish on run from both). Every budget counts work, not time, so a
//! plan gives the same spheres on any machine and for any thread count.

use crate::FitError;

/// Named plans of the variational fit (`spherebake bake --preset`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
#[non_exhaustive]
pub enum Preset {
    /// [`FitPlan::fast`]: fewer Lloyd iterations from one thinning of the start, no polish,
    /// fewer descent trials, a coarser voxel grid ([`Preset::voxels`]); higher E.
    Fast,
    /// [`FitPlan::default`]: the measured default.
    #[default]
    Default,
    /// [`FitPlan::best`]: the default's fit from four seeds, the lowest E kept (never higher than
    /// the default's at the same seed); about four times the fit time.
    Best,
}

impl Preset {
    /// The plan of this preset.
    pub fn plan(self) -> FitPlan {
        match self {
            Preset::Fast => FitPlan::fast(),
            Preset::Default => FitPlan::default(),
            Preset::Best => FitPlan::best(),
        }
    }

    /// Voxel cells along the longest bounding-box axis this preset bakes at unless one is given
    /// (`spherebake bake --voxels`): 96 for [`Preset::Fast`] (see [`FitPlan::fast`]), 128 for
    /// the others. The grid is the fit's proxy, and for an open mesh also its solid (E is then
    /// measured against the voxel solid at this resolution).
    pub fn voxels(self) -> u32 {
        match self {
            Preset::Fast => 96,
            Preset::Default | Preset::Best => 128,
        }
    }

    /// The lowercase name (`fast`, `default`, `best`).
    pub fn name(self) -> &'static str {
        match self {
            Preset::Fast => "fast",
            Preset::Default => "default",
            Preset::Best => "best",
        }
    }

    /// Parses a lowercase name.
    pub fn from_name(s: &str) -> Option<Preset> {
        match s {
            "fast" => Some(Preset::Fast),
            "default" => Some(Preset::Default),
            "best" => Some(Preset::Best),
            _ => None,
        }
    }
}

/// How much work each stage of the variational fit does. Lengths are relative (point
/// spacings, voxel cells), so a plan fits every model size. Start from a preset and change
/// fields: `FitPlan { descent_trials: 128, ..FitPlan::default() }`.
#[derive(Clone, Debug, PartialEq)]
pub struct FitPlan {
    // --- points ---
    /// Clustering lattice: points along the longest bounding-box axis (interior lattice
    /// corners and surface-sample spacing `h_pts`). More: finer clustering, cost ∝ points.
    /// Range 8..=256.
    pub point_resolution: u32,
    /// Dense point set (polish): triangles longer than `h_pts / dense_points_per_spacing` get a
    /// barycentric grid of that spacing. Range (0, 64].
    pub dense_points_per_spacing: f64,
    /// Dense point set: at most this many divisions per triangle edge (the total is also held
    /// to `points::GRID_BUDGET`). Range 1..=1024.
    pub dense_grid_cap: usize,

    /// A dense or descent point set with more surface points than `point_budget` keeps one
    /// per cube of this edge, in voxel cells (the first in mesh order;
    /// `points::keep_per_cell`): a mesh finer than the voxel grid then costs what the grid
    /// resolves, not its triangle count. When that still leaves more than the budget (a solid
    /// of many small parts, whose surface crosses far more cells than its volume suggests),
    /// the cube's edge doubles until it does, four times at most. 0 never thins. The bounding
    /// pass covers the surface exactly either way. Range [0, 64].
    pub point_cell: f64,
    /// Surface points a dense or descent set may hold before it is thinned to one per
    /// [`FitPlan::point_cell`] cube. Sets below it (every shared test model's: at most
    /// 280 000 dense and 112 000 descent points at 64 spheres) are kept whole, since thinning
    /// them saves little and moves the result within its seed-to-seed spread; the bunny
    /// subdivided to 1.1 M triangles has 3.4 M dense and 574 000 descent points. The band
    /// stage keeps at most this many band points too. Range ≥ 1.
    pub point_budget: usize,

    // --- Lloyd ---
    /// Lloyd iterations at most, teleportation trials included. Range 1..=1000.
    pub max_iterations: usize,
    /// Teleportation trials of the Lloyd stage at most (the descent has its own trials).
    /// Range 0..=1000.
    pub teleport_attempts: usize,
    /// Teleportation stops after this many rejected trials in a row. Range 1..=1000.
    pub teleport_max_fails: usize,
    /// Powell direction-set sweeps per centre update (Lloyd and polish). Range 1..=20.
    pub powell_sweeps: usize,
    /// Independent seeded Lloyd starts; the lowest proxy E is kept. Cost ∝ starts (each start
    /// runs from both thinnings of the cover start when its sets are capped and
    /// [`FitPlan::both_thinnings`] is set). Range 1..=16.
    pub starts: usize,
    /// When the cover start thins its sets (`cover::is_capped`), each start runs Lloyd from both
    /// thinnings, strided and spatially even, and keeps the lower proxy E (true); or from the
    /// even thinning only (false: half of Lloyd's cost, see [`FitPlan::fast`]). Neither start is
    /// better everywhere: the strided one depends on the order of the file's elements, and it
    /// wins on the Duck (default, seeds 1–4: E 0.1012 with both, 0.1121 with the even one only).
    pub both_thinnings: bool,
    /// Whole-fit runs (every stage, bound and exact E included) from this many seeds, the first
    /// being the fit's own seed; the lowest exact E is kept, so the result is never worse than
    /// one run's. The runs that read no random numbers (the descents from the lattice start
    /// and the split starts) run once and are reused by the later restarts (the starts
    /// themselves, a few milliseconds, are made again). Cost ∝ restarts for Lloyd's run.
    /// Range 1..=16.
    pub restarts: usize,

    /// When the lattice start's proxy E and Lloyd's differ by less than this share (|ratio − 1|),
    /// the fit runs from both and keeps the lower exact E; else from the lower one only. At
    /// such a near tie the proxies before the descent do not tell which start ends lower (the
    /// textured cube at 260 spheres: Lloyd 0.2975 against the lattice's 0.2985, ending at E
    /// 0.276 against 0.198). Only box-like solids come near a tie; elsewhere the lattice is
    /// 10–70 × worse. Cost up to 2× the descent and bound of those. Range [0, 10].
    pub start_tie: f64,

    /// The split starts ([`crate::baselines::split_start`], along x, y and z and then with the
    /// cells' principal axes, the second only when its proxy E is below the first's) run too,
    /// and the lowest exact E is kept, when a proxy E is at most (1 + this) × Lloyd's and
    /// below the lattice start's.
    /// At 0 (`fast`) it runs where its proxy is at most Lloyd's. The default's 25 % also takes
    /// the near ties, where the proxies before the descent do not rank the starts: a 64-sided
    /// cylinder at 16 spheres, split proxy 2.8 % above Lloyd's, ends at E 0.253 against
    /// Lloyd's 0.403; a 16-sided long cylinder at 32 spheres 0.162 against 0.205. Of 30
    /// generated shapes at 16, 32 and 64 spheres, 17 runs changed, each lower, at up to 3.1 ×
    /// the CPU; no shared model, fixture or unit cube at 16–128 spheres has such a tie (the
    /// same files; `docs/benchmarks.md`, "The split start at near ties"). At 50 % (`best`)
    /// it also runs on the unit cube at 64 spheres (4.4 s of CPU instead of 1.9 s, the same
    /// E) and on the capsule chain at 32 (E 0.351 → 0.308; `docs/benchmarks.md`, "The split
    /// start"). Cost up to one more descent and bound where it runs. When a split start's k
    /// cells miss this bar, its cuts stopped at their best count below k are held to it
    /// instead, and must also start below Lloyd's proxy E ([`crate::baselines::split_starts`]:
    /// a round part at more spheres than its best chain; `docs/benchmarks.md`, "More spheres
    /// than the chain needs"). Range [0, 10].
    pub split_start_tie: f64,

    /// Whether the second split start, with the cells' principal axes, is made at all (it
    /// runs only where its proxy E qualifies and is below the first's: oblique rods, tubes,
    /// turned tables). Its cuts cost 1–66 ms where it does not run, on the shared models
    /// about 2 % of a default bake and 4–10 % of a `fast` one (the unit cube 0.59 → 0.65 s,
    /// the bunny 0.91 → 0.95 s against `fast`'s 1.0 s target), so `fast` does without it.
    pub split_start_oblique: bool,

    /// When Lloyd's proxy E is at least this multiple of the enclosing ball's exact E (stage
    /// 10, computed first), the stages after Lloyd are skipped: Lloyd's spheres are made
    /// bounding and the ball is returned. From Lloyd to the end the fit's E fell by at most 12 %
    /// on the shared models (and rose on some), never by half, so at 2 the skipped stages could
    /// not have beaten the ball. A 2 208-triangle UV sphere at 64 spheres spent 7.6 s of CPU
    /// on them (Lloyd 0.022, the ball 0.0072, the fit's end 0.0218), now 0.97 s. Range [1, ∞]; ∞ never skips them.
    pub ball_bar: f64,

    // --- polish ---
    /// Rounds of assignment + radius shrinking + centre update on the dense point set.
    /// Range 0..=100.
    pub polish_rounds: usize,

    // --- exclusive descent ---
    /// Descent point set: triangles longer than this many voxel cells get a barycentric grid
    /// of that spacing. Range (0, 64].
    pub descent_grid_cells: f64,
    /// The exclusive descent and the seam rounds (stages 5–6) from Lloyd's and the lattice start
    /// read the voxel proxy in blocks of this many cells per axis, a block solid when at least
    /// half its cells are (`VoxelGrid::coarsened`); Lloyd, the polish, the band, the gap rounds
    /// and the bounding pass read the cells themselves. Those two stages' point spacings and
    /// search steps, set in voxel cells, are then in blocks too. 1: the cells. The cells are
    /// read anyway where ball volumes are exact (closed meshes of a few dozen triangles), on
    /// thin solids (more than a fifth of the cells on the boundary: parts under about ten
    /// cells thick, such as an animated character's limbs) and from the split starts (chains
    /// of slab spheres as thick as the part). Range 1..=4.
    ///
    /// The descent's moves are decided by proxy differences of a cell or more, which blocks
    /// of two resolve; the band and gap rounds then settle the boundaries on the cells. Measured
    /// at 2 against 1 (whole bake, one thread, 64 spheres unless noted, seeds 1–4, mean E,
    /// median CPU; 2026-12-07): bunny E 0.2218 → 0.2212 (CPU −22 %), armadillo 0.3936 →
    /// 0.3865 (−27 %), spot 0.1507 → 0.1513 (−40 %), Duck 0.1024 → 0.0987 (−46 %), teapot
    /// 0.1713 → 0.1598 (−40 %), the capsule 0.0508 → 0.0509 (−17 %), the bunny at 128
    /// spheres 0.1411 → 0.1416 (−19 %), spot at 16 0.4883 → 0.4742, the armadillo at 32
    /// 0.6072 → 0.6072. On blocks CesiumMan went 0.6578 → 0.6712 and the Fox 0.4862 → 0.4888,
    /// and the 10 : 1 rod's split run 0.130 → 0.170, hence the cells there. A block solid only
    /// when more than half its cells are lost the armadillo's thin limbs (0.4092); a second,
    /// coarser voxelization of the mesh instead of blocks gave the armadillo 0.4061 with Lloyd
    /// and the polish on it too, 0.3950 without. `fast` keeps 1: on its 96-cell grid blocks
    /// cost the bunny 19 % more CPU (its budgets, in rows, buy more trials) and the armadillo
    /// E 0.4365 → 0.4500 (`docs/benchmarks.md`, "The descent on blocks of two cells").
    pub descent_block: u32,
    /// Gauss–Seidel sweeps over all spheres before the split/delete trials at most (they stop
    /// earlier when a sweep gains < 0.01 %). Range 0..=100.
    pub descent_sweeps: usize,
    /// Split/delete rounds of the first descent at most; a round tries the two best pairs
    /// that share no sphere at once, so up to twice as many trials. Range 0..=1000.
    pub descent_trials: usize,
    /// The first descent's trials stop after this many rejections in a row. Range 1..=1000.
    pub descent_max_fails: usize,
    /// Work after which the first descent starts no new trial, in voxel rows read by the proxy
    /// (deterministic; the bunny at 64 spheres spends 60 M in ≈ 0.8 s), for up to 64 spheres;
    /// a fit of k > 64 spheres gets k / 64 times this (its trials grow with k; the trial counts
    /// still cap them). The default was 60 M (seam rounds 15 M) until the boundary moves and
    /// the gap round made trials pay more: doubled, the bunny at 64 spheres (whole bake, seeds
    /// 1–4) went 0.2272 → 0.2235 for about a third more CPU (fit alone, seeds 1–8: every seed
    /// lower); four times gave 0.2221 on the fit alone, with the teapot worse than at two.
    /// Range ≤ 10¹².
    pub descent_work_budget: u64,

    // --- seam rounds ---
    /// Seam rounds at most: the surface points between vertices that no sphere covers join
    /// the descent's points and the descent runs again (ends early when there are none).
    /// Range 0..=10.
    pub seam_rounds: usize,
    /// Seam search spacing on the triangles, in voxel cells. Range (0, 64].
    pub seam_spacing_cells: f64,
    /// Split/delete rounds per seam round at most (up to two trials each, as
    /// [`FitPlan::descent_trials`]). Range 0..=1000.
    pub seam_trials: usize,
    /// A seam round's trials stop after this many rejections in a row. Range 1..=1000.
    pub seam_max_fails: usize,
    /// Work budget of each seam round's trials (as `descent_work_budget`, scaled the same way
    /// above 64 spheres). Range ≤ 10¹².
    pub seam_work_budget: u64,

    // --- band ---
    /// Gauss–Seidel sweeps of the band stage at most (0: no band stage). After the seam
    /// rounds, the surface grid points at the seam spacing within `band_width_cells` of a
    /// sphere's surface join the descent points and the spheres are swept once more (no
    /// trials), so the gaps the bounding pass must close are a seam spacing wide, not a descent
    /// spacing. Range 0..=100.
    pub band_sweeps: usize,
    /// Half-width of the band around each sphere's surface, in voxel cells. Range (0, 64].
    ///
    /// A quarter of a cell in every preset: the band's gain comes from the points nearest the
    /// spheres' surfaces, and the wider band's points cost more than they bring. Measured for
    /// the default (whole bake, 64 spheres, seeds 1–4, mean E; 2026-12-08, session 56), one
    /// cell → half → a quarter: bunny 0.2212 → 0.2212 → 0.2221, armadillo 0.3865 → 0.3855 →
    /// 0.3864, spot 0.1513 → 0.1499 → 0.1504, Duck 0.0987 → 0.0987 → 0.0992, teapot 0.1598
    /// → 0.1610 → 0.1608, Fox 0.4862 → 0.4879 → 0.4939, CesiumMan 0.6578 → 0.6589 → 0.6637,
    /// milk truck 0.4451 → 0.4435 → 0.4453, capsule 0.0509 → 0.0507 → 0.0509, unit cube
    /// 0.2830 → 0.2830 → 0.2839; the bunny at 128 spheres 0.1416 → 0.1413 → 0.1416.
    /// Instructions executed by the bunny's bake (cachegrind, seed 1): 24.05 G → 23.31 G
    /// (−3.1 %) → 21.95 G (−8.7 %). For `fast`, see [`FitPlan::fast`].
    pub band_width_cells: f64,
    /// Gap rounds after the band at most (stage 6c; ends early when there are no gap points):
    /// the surface points at the seam spacing that no sphere covers after the band's sweeps
    /// join the points, are covered (the cheapest of the three nearest spheres grows), and one
    /// sweep of boundary moves ([`FitPlan::pair_first_cut`]; none when that is 0) re-fits the
    /// pairs around them. Measured at 64 spheres (fit alone, seeds 1–4, every seed lower or
    /// equal): bunny E 0.2272 → 0.2264 (seeds 1–8 0.2245 → 0.2239), at 128 0.1455 → 0.1447,
    /// armadillo 0.3975 → 0.3961, spot 0.1524 → 0.1520, teapot 0.1766 → 0.1759, unit cube
    /// 0.2930 → 0.2913; CPU +3 to +10 % (all with the trial budgets of then, 60 M and 15 M).
    /// A second round gained 0.0004 more on the bunny for as much again. Range 0..=10.
    pub gap_rounds: usize,

    // --- boundary moves ---
    /// Each seam round, the band stage and each gap round end with one sweep of boundary moves
    /// (`descent::Cover::pair_refit`): each sphere and the neighbour it shares most points
    /// with hand points across their boundary, this share of the two's points first, doubled
    /// while it pays, and both centres are re-fitted. 0: none. Measured at 64 spheres (fit
    /// alone, seeds 1–8): bunny E 0.2311 → 0.2246, armadillo 0.4188 → 0.3967, spot −3 %;
    /// the whole bake's CPU +3 % (bunny) to +70 % (the capsule, a small mesh). In the first
    /// descent too it gained nothing more. Range [0, 0.5].
    pub pair_first_cut: f64,

    // --- pattern search ---
    /// The pattern search that moves a sphere in the descent, the seam, band and gap rounds
    /// and the boundary moves (`descent::best_ball`) starts at this share of the ball's radius
    /// plus [`FitPlan::search_first_cells`]. Range [0, 1].
    ///
    /// The three steps were measured together on 2026-12-06 (whole bake, one thread, 64
    /// spheres, seeds 1–16, mean E and mean CPU of the bunny and the armadillo, two bakes at
    /// a time): a first step of a tenth of the radius plus half a cell instead of one cell
    /// gave E +0.0017 / −0.0005 for 5 / 3 % less CPU; a stop at 0.12 cells instead of 0.03
    /// +0.0005 / +0.0023 for 8 / 11 % less; the same stop for the boundary moves only
    /// +0.0005 / +0.0082 for 2 / 8 % less. With the descent grid at 3 cells and no gap round
    /// as well, 20 / 25 % less CPU cost E +0.0018 / +0.0062 (the bunny 0.2201 → 0.2219, the
    /// armadillo 0.3999 → 0.4061), so the default keeps these values (`docs/benchmarks.md`).
    pub search_first_share: f64,
    /// Voxel cells added to the pattern search's first step. Range [0, 64].
    pub search_first_cells: f64,
    /// The pattern search stops once its step is below this many voxel cells. Range (0, 64].
    pub search_stop_cells: f64,

    // --- bound ---
    /// The bounding pass grows the sphere with the least weighted growth; a sphere's weight
    /// is the outside share of a one-cell shell around it, clamped to [this, 1] so a sphere
    /// deep inside still costs something. Range [0, 1].
    pub bound_weight_min: f64,

    // --- target mode (`max_outside_ratio`) ---
    /// Sphere count of target mode's first run; counts then double. Range 1..=4096.
    pub target_start: usize,
    /// Target mode's largest count per part (also held to 4096 / parts). Range 1..=4096.
    pub target_max_spheres: usize,
    /// Target mode stops doubling when a doubling lowered E by less than this share.
    /// Range [0, 1).
    pub target_min_progress: f64,
    /// Target mode stops doubling when, at the rate E fell (E ∝ k^−α), the target needs more
    /// than this many times `target_max_spheres`. Range ≥ 1.
    pub target_reach_factor: f64,
    /// The bisection after the doubling stops when the bracket is at most 1/this of the
    /// count (and at most 1 sphere wide at small counts). Range 1..=4096.
    pub target_bisect_fraction: usize,
}

impl Default for FitPlan {
    /// The measured default (bunny at 64 spheres, whole bake: E 0.2252 at seed 1, mean
    /// 0.2221 over seeds 1–4; `docs/benchmarks.md`, "The descent on blocks of two cells" and
    /// the band's width, [`FitPlan::band_width_cells`]).
    fn default() -> Self {
        Self {
            point_resolution: 40,
            dense_points_per_spacing: 2.0,
            dense_grid_cap: 256,
            point_cell: 1.0,
            point_budget: 400_000,
            max_iterations: 24,
            teleport_attempts: 2,
            teleport_max_fails: 3,
            powell_sweeps: 2,
            starts: 1,
            both_thinnings: true,
            restarts: 1,
            start_tie: 0.05,
            split_start_tie: 0.25,
            split_start_oblique: true,
            ball_bar: 2.0,
            polish_rounds: 4,
            descent_grid_cells: 2.0,
            descent_block: 2,
            descent_sweeps: 8,
            descent_trials: 64,
            descent_max_fails: 20,
            descent_work_budget: 120_000_000,
            seam_rounds: 5,
            seam_spacing_cells: 0.25,
            seam_trials: 16,
            seam_max_fails: 3,
            seam_work_budget: 30_000_000,
            band_sweeps: 8,
            band_width_cells: 0.25,
            gap_rounds: 1,
            pair_first_cut: 1.0 / 16.0,
            search_first_share: 0.1,
            search_first_cells: 1.0,
            search_stop_cells: 0.03,
            bound_weight_min: 0.02,
            target_start: 8,
            target_max_spheres: 1024,
            target_min_progress: 1e-3,
            target_reach_factor: 8.0,
            target_bisect_fraction: 16,
        }
    }
}

impl FitPlan {
    /// Less work in every stage: half the Lloyd iterations from the even thinning of the cover
    /// start only ([`FitPlan::both_thinnings`]), no polish (the descent covers the
    /// points from the Lloyd result directly), two Gauss–Seidel sweeps before the trials of
    /// the descent and of each seam round (not eight), a quarter of the descent's trials and a
    /// thirtieth of its budget, one seam round with a quarter of its trials on a grid of
    /// half a voxel cell (not five on a quarter), one band sweep (not eight), no boundary
    /// moves and no gap round; and, through [`Preset::voxels`], a voxel grid of 96 cells
    /// instead of 128, whose cells its descent reads directly ([`FitPlan::descent_block`] 1,
    /// see there).
    ///
    /// One seam round, not two, was chosen last (whole bake, one thread, 64 spheres, seeds 1–4,
    /// the bunny 1–8; 2026-12-07, session 55), for the bunny's 1.0 s of CPU: with the exact
    /// speed-ups of that session the bake took 0.98 s (median of 7, 0.92–1.10 s), at the
    /// target's edge as the machine's speed varies. Instructions of the bunny's bake
    /// (cachegrind, seed 1): −9.4 %. Mean E at two rounds → one: bunny 0.2376 → 0.2411 (every
    /// seed at most 0.2450, under the 0.25), armadillo 0.4375 → 0.4486, spot 0.1684 →
    /// 0.1697, Duck 0.1243 → 0.1262, teapot 0.1903 → 0.1948, Fox 0.5073 → 0.5246, CesiumMan
    /// 0.7410 → 0.7464, the capsule and the unit cube the same. A smaller seam budget (0.5 M)
    /// saved 5.0 % and kept the bunny (0.2378) but not the armadillo (0.4468) or the Duck
    /// (0.1267); one round with twice the trials and budget saved about 9 % for 0.2398.
    ///
    /// The band's width was measured for `fast` first, which took a quarter of a cell before
    /// the default did (whole bake, 64 spheres, seeds 1–4 unless noted; 2026-12-07, session
    /// 54). The band's gain comes from the points nearest the spheres' surfaces: a quarter of
    /// a cell keeps it with a fifth of the band points (the bunny, seed
    /// 1: 247 000 → 55 000; the band stage 0.08 → 0.04 s). Mean E at one cell → a quarter:
    /// bunny 0.2379 → 0.2376 (seeds 1–8), armadillo 0.4373 → 0.4375, spot 0.1684 → 0.1684,
    /// Duck 0.1242 → 0.1243, teapot 0.1903 → 0.1903, capsule 0.0578 → 0.0578, Fox 0.5066 →
    /// 0.5073, milk truck 0.5543 → 0.5546, unit cube 0.3002 → 0.3023, CesiumMan 0.7355 →
    /// 0.7410. Instructions executed by the bunny's bake (cachegrind, seed 1): 9.85 G → 9.44 G
    /// (−4.1 %). Half a cell saved 2.4 %, a tenth 5.1 % at a higher E (CesiumMan 0.7448, unit
    /// cube 0.3034).
    ///
    /// The sweep counts were measured last (whole bake, one thread, 64 spheres, seeds 1–4
    /// unless noted; 2026-12-07, session 53). With four of each, the sweeps stopped at their
    /// 0.01 % rule, and on the bunny their gains were 20 %, 0.3 % and nothing (the descent;
    /// each seam round alike) and 1.6 %, 0.13 % and nothing (the band, whose sweeps over
    /// 250 000 band points were three quarters of its time). Two and one: mean E of the bunny
    /// 0.2381 → 0.2379 over seeds 1–8 (every seed within 0.002), armadillo 0.4365 → 0.4373,
    /// teapot 0.1914 → 0.1903, spot 0.1684 → 0.1684, Duck 0.1245 → 0.1242, unit cube 0.3048 →
    /// 0.3023, CesiumMan 0.7420 → 0.7355, Fox 0.5056 → 0.5066, milk truck 0.5535 → 0.5543, the
    /// capsule the same file. Instructions executed (cachegrind, seed 1; CPU times were too
    /// noisy that day to resolve this): bunny −5.3 %, spot −5.3 %, Duck −5.9 %, armadillo
    /// −3.3 %, CesiumMan −3.0 %, teapot −1.5 %, unit cube +1.4 % (another trajectory, lower
    /// E). One sweep before the trials too raised E (armadillo 0.4485, teapot 0.1953).
    ///
    /// The coarser grid was measured first (fit alone, CPU, one thread, load ≈ 2, 64 spheres):
    /// with three seam rounds at a quarter cell, 96 cells gave the bunny E 0.2372 over seeds
    /// 1–8 against 0.2438 at 128 (every seed at most 0.2440; 80 and 64 cells: 0.2423, 0.2402),
    /// and the armadillo and the teapot lower E too (seeds 1–4: 0.4347 against 0.4405, 0.1876
    /// against 0.1909): the descent's budgets count voxel rows, and rows of a coarser grid are
    /// cheaper, so the same budget buys more trials. Two seam rounds at half a cell then cost
    /// E 0.2402 on the bunny (seeds 1–8; one round 0.2430, none 0.2496) for 12 % less CPU.
    /// Against the plan before (three rounds at a quarter cell, 128 cells), seeds 1–4: bunny
    /// 0.2448 → 0.2402 (seeds 1–8: 0.2438 → 0.2402), armadillo 0.4405 → 0.4395, teapot 0.1909
    /// → 0.1919, spot 0.1645 → 0.1684, unit cube 0.3115 → 0.3048, capsule 0.0507 → 0.0585, for
    /// 18 % (armadillo) to 54 % (capsule) less CPU of the fit.
    ///
    /// One Lloyd run instead of two (the even thinning only) was measured last (whole bake,
    /// CPU, one thread, 64 spheres, seeds 1–4; 2026-12-06). The bunny keeps its E at every one
    /// of seeds 1–8 (mean 0.2360 over 1–4; the even run had the lower Lloyd proxy at each)
    /// for 1.11 → 0.93 s; spot (0.66 → 0.56 s) and the unit cube (0.80 → 0.57 s) keep theirs
    /// too, the capsule goes 0.0585 → 0.0583; the Duck 0.1209 → 0.1226 and the milk truck
    /// 0.5738 → 0.5774, where the strided run won. The armadillo, the teapot, the Fox,
    /// CesiumMan, RiggedFigure, RiggedSimple and the glass are within the cap (one run either
    /// way, the same files).
    ///
    /// Before: the budgets were 15 M and 4 M until the pattern search polled only its
    /// predicted moves (a trial then reads fewer rows): at 4 M and 1 M the bunny at 64 spheres
    /// (fit alone, seeds 1–6) went E 0.2523 → 0.2451 and CPU 2.0 → 1.9 s, the armadillo
    /// 0.4503 → 0.4414 and 1.8 → 1.4 s; at 15 M and 4 M it gave 0.2400 in 2.7 s. First chosen
    /// on the bunny at 64 spheres (fit alone, CPU, load ≈ 6): polish 2 and one seam round E
    /// 0.266 in 1.5 s; no polish and three seam rounds E 0.257 in 1.6 s; the default E 0.238
    /// in ≈ 5.5 s (before the band stage, which brings fast to 0.2525 and the default to 0.2331
    /// in the whole bake).
    pub fn fast() -> Self {
        Self {
            max_iterations: 12,
            teleport_attempts: 1,
            both_thinnings: false,
            start_tie: 0.0,
            split_start_tie: 0.0,
            split_start_oblique: false,
            polish_rounds: 0,
            descent_sweeps: 2,
            descent_trials: 16,
            descent_max_fails: 8,
            descent_work_budget: 4_000_000,
            seam_rounds: 1,
            seam_spacing_cells: 0.5,
            seam_trials: 4,
            seam_max_fails: 2,
            seam_work_budget: 1_000_000,
            band_sweeps: 1,
            gap_rounds: 0,
            pair_first_cut: 0.0,
            descent_block: 1,
            ..Self::default()
        }
    }

    /// The default's plan run from four seeds (`restarts`), keeping the lowest exact E: never
    /// worse than the default at the same seed, about four times its fit time. (Larger
    /// budgets for one run were measured first and are not a reliable gain: four times the
    /// descent's trials and budget and eight seam rounds gave the bunny at 64 E 0.249 against
    /// the default's 0.238, the descent's moves being greedy.) It also runs from both the
    /// lattice start and Lloyd's when their proxy E are within 30 % (`start_tie`; the
    /// default's 5 % is a subset, so each of its runs is never worse than the default's).
    pub fn best() -> Self {
        Self { restarts: 4, start_tie: 0.3, split_start_tie: 0.5, ball_bar: 4.0, ..Self::default() }
    }

    /// The pattern search's steps ([`FitPlan::search_first_share`], …).
    pub(crate) fn search(&self) -> crate::descent::Search {
        crate::descent::Search {
            first_share: self.search_first_share,
            first_cells: self.search_first_cells,
            stop_cells: self.search_stop_cells,
        }
    }

    /// Checks every field's range; the error names the field.
    pub fn validate(&self) -> Result<(), FitError> {
        use crate::check_range as range;
        fn positive(name: &'static str, v: f64, hi: f64, expected: &'static str) -> Result<(), FitError> {
            if !(v > 0.0 && v <= hi) {
                return Err(FitError::InvalidSetting { name, value: v.to_string(), expected });
            }
            Ok(())
        }
        range("point_resolution", self.point_resolution, 8, 256, "8..=256")?;
        positive("dense_points_per_spacing", self.dense_points_per_spacing, 64.0, "(0, 64]")?;
        range("dense_grid_cap", self.dense_grid_cap, 1, 1024, "1..=1024")?;
        range("point_cell", self.point_cell, 0.0, 64.0, "[0, 64]")?;
        range("point_budget", self.point_budget, 1, usize::MAX, "≥ 1")?;
        range("max_iterations", self.max_iterations, 1, 1000, "1..=1000")?;
        range("teleport_attempts", self.teleport_attempts, 0, 1000, "0..=1000")?;
        range("teleport_max_fails", self.teleport_max_fails, 1, 1000, "1..=1000")?;
        range("powell_sweeps", self.powell_sweeps, 1, 20, "1..=20")?;
        range("starts", self.starts, 1, 16, "1..=16")?;
        range("restarts", self.restarts, 1, 16, "1..=16")?;
        range("start_tie", self.start_tie, 0.0, 10.0, "[0, 10]")?;
        range("split_start_tie", self.split_start_tie, 0.0, 10.0, "[0, 10]")?;
        range("ball_bar", self.ball_bar, 1.0, f64::INFINITY, "[1, ∞] (∞: never)")?;
        range("polish_rounds", self.polish_rounds, 0, 100, "0..=100")?;
        positive("descent_grid_cells", self.descent_grid_cells, 64.0, "(0, 64]")?;
        range("descent_block", self.descent_block, 1, 4, "1..=4")?;
        range("descent_sweeps", self.descent_sweeps, 0, 100, "0..=100")?;
        range("descent_trials", self.descent_trials, 0, 1000, "0..=1000")?;
        range("descent_max_fails", self.descent_max_fails, 1, 1000, "1..=1000")?;
        range("descent_work_budget", self.descent_work_budget, 0, 1_000_000_000_000, "0..=1e12")?;
        range("seam_rounds", self.seam_rounds, 0, 10, "0..=10")?;
        positive("seam_spacing_cells", self.seam_spacing_cells, 64.0, "(0, 64]")?;
        range("seam_trials", self.seam_trials, 0, 1000, "0..=1000")?;
        range("seam_max_fails", self.seam_max_fails, 1, 1000, "1..=1000")?;
        range("seam_work_budget", self.seam_work_budget, 0, 1_000_000_000_000, "0..=1e12")?;
        range("band_sweeps", self.band_sweeps, 0, 100, "0..=100")?;
        positive("band_width_cells", self.band_width_cells, 64.0, "(0, 64]")?;
        range("gap_rounds", self.gap_rounds, 0, 10, "0..=10")?;
        range("pair_first_cut", self.pair_first_cut, 0.0, 0.5, "[0, 0.5]")?;
        range("search_first_share", self.search_first_share, 0.0, 1.0, "[0, 1]")?;
        range("search_first_cells", self.search_first_cells, 0.0, 64.0, "[0, 64]")?;
        positive("search_stop_cells", self.search_stop_cells, 64.0, "(0, 64]")?;
        range("bound_weight_min", self.bound_weight_min, 0.0, 1.0, "[0, 1]")?;
        range("target_start", self.target_start, 1, 4096, "1..=4096")?;
        range("target_max_spheres", self.target_max_spheres, 1, 4096, "1..=4096")?;
        range("target_min_progress", self.target_min_progress, 0.0, 0.999_999, "[0, 1)")?;
        range("target_reach_factor", self.target_reach_factor, 1.0, 1e9, "1..=1e9")?;
        range("target_bisect_fraction", self.target_bisect_fraction, 1, 4096, "1..=4096")?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn presets_are_valid_and_ordered_by_work() {
        let (f, d, b) = (FitPlan::fast(), FitPlan::default(), FitPlan::best());
        for p in [&f, &d, &b] {
            p.validate().expect("valid preset");
        }
        // Every work knob of fast is at most the default's, and of best at least.
        let work = |p: &FitPlan| {
            [
                p.restarts as u64,
                (p.start_tie * 1000.0) as u64,
                (p.split_start_tie * 1000.0) as u64,
                u64::from(p.split_start_oblique),
                (p.ball_bar * 1000.0) as u64,
                p.max_iterations as u64,
                p.teleport_attempts as u64,
                p.polish_rounds as u64,
                p.descent_sweeps as u64,
                p.descent_trials as u64,
                p.descent_work_budget,
                p.seam_rounds as u64,
                p.seam_trials as u64,
                p.seam_work_budget,
                (1000.0 / p.seam_spacing_cells) as u64,
                p.band_sweeps as u64,
                p.gap_rounds as u64,
                (p.pair_first_cut > 0.0) as u64,
            ]
        };
        let (wf, wd, wb) = (work(&f), work(&d), work(&b));
        for i in 0..wf.len() {
            assert!(wf[i] <= wd[i] && wd[i] <= wb[i], "knob {i}: {} {} {}", wf[i], wd[i], wb[i]);
        }
        assert!(wf != wd && wd != wb);
        assert!(Preset::Fast.voxels() < Preset::Default.voxels());
        assert_eq!(Preset::Default.voxels(), Preset::Best.voxels());
        for p in [Preset::Fast, Preset::Default, Preset::Best] {
            assert_eq!(Preset::from_name(p.name()), Some(p));
        }
        assert_eq!(Preset::from_name("quick"), None);
    }

    #[test]
    fn out_of_range_fields_are_named() {
        let bad = FitPlan { seam_spacing_cells: f64::NAN, ..FitPlan::default() };
        match bad.validate() {
            Err(FitError::InvalidSetting { name, .. }) => assert_eq!(name, "seam_spacing_cells"),
            other => panic!("{other:?}"),
        }
        let bad = FitPlan { starts: 0, ..FitPlan::default() };
        assert!(matches!(bad.validate(), Err(FitError::InvalidSetting { name: "starts", .. })));
        let bad = FitPlan { search_stop_cells: 0.0, ..FitPlan::default() };
        assert!(matches!(bad.validate(), Err(FitError::InvalidSetting { name: "search_stop_cells", .. })));
        let bad = FitPlan { search_first_share: f64::NAN, ..FitPlan::default() };
        assert!(matches!(bad.validate(), Err(FitError::InvalidSetting { name: "search_first_share", .. })));
    }
}
