//! Semi-global aggregation of a plane cost volume (Hirschmüller, "Stereo processing by
//! semiglobal matching and mutual information", PAMI 2008), over a family of parallel planes
//! in sweep order instead of disparities.
//!
//! Along each of 4 or 8 scan directions `r` a path cost is accumulated,
//!
//! `L_r(p, k) = C(p, k) + min(L_r(p−r, k), L_r(p−r, k±1) + P1, min_j L_r(p−r, j) + P2) − min_j L_r(p−r, j)`,
//!
//! and the aggregated cost is the sum over the directions. Consecutive planes of a sweep family
//! are about a pixel of disparity apart ([`super::multisweep`]'s plane density), so `P1` is the
//! penalty of a one-pixel step along a slanted surface and `P2` that of a depth jump. `P2` is
//! lowered across a grey-level edge of the reference image, where depth edges are likely.
//!
//! The sum is returned rescaled into the cost volume's `[0, 1]`: since
//! `C ≤ L_r ≤ C + P2`, the mean over directions divided by `1 + P2` stays below 1 wherever
//! some plane has evidence, and a pixel with no evidence on any plane keeps cost 1 on every
//! plane, so [`super::winner_takes_all`] still leaves it without a plane.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::volume::CostVolume;
use super::PhotoError;
use crate::raster::ImageF32;

/// Settings of the semi-global aggregation ([`semi_global`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct SgmConfig {
    /// Scan directions: 0 (off: plain winner-takes-all), 4 (horizontal and vertical) or 8
    /// (and the diagonals). Off unless a sweep turns it on (the sweep baseline: 8): the
    /// paths pull trees and statues onto the wall behind them, which the non-planar label
    /// must not have.
    pub paths: usize,
    /// Penalty for a change of one plane between consecutive pixels of a path, in cost
    /// units (costs are in [0, 1]), ≥ 0: consecutive planes are about a pixel of disparity
    /// apart, so this is a one-pixel step along a slanted surface. With `p2`, the best pair
    /// of those tried on one view of every scene (docs/notes/photo-and-sweep-baseline.md).
    pub p1: f64,
    /// Penalty for a change of more than one plane (a depth jump), in cost units, ≥ `p1`.
    pub p2: f64,
    /// Edge-aware `P2`: divided by `1 + |ΔI| / p2_edge` between consecutive pixels whose
    /// grey levels (in [0, 1]) differ by `ΔI`, never below `p1`; in grey levels, ≥ 0,
    /// 0 = a constant `P2`. Depth jumps are likely across grey-level edges; a constant P2
    /// lost on the `thin` scene (docs/notes/photo-and-sweep-baseline.md).
    pub p2_edge: f64,
    /// Where the sub-plane refinement ([`super::refine_subplane`]) fits its parabola after
    /// the paths picked the winner: `true` — to the local (pre-path) costs where they have
    /// evidence and a convex minimum around the winning plane, to the aggregated ones
    /// elsewhere; `false` — to the aggregated costs only. The paths' min-plus-penalty sums
    /// flatten the cost curve about its minimum and bias the fit towards the plane itself,
    /// yet the local fit lost over every view of the 13 scenes, so it is off
    /// (docs/notes/photo-and-sweep-baseline.md).
    pub subplane_on_local: bool,
}

impl Default for SgmConfig {
    fn default() -> Self {
        SgmConfig {
            paths: 0,
            p1: 0.06,
            p2: 0.6,
            p2_edge: 0.05,
            subplane_on_local: false,
        }
    }
}

impl SgmConfig {
    /// Whether the aggregation runs.
    pub fn enabled(&self) -> bool {
        self.paths > 0
    }

    /// Checks every field; the error names it.
    pub fn validate(&self) -> Result<(), PhotoError> {
        let bad = |m: String| Err(PhotoError::InvalidInput(m));
        if ![0, 4, 8].contains(&self.paths) {
            return bad(format!("sgm.paths must be 0, 4 or 8, got {}", self.paths));
        }
        if !(self.p1.is_finite() && self.p1 >= 0.0) {
            return bad(format!("sgm.p1 must be finite and ≥ 0, got {}", self.p1));
        }
        if !(self.p2.is_finite() && self.p2 >= self.p1) {
            return bad(format!(
                "sgm.p2 must be finite and ≥ sgm.p1 = {}, got {}",
                self.p1, self.p2
            ));
        }
        if !(self.p2_edge.is_finite() && self.p2_edge >= 0.0) {
            return bad(format!(
                "sgm.p2_edge must be finite and ≥ 0, got {}",
                self.p2_edge
            ));
        }
        Ok(())
    }

