//! Line segments of one image, in the spirit of LSD (von Gioi, Jakubowicz, Morel & Randall,
//! PAMI 2010): pixels whose level-line angle (the direction of the edge, perpendicular to
//! the gradient) agrees within a tolerance τ grow into regions; each region is approximated
//! by a rectangle (the gradient-weighted centroid and principal axis, so the segment is
//! located to a fraction of a pixel); the rectangle is kept when it is meaningful in the
//! a-contrario sense: the number of false alarms NFA = N_tests · P[Binomial(n, τ/π) ≥ k],
//! for k aligned pixels among the n in the rectangle, is at most ε. The thresholds are
//! LSD's and are not tuned per scene (papers.md).
//!
//! Our own code, written from the paper's description. What it leaves out of LSD: the
//! Gaussian sub-sampling to 80 % (renders and photographs here are not aliased enough to
//! need it) and the rectangle refinement steps for rectangles that fail the test.

use std::f64::consts::PI;

use crate::raster::ImageF32;

/// LSD's gradient quantisation error bound q, in grey levels of a 0–255 image: a gradient
/// below q / sin τ gives no reliable angle.
const QUANT_ERROR: f64 = 2.0;
/// Grey levels per unit of an image in [0, 1].
const GREY_LEVELS: f64 = 255.0;

/// A straight image segment.
#[derive(Debug, Clone, PartialEq)]
pub struct Segment {
    /// First endpoint, image coordinates (pixel (x, y) spans [x, x + 1) × [y, y + 1)).
    pub a: [f64; 2],
    /// Second endpoint. `b − a` is the edge direction with the brighter side on its left
    /// in image coordinates (y down), as LSD orients them.
    pub b: [f64; 2],
    /// Width of the rectangle, pixels.
    pub width: f64,
    /// −log10 NFA: how meaningful the segment is (≥ −`log_eps`; larger is more).
    pub significance: f64,
    /// Mean gradient magnitude of the region's pixels, grey levels of a [0, 1] image per
    /// pixel: the segment's contrast.
    pub gradient: f64,
}

impl Segment {
    /// Length in pixels.
    pub fn length(&self) -> f64 {
        (self.b[0] - self.a[0]).hypot(self.b[1] - self.a[1])
    }

    /// Midpoint.
    pub fn midpoint(&self) -> [f64; 2] {
        [0.5 * (self.a[0] + self.b[0]), 0.5 * (self.a[1] + self.b[1])]
    }
}

/// Settings of [`detect_segments`], LSD's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DetectParams {
    /// Angle tolerance τ in degrees, in (0, 90): LSD's 22.5°.
    pub angle_tolerance_deg: f64,
    /// log10 ε, the most false alarms accepted per image: LSD's 0 (ε = 1).
    pub log_eps: f64,
}

impl Default for DetectParams {
    fn default() -> Self {
        DetectParams {
            angle_tolerance_deg: 22.5,
            log_eps: 0.0,
        }
    }
}

/// The gradient of a grey image on the grid of pixel corners: value `i = y·(w−1) + x` is the
/// 2×2 gradient of pixels (x..x+1, y..y+1), located at image point (x + 1, y + 1).
struct Gradient {
    w: usize,
    h: usize,
    /// Level-line angle (radians), `None` where the gradient is below the threshold.
    angle: Vec<Option<f64>>,
    /// Gradient magnitude, grey levels (0–255) per pixel.
    magnitude: Vec<f64>,
}

fn gradient(gray: &ImageF32, threshold: f64) -> Gradient {
    let (iw, ih) = (gray.width as usize, gray.height as usize);
    let (w, h) = (iw.saturating_sub(1), ih.saturating_sub(1));
    let px = |x: usize, y: usize| gray.data[(y * iw + x) * gray.channels as usize] as f64;
    let mut angle = vec![None; w * h];
    let mut magnitude = vec![0.0; w * h];
    for y in 0..h {
        for x in 0..w {
            let (a, b, c, d) = (px(x, y), px(x + 1, y), px(x, y + 1), px(x + 1, y + 1));
            let gx = 0.5 * (b + d - a - c) * GREY_LEVELS;
            let gy = 0.5 * (c + d - a - b) * GREY_LEVELS;
            let m = gx.hypot(gy);
            let i = y * w + x;
            magnitude[i] = m;
            if m > threshold {
                // The level line is perpendicular to the gradient.
                angle[i] = Some(gx.atan2(-gy));
            }
        }
    }
    Gradient {
        w,
        h,
        angle,
        magnitude,
    }
}

