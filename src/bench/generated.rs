//! Generated scenes in the benchmark (`planemap bench --generated KIND:COUNT[@FIRST_SEED]`,
//! issue 35's held-out protocol).
//!
//! - [`parse_generated`] reads the option into a [`GeneratedSet`]; `write_generated` draws
//!   each (kind, seed) with [`generate::generate`] and writes `OUT/generated/NAME.toml`, which
//!   the benchmark then caches, runs and scores exactly like a scene file, tagging its
//!   [`super::SceneResult`] with a [`GeneratedTag`].
//! - [`kind_summaries`] gives, per kind and method, the mean over the scenes of depth within
//!   1 %, the 10th-percentile view, the worst view, the planar and non-planar pixels' figures
//!   and the views collapsed to one plane ([`crate::eval::metrics::view_collapsed`]).
//! - [`markdown`] is results.md: the scene files' tables as before, then a "Generated
//!   scenes" section ([`generated_markdown`]) whose heading names the split of its seeds;
//!   results.json gets the same summaries under its `generated` key.

use std::path::{Path, PathBuf};

use serde::Serialize;

use super::{io_err, report, BenchError, BenchResults, SceneResult};
use crate::eval::metrics::{
    Collapses, COLLAPSE_GT_PLANES, COLLAPSE_GT_PLANE_SHARE, COLLAPSE_LABEL_SHARE,
};
use crate::synth::generate::{self, GenerateOptions, Kind, TEST_SEEDS};

/// At most this many seeds per kind in one `--generated` set: the test split has 1000.
pub const MAX_GENERATED_COUNT: u64 = 10_000;

/// Collapsed views named in a row of results.md (results.json names them all).
const COLLAPSES_NAMED: usize = 3;

/// A set of generated scenes: `count` consecutive seeds from `first_seed` of each kind.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct GeneratedSet {
    /// The kinds, in report order.
    pub kinds: Vec<Kind>,
    /// Seeds per kind.
    pub count: u64,
    /// The first seed (below [`TEST_SEEDS`] for development, in it for the test split).
    pub first_seed: u64,
}

impl GeneratedSet {
    /// The (kind, seed) pairs, kind by kind.
    pub fn scenes(&self) -> impl Iterator<Item = (Kind, u64)> + '_ {
        self.kinds.iter().flat_map(move |&k| {
            (self.first_seed..self.first_seed.saturating_add(self.count)).map(move |s| (k, s))
        })
    }
}

/// Parses `--generated`: `KIND:COUNT[@FIRST_SEED]`, KIND a [`Kind`] name or `all` (every
/// kind), COUNT 1 to [`MAX_GENERATED_COUNT`], FIRST_SEED 0 by default (development seeds),
/// e.g. `all:10@1000` (the test split's first ten seeds of every kind).
pub fn parse_generated(s: &str) -> Result<GeneratedSet, BenchError> {
    let bad = |why: &str| {
        let kinds: Vec<&str> = Kind::ALL.iter().map(|k| k.name()).collect();
        BenchError::Option(format!(
            "bad --generated {s:?}: {why}; expected KIND:COUNT[@FIRST_SEED] with KIND one of \
             {} or all, e.g. all:10@1000 (seeds below {} develop, {}–{} are the test split)",
            kinds.join(", "),
            TEST_SEEDS.start,
            TEST_SEEDS.start,
            TEST_SEEDS.end - 1
        ))
    };
    let (kind, rest) = s.trim().split_once(':').ok_or_else(|| bad("no ':'"))?;
    let (count, first) = match rest.split_once('@') {
        Some((c, f)) => (c, Some(f)),
        None => (rest, None),
    };
    let kinds = match kind.trim() {
        "all" => Kind::ALL.to_vec(),
        k => vec![Kind::from_name(k).ok_or_else(|| bad(&format!("unknown kind {k:?}")))?],
    };
    let count: u64 = count
        .trim()
        .parse()
        .map_err(|_| bad(&format!("COUNT {:?} is not a number", count.trim())))?;
    if count == 0 {
        return Err(bad("COUNT must be at least 1"));
    }
    if count > MAX_GENERATED_COUNT {
        return Err(bad(&format!("COUNT must be at most {MAX_GENERATED_COUNT}")));
    }
    let first_seed: u64 = match first {
        Some(f) => f
            .trim()
            .parse()
            .map_err(|_| bad(&format!("FIRST_SEED {:?} is not a number", f.trim())))?,
        None => 0,
    };
    Ok(GeneratedSet {
        kinds,
        count,
        first_seed,
    })
}

