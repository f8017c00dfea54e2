//! Per-cell appearance and geometry features for the planar / non-planar classifier
//! (Gallup et al., CVPR 2010, §4: colour + texture per image patch; here plus a label-free
//! geometric cue from the sparse points).
//!
//! The image is cut into a regular grid of `cell × cell` pixel cells; each cell's feature
//! vector is computed over a window that extends the cell by `margin` pixels on every side
//! (clipped at the border), so neighbouring windows overlap and the classifier sees a bit of
//! context. The layout of the [`FEATURE_DIM`]-vector is fixed (see the `*_OFFSET` constants):
//!
//! | offset | length | what |
//! |---|---|---|
//! | [`L_OFFSET`] | 8 | CIE L\* histogram over [0, 100] (fractions of the window's pixels) |
//! | [`A_OFFSET`] | 5 | a\* histogram over [−50, 50] (values beyond clamp to the end bins) |
//! | [`B_OFFSET`] | 5 | b\* histogram over [−50, 50] |
//! | [`COLOUR_STATS_OFFSET`] | 3 | std of L\* / 100, mean a\* / 50, mean b\* / 50 |
//! | [`ORIENT_OFFSET`] | 8 | unsigned gradient-orientation histogram (bin `k` covers `[k, k+1)·22.5°`, magnitude-weighted, sums to 1 or is all 0 on a flat window) |
//! | [`GRADIENT_STATS_OFFSET`] | 2 | mean gradient magnitude (grey levels per pixel × 10), orientation coherence `(λ1−λ2)/(λ1+λ2)` of the structure tensor |
//! | [`LBP_OFFSET`] | 10 | rotation-invariant uniform LBP (8 neighbours, radius 1; bin = number of brighter neighbours for uniform codes, bin 9 for non-uniform) |
//! | [`GEOMETRY_OFFSET`] | 4 | sparse points near the cell: has-enough-points flag, plane-fit residual `ln(1 + 10·r)` with `r` = rms distance / mean depth in %, surface variation `λmin/(λ0+λ1+λ2)` × 10, normal spread `1 − |mean normal|` |
//!
//! The geometric cue needs no labels: the sparse points whose track contains the view and
//! whose projection lies within `geo_radius_px` of the cell centre are fit by a plane (PCA);
//! on a wall or floor the residual is at the points' noise level, on a tree crown or column it
//! is not. Cells with fewer than `geo_min_points` points (plain paint, sky) get all-zero
//! geometry features. Everything is deterministic (no randomness, fixed summation order).

use nalgebra::{Matrix3, SymmetricEigen, Vector3};
use rayon::prelude::*;

use super::ClassifyError;
use crate::raster::ImageF32;
use crate::scene::Scene;

/// Bins of the L\* histogram.
pub const L_BINS: usize = 8;
/// Bins of each of the a\* and b\* histograms.
pub const AB_BINS: usize = 5;
/// Bins of the gradient-orientation histogram (over 180°).
pub const ORIENT_BINS: usize = 8;
/// Bins of the rotation-invariant uniform LBP histogram (P = 8: 0..=8 ones, 9 = non-uniform).
pub const LBP_BINS: usize = 10;
/// Geometric features.
pub const GEOMETRY_FEATURES: usize = 4;

/// Start of the L\* histogram.
pub const L_OFFSET: usize = 0;
/// Start of the a\* histogram.
pub const A_OFFSET: usize = L_OFFSET + L_BINS;
/// Start of the b\* histogram.
pub const B_OFFSET: usize = A_OFFSET + AB_BINS;
/// Start of the colour statistics (std L\*, mean a\*, mean b\*).
pub const COLOUR_STATS_OFFSET: usize = B_OFFSET + AB_BINS;
/// Start of the gradient-orientation histogram.
pub const ORIENT_OFFSET: usize = COLOUR_STATS_OFFSET + 3;
/// Start of the gradient statistics (mean magnitude, coherence).
pub const GRADIENT_STATS_OFFSET: usize = ORIENT_OFFSET + ORIENT_BINS;
/// Start of the LBP histogram.
pub const LBP_OFFSET: usize = GRADIENT_STATS_OFFSET + 2;
/// Start of the geometric features.
pub const GEOMETRY_OFFSET: usize = LBP_OFFSET + LBP_BINS;
/// Length of a feature vector.
pub const FEATURE_DIM: usize = GEOMETRY_OFFSET + GEOMETRY_FEATURES;