/// |a − b| wrapped to [0, π].
fn angle_diff(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(2.0 * PI);
    if d > PI {
        2.0 * PI - d
    } else {
        d
    }
}

/// ln Γ(x) for x > 0 (Lanczos, g = 7, nine terms; relative error below 1e-13).
pub(crate) fn ln_gamma(x: f64) -> f64 {
    const G: f64 = 7.0;
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // Reflection.
        return (PI / (PI * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut s = C[0];
    for (i, c) in C.iter().enumerate().skip(1) {
        s += c / (x + i as f64);
    }
    let t = x + G + 0.5;
    0.5 * (2.0 * PI).ln() + (x + 0.5) * t.ln() - t + s.ln()
}

/// log10 P[Binomial(n, p) ≥ k]; 0 when k ≤ n·p (the tail is then not small).
pub(crate) fn log10_binomial_tail(n: usize, k: usize, p: f64) -> f64 {
    if k == 0 || (k as f64) <= n as f64 * p {
        return 0.0;
    }
    if k > n {
        return f64::NEG_INFINITY;
    }
    let (nf, kf) = (n as f64, k as f64);
    let log_first = ln_gamma(nf + 1.0) - ln_gamma(kf + 1.0) - ln_gamma(nf - kf + 1.0)
        + kf * p.ln()
        + (nf - kf) * (1.0 - p).ln();
    // Terms after the first shrink (k > n·p): sum their ratios to the first.
    let (mut sum, mut term) = (1.0f64, 1.0f64);
    for i in k..n {
        term *= (n - i) as f64 / (i + 1) as f64 * p / (1.0 - p);
        sum += term;
        if term < sum * 1e-15 {
            break;
        }
    }
    (log_first + sum.ln()) / std::f64::consts::LN_10
}

/// The rectangle approximating a region.
struct Rect {
    centre: [f64; 2],
    /// Unit direction along the segment (the level-line orientation).
    dir: [f64; 2],
    /// Extent along `dir` from `centre`.
    l: (f64, f64),
    /// Half width across.
    half_width: f64,
    angle: f64,
}

fn region_rect(g: &Gradient, region: &[usize], region_angle: f64) -> Rect {
    let pos = |i: usize| [(i % g.w) as f64 + 1.0, (i / g.w) as f64 + 1.0];
    let (mut sw, mut cx, mut cy) = (0.0, 0.0, 0.0);
    for &i in region {
        let m = g.magnitude[i];
        let p = pos(i);
        sw += m;
        cx += m * p[0];
        cy += m * p[1];
    }
    let (cx, cy) = (cx / sw, cy / sw);
    let (mut sxx, mut syy, mut sxy) = (0.0, 0.0, 0.0);
    for &i in region {
        let m = g.magnitude[i];
        let p = pos(i);
        let (dx, dy) = (p[0] - cx, p[1] - cy);
        sxx += m * dx * dx;
        syy += m * dy * dy;
        sxy += m * dx * dy;
    }
    // Principal axis of the weighted scatter.
    let mut theta = 0.5 * (2.0 * sxy).atan2(sxx - syy);
    if angle_diff(theta, region_angle) > PI / 2.0 {
        theta += PI;
    }
    let dir = [theta.cos(), theta.sin()];
    let (mut l0, mut l1, mut w0, mut w1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &i in region {
        let p = pos(i);
        let (dx, dy) = (p[0] - cx, p[1] - cy);
        let l = dx * dir[0] + dy * dir[1];
        let w = -dx * dir[1] + dy * dir[0];
        l0 = l0.min(l);
        l1 = l1.max(l);
        w0 = w0.min(w);
        w1 = w1.max(w);
    }
    // Centre the rectangle across its width.
    let wc = 0.5 * (w0 + w1);
    Rect {
        centre: [cx - wc * dir[1], cy + wc * dir[0]],
        dir,
        l: (l0, l1),
        half_width: 0.5 * (w1 - w0 + 1.0),
        angle: theta,
    }
}

/// (n, k): the gradient points inside the rectangle and those aligned with it within `tau`.
fn rect_counts(g: &Gradient, r: &Rect, tau: f64) -> (usize, usize) {
    let corners = [
        (r.l.0, -r.half_width),
        (r.l.0, r.half_width),
        (r.l.1, -r.half_width),
        (r.l.1, r.half_width),
    ]
    .map(|(l, w)| {
        [
            r.centre[0] + l * r.dir[0] - w * r.dir[1],
            r.centre[1] + l * r.dir[1] + w * r.dir[0],
        ]
    });
    let xmin = corners
        .iter()
        .map(|c| c[0])
        .fold(f64::MAX, f64::min)
        .floor();
    let xmax = corners.iter().map(|c| c[0]).fold(f64::MIN, f64::max).ceil();
    let ymin = corners
        .iter()
        .map(|c| c[1])
        .fold(f64::MAX, f64::min)
        .floor();
    let ymax = corners.iter().map(|c| c[1]).fold(f64::MIN, f64::max).ceil();
    let (mut n, mut k) = (0, 0);
    // Grid point i sits at (x + 1, y + 1).
    let x_lo = (xmin - 1.0).max(0.0) as usize;
    let y_lo = (ymin - 1.0).max(0.0) as usize;
    let x_hi = ((xmax - 1.0).max(0.0) as usize).min(g.w.saturating_sub(1));
    let y_hi = ((ymax - 1.0).max(0.0) as usize).min(g.h.saturating_sub(1));
    for y in y_lo..=y_hi {
        for x in x_lo..=x_hi {
            let (dx, dy) = (x as f64 + 1.0 - r.centre[0], y as f64 + 1.0 - r.centre[1]);
            let l = dx * r.dir[0] + dy * r.dir[1];
            let w = -dx * r.dir[1] + dy * r.dir[0];
            if l < r.l.0 - 0.5 || l > r.l.1 + 0.5 || w.abs() > r.half_width {
                continue;
            }
            n += 1;
            if let Some(a) = g.angle[y * g.w + x] {
                if angle_diff(a, r.angle) <= tau {
                    k += 1;
                }
            }
        }
    }
    (n, k)
}

/// Line segments of a grey image (channel 0 is read, values in [0, 1]), ordered as found:
/// from the strongest gradients down. Deterministic.
pub fn detect_segments(gray: &ImageF32, params: &DetectParams) -> Vec<Segment> {
    let tau = params.angle_tolerance_deg.to_radians();
    let p = tau / PI;
    let threshold = QUANT_ERROR / tau.sin();
    let g = gradient(gray, threshold);
    if g.w < 2 || g.h < 2 {
        return Vec::new();
    }
    let log_nt = 2.5 * ((g.w as f64).log10() + (g.h as f64).log10()) + 11f64.log10();
    // A region smaller than this cannot be meaningful even with every pixel aligned.
    let min_region = (-log_nt / p.log10()).ceil().max(2.0) as usize;
    let mut seeds: Vec<usize> = (0..g.angle.len())
        .filter(|&i| g.angle[i].is_some())
        .collect();
    seeds.sort_by(|&a, &b| g.magnitude[b].total_cmp(&g.magnitude[a]).then(a.cmp(&b)));
    let mut used = vec![false; g.angle.len()];
    let mut segments = Vec::new();
    let mut region = Vec::new();
    for &seed in &seeds {
        if used[seed] {
            continue;
        }
        // Region growing on level-line angles.
        region.clear();
        region.push(seed);
        used[seed] = true;
        let a0 = g.angle[seed].unwrap_or(0.0);
        let (mut sx, mut sy) = (a0.cos(), a0.sin());
        let mut reg_angle = a0;
        let mut head = 0;
        while head < region.len() {
            let i = region[head];
            head += 1;
            let (x, y) = ((i % g.w) as i64, (i / g.w) as i64);
            for dy in -1..=1i64 {
                for dx in -1..=1i64 {
                    let (nx, ny) = (x + dx, y + dy);
                    if nx < 0 || ny < 0 || nx >= g.w as i64 || ny >= g.h as i64 {
                        continue;
                    }
                    let j = ny as usize * g.w + nx as usize;
                    if used[j] {
                        continue;
                    }
                    if let Some(a) = g.angle[j] {
                        if angle_diff(a, reg_angle) <= tau {
                            used[j] = true;
                            region.push(j);
                            sx += a.cos();
                            sy += a.sin();
                            reg_angle = sy.atan2(sx);
                        }
                    }
                }
            }
        }
        if region.len() < min_region {
            continue;
        }
        let rect = region_rect(&g, &region, reg_angle);
        let (n, k) = rect_counts(&g, &rect, tau);
        let log_nfa = log_nt + log10_binomial_tail(n, k, p);
        if log_nfa > params.log_eps {
            continue;
        }
        let (c, d) = (rect.centre, rect.dir);
        let gradient =
            region.iter().map(|&i| g.magnitude[i]).sum::<f64>() / region.len() as f64 / GREY_LEVELS;
        segments.push(Segment {
            a: [c[0] + rect.l.0 * d[0], c[1] + rect.l.0 * d[1]],
            b: [c[0] + rect.l.1 * d[0], c[1] + rect.l.1 * d[1]],
            width: 2.0 * rect.half_width,
            significance: -log_nfa,
            gradient,
        });
    }
    segments
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(w: u32, h: u32, f: impl Fn(f64, f64) -> f32) -> ImageF32 {
        let mut img = ImageF32::filled(w, h, 1, 0.0);
        for y in 0..h {
            for x in 0..w {
                img.pixel_mut(x, y)[0] = f(x as f64 + 0.5, y as f64 + 0.5);
            }
        }
        img
    }

    /// The distance from point `p` to the infinite line through `a`, `b`.
    fn dist(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        ((p[0] - a[0]) * dy - (p[1] - a[1]) * dx).abs() / dx.hypot(dy)
    }

    #[test]
    fn ln_gamma_matches_factorials() {
        let mut f = 1.0f64;
        for n in 1..20 {
            f *= n as f64;
            assert!((ln_gamma(n as f64 + 1.0) - f.ln()).abs() < 1e-10, "{n}");
        }
        assert!((ln_gamma(0.5) - PI.sqrt().ln()).abs() < 1e-12);
    }

    #[test]
    fn binomial_tail_matches_direct_sum() {
        let (n, p) = (40usize, 0.125f64);
        for k in [6, 10, 20, 40] {
            let mut s = 0.0;
            for i in k..=n {
                let c = (ln_gamma(n as f64 + 1.0)
                    - ln_gamma(i as f64 + 1.0)
                    - ln_gamma((n - i) as f64 + 1.0))
                .exp();
                s += c * p.powi(i as i32) * (1.0 - p).powi((n - i) as i32);
            }
            let got = log10_binomial_tail(n, k, p);
            assert!(
                (got - s.log10()).abs() < 1e-9,
                "k {k}: {got} vs {}",
                s.log10()
            );
        }
        assert_eq!(log10_binomial_tail(40, 3, 0.125), 0.0);
    }

    #[test]
    fn a_slanted_step_edge_is_one_segment_on_the_edge() {
        // Edge through (20, 10) and (100, 70): dark left-below, bright right-above.
        let (a, b) = ([20.0, 10.0], [100.0, 70.0]);
        let img = image(120, 80, |x, y| {
            let s = (x - a[0]) * (b[1] - a[1]) - (y - a[1]) * (b[0] - a[0]);
            // Anti-aliased: a one-pixel ramp across the edge.
            let d = s / (b[0] - a[0]).hypot(b[1] - a[1]);
            (0.3 + 0.4 * (d + 0.5).clamp(0.0, 1.0)) as f32
        });
        let segs = detect_segments(&img, &DetectParams::default());
        let long: Vec<_> = segs.iter().filter(|s| s.length() > 20.0).collect();
        assert_eq!(long.len(), 1, "{segs:?}");
        let s = long[0];
        assert!(s.length() > 0.8 * 100.0, "length {}", s.length());
        for p in [s.a, s.b, s.midpoint()] {
            assert!(
                dist(p, a, b) < 0.35,
                "endpoint {p:?} off the edge by {}",
                dist(p, a, b)
            );
        }
        assert!(s.significance > 10.0);
        // The 2×2 gradient spreads a one-pixel ramp over two rows of the region.
        assert!(
            s.gradient > 0.1 && s.gradient < 0.45,
            "contrast {}",
            s.gradient
        );
    }

    #[test]
    fn noise_and_flat_images_give_no_segment() {
        let flat = image(64, 48, |_, _| 0.5);
        assert!(detect_segments(&flat, &DetectParams::default()).is_empty());
        // Deterministic pseudo-random noise.
        let noise = image(64, 48, |x, y| {
            let h = ((x * 12.9898 + y * 78.233).sin() * 43758.5453).fract();
            h.abs() as f32
        });
        let segs = detect_segments(&noise, &DetectParams::default());
        assert!(segs.iter().all(|s| s.length() < 8.0), "{segs:?}");
    }

    #[test]
    fn a_rectangle_gives_its_four_sides() {
        let img = image(100, 80, |x, y| {
            if (20.0..80.0).contains(&x) && (15.0..60.0).contains(&y) {
                0.8
            } else {
                0.2
            }
        });
        let segs = detect_segments(&img, &DetectParams::default());
        let long: Vec<_> = segs.iter().filter(|s| s.length() > 30.0).collect();
        assert_eq!(long.len(), 4, "{segs:?}");
        let horizontal = long
            .iter()
            .filter(|s| (s.a[1] - s.b[1]).abs() < 0.5)
            .count();
        assert_eq!(horizontal, 2);
    }
}
