//! Aggregation of cost slices (tutorial §2.1, "photo-consistency aggregation"): box filter
//! from integral images (O(1) per pixel whatever the radius), and the edge-aware filters the
//! tutorial lists — bilateral, guided (He, Sun, Tang 2010) and weighted median — guided by
//! the reference image so that costs are not smeared across intensity edges.
//!
//! A slice is one cost per pixel, row-major `width × height`. Windows are clipped at the
//! image border (a border pixel averages over the part of its window inside the image).

use super::PhotoError;
use crate::raster::ImageF32;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// A summed-area table ("integral image") in `f64`, `(width+1) × (height+1)` entries with a
/// zero first row and column. `f64` keeps `E[x²] − E[x]²` accurate over large images (an
/// `f32` table of a 640×480 image loses about 0.03 in absolute value).
#[derive(Debug, Clone, Default)]
pub struct Integral {
    width: usize,
    height: usize,
    table: Vec<f64>,
}

impl Integral {
    /// An empty table for a `width × height` slice (all sums 0 until built).
    pub fn new(width: usize, height: usize) -> Self {
        Integral {
            width,
            height,
            table: vec![0.0; (width + 1) * (height + 1)],
        }
    }

    /// Fills the table with the values `value(i)` of the pixels `i = y·width + x`.
    #[inline]
    pub fn build_with(&mut self, mut value: impl FnMut(usize) -> f64) {
        let stride = self.width + 1;
        for y in 0..self.height {
            let mut row_sum = 0.0f64;
            let (above, here) = self.table[y * stride..(y + 2) * stride].split_at_mut(stride);
            for x in 0..self.width {
                row_sum += value(y * self.width + x);
                here[x + 1] = above[x + 1] + row_sum;
            }
        }
    }

    /// Fills the table from a slice of `width × height` values.
    pub fn build(&mut self, src: &[f32]) {
        self.build_with(|i| src[i] as f64);
    }

    /// Sum over the half-open pixel rectangle `[x0, x1) × [y0, y1)`.
    #[inline]
    pub fn rect_sum(&self, x0: usize, y0: usize, x1: usize, y1: usize) -> f64 {
        let s = self.width + 1;
        self.table[y1 * s + x1] - self.table[y0 * s + x1] - self.table[y1 * s + x0]
            + self.table[y0 * s + x0]
    }
}

/// The clipped window `[lo, hi)` of radius `r` around index `i` in `0..n`.
#[inline]
pub fn window(i: usize, r: usize, n: usize) -> (usize, usize) {
    (i.saturating_sub(r), (i + r + 1).min(n))
}

fn check_slice(len: usize, width: usize, height: usize, what: &str) -> Result<(), PhotoError> {
    if len != width * height {
        return Err(PhotoError::Size(format!(
            "{what} has {len} values, expected {width}×{height} = {}",
            width * height
        )));
    }
    Ok(())
}

fn check_guide(guide: &ImageF32, width: usize, height: usize) -> Result<(), PhotoError> {
    if guide.width as usize != width || guide.height as usize != height || guide.channels == 0 {
        return Err(PhotoError::Size(format!(
            "guide image is {}×{}×{}, expected {width}×{height} with at least one channel",
            guide.width, guide.height, guide.channels
        )));
    }
    check_slice(
        guide.data.len(),
        width * guide.channels as usize,
        height,
        "guide image data",
    )
}

/// Box filter: the mean of `src` over the clipped `(2·radius+1)²` window of every pixel,
/// through an integral image, so each output costs four look-ups whatever the radius.
pub fn box_filter(
    src: &[f32],
    width: usize,
    height: usize,
    radius: usize,
) -> Result<Vec<f32>, PhotoError> {
    check_slice(src.len(), width, height, "cost slice")?;
    let mut integral = Integral::new(width, height);
    integral.build(src);
    let mut out = vec![0.0f32; width * height];
    out.par_chunks_mut(width.max(1))
        .enumerate()
        .for_each(|(y, row)| {
            let (y0, y1) = window(y, radius, height);
            for (x, o) in row.iter_mut().enumerate() {
                let (x0, x1) = window(x, radius, width);
                let area = ((x1 - x0) * (y1 - y0)) as f64;
                *o = (integral.rect_sum(x0, y0, x1, y1) / area) as f32;
            }
        });
    Ok(out)
}