/// Version of the feature layout above; stored in model files so that a model trained on
/// another layout is refused rather than silently misread.
pub const FEATURE_LAYOUT_VERSION: u16 = 1;

/// How features are computed: stored in every model file, so a model is always applied with
/// the spec it was trained with.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FeatureSpec {
    /// Grid cell size in pixels (the unit that gets one label / probability).
    pub cell: u32,
    /// Extra pixels of context on each side of a cell for the appearance features.
    pub margin: u32,
    /// LBP threshold: a neighbour counts as brighter when it exceeds the centre by this much
    /// (grey levels in [0, 1]); keeps sensor noise on plain paint from looking like texture.
    pub lbp_threshold: f32,
    /// Radius (pixels) around a cell centre within which sparse points feed the geometric cue.
    pub geo_radius_px: f32,
    /// Minimal number of sparse points for the plane fit (below: geometry features are 0).
    pub geo_min_points: u32,
}

impl Default for FeatureSpec {
    fn default() -> Self {
        FeatureSpec {
            cell: 8,
            margin: 4,
            lbp_threshold: 0.03,
            geo_radius_px: 20.0,
            geo_min_points: 6,
        }
    }
}

impl FeatureSpec {
    /// Checks ranges; the error names the field.
    pub fn validate(&self) -> Result<(), ClassifyError> {
        let bad = |m: String| Err(ClassifyError::InvalidConfig(m));
        if self.cell == 0 || self.cell > 256 {
            return bad(format!(
                "feature cell = {} (want 1..=256 pixels)",
                self.cell
            ));
        }
        if self.margin > 256 {
            return bad(format!("feature margin = {} (want ≤ 256)", self.margin));
        }
        if !(self.lbp_threshold.is_finite() && self.lbp_threshold >= 0.0) {
            return bad(format!("lbp_threshold = {} (want ≥ 0)", self.lbp_threshold));
        }
        if !(self.geo_radius_px.is_finite() && self.geo_radius_px > 0.0) {
            return bad(format!("geo_radius_px = {} (want > 0)", self.geo_radius_px));
        }
        if self.geo_min_points < 3 {
            return bad(format!(
                "geo_min_points = {} (a plane needs ≥ 3)",
                self.geo_min_points
            ));
        }
        Ok(())
    }

    /// Grid size `(cols, rows)` for an image of `width × height` pixels.
    pub fn grid(&self, width: u32, height: u32) -> (u32, u32) {
        (width.div_ceil(self.cell), height.div_ceil(self.cell))
    }
}

/// Features of every cell of one image: `cols × rows` vectors of [`FEATURE_DIM`], row-major.
#[derive(Debug, Clone, PartialEq)]
pub struct CellFeatures {
    /// Cells per row.
    pub cols: u32,
    /// Cell rows.
    pub rows: u32,
    /// `cols · rows · FEATURE_DIM` values; cell `(cx, cy)` starts at `(cy·cols + cx)·FEATURE_DIM`.
    pub data: Vec<f32>,
}

impl CellFeatures {
    /// The feature vector of cell `(cx, cy)`.
    pub fn cell(&self, cx: u32, cy: u32) -> &[f32] {
        let i = (cy * self.cols + cx) as usize * FEATURE_DIM;
        &self.data[i..i + FEATURE_DIM]
    }
}

/// Sparse points as seen from one view: image coordinates, camera depth, world position and
/// (if the cloud has them) world normal.
#[derive(Debug, Clone, Default)]
pub struct ViewPoints {
    /// Image coordinates (pixel centres at +0.5).
    pub xy: Vec<[f32; 2]>,
    /// Depth (camera z, scene units).
    pub depth: Vec<f64>,
    /// World positions.
    pub position: Vec<Vector3<f64>>,
    /// World normals, when the sparse cloud has them.
    pub normal: Option<Vec<Vector3<f64>>>,
}