/// What a generated scene is, in its [`SceneResult`].
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct GeneratedTag {
    /// The kind.
    pub kind: Kind,
    /// The seed.
    pub seed: u64,
    /// `development`, `test` or `reserved` ([`generate::split`]).
    pub split: &'static str,
    /// [`generate::GENERATOR_VERSION`].
    pub generator_version: u32,
}

/// Draws the scenes of `sets` (each (kind, seed) once, in order) and writes them to
/// `dir/NAME.toml`; returns the files with their tags. The bench cache is keyed by a
/// file's bytes, so a generated scene is rendered again only when the generator changes it.
pub(super) fn write_generated(
    sets: &[GeneratedSet],
    dir: &Path,
) -> Result<Vec<(PathBuf, Option<GeneratedTag>)>, BenchError> {
    let mut out = Vec::new();
    let mut seen = std::collections::BTreeSet::new();
    for (kind, seed) in sets.iter().flat_map(GeneratedSet::scenes) {
        if !seen.insert((kind, seed)) {
            continue;
        }
        if out.is_empty() {
            std::fs::create_dir_all(dir).map_err(|e| io_err(dir, e))?;
        }
        let g = generate::generate(kind, seed, &GenerateOptions::default())?;
        let path = dir.join(format!("{}.toml", g.spec.name));
        g.write_toml(&path)?;
        out.push((
            path,
            Some(GeneratedTag {
                kind,
                seed,
                split: generate::split(seed),
                generator_version: generate::GENERATOR_VERSION,
            }),
        ));
    }
    Ok(out)
}

/// results.json with the per-kind summaries beside the scenes.
#[derive(Serialize)]
struct ResultsJson<'a> {
    #[serde(flatten)]
    results: &'a BenchResults,
    /// Absent when the run has no generated scene.
    #[serde(skip_serializing_if = "Option::is_none")]
    generated: Option<GeneratedJson>,
}

/// The `generated` key of results.json.
#[derive(Serialize)]
struct GeneratedJson {
    generator_version: u32,
    /// Seeds below this develop.
    development_seeds_below: u64,
    /// First and last seed of the test split.
    test_seeds: [u64; 2],
    /// The splits of the run's generated seeds, as in results.md's heading.
    splits: String,
    /// A view collapses when one label covers over this share of it …
    collapse_label_share: f64,
    /// … and its ground truth shows at least `collapse_gt_planes` planes over this share.
    collapse_gt_plane_share: f64,
    collapse_gt_planes: usize,
    kinds: Vec<KindSummary>,
}

/// [`report::write_reports`], with results.md as [`markdown`] writes it and results.json
/// with the generated scenes' per-kind summaries under `generated`.
pub(super) fn write_reports(results: &BenchResults, out: &Path) -> Result<(), BenchError> {
    report::write_reports(results, out)?;
    let generated = results.subset(true);
    if generated.scenes.is_empty() {
        return Ok(());
    }
    let json = ResultsJson {
        results,
        generated: Some(GeneratedJson {
            generator_version: generate::GENERATOR_VERSION,
            development_seeds_below: TEST_SEEDS.start,
            test_seeds: [TEST_SEEDS.start, TEST_SEEDS.end - 1],
            splits: splits_of(&generated),
            collapse_label_share: COLLAPSE_LABEL_SHARE,
            collapse_gt_plane_share: COLLAPSE_GT_PLANE_SHARE,
            collapse_gt_planes: COLLAPSE_GT_PLANES,
            kinds: kind_summaries(&generated),
        }),
    };
    let text = serde_json::to_string_pretty(&json).map_err(|e| io_err(out, e))?;
    report::write_atomic(&out.join("results.json"), text.as_bytes())?;
    report::write_atomic(&out.join("results.md"), markdown(results).as_bytes())
}

