//! The run configuration: one section per stage, as `--config FILE` and `--set` read it.

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::PipelineError;
use crate::axes::AxesConfig;
use crate::hypotheses::HypothesesConfig;
use crate::lines::LinesConfig;
use crate::nonplanar::NonplanarConfig;
use crate::normals::NormalsConfig;
use crate::planemap::PlanemapConfig;
use crate::sky::SkyConfig;

/// Options of the α-expansion solve.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct SolverConfig {
    /// Upper bound on α-expansion cycles (one cycle tries the expansion move of every
    /// label), a count; the solve stops earlier once a cycle changes nothing. A bound, not
    /// a tuned value: the 640×480 room converges in 2.
    pub max_cycles: usize,
    /// Integer cost units per unit of real cost (data-cost units), in (0, 10⁶]: costs are
    /// rounded to integers so that the max-flow is exact, and this scale keeps the rounding
    /// below 0.1 % of the smallest useful cost. The solver's capacities are 32-bit: above
    /// 10⁶ a pixel's summed costs (tens of units) would saturate them.
    pub cost_scale: f64,
    /// Coarse-to-fine levels of the α-expansion solve (0 = one solve at full resolution):
    /// each level solves a 2× coarser grid first and refines its labelling at the finer
    /// resolution only in a band around its label changes
    /// ([`planemap_solvers::pyramid`]). 1: on the real sets (768×512) held-out accuracy and
    /// the views' agreement rise slightly and runs take 0.85–0.88× the time; images below
    /// `coarse_min_pixels` are not affected.
    pub coarse_levels: usize,
    /// Half-width of the refinement band around a coarse labelling's label changes, in
    /// pixels of the finer level, ≥ 1.
    pub coarse_band: usize,
    /// A coarser level is used only if it keeps at least this many pixels: small images
    /// are solved at full resolution, where a 2×2 block is a large share of a thin
    /// structure.
    pub coarse_min_pixels: usize,
    /// After each level's band refinement, one α-expansion cycle over every label on the
    /// whole level: whole regions may still change label, and regions the coarser level
    /// lost may come back.
    pub coarse_polish: bool,
}

/// The largest `solver.cost_scale`: costs of tens of units per pixel then stay far below the
/// solver's 32-bit capacities.
pub const MAX_COST_SCALE: f64 = 1e6;

impl Default for SolverConfig {
    fn default() -> Self {
        SolverConfig {
            max_cycles: 10,
            cost_scale: 1000.0,
            coarse_levels: 1,
            coarse_band: 2,
            coarse_min_pixels: 65536,
            coarse_polish: true,
        }
    }
}

/// Options of the fused point cloud.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct FusionConfig {
    /// Keep a pixel's point only if at least this many other labelled views see the same
    /// depth there (within `depth_tolerance`), a count; 0 = keep every point. Not tuned.
    pub min_consistent_views: usize,
    /// Relative depth tolerance of "agree", `|z_j − z| ≤ tolerance · z`, a fraction > 0:
    /// the benchmark's 1 % scoring tolerance; not tuned.
    pub depth_tolerance: f64,
    /// Take every `stride`-th pixel in x and y, a count ≥ 1 (1 = all): every second pixel
    /// keeps `fused.ply` small; not tuned.
    pub stride: u32,
}

impl Default for FusionConfig {
    fn default() -> Self {
        FusionConfig {
            min_consistent_views: 1,
            depth_tolerance: 0.01,
            stride: 2,
        }
    }
}

/// A whole run's configuration: one section per stage (TOML).
#[derive(Debug, Clone, Default, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct Config {
    /// Normals for points without them.
    pub normals: NormalsConfig,
    /// Dominant axes.
    pub axes: AxesConfig,
    /// 3D lines: segment detection, vanishing directions, matching (used by
    /// `hypotheses.lines`).
    pub lines: LinesConfig,
    /// Plane hypotheses.
    pub hypotheses: HypothesesConfig,
    /// Per-view planemap energy.
    pub planemap: PlanemapConfig,
    /// α-expansion.
    pub solver: SolverConfig,
    /// Fused point cloud.
    pub fusion: FusionConfig,
    /// The classifier-driven "non-planar" label (off by default).
    pub nonplanar: NonplanarConfig,
    /// Sky: pixels that see no surface get no depth ([`crate::sky`]).
    pub sky: SkyConfig,
}

impl Config {
    /// Parses a TOML config onto the defaults ([`crate::config::from_toml_str`]); errors
    /// name `origin` and the line.
    pub fn from_toml_str(text: &str, origin: &str) -> Result<Config, PipelineError> {
        Ok(crate::config::from_toml_str(text, origin)?)
    }

    /// Reads a TOML config file.
    pub fn from_path(path: &Path) -> Result<Config, PipelineError> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| PipelineError::Config(format!("{}: {e}", path.display())))?;
        Self::from_toml_str(&text, &path.display().to_string())
    }

    /// The configuration as TOML, each key preceded by its documentation (meaning, unit,
    /// range) as comments: what `planemap config --defaults` prints.
    pub fn describe(&self) -> Result<String, PipelineError> {
        Ok(crate::config::describe(
            self,
            crate::config::CONFIG_DOCS,
            "",
        )?)
    }

    /// Checks every stage's config.
    pub fn validate(&self) -> Result<(), PipelineError> {
        self.normals.validate()?;
        self.axes.validate()?;
        self.lines.validate().map_err(PipelineError::Config)?;
        self.hypotheses.validate()?;
        self.planemap
            .validate()
            .map_err(|e| PipelineError::Config(format!("planemap: {e}")))?;
        self.nonplanar
            .validate()
            .map_err(|e| PipelineError::Config(e.to_string()))?;
        self.sky.validate().map_err(PipelineError::Config)?;
        let scale = self.solver.cost_scale;
        if !(scale.is_finite() && scale > 0.0 && scale <= MAX_COST_SCALE) {
            return Err(PipelineError::Config(format!(
                "solver.cost_scale = {scale:e} must be in (0, {MAX_COST_SCALE}] (integer cost \
                 units per unit of cost; larger ones overflow the solver's 32-bit capacities)"
            )));
        }
        if self.solver.coarse_band == 0 {
            return Err(PipelineError::Config(
                "solver.coarse_band must be ≥ 1 (pixels of refinement around a coarse label \
                 change)"
                    .into(),
            ));
        }
        let tolerance_ok =
            self.fusion.depth_tolerance.is_finite() && self.fusion.depth_tolerance > 0.0;
        if self.fusion.stride == 0 || !tolerance_ok {
            return Err(PipelineError::Config(
                "fusion.stride must be ≥ 1 and fusion.depth_tolerance > 0".into(),
            ));
        }
        Ok(())
    }
}