impl ViewPoints {
    /// The sparse points whose track contains view `view_index` and that project inside its
    /// image in front of the camera (camera with distortion: the distorted image, as loaded).
    pub fn from_scene(scene: &Scene, view_index: usize) -> Self {
        let Some(view) = scene.views.get(view_index) else {
            return ViewPoints::default();
        };
        let cloud = &scene.cloud;
        let (w, h) = (view.camera.width as f64, view.camera.height as f64);
        let mut out = ViewPoints {
            normal: cloud.normals.as_ref().map(|_| Vec::new()),
            ..Default::default()
        };
        for (i, p) in cloud.positions.iter().enumerate() {
            let seen = cloud
                .tracks
                .get(i)
                .is_some_and(|t| t.contains(&(view_index as u32)));
            if !seen {
                continue;
            }
            let Some((xy, depth)) = view.project(p) else {
                continue;
            };
            if depth <= 0.0 || xy.x < 0.0 || xy.y < 0.0 || xy.x >= w || xy.y >= h {
                continue;
            }
            out.xy.push([xy.x as f32, xy.y as f32]);
            out.depth.push(depth);
            out.position.push(*p);
            if let (Some(dst), Some(src)) = (out.normal.as_mut(), cloud.normals.as_ref()) {
                dst.push(src[i]);
            }
        }
        out
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.xy.len()
    }

    /// No points.
    pub fn is_empty(&self) -> bool {
        self.xy.is_empty()
    }
}

/// Per-pixel quantities computed once per image and summed per window.
struct PixelMaps {
    width: usize,
    height: usize,
    /// CIE L\*a\*b\* per pixel.
    lab: Vec<[f32; 3]>,
    /// Gradient (x, y) of the grey image per pixel (central differences, grey per pixel).
    grad: Vec<[f32; 2]>,
    /// Rotation-invariant uniform LBP bin per pixel.
    lbp: Vec<u8>,
}

/// sRGB-encoded [0,1] → linear.
fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// RGB in [0, 1] (sRGB-encoded, as stored in the images) → CIE L\*a\*b\* (D65).
pub fn rgb_to_lab(rgb: [f32; 3]) -> [f32; 3] {
    let [r, g, b] = rgb.map(|c| srgb_to_linear(c.clamp(0.0, 1.0)));
    let x = (0.412_456_4 * r + 0.357_576_1 * g + 0.180_437_5 * b) / 0.950_47;
    let y = 0.212_672_9 * r + 0.715_152_2 * g + 0.072_175 * b;
    let z = (0.019_333_9 * r + 0.119_192 * g + 0.950_304_1 * b) / 1.088_83;
    let f = |t: f32| {
        const DELTA: f32 = 6.0 / 29.0;
        if t > DELTA * DELTA * DELTA {
            t.cbrt()
        } else {
            t / (3.0 * DELTA * DELTA) + 4.0 / 29.0
        }
    };
    let (fx, fy, fz) = (f(x), f(y), f(z));
    [116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)]
}

/// Rotation-invariant uniform LBP bin (riu2, P = 8) from the 8 neighbour bits in circular
/// order: number of ones if the circular pattern has ≤ 2 transitions, else 9.
fn lbp_riu2(bits: u8) -> u8 {
    let rotated = bits.rotate_left(1);
    let transitions = (bits ^ rotated).count_ones();
    if transitions <= 2 {
        bits.count_ones() as u8
    } else {
        9
    }
}