/// Squared colour distance between pixels `p` and `q` of the guide (all channels).
#[inline]
fn guide_dist2(guide: &[f32], channels: usize, p: usize, q: usize) -> f32 {
    let mut d2 = 0.0;
    for c in 0..channels {
        let d = guide[p * channels + c] - guide[q * channels + c];
        d2 += d * d;
    }
    d2
}

/// The spatial Gaussian `exp(−(dx²+dy²)/(2σ²))` over a `(2r+1)²` window, row-major.
fn spatial_kernel(radius: usize, sigma_space: f32) -> Vec<f32> {
    let side = 2 * radius + 1;
    let mut k = Vec::with_capacity(side * side);
    for dy in 0..side {
        for dx in 0..side {
            let (fx, fy) = (dx as f32 - radius as f32, dy as f32 - radius as f32);
            k.push((-(fx * fx + fy * fy) / (2.0 * sigma_space * sigma_space)).exp());
        }
    }
    k
}

/// Bilateral filter (Tomasi & Manduchi 1998; Yoon & Kweon's adaptive support weights are the
/// same idea): each pixel's cost becomes the mean over its window weighted by
/// `exp(−Δxy²/(2σ_s²)) · exp(−‖guide(p) − guide(q)‖²/(2σ_c²))`. O(radius²) per pixel.
pub fn bilateral_filter(
    src: &[f32],
    guide: &ImageF32,
    radius: usize,
    sigma_space: f32,
    sigma_color: f32,
) -> Result<Vec<f32>, PhotoError> {
    let (width, height) = (guide.width as usize, guide.height as usize);
    check_guide(guide, width, height)?;
    check_slice(src.len(), width, height, "cost slice")?;
    let kernel = spatial_kernel(radius, sigma_space);
    let ch = guide.channels as usize;
    let inv_2sc2 = 1.0 / (2.0 * sigma_color * sigma_color);
    let side = 2 * radius + 1;
    let mut out = vec![0.0f32; width * height];
    out.par_chunks_mut(width.max(1))
        .enumerate()
        .for_each(|(y, row)| {
            let (y0, y1) = window(y, radius, height);
            for (x, o) in row.iter_mut().enumerate() {
                let (x0, x1) = window(x, radius, width);
                let p = y * width + x;
                let (mut num, mut den) = (0.0f32, 0.0f32);
                for qy in y0..y1 {
                    let krow = (qy + radius - y) * side;
                    for qx in x0..x1 {
                        let q = qy * width + qx;
                        let w = kernel[krow + qx + radius - x]
                            * (-guide_dist2(&guide.data, ch, p, q) * inv_2sc2).exp();
                        num += w * src[q];
                        den += w;
                    }
                }
                // den ≥ 1 (the centre weighs 1).
                *o = num / den;
            }
        });
    Ok(out)
}