    /// P2 between two pixels of grey levels `a` and `b` (computed in f32, as the costs).
    fn p2_between(&self, a: f32, b: f32) -> f32 {
        let (p1, p2, p2_edge) = (self.p1 as f32, self.p2 as f32, self.p2_edge as f32);
        if p2_edge > 0.0 {
            (p2 / (1.0 + (a - b).abs() / p2_edge)).max(p1)
        } else {
            p2
        }
    }
}

/// Scan directions `(dx, dy)`: the first 4 are the 4-path set, all 8 the 8-path set.
const DIRECTIONS: [(isize, isize); 8] = [
    (1, 0),
    (-1, 0),
    (0, 1),
    (0, -1),
    (1, 1),
    (-1, 1),
    (1, -1),
    (-1, -1),
];

/// One step of a path: `out = L_r(p, ·)` from the pixel's costs and its predecessor's path
/// costs `prev` (with their minimum `prev_min`); returns `min out`.
fn step(cost: &[f32], prev: &[f32], prev_min: f32, p1: f32, p2: f32, out: &mut [f32]) -> f32 {
    let n = cost.len();
    let jump = prev_min + p2;
    let mut new_min = f32::INFINITY;
    for k in 0..n {
        let mut m = prev[k].min(jump);
        if k > 0 {
            m = m.min(prev[k - 1] + p1);
        }
        if k + 1 < n {
            m = m.min(prev[k + 1] + p1);
        }
        let v = cost[k] + m - prev_min;
        out[k] = v;
        new_min = new_min.min(v);
    }
    new_min
}

fn min_of(v: &[f32]) -> f32 {
    v.iter().copied().fold(f32::INFINITY, f32::min)
}