impl PixelMaps {
    fn new(image: &ImageF32, lbp_threshold: f32) -> Self {
        let (w, h) = (image.width as usize, image.height as usize);
        let c = image.channels as usize;
        let lab: Vec<[f32; 3]> = (0..w * h)
            .map(|i| {
                let px = &image.data[i * c..i * c + c];
                let rgb = if c >= 3 {
                    [px[0], px[1], px[2]]
                } else {
                    [px[0]; 3]
                };
                rgb_to_lab(rgb)
            })
            .collect();
        let gray = if c == 1 {
            image.data.clone()
        } else {
            image.to_gray().data
        };
        let at = |x: isize, y: isize| -> f32 {
            let xc = x.clamp(0, w as isize - 1) as usize;
            let yc = y.clamp(0, h as isize - 1) as usize;
            gray[yc * w + xc]
        };
        let mut grad = vec![[0.0f32; 2]; w * h];
        let mut lbp = vec![0u8; w * h];
        // Circular neighbour order for LBP (right, down-right, down, …).
        const RING: [(isize, isize); 8] = [
            (1, 0),
            (1, 1),
            (0, 1),
            (-1, 1),
            (-1, 0),
            (-1, -1),
            (0, -1),
            (1, -1),
        ];
        for y in 0..h {
            for x in 0..w {
                let (xi, yi) = (x as isize, y as isize);
                let gx = 0.5 * (at(xi + 1, yi) - at(xi - 1, yi));
                let gy = 0.5 * (at(xi, yi + 1) - at(xi, yi - 1));
                grad[y * w + x] = [gx, gy];
                let centre = gray[y * w + x];
                let mut bits = 0u8;
                for (k, (dx, dy)) in RING.iter().enumerate() {
                    if at(xi + dx, yi + dy) > centre + lbp_threshold {
                        bits |= 1 << k;
                    }
                }
                lbp[y * w + x] = lbp_riu2(bits);
            }
        }
        PixelMaps {
            width: w,
            height: h,
            lab,
            grad,
            lbp,
        }
    }
}

fn hist_bin(v: f32, lo: f32, hi: f32, bins: usize) -> usize {
    let t = ((v - lo) / (hi - lo) * bins as f32).floor();
    if t.is_nan() || t < 0.0 {
        0
    } else {
        (t as usize).min(bins - 1)
    }
}

/// Appearance features of the window `[x0, x1) × [y0, y1)` into `out[..GEOMETRY_OFFSET]`.
fn appearance_features(
    maps: &PixelMaps,
    x0: usize,
    x1: usize,
    y0: usize,
    y1: usize,
    out: &mut [f32],
) {
    let n = ((x1 - x0) * (y1 - y0)) as f32;
    let mut sum_l = 0.0f64;
    let mut sum_l2 = 0.0f64;
    let mut sum_a = 0.0f64;
    let mut sum_b = 0.0f64;
    let mut mag_sum = 0.0f64;
    let (mut jxx, mut jxy, mut jyy) = (0.0f64, 0.0f64, 0.0f64);
    for y in y0..y1 {
        for x in x0..x1 {
            let i = y * maps.width + x;
            let [l, a, b] = maps.lab[i];
            out[L_OFFSET + hist_bin(l, 0.0, 100.0, L_BINS)] += 1.0;
            out[A_OFFSET + hist_bin(a, -50.0, 50.0, AB_BINS)] += 1.0;
            out[B_OFFSET + hist_bin(b, -50.0, 50.0, AB_BINS)] += 1.0;
            sum_l += l as f64;
            sum_l2 += (l as f64) * (l as f64);
            sum_a += a as f64;
            sum_b += b as f64;
            let [gx, gy] = maps.grad[i];
            let mag = (gx * gx + gy * gy).sqrt();
            mag_sum += mag as f64;
            jxx += (gx * gx) as f64;
            jxy += (gx * gy) as f64;
            jyy += (gy * gy) as f64;
            if mag > 0.0 {
                // Unsigned orientation in [0, π): a stripe and its mirror are one direction.
                let mut theta = gy.atan2(gx);
                if theta < 0.0 {
                    theta += std::f32::consts::PI;
                }
                let bin = hist_bin(theta, 0.0, std::f32::consts::PI, ORIENT_BINS);
                out[ORIENT_OFFSET + bin] += mag;
            }
            out[LBP_OFFSET + maps.lbp[i] as usize] += 1.0;
        }
    }
    for v in &mut out[L_OFFSET..COLOUR_STATS_OFFSET] {
        *v /= n;
    }
    for v in &mut out[LBP_OFFSET..LBP_OFFSET + LBP_BINS] {
        *v /= n;
    }
    let nf = n as f64;
    let mean_l = sum_l / nf;
    let var_l = (sum_l2 / nf - mean_l * mean_l).max(0.0);
    out[COLOUR_STATS_OFFSET] = (var_l.sqrt() / 100.0) as f32;
    out[COLOUR_STATS_OFFSET + 1] = (sum_a / nf / 50.0) as f32;
    out[COLOUR_STATS_OFFSET + 2] = (sum_b / nf / 50.0) as f32;
    let total: f32 = out[ORIENT_OFFSET..ORIENT_OFFSET + ORIENT_BINS].iter().sum();
    // Below this summed magnitude the window is flat up to noise: no orientation.
    const FLAT_MAGNITUDE: f32 = 1e-6;
    for v in &mut out[ORIENT_OFFSET..ORIENT_OFFSET + ORIENT_BINS] {
        *v = if total > FLAT_MAGNITUDE {
            *v / total
        } else {
            0.0
        };
    }
    out[GRADIENT_STATS_OFFSET] = (mag_sum / nf * 10.0) as f32;
    let trace = jxx + jyy;
    let coherence = if trace > 1e-12 {
        ((jxx - jyy).powi(2) + 4.0 * jxy * jxy).sqrt() / trace
    } else {
        0.0
    };
    out[GRADIENT_STATS_OFFSET + 1] = coherence as f32;
}