/// Guided filter (He, Sun, Tang, ECCV 2010) with the grey version of `guide`: in every window
/// the output is the local linear model `a·I + b` of the guide that best fits the costs
/// (ridge `eps` on `a`), averaged over the windows covering the pixel. Edge-preserving like
/// the bilateral filter, but O(1) per pixel (six box filters) whatever the radius.
pub fn guided_filter(
    src: &[f32],
    guide: &ImageF32,
    radius: usize,
    eps: f32,
) -> Result<Vec<f32>, PhotoError> {
    let (width, height) = (guide.width as usize, guide.height as usize);
    check_guide(guide, width, height)?;
    check_slice(src.len(), width, height, "cost slice")?;
    let grey = guide.to_gray();
    let i = &grey.data;
    let n = width * height;
    let mean = |f: &dyn Fn(usize) -> f64| -> Vec<f64> {
        let mut integral = Integral::new(width, height);
        integral.build_with(f);
        let mut out = vec![0.0f64; n];
        out.par_chunks_mut(width.max(1))
            .enumerate()
            .for_each(|(y, row)| {
                let (y0, y1) = window(y, radius, height);
                for (x, o) in row.iter_mut().enumerate() {
                    let (x0, x1) = window(x, radius, width);
                    *o = integral.rect_sum(x0, y0, x1, y1) / ((x1 - x0) * (y1 - y0)) as f64;
                }
            });
        out
    };
    let mean_i = mean(&|k| i[k] as f64);
    let mean_p = mean(&|k| src[k] as f64);
    let corr_ii = mean(&|k| (i[k] as f64) * (i[k] as f64));
    let corr_ip = mean(&|k| (i[k] as f64) * (src[k] as f64));
    let mut a = vec![0.0f64; n];
    let mut b = vec![0.0f64; n];
    for k in 0..n {
        let var = corr_ii[k] - mean_i[k] * mean_i[k];
        let cov = corr_ip[k] - mean_i[k] * mean_p[k];
        a[k] = cov / (var + eps as f64);
        b[k] = mean_p[k] - a[k] * mean_i[k];
    }
    let mean_a = mean(&|k| a[k]);
    let mean_b = mean(&|k| b[k]);
    Ok((0..n)
        .map(|k| (mean_a[k] * i[k] as f64 + mean_b[k]) as f32)
        .collect())
}

/// The lower weighted median of `(value, weight)` pairs: the smallest value at which the
/// cumulative weight (values sorted ascending) reaches half the total. It minimises
/// `Σ wᵢ·|v − valueᵢ|`. Sorts `pairs` in place.
pub fn weighted_median(pairs: &mut [(f32, f32)]) -> f32 {
    pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
    let total: f32 = pairs.iter().map(|p| p.1).sum();
    let mut acc = 0.0;
    for &(v, w) in pairs.iter() {
        acc += w;
        if acc >= 0.5 * total {
            return v;
        }
    }
    pairs.last().map_or(f32::NAN, |p| p.0)
}

/// Weighted median filter (Ma et al. CVPR 2013 use it on cost volumes; Hosni et al. on
/// disparities): each pixel takes the weighted median of its window with the bilateral
/// weights. Robust to outlier costs, keeps edges. O(radius² log radius) per pixel.
pub fn weighted_median_filter(
    src: &[f32],
    guide: &ImageF32,
    radius: usize,
    sigma_space: f32,
    sigma_color: f32,
) -> Result<Vec<f32>, PhotoError> {
    let (width, height) = (guide.width as usize, guide.height as usize);
    check_guide(guide, width, height)?;
    check_slice(src.len(), width, height, "cost slice")?;
    let kernel = spatial_kernel(radius, sigma_space);
    let ch = guide.channels as usize;
    let inv_2sc2 = 1.0 / (2.0 * sigma_color * sigma_color);
    let side = 2 * radius + 1;
    let mut out = vec![0.0f32; width * height];
    out.par_chunks_mut(width.max(1))
        .enumerate()
        .for_each(|(y, row)| {
            let (y0, y1) = window(y, radius, height);
            let mut pairs: Vec<(f32, f32)> = Vec::with_capacity(side * side);
            for (x, o) in row.iter_mut().enumerate() {
                let (x0, x1) = window(x, radius, width);
                let p = y * width + x;
                pairs.clear();
                for qy in y0..y1 {
                    let krow = (qy + radius - y) * side;
                    for qx in x0..x1 {
                        let q = qy * width + qx;
                        let w = kernel[krow + qx + radius - x]
                            * (-guide_dist2(&guide.data, ch, p, q) * inv_2sc2).exp();
                        pairs.push((src[q], w));
                    }
                }
                *o = weighted_median(&mut pairs);
            }
        });
    Ok(out)
}