/// Semi-global aggregation of `volume` (one family of parallel planes in sweep order, so that
/// plane `k ± 1` is the next plane along the sweep), with `guide` (the reference image, grey
/// or RGB, the volume's size; its luma steers the edge-aware `P2`). Returns the aggregated volume
/// rescaled into `[0, 1]` (see the module documentation); with `cfg.paths == 0` a copy.
/// The result does not depend on the thread count: each direction is computed in a fixed
/// order and the directions are summed in a fixed order.
pub fn semi_global(
    volume: &CostVolume,
    guide: &ImageF32,
    cfg: &SgmConfig,
) -> Result<CostVolume, PhotoError> {
    cfg.validate()?;
    let (w, h, np) = (volume.width, volume.height, volume.num_planes);
    if volume.costs.len() != w * h * np {
        return Err(PhotoError::Size(format!(
            "cost volume {w}×{h}×{np} with {} values",
            volume.costs.len()
        )));
    }
    if guide.width as usize != w || guide.height as usize != h || !matches!(guide.channels, 1 | 3) {
        return Err(PhotoError::Size(format!(
            "guide {}×{}×{} for a {w}×{h} cost volume",
            guide.width, guide.height, guide.channels
        )));
    }
    if !cfg.enabled() || np == 0 || w == 0 || h == 0 {
        return Ok(volume.clone());
    }
    let grey = guide.to_gray().data;
    let c = &volume.costs;
    let mut sum = vec![0.0f32; w * h * np];
    let dirs = &DIRECTIONS[..cfg.paths];
    for &(dx, dy) in dirs {
        if dy == 0 {
            // Rows are independent paths.
            sum.par_chunks_mut(w * np)
                .enumerate()
                .for_each(|(y, s_row)| {
                    let mut prev = vec![0.0f32; np];
                    let mut cur = vec![0.0f32; np];
                    let mut prev_min = 0.0f32;
                    for i in 0..w {
                        let x = if dx > 0 { i } else { w - 1 - i };
                        let p = y * w + x;
                        let cost = &c[p * np..(p + 1) * np];
                        if i == 0 {
                            cur.copy_from_slice(cost);
                            prev_min = min_of(cost);
                        } else {
                            let q = (p as isize - dx) as usize;
                            let p2 = cfg.p2_between(grey[p], grey[q]);
                            prev_min = step(cost, &prev, prev_min, cfg.p1 as f32, p2, &mut cur);
                        }
                        for (s, &v) in s_row[x * np..(x + 1) * np].iter_mut().zip(&cur) {
                            *s += v;
                        }
                        std::mem::swap(&mut prev, &mut cur);
                    }
                });
        } else {
            // Row after row along dy; the pixels of a row are independent given the previous.
            let mut prev = vec![0.0f32; w * np];
            let mut prev_min = vec![0.0f32; w];
            let mut cur = vec![0.0f32; w * np];
            let mut cur_min = vec![0.0f32; w];
            for i in 0..h {
                let y = if dy > 0 { i } else { h - 1 - i };
                cur.par_chunks_mut(np)
                    .zip(cur_min.par_iter_mut())
                    .enumerate()
                    .for_each(|(x, (out, m))| {
                        let p = y * w + x;
                        let cost = &c[p * np..(p + 1) * np];
                        let qx = x as isize - dx;
                        if i == 0 || qx < 0 || qx >= w as isize {
                            out.copy_from_slice(cost);
                            *m = min_of(cost);
                        } else {
                            let qx = qx as usize;
                            let qy = (y as isize - dy) as usize;
                            let p2 = cfg.p2_between(grey[p], grey[qy * w + qx]);
                            *m = step(
                                cost,
                                &prev[qx * np..(qx + 1) * np],
                                prev_min[qx],
                                cfg.p1 as f32,
                                p2,
                                out,
                            );
                        }
                    });
                sum[y * w * np..(y + 1) * w * np]
                    .par_chunks_mut(np)
                    .zip(cur.par_chunks(np))
                    .for_each(|(s, l)| {
                        for (s, &v) in s.iter_mut().zip(l) {
                            *s += v;
                        }
                    });
                std::mem::swap(&mut prev, &mut cur);
                std::mem::swap(&mut prev_min, &mut cur_min);
            }
        }
    }
    let scale = 1.0 / (dirs.len() as f32 * (1.0 + cfg.p2 as f32));
    sum.par_chunks_mut(np)
        .zip(c.par_chunks(np))
        .for_each(|(s, raw)| {
            if min_of(raw) >= 1.0 {
                s.fill(1.0);
            } else {
                s.iter_mut().for_each(|v| *v = (*v * scale).min(1.0));
            }
        });
    Ok(CostVolume {
        width: w,
        height: h,
        num_planes: np,
        costs: sum,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// A direct implementation of the recursion over explicit paths, one direction at a time.
    fn naive(volume: &CostVolume, grey: &[f32], cfg: &SgmConfig) -> Vec<f32> {
        let (w, h, np) = (volume.width, volume.height, volume.num_planes);
        let mut total = vec![0.0f64; w * h * np];
        for &(dx, dy) in &DIRECTIONS[..cfg.paths] {
            let mut l = vec![f64::NAN; w * h * np];
            // Visit pixels so that the predecessor (x − dx, y − dy) comes first.
            let ys: Vec<usize> = if dy >= 0 {
                (0..h).collect()
            } else {
                (0..h).rev().collect()
            };
            let xs: Vec<usize> = if dx >= 0 {
                (0..w).collect()
            } else {
                (0..w).rev().collect()
            };
            for &y in &ys {
                for &x in &xs {
                    let p = y * w + x;
                    let (qx, qy) = (x as isize - dx, y as isize - dy);
                    let inside = qx >= 0 && qy >= 0 && qx < w as isize && qy < h as isize;
                    for k in 0..np {
                        let cost = volume.costs[p * np + k] as f64;
                        l[p * np + k] = if inside {
                            let q = qy as usize * w + qx as usize;
                            let prev = &l[q * np..(q + 1) * np];
                            let pm = prev.iter().copied().fold(f64::INFINITY, f64::min);
                            let p2 = cfg.p2_between(grey[p], grey[q]) as f64;
                            let mut m = prev[k].min(pm + p2);
                            if k > 0 {
                                m = m.min(prev[k - 1] + cfg.p1 as f32 as f64);
                            }
                            if k + 1 < np {
                                m = m.min(prev[k + 1] + cfg.p1 as f32 as f64);
                            }
                            cost + m - pm
                        } else {
                            cost
                        };
                    }
                }
            }
            for (t, v) in total.iter_mut().zip(&l) {
                *t += v;
            }
        }
        let n = cfg.paths as f64 * (1.0 + cfg.p2 as f32 as f64);
        total
            .chunks(np)
            .zip(volume.costs.chunks(np))
            .flat_map(|(t, raw)| {
                let none = raw.iter().all(|&c| c >= 1.0);
                t.iter()
                    .map(move |&v| if none { 1.0 } else { (v / n).min(1.0) as f32 })
                    .collect::<Vec<_>>()
            })
            .collect()
    }

    fn random_volume(w: usize, h: usize, np: usize, seed: u64) -> (CostVolume, ImageF32) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut costs: Vec<f32> = (0..w * h * np).map(|_| rng.random::<f32>()).collect();
        // One pixel without evidence.
        costs[..np].fill(1.0);
        let data: Vec<f32> = (0..w * h).map(|_| rng.random::<f32>()).collect();
        (
            CostVolume {
                width: w,
                height: h,
                num_planes: np,
                costs,
            },
            ImageF32 {
                width: w as u32,
                height: h as u32,
                channels: 1,
                data,
            },
        )
    }

    #[test]
    fn matches_the_recursion_on_explicit_paths() {
        let (vol, guide) = random_volume(9, 7, 6, 3);
        for paths in [4, 8] {
            for p2_edge in [0.0, 0.1] {
                let cfg = SgmConfig {
                    paths,
                    p1: 0.05,
                    p2: 0.4,
                    p2_edge,
                    ..Default::default()
                };
                let got = semi_global(&vol, &guide, &cfg).unwrap();
                let want = naive(&vol, &guide.data, &cfg);
                for (i, (a, b)) in got.costs.iter().zip(&want).enumerate() {
                    assert!((a - b).abs() < 1e-5, "paths {paths}, value {i}: {a} vs {b}");
                }
                // The pixel without evidence keeps 1 on every plane; the others stay below.
                assert!(got.costs[..6].iter().all(|&v| v == 1.0));
                for px in 1..63 {
                    let best = got.costs[px * 6..(px + 1) * 6]
                        .iter()
                        .copied()
                        .fold(f32::INFINITY, f32::min);
                    assert!(best < 1.0, "pixel {px}: {best}");
                }
            }
        }
    }

    #[test]
    fn off_is_a_copy_and_results_do_not_depend_on_threads() {
        let (vol, guide) = random_volume(31, 17, 12, 5);
        let off = semi_global(&vol, &guide, &SgmConfig::default()).unwrap();
        assert_eq!(off, vol);
        let cfg = SgmConfig {
            paths: 8,
            ..Default::default()
        };
        let run = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| semi_global(&vol, &guide, &cfg).unwrap())
        };
        let (a, b) = (run(1), run(3));
        assert!(a
            .costs
            .iter()
            .zip(&b.costs)
            .all(|(x, y)| x.to_bits() == y.to_bits()));
    }

    #[test]
    fn a_weak_pixel_takes_its_neighbours_plane() {
        // A 15×1 strip on plane 5 of 10, whose middle pixel's own costs prefer plane 1
        // slightly: aggregation hands it plane 5, and every other pixel keeps plane 5.
        let (w, np) = (15usize, 10usize);
        let mut costs = vec![0.8f32; w * np];
        for x in 0..w {
            costs[x * np + 5] = 0.1;
        }
        let mid = 7 * np;
        costs[mid + 5] = 0.6;
        costs[mid + 1] = 0.55;
        let vol = CostVolume {
            width: w,
            height: 1,
            num_planes: np,
            costs,
        };
        let guide = ImageF32 {
            width: w as u32,
            height: 1,
            channels: 1,
            data: vec![0.5; w],
        };
        let argmin = |v: &[f32]| {
            v.iter()
                .enumerate()
                .fold(
                    (0, f32::INFINITY),
                    |a, (k, &c)| if c < a.1 { (k, c) } else { a },
                )
                .0
        };
        assert_eq!(argmin(&vol.costs[mid..mid + np]), 1);
        let cfg = SgmConfig {
            paths: 4,
            p1: 0.02,
            p2: 0.2,
            p2_edge: 0.0,
            ..Default::default()
        };
        let agg = semi_global(&vol, &guide, &cfg).unwrap();
        assert_eq!(argmin(&agg.costs[mid..mid + np]), 5);
        for x in 0..w {
            assert_eq!(argmin(&agg.costs[x * np..(x + 1) * np]), 5);
        }
    }

    #[test]
    fn bad_settings_are_named() {
        let (vol, guide) = random_volume(4, 3, 2, 1);
        for (cfg, name) in [
            (
                SgmConfig {
                    paths: 3,
                    ..Default::default()
                },
                "sgm.paths",
            ),
            (
                SgmConfig {
                    paths: 4,
                    p1: 0.5,
                    p2: 0.1,
                    ..Default::default()
                },
                "sgm.p2",
            ),
            (
                SgmConfig {
                    paths: 4,
                    p2_edge: -1.0,
                    ..Default::default()
                },
                "sgm.p2_edge",
            ),
        ] {
            let err = semi_global(&vol, &guide, &cfg).unwrap_err().to_string();
            assert!(err.contains(name), "{err}");
        }
        let small = ImageF32 {
            width: 2,
            height: 3,
            channels: 1,
            data: vec![0.0; 6],
        };
        assert!(semi_global(&vol, &small, &SgmConfig::default()).is_err());
    }
}