impl BenchResults {
    /// The same run restricted to the scene files (`generated == false`) or to the
    /// generated scenes (`true`).
    pub fn subset(&self, generated: bool) -> BenchResults {
        BenchResults {
            scenes: self
                .scenes
                .iter()
                .filter(|s| s.generated.is_some() == generated)
                .cloned()
                .collect(),
            ..self.clone()
        }
    }
}

/// results.md: [`report::markdown`] of the scene files and, when the run has generated
/// scenes, a "Generated scenes" section ([`generated_markdown`]) after them. A run without
/// generated scenes gets exactly [`report::markdown`].
pub fn markdown(results: &BenchResults) -> String {
    let files = results.subset(false);
    let generated = results.subset(true);
    if generated.scenes.is_empty() {
        return report::markdown(results);
    }
    let mut s = String::new();
    if !files.scenes.is_empty() {
        s.push_str("## Scene files\n\n");
        s.push_str(&report::markdown(&files));
        s.push('\n');
    }
    s.push_str(&generated_markdown(&generated));
    s
}

/// One kind's figures for one method over the generated scenes of a run.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct KindSummary {
    /// The kind.
    pub kind: Kind,
    /// The method.
    pub method: String,
    /// Scenes the method ran on without failing.
    pub scenes: usize,
    /// Scenes where the method failed.
    pub failed: usize,
    /// Smallest and largest seed.
    pub seeds: (u64, u64),
    /// The splits of those seeds, `+`-joined (`development`, `test`, `reserved`).
    pub split: String,
    /// Mean over the scenes of depth within 1 % (share of ground-truth pixels).
    pub mean_within_1pct: f64,
    /// Mean F-score of the fused points.
    pub mean_f_score: f64,
    /// Nearest-rank 10th percentile of the per-view depth within 1 % over every view of
    /// every scene of the kind.
    pub p10_view_within_1pct: f64,
    /// The worst view's depth within 1 % …
    pub worst_view_within_1pct: f64,
    /// … and its `SCENE/VIEW` name.
    pub worst_view: String,
    /// Mean over the scenes with ground-truth planar pixels of depth within 1 % on them
    /// (NaN = none).
    pub planar_within_1pct: f64,
    /// Mean over the scenes with ground-truth non-planar pixels of depth within 1 % on them
    /// (NaN = none).
    pub nonplanar_within_1pct: f64,
    /// Share of the ground-truth pixels of the kind's scenes that are non-planar.
    pub nonplanar_share: f64,
    /// Views collapsed to one plane label over every scene of the kind, names `SCENE/VIEW`
    /// (`None` for a method without plane labels).
    pub collapses: Option<Collapses>,
}