/// How a cost slice is aggregated before the winner is taken.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum Aggregation {
    /// No aggregation beyond the measure's own support window.
    #[default]
    None,
    /// Box mean over a `(2·radius+1)²` window (integral image).
    Box {
        /// Window radius in pixels.
        radius: u32,
    },
    /// Bilateral mean guided by the reference image.
    Bilateral {
        /// Window radius in pixels.
        radius: u32,
        /// Spatial standard deviation in pixels.
        sigma_space: f64,
        /// Colour standard deviation in intensity units (`[0, 1]` scale).
        sigma_color: f64,
    },
    /// Guided filter with the grey reference image as guide.
    Guided {
        /// Window radius in pixels.
        radius: u32,
        /// Ridge regulariser on the local slope, in squared intensity units (He et al. use
        /// `0.01²`–`0.1²`: larger smooths more across weak edges).
        eps: f64,
    },
    /// Weighted median with bilateral weights.
    WeightedMedian {
        /// Window radius in pixels.
        radius: u32,
        /// Spatial standard deviation in pixels.
        sigma_space: f64,
        /// Colour standard deviation in intensity units.
        sigma_color: f64,
    },
}

impl Aggregation {
    /// Checks the parameters (positive, finite).
    pub fn validate(&self) -> Result<(), PhotoError> {
        let positive = |v: f64, what: &str| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(PhotoError::InvalidConfig(format!(
                    "aggregation: {what} must be finite and > 0, got {v}"
                )))
            }
        };
        match *self {
            Aggregation::None | Aggregation::Box { .. } => Ok(()),
            Aggregation::Bilateral {
                sigma_space,
                sigma_color,
                ..
            }
            | Aggregation::WeightedMedian {
                sigma_space,
                sigma_color,
                ..
            } => {
                positive(sigma_space, "sigma_space")?;
                positive(sigma_color, "sigma_color")
            }
            Aggregation::Guided { eps, .. } => positive(eps, "eps"),
        }
    }

    /// Aggregates one cost slice (`guide`'s size) guided by `guide`.
    pub fn apply(&self, costs: &[f32], guide: &ImageF32) -> Result<Vec<f32>, PhotoError> {
        let (w, h) = (guide.width as usize, guide.height as usize);
        match *self {
            Aggregation::None => {
                check_slice(costs.len(), w, h, "cost slice")?;
                Ok(costs.to_vec())
            }
            Aggregation::Box { radius } => box_filter(costs, w, h, radius as usize),
            Aggregation::Bilateral {
                radius,
                sigma_space,
                sigma_color,
            } => bilateral_filter(
                costs,
                guide,
                radius as usize,
                sigma_space as f32,
                sigma_color as f32,
            ),
            Aggregation::Guided { radius, eps } => {
                guided_filter(costs, guide, radius as usize, eps as f32)
            }
            Aggregation::WeightedMedian {
                radius,
                sigma_space,
                sigma_color,
            } => weighted_median_filter(
                costs,
                guide,
                radius as usize,
                sigma_space as f32,
                sigma_color as f32,
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    const W: usize = 23;
    const H: usize = 17;

    fn random_slice(seed: u64) -> Vec<f32> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        (0..W * H).map(|_| rng.random::<f32>()).collect()
    }

    /// A guide with two flat regions split by a vertical edge, plus mild noise.
    fn edge_guide(seed: u64, channels: u32) -> ImageF32 {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut g = ImageF32::filled(W as u32, H as u32, channels, 0.0);
        for y in 0..H {
            for x in 0..W {
                for c in 0..channels as usize {
                    let base = if x < W / 2 { 0.2 } else { 0.8 };
                    g.data[(y * W + x) * channels as usize + c] = base + 0.05 * rng.random::<f32>();
                }
            }
        }
        g
    }

    /// The windowed mean written out with loops.
    fn naive_mean(src: &[f64], r: usize) -> Vec<f64> {
        let mut out = vec![0.0; W * H];
        for y in 0..H {
            for x in 0..W {
                let (mut s, mut n) = (0.0, 0.0);
                for qy in y.saturating_sub(r)..(y + r + 1).min(H) {
                    for qx in x.saturating_sub(r)..(x + r + 1).min(W) {
                        s += src[qy * W + qx];
                        n += 1.0;
                    }
                }
                out[y * W + x] = s / n;
            }
        }
        out
    }

    #[test]
    fn box_filter_matches_naive_mean() {
        let src = random_slice(1);
        let src64: Vec<f64> = src.iter().map(|&v| v as f64).collect();
        for r in [0usize, 1, 3, 7, 30] {
            let fast = box_filter(&src, W, H, r).unwrap();
            let slow = naive_mean(&src64, r);
            for (a, b) in fast.iter().zip(&slow) {
                assert!((*a as f64 - b).abs() < 1e-6, "r={r}: {a} vs {b}");
            }
        }
        assert!(box_filter(&src[1..], W, H, 1).is_err());
    }

    #[test]
    fn bilateral_matches_naive_definition_and_keeps_edges() {
        let src = random_slice(2);
        let guide = edge_guide(3, 3);
        let (r, ss, sc) = (3usize, 2.0f64, 0.1f64);
        let fast = bilateral_filter(&src, &guide, r, ss as f32, sc as f32).unwrap();
        for y in 0..H {
            for x in 0..W {
                let (mut num, mut den) = (0.0f64, 0.0f64);
                for qy in y.saturating_sub(r)..(y + r + 1).min(H) {
                    for qx in x.saturating_sub(r)..(x + r + 1).min(W) {
                        let d2s = ((qx as f64 - x as f64).powi(2) + (qy as f64 - y as f64).powi(2))
                            / (2.0 * ss * ss);
                        let mut d2c = 0.0;
                        for c in 0..3 {
                            let d = guide.get(x as u32, y as u32, c) as f64
                                - guide.get(qx as u32, qy as u32, c) as f64;
                            d2c += d * d;
                        }
                        let w = (-d2s - d2c / (2.0 * sc * sc)).exp();
                        num += w * src[qy * W + qx] as f64;
                        den += w;
                    }
                }
                let a = fast[y * W + x] as f64;
                assert!(
                    (a - num / den).abs() < 1e-5,
                    "({x},{y}) {a} vs {}",
                    num / den
                );
            }
        }
        // Edge-preserving: costs 0 left of the guide's edge and 1 right stay near 0 / 1.
        let step: Vec<f32> = (0..W * H)
            .map(|i| if i % W < W / 2 { 0.0 } else { 1.0 })
            .collect();
        let f = bilateral_filter(&step, &guide, 3, 2.0, 0.05).unwrap();
        let at = |x: usize| f[8 * W + x];
        assert!(
            at(W / 2 - 1) < 0.01 && at(W / 2) > 0.99,
            "{} {}",
            at(W / 2 - 1),
            at(W / 2)
        );
        let boxed = box_filter(&step, W, H, 3).unwrap();
        assert!(boxed[8 * W + W / 2 - 1] > 0.3);
    }

    #[test]
    fn guided_filter_matches_naive_windows() {
        let src = random_slice(4);
        let guide = edge_guide(5, 1);
        let (r, eps) = (2usize, 0.01f32);
        let fast = guided_filter(&src, &guide, r, eps).unwrap();
        // Naive: per window, fit a, b by explicit loops; then average a, b over windows.
        let i: Vec<f64> = guide.data.iter().map(|&v| v as f64).collect();
        let p: Vec<f64> = src.iter().map(|&v| v as f64).collect();
        let mut a = vec![0.0; W * H];
        let mut b = vec![0.0; W * H];
        for y in 0..H {
            for x in 0..W {
                let mut idx = Vec::new();
                for qy in y.saturating_sub(r)..(y + r + 1).min(H) {
                    for qx in x.saturating_sub(r)..(x + r + 1).min(W) {
                        idx.push(qy * W + qx);
                    }
                }
                let n = idx.len() as f64;
                let mi = idx.iter().map(|&k| i[k]).sum::<f64>() / n;
                let mp = idx.iter().map(|&k| p[k]).sum::<f64>() / n;
                let var = idx.iter().map(|&k| (i[k] - mi).powi(2)).sum::<f64>() / n;
                let cov = idx.iter().map(|&k| (i[k] - mi) * (p[k] - mp)).sum::<f64>() / n;
                a[y * W + x] = cov / (var + eps as f64);
                b[y * W + x] = mp - a[y * W + x] * mi;
            }
        }
        let ma = naive_mean(&a, r);
        let mb = naive_mean(&b, r);
        for k in 0..W * H {
            let want = ma[k] * i[k] + mb[k];
            assert!(
                (fast[k] as f64 - want).abs() < 1e-5,
                "{k}: {} vs {want}",
                fast[k]
            );
        }
    }

    #[test]
    fn weighted_median_minimises_weighted_absolute_deviation() {
        let src = random_slice(6);
        let guide = edge_guide(7, 3);
        let (r, ss, sc) = (2usize, 1.5f32, 0.1f32);
        let fast = weighted_median_filter(&src, &guide, r, ss, sc).unwrap();
        let kernel = spatial_kernel(r, ss);
        for y in 0..H {
            for x in 0..W {
                let mut pairs = Vec::new();
                for qy in y.saturating_sub(r)..(y + r + 1).min(H) {
                    for qx in x.saturating_sub(r)..(x + r + 1).min(W) {
                        let mut d2 = 0.0f32;
                        for c in 0..3 {
                            let d = guide.get(x as u32, y as u32, c)
                                - guide.get(qx as u32, qy as u32, c);
                            d2 += d * d;
                        }
                        let w = kernel[(qy + r - y) * (2 * r + 1) + qx + r - x]
                            * (-d2 / (2.0 * sc * sc)).exp();
                        pairs.push((src[qy * W + qx] as f64, w as f64));
                    }
                }
                // Naive: try every sample as the median, keep the best objective.
                let objective = |v: f64| pairs.iter().map(|(x, w)| w * (v - x).abs()).sum::<f64>();
                let best = pairs
                    .iter()
                    .map(|p| objective(p.0))
                    .fold(f64::INFINITY, f64::min);
                let got = fast[y * W + x] as f64;
                assert!(
                    pairs.iter().any(|p| p.0 == got),
                    "output is not a window sample"
                );
                assert!(
                    objective(got) <= best + 1e-5,
                    "({x},{y}) {} > {best}",
                    objective(got)
                );
            }
        }
        // Integer weights: equals the plain median of the replicated samples.
        let mut pairs = vec![(0.3f32, 1.0f32), (0.1, 2.0), (0.9, 1.0), (0.5, 3.0)];
        // Replicated: 0.1 0.1 0.3 0.5 0.5 0.5 0.9 → median 0.5.
        assert_eq!(weighted_median(&mut pairs), 0.5);
    }

    #[test]
    fn aggregation_config_is_validated() {
        assert!(Aggregation::Guided {
            radius: 2,
            eps: 0.0
        }
        .validate()
        .is_err());
        assert!(Aggregation::Bilateral {
            radius: 2,
            sigma_space: 1.0,
            sigma_color: -1.0
        }
        .validate()
        .is_err());
        assert!(Aggregation::Box { radius: 4 }.validate().is_ok());
        let g = edge_guide(1, 1);
        let src = random_slice(1);
        assert_eq!(Aggregation::None.apply(&src, &g).unwrap(), src);
        assert_eq!(
            Aggregation::Box { radius: 2 }.apply(&src, &g).unwrap(),
            box_filter(&src, W, H, 2).unwrap()
        );
    }
}