/// Geometric features of the sparse points within `radius` of `(cx, cy)`.
fn geometry_features(points: &ViewPoints, cx: f32, cy: f32, spec: &FeatureSpec, out: &mut [f32]) {
    let r2 = spec.geo_radius_px * spec.geo_radius_px;
    let mut sum = Vector3::zeros();
    let mut n = 0usize;
    let mut depth_sum = 0.0;
    let mut normal_sum = Vector3::zeros();
    for (i, xy) in points.xy.iter().enumerate() {
        let (dx, dy) = (xy[0] - cx, xy[1] - cy);
        if dx * dx + dy * dy <= r2 {
            sum += points.position[i];
            depth_sum += points.depth[i];
            if let Some(nm) = &points.normal {
                normal_sum += nm[i];
            }
            n += 1;
        }
    }
    if n < spec.geo_min_points as usize {
        return;
    }
    let mean = sum / n as f64;
    let mut cov = Matrix3::zeros();
    for (i, xy) in points.xy.iter().enumerate() {
        let (dx, dy) = (xy[0] - cx, xy[1] - cy);
        if dx * dx + dy * dy <= r2 {
            let d = points.position[i] - mean;
            cov += d * d.transpose();
        }
    }
    cov /= n as f64;
    let eig = SymmetricEigen::new(cov).eigenvalues;
    let lmin = eig.min().max(0.0);
    let total = eig.iter().map(|v| v.max(0.0)).sum::<f64>();
    let mean_depth = (depth_sum / n as f64).max(1e-9);
    out[0] = 1.0;
    // Clamp: a fit across a depth jump can be arbitrarily bad; beyond this it is all alike.
    const MAX_RESIDUAL: f64 = 10.0;
    // Log scale: the residual spans noise level (≈ 0.1 %) to depth jumps (≈ 10 %), and a
    // linear classifier separates the decades better than the raw percentage.
    let residual = (lmin.sqrt() / mean_depth * 100.0).min(MAX_RESIDUAL);
    out[1] = (10.0 * residual).ln_1p() as f32;
    out[2] = if total > 0.0 {
        (lmin / total * 10.0) as f32
    } else {
        0.0
    };
    out[3] = if points.normal.is_some() {
        (1.0 - normal_sum.norm() / n as f64).clamp(0.0, 1.0) as f32
    } else {
        0.0
    };
}