/// Per kind and method: the mean, the 10th-percentile view and the worst view (views with
/// no ground-truth pixels are left out), the planar / non-planar figures and the collapsed
/// views, from the generated scenes of `results`.
pub fn kind_summaries(results: &BenchResults) -> Vec<KindSummary> {
    let mut out = Vec::new();
    let methods: Vec<String> = results
        .scenes
        .first()
        .map(|s| s.methods.iter().map(|m| m.method.clone()).collect())
        .unwrap_or_default();
    for kind in Kind::ALL {
        let scenes: Vec<&SceneResult> = results
            .scenes
            .iter()
            .filter(|s| s.generated.as_ref().is_some_and(|g| g.kind == kind))
            .collect();
        if scenes.is_empty() {
            continue;
        }
        let seeds: Vec<u64> = scenes
            .iter()
            .filter_map(|s| s.generated.as_ref().map(|g| g.seed))
            .collect();
        let mut splits: Vec<&str> = scenes
            .iter()
            .filter_map(|s| s.generated.as_ref().map(|g| g.split))
            .collect();
        splits.sort_unstable();
        splits.dedup();
        for method in &methods {
            let (mut n, mut failed, mut acc, mut f) = (0usize, 0usize, 0.0, 0.0);
            let (mut planar, mut n_planar, mut nonplanar, mut n_nonplanar) = (0.0, 0, 0.0, 0);
            let (mut gt_pixels, mut nonplanar_pixels) = (0u64, 0u64);
            let mut collapses = Some(Collapses::default());
            let mut views: Vec<(f64, String)> = Vec::new();
            for sc in &scenes {
                match sc.methods.iter().find(|m| &m.method == method) {
                    Some(m) if m.error.is_none() => {
                        n += 1;
                        acc += m.depth.accuracy(1);
                        f += m.cloud.f_score;
                        gt_pixels += m.depth.gt_pixels;
                        nonplanar_pixels += m.nonplanar_depth.gt_pixels;
                        if m.planar_depth.gt_pixels > 0 {
                            planar += m.planar_depth.accuracy(1);
                            n_planar += 1;
                        }
                        if m.nonplanar_depth.gt_pixels > 0 {
                            nonplanar += m.nonplanar_depth.accuracy(1);
                            n_nonplanar += 1;
                        }
                        collapses = match (collapses, &m.collapse) {
                            (Some(mut all), Some(c)) => {
                                all.add(c, &format!("{}/", sc.name));
                                Some(all)
                            }
                            _ => None,
                        };
                        for (name, c) in &m.views {
                            if c.gt_pixels > 0 {
                                views.push((c.accuracy(1), format!("{}/{name}", sc.name)));
                            }
                        }
                    }
                    Some(_) => failed += 1,
                    None => {}
                }
            }
            views.sort_by(|a, b| a.0.total_cmp(&b.0).then_with(|| a.1.cmp(&b.1)));
            let p10 = if views.is_empty() {
                f64::NAN
            } else {
                // Nearest rank: the smallest value with at least 10 % of the views at or
                // below it.
                let rank = (0.1 * views.len() as f64).ceil().max(1.0) as usize;
                views[rank - 1].0
            };
            let mean = |sum: f64, k: usize| if k > 0 { sum / k as f64 } else { f64::NAN };
            let (worst, worst_name) = views.first().cloned().unwrap_or((f64::NAN, String::new()));
            out.push(KindSummary {
                kind,
                method: method.clone(),
                scenes: n,
                failed,
                seeds: (
                    seeds.iter().copied().min().unwrap_or(0),
                    seeds.iter().copied().max().unwrap_or(0),
                ),
                split: splits.join("+"),
                mean_within_1pct: mean(acc, n),
                mean_f_score: mean(f, n),
                p10_view_within_1pct: p10,
                worst_view_within_1pct: worst,
                worst_view: worst_name,
                planar_within_1pct: mean(planar, n_planar),
                nonplanar_within_1pct: mean(nonplanar, n_nonplanar),
                nonplanar_share: nonplanar_pixels as f64 / gt_pixels.max(1) as f64,
                collapses: if n > 0 { collapses } else { None },
            });
        }
    }
    out
}

/// The splits of the generated scenes of `results`, as results.md's heading names them:
/// e.g. `test split (seeds 1000–1999, never tuned on)`.
fn splits_of(results: &BenchResults) -> String {
    let mut splits: Vec<&str> = results
        .scenes
        .iter()
        .filter_map(|s| s.generated.as_ref().map(|g| g.split))
        .collect();
    splits.sort_unstable();
    splits.dedup();
    let named: Vec<String> = splits
        .iter()
        .map(|&s| match s {
            "development" => format!(
                "development split (seeds below {}, for tuning)",
                TEST_SEEDS.start
            ),
            "test" => format!(
                "test split (seeds {}–{}, never tuned on)",
                TEST_SEEDS.start,
                TEST_SEEDS.end - 1
            ),
            other => format!("{other} seeds (from {}, no split yet)", TEST_SEEDS.end),
        })
        .collect();
    named.join(" + ")
}

/// The "Generated scenes" section of results.md: a heading that names the split, the
/// per-kind table of [`kind_summaries`], the planar / non-planar table for kinds with
/// non-planar surfaces, then [`report::markdown`] of the generated scenes one by one.
pub fn generated_markdown(generated: &BenchResults) -> String {
    let pct = |x: f64| {
        if x.is_finite() {
            format!("{:.1}", 100.0 * x)
        } else {
            "–".to_string()
        }
    };
    let summaries = kind_summaries(generated);
    let mut s = format!("## Generated scenes: {}\n\n", splits_of(generated));
    s.push_str(&format!(
        "Procedural scenes (`planemap synth --generate`, generator v{}): seeds below {} are \
         for development and tuning, seeds {}–{} are the test split, reported and never tuned \
         on. Per kind and method: the mean over the scenes of depth within 1 % of ground truth \
         (% of ground-truth pixels) and of the F-score, the 10th-percentile view \
         (nearest rank over every view of the kind), the worst view, and the views collapsed \
         to one plane: one label over {:.0} % of a view whose ground truth shows {} or more \
         planes of over {:.0} % each (collapsed / views checked; – for a method without \
         plane labels).\n\n",
        generate::GENERATOR_VERSION,
        TEST_SEEDS.start,
        TEST_SEEDS.start,
        TEST_SEEDS.end - 1,
        100.0 * COLLAPSE_LABEL_SHARE,
        COLLAPSE_GT_PLANES,
        100.0 * COLLAPSE_GT_PLANE_SHARE,
    ));
    s.push_str(
        "| kind | seeds | split | method | scenes | mean ≤1% | mean F | 10th-pct view ≤1% | worst view ≤1% | collapsed views |\n\
         |---|---|---|---|---|---|---|---|---|---|\n",
    );
    for k in &summaries {
        let seeds = if k.seeds.0 == k.seeds.1 {
            k.seeds.0.to_string()
        } else {
            format!("{}–{}", k.seeds.0, k.seeds.1)
        };
        let scenes = if k.failed > 0 {
            format!("{} ({} failed)", k.scenes, k.failed)
        } else {
            k.scenes.to_string()
        };
        let collapsed = match &k.collapses {
            Some(c) if c.collapsed.is_empty() => format!("0 / {}", c.checked),
            // The first few names here; results.json lists them all.
            Some(c) => format!(
                "{} / {} ({}{})",
                c.collapsed.len(),
                c.checked,
                c.collapsed[..c.collapsed.len().min(COLLAPSES_NAMED)].join(", "),
                if c.collapsed.len() > COLLAPSES_NAMED {
                    ", …"
                } else {
                    ""
                }
            ),
            None => "–".to_string(),
        };
        s.push_str(&format!(
            "| {} | {seeds} | {} | {} | {scenes} | {} | {} | {} | {} ({}) | {collapsed} |\n",
            k.kind,
            k.split,
            k.method,
            pct(k.mean_within_1pct),
            pct(k.mean_f_score),
            pct(k.p10_view_within_1pct),
            pct(k.worst_view_within_1pct),
            k.worst_view,
        ));
    }
    // Plazas always (issue 35 sets their planar and non-planar targets), other kinds when
    // non-planar surfaces are 1 % or more of their ground-truth pixels.
    let split: Vec<&KindSummary> = summaries
        .iter()
        .filter(|k| k.kind == Kind::Plaza || k.nonplanar_share >= 0.01)
        .collect();
    if !split.is_empty() {
        s.push_str(
            "\nPlanar and non-planar ground-truth pixels, per kind: the mean over the scenes \
             of depth within 1 % (%) on each.\n\n\
             | kind | method | non-planar share | planar ≤1% | non-planar ≤1% |\n\
             |---|---|---|---|---|\n",
        );
        for k in split {
            s.push_str(&format!(
                "| {} | {} | {} | {} | {} |\n",
                k.kind,
                k.method,
                pct(k.nonplanar_share),
                pct(k.planar_within_1pct),
                pct(k.nonplanar_within_1pct)
            ));
        }
    }
    s.push_str("\n### Generated scenes one by one\n\n");
    s.push_str(&report::markdown(generated));
    s
}

#[cfg(test)]
mod tests {
    use std::path::PathBuf;

    use super::super::{MethodResult, SceneResult};
    use super::*;
    use crate::eval::metrics::{self, CloudScores, DepthCounts};

    #[test]
    fn generated_sets_parse_and_bad_ones_are_errors() {
        let g = parse_generated("all:10@1000").unwrap();
        assert_eq!(g.kinds, Kind::ALL.to_vec());
        assert_eq!((g.count, g.first_seed), (10, 1000));
        let g = parse_generated(" plaza:3 ").unwrap();
        assert_eq!(g.kinds, vec![Kind::Plaza]);
        assert_eq!((g.count, g.first_seed), (3, 0));
        let pairs: Vec<(Kind, u64)> = parse_generated("street:2@5").unwrap().scenes().collect();
        assert_eq!(pairs, vec![(Kind::Street, 5), (Kind::Street, 6)]);
        for (bad, why) in [
            ("castle:3", "unknown kind \"castle\""),
            ("foo:3", "unknown kind \"foo\""),
            ("hall", "no ':'"),
            ("hall:0", "at least 1"),
            ("all:0", "at least 1"),
            ("hall:20000", "at most 10000"),
            ("hall:x", "COUNT \"x\" is not a number"),
            ("hall:2@y", "FIRST_SEED \"y\" is not a number"),
            ("interior:2@abc", "FIRST_SEED \"abc\""),
        ] {
            let err = parse_generated(bad).unwrap_err().to_string();
            assert!(
                err.contains(why) && err.contains("all:10@1000") && err.contains("pavilion"),
                "{bad}: {err}"
            );
        }
    }