/// Computes the feature vector of every grid cell of `image` (RGB or grey in [0, 1]).
/// `points`: the view's sparse points for the geometric cue (`None` or empty: zeros).
pub fn cell_features(
    image: &ImageF32,
    points: Option<&ViewPoints>,
    spec: &FeatureSpec,
) -> Result<CellFeatures, ClassifyError> {
    spec.validate()?;
    if image.width == 0 || image.height == 0 || image.channels == 0 {
        return Err(ClassifyError::InvalidInput(format!(
            "empty image {}x{}x{}",
            image.width, image.height, image.channels
        )));
    }
    let maps = PixelMaps::new(image, spec.lbp_threshold);
    let (cols, rows) = spec.grid(image.width, image.height);
    let (w, h) = (maps.width, maps.height);
    let (cell, margin) = (spec.cell as usize, spec.margin as usize);
    let mut data = vec![0.0f32; cols as usize * rows as usize * FEATURE_DIM];
    data.par_chunks_mut(FEATURE_DIM)
        .enumerate()
        .for_each(|(i, out)| {
            let (gx, gy) = (i % cols as usize, i / cols as usize);
            let x0 = (gx * cell).saturating_sub(margin);
            let y0 = (gy * cell).saturating_sub(margin);
            let x1 = ((gx + 1) * cell + margin).min(w);
            let y1 = ((gy + 1) * cell + margin).min(h);
            appearance_features(&maps, x0, x1, y0, y1, &mut out[..GEOMETRY_OFFSET]);
            if let Some(p) = points.filter(|p| !p.is_empty()) {
                let cx = ((gx * cell) as f32 + ((gx + 1) * cell).min(w) as f32) * 0.5;
                let cy = ((gy * cell) as f32 + ((gy + 1) * cell).min(h) as f32) * 0.5;
                geometry_features(p, cx, cy, spec, &mut out[GEOMETRY_OFFSET..]);
            }
        });
    Ok(CellFeatures { cols, rows, data })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image_from(w: u32, h: u32, f: impl Fn(f32, f32) -> [f32; 3]) -> ImageF32 {
        let mut img = ImageF32::filled(w, h, 3, 0.0);
        for y in 0..h {
            for x in 0..w {
                let v = f(x as f32 + 0.5, y as f32 + 0.5);
                img.pixel_mut(x, y).copy_from_slice(&v);
            }
        }
        img
    }

    #[test]
    fn flat_colour_cell_has_one_hot_histograms_and_no_texture() {
        // Mid grey: L* ≈ 53.4 → bin 4 of 8; a* = b* = 0 → middle bin 2 of 5.
        let img = image_from(32, 32, |_, _| [0.5, 0.5, 0.5]);
        let f = cell_features(&img, None, &FeatureSpec::default()).unwrap();
        assert_eq!((f.cols, f.rows), (4, 4));
        let v = f.cell(1, 2);
        let lab = rgb_to_lab([0.5; 3]);
        assert!((lab[0] - 53.39).abs() < 0.05, "L* = {}", lab[0]);
        assert!(lab[1].abs() < 0.01 && lab[2].abs() < 0.01);
        for k in 0..L_BINS {
            assert_eq!(v[L_OFFSET + k], if k == 4 { 1.0 } else { 0.0 }, "L bin {k}");
        }
        for k in 0..AB_BINS {
            let want = if k == 2 { 1.0 } else { 0.0 };
            assert_eq!(v[A_OFFSET + k], want);
            assert_eq!(v[B_OFFSET + k], want);
        }
        assert_eq!(v[COLOUR_STATS_OFFSET], 0.0);
        assert!(v[ORIENT_OFFSET..ORIENT_OFFSET + ORIENT_BINS]
            .iter()
            .all(|&x| x == 0.0));
        assert_eq!(v[GRADIENT_STATS_OFFSET], 0.0);
        // Flat: no neighbour is brighter → uniform code with zero ones.
        assert_eq!(v[LBP_OFFSET], 1.0);
        assert!(v[GEOMETRY_OFFSET..].iter().all(|&x| x == 0.0));
    }

    #[test]
    fn pure_red_lands_in_high_a_bin() {
        let img = image_from(16, 16, |_, _| [1.0, 0.0, 0.0]);
        let f = cell_features(&img, None, &FeatureSpec::default()).unwrap();
        let v = f.cell(0, 0);
        let lab = rgb_to_lab([1.0, 0.0, 0.0]);
        assert!((lab[0] - 53.24).abs() < 0.1 && (lab[1] - 80.09).abs() < 0.2);
        assert_eq!(v[A_OFFSET + AB_BINS - 1], 1.0);
        assert!((v[COLOUR_STATS_OFFSET + 1] - lab[1] / 50.0).abs() < 1e-4);
    }

    fn stripes(angle_deg: f32) -> ImageF32 {
        let (s, c) = angle_deg.to_radians().sin_cos();
        image_from(48, 48, move |x, y| {
            let v = 0.5 + 0.4 * (std::f32::consts::TAU * (x * c + y * s) / 6.0).sin();
            [v; 3]
        })
    }

    fn peak_orientation_bin(img: &ImageF32) -> (usize, f32) {
        let f = cell_features(img, None, &FeatureSpec::default()).unwrap();
        let v = f.cell(2, 2);
        let hist = &v[ORIENT_OFFSET..ORIENT_OFFSET + ORIENT_BINS];
        let (k, m) = hist
            .iter()
            .enumerate()
            .fold((0, 0.0f32), |b, (k, &m)| if m > b.1 { (k, m) } else { b });
        (k, m)
    }

    #[test]
    fn rotating_a_texture_shifts_the_orientation_histogram() {
        // Gradient direction 10° → bin 0; rotated by 45° → 55° → bin 2 (22.5° bins).
        let (k0, m0) = peak_orientation_bin(&stripes(10.0));
        let (k1, m1) = peak_orientation_bin(&stripes(55.0));
        let (k2, _) = peak_orientation_bin(&stripes(100.0));
        assert_eq!(k0, 0);
        assert_eq!(k1, 2);
        assert_eq!(k2, 4);
        assert!(m0 > 0.6 && m1 > 0.6, "peaks {m0} {m1}");
        // Stripes are strongly oriented.
        let f = cell_features(&stripes(10.0), None, &FeatureSpec::default()).unwrap();
        assert!(f.cell(2, 2)[GRADIENT_STATS_OFFSET + 1] > 0.9);
    }

    #[test]
    fn lbp_riu2_codes() {
        assert_eq!(lbp_riu2(0), 0);
        assert_eq!(lbp_riu2(0xff), 8);
        assert_eq!(lbp_riu2(0b0000_0111), 3);
        assert_eq!(lbp_riu2(0b1000_0011), 3); // wraps around: still uniform
        assert_eq!(lbp_riu2(0b0101_0101), 9);
    }

    #[test]
    fn geometry_cue_separates_plane_from_sphere() {
        // Points on the plane z = 5 vs on a sphere of radius 1 at depth 5, seen at identity.
        let spec = FeatureSpec::default();
        let mut plane = ViewPoints::default();
        let mut sphere = ViewPoints::default();
        for i in 0..10 {
            for j in 0..10 {
                let (u, v) = (i as f64 * 0.1 - 0.45, j as f64 * 0.1 - 0.45);
                let p = Vector3::new(u, v, 5.0);
                plane
                    .xy
                    .push([50.0 + i as f32 * 2.0, 50.0 + j as f32 * 2.0]);
                plane.depth.push(5.0);
                plane.position.push(p);
                let q = Vector3::new(u * 1.5, v * 1.5, 0.0);
                let z = 5.0 - (1.0 - q.norm_squared()).max(0.0).sqrt();
                sphere
                    .xy
                    .push([50.0 + i as f32 * 2.0, 50.0 + j as f32 * 2.0]);
                sphere.depth.push(z);
                sphere.position.push(Vector3::new(q.x, q.y, z));
            }
        }
        let mut gp = [0.0f32; GEOMETRY_FEATURES];
        let mut gs = [0.0f32; GEOMETRY_FEATURES];
        geometry_features(&plane, 59.0, 59.0, &spec, &mut gp);
        geometry_features(&sphere, 59.0, 59.0, &spec, &mut gs);
        assert_eq!(gp[0], 1.0);
        assert_eq!(gs[0], 1.0);
        assert!(gp[1] < 1e-3, "plane residual {}", gp[1]);
        // ln(1 + 10·r) > ln(11): the sphere's rms residual exceeds 1 % of its depth.
        assert!(gs[1] > 11f32.ln(), "sphere residual {}", gs[1]);
        // Too few points → all zero.
        let mut none = [9.0f32; GEOMETRY_FEATURES];
        none.fill(0.0);
        geometry_features(&plane, 500.0, 500.0, &spec, &mut none);
        assert!(none.iter().all(|&v| v == 0.0));
    }

    #[test]
    fn features_do_not_depend_on_thread_count() {
        let img = stripes(33.0);
        let spec = FeatureSpec::default();
        let a = cell_features(&img, None, &spec).unwrap();
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let b = pool.install(|| cell_features(&img, None, &spec).unwrap());
        assert_eq!(a, b);
    }
}