    /// A scene result with one method whose views score `accs` (depth within 1 %), with a
    /// collapse record if `collapsed` is given (views checked, collapsed view names).
    fn scene_with_views(
        name: &str,
        kind: Kind,
        seed: u64,
        accs: &[f64],
        collapse: Option<Collapses>,
    ) -> SceneResult {
        let views: Vec<(String, DepthCounts)> = accs
            .iter()
            .enumerate()
            .map(|(i, &a)| {
                let c = DepthCounts {
                    gt_pixels: 1000,
                    predicted: 1000,
                    within: [0, (a * 1000.0).round() as u64, 1000],
                    ..DepthCounts::default()
                };
                (format!("view_{i:04}.png"), c)
            })
            .collect();
        let mut depth = DepthCounts::default();
        for (_, c) in &views {
            depth.add(c);
        }
        // Planar pixels all right, non-planar ones (a fifth of a plaza) half right.
        let share = if kind == Kind::Plaza { 0.2 } else { 0.0 };
        let px = depth.gt_pixels as f64;
        let nonplanar_depth = DepthCounts {
            gt_pixels: (share * px) as u64,
            within: [0, (share * px / 2.0) as u64, 0],
            ..DepthCounts::default()
        };
        let planar_depth = DepthCounts {
            gt_pixels: ((1.0 - share) * px) as u64,
            within: [0, ((1.0 - share) * px) as u64, 0],
            ..DepthCounts::default()
        };
        SceneResult {
            name: name.into(),
            category: kind.category().into(),
            file: PathBuf::from(format!("{name}.toml")),
            width: 96,
            height: 72,
            views: accs.len(),
            sparse_points: 0,
            cache_hit: false,
            render_seconds: 0.0,
            median_depth: 1.0,
            methods: vec![MethodResult {
                method: "sweep".into(),
                error: None,
                depth,
                planar_depth,
                nonplanar_depth,
                views,
                segmentation: None,
                collapse,
                cloud: CloudScores::default(),
                stages: Vec::new(),
                seconds: 0.0,
                peak_memory_bytes: None,
                start_memory_bytes: None,
            }],
            generated: Some(GeneratedTag {
                kind,
                seed,
                split: generate::split(seed),
                generator_version: generate::GENERATOR_VERSION,
            }),
        }
    }

    fn results(scenes: Vec<SceneResult>) -> BenchResults {
        BenchResults {
            renderer_version: 0,
            depth_thresholds: metrics::DEPTH_THRESHOLDS,
            cloud_tolerance_fraction: 0.01,
            scenes,
            seconds: 0.0,
        }
    }

    #[test]
    fn kind_summaries_give_the_mean_the_10th_percentile_and_the_worst_view() {
        // Twenty views over two hall scenes: 0.00, 0.05, …, 0.95.
        let a: Vec<f64> = (0..10).map(|i| 0.1 * i as f64).collect();
        let b: Vec<f64> = (0..10).map(|i| 0.1 * i as f64 + 0.05).collect();
        let mut plain = scene_with_views("tiny", Kind::Hall, 0, &[0.5], None);
        plain.generated = None;
        let collapsed = |checked, views: &[&str]| {
            Some(Collapses {
                checked,
                collapsed: views.iter().map(|v| v.to_string()).collect(),
            })
        };
        let results = results(vec![
            plain,
            scene_with_views(
                "hall-1000",
                Kind::Hall,
                1000,
                &a,
                collapsed(7, &["view_0003.png"]),
            ),
            scene_with_views(
                "hall-1001",
                Kind::Hall,
                1001,
                &b,
                collapsed(5, &["v1.png", "v2.png", "v3.png"]),
            ),
            scene_with_views("plaza-0004", Kind::Plaza, 4, &[0.8, 0.6], None),
        ]);
        let k = kind_summaries(&results.subset(true));
        assert_eq!(k.len(), 2);
        let hall = &k[0];
        assert_eq!(
            (hall.kind, hall.scenes, hall.seeds),
            (Kind::Hall, 2, (1000, 1001))
        );
        assert_eq!(hall.split, "test");
        assert!((hall.mean_within_1pct - 0.475).abs() < 1e-9);
        // Nearest rank of 10 % of 20 views: the 2nd smallest, 0.05.
        assert!((hall.p10_view_within_1pct - 0.05).abs() < 1e-9);
        assert_eq!(
            (hall.worst_view_within_1pct, hall.worst_view.as_str()),
            (0.0, "hall-1000/view_0000.png")
        );
        assert_eq!(
            hall.collapses,
            collapsed(
                12,
                &[
                    "hall-1000/view_0003.png",
                    "hall-1001/v1.png",
                    "hall-1001/v2.png",
                    "hall-1001/v3.png"
                ]
            ),
            "summed over the scenes, named by scene"
        );
        let plaza = &k[1];
        assert!((plaza.p10_view_within_1pct - 0.6).abs() < 1e-9);
        assert!((plaza.planar_within_1pct - 1.0).abs() < 1e-9);
        assert!((plaza.nonplanar_within_1pct - 0.5).abs() < 1e-9);
        assert!((plaza.nonplanar_share - 0.2).abs() < 1e-9);
        assert_eq!(plaza.collapses, None, "no label map, no collapse count");

        // results.md: the scene files' table, then the generated heading naming the splits
        // and one row per kind and method; the scene files' table does not list generated
        // scenes.
        let md = markdown(&results);
        let (files, generated) = md.split_once("## Generated scenes: ").unwrap();
        assert!(files.starts_with("## Scene files"));
        assert!(files.contains("| tiny |") && !files.contains("hall-1000"));
        assert!(
            generated.starts_with(
                "development split (seeds below 1000, for tuning) + test split (seeds \
                 1000–1999, never tuned on)\n"
            ),
            "{generated}"
        );
        assert!(
            generated.contains(
                "| hall | 1000–1001 | test | sweep | 2 | 47.5 | 0.0 | 5.0 | 0.0 \
                 (hall-1000/view_0000.png) | 4 / 12 (hall-1000/view_0003.png, \
                 hall-1001/v1.png, hall-1001/v2.png, …) |"
            ),
            "{md}"
        );
        assert!(
            generated.contains(
                "| plaza | 4 | development | sweep | 1 | 70.0 | 0.0 | 60.0 | 60.0 \
                 (plaza-0004/view_0001.png) | – |"
            ),
            "{md}"
        );
        // Planar / non-planar for the plaza only (the halls have no non-planar pixels).
        assert!(
            generated.contains("| plaza | sweep | 20.0 | 100.0 | 50.0 |"),
            "{md}"
        );
        assert!(!generated.contains("| hall | sweep |"), "{md}");
        // Without generated scenes results.md is what it was.
        assert_eq!(
            markdown(&results.subset(false)),
            report::markdown(&results.subset(false))
        );
    }

    #[test]
    fn results_json_carries_the_kind_summaries() {
        let dir = tempfile::tempdir().unwrap();
        let r = results(vec![scene_with_views(
            "street-1002",
            Kind::Street,
            1002,
            &[0.9, 0.7],
            Some(Collapses::default()),
        )]);
        write_reports(&r, dir.path()).unwrap();
        let json: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(dir.path().join("results.json")).unwrap(),
        )
        .unwrap();
        assert_eq!(json["scenes"][0]["generated"]["split"], "test");
        let g = &json["generated"];
        assert_eq!(g["test_seeds"], serde_json::json!([1000, 1999]));
        assert_eq!(g["kinds"][0]["kind"], "street");
        assert_eq!(g["kinds"][0]["p10_view_within_1pct"], 0.7);
        assert_eq!(g["kinds"][0]["collapses"]["checked"], 0);
        let md = std::fs::read_to_string(dir.path().join("results.md")).unwrap();
        assert!(md.starts_with("## Generated scenes: test split"), "{md}");
    }
}
