//! The costing core of the plane sweep: for every plane of a family and every neighbour view,
//! the neighbour image is warped onto the reference pixel grid through the plane-induced
//! homography, once, into a flat buffer. SSD, SAD and NCC are then evaluated from integral
//! images of the reference, the warped image and their products, so their cost per pixel
//! does not depend on the window size; Census, Rank and MI visit the window. Neighbour costs
//! are combined by the mean of the best k (occlusion) and each plane's slice is aggregated.

use nalgebra::Matrix3;
use rayon::prelude::*;

use super::aggregate::{window, Integral};
use super::measures::{ncc_from_moments, ncc_from_weighted_moments, raw_cost, Measure};
use super::{ColorMode, PhotoConfig, PhotoError};
use crate::geometry::{plane_homography, Plane};
use crate::raster::ImageF32;
use crate::scene::View;

/// Per-neighbour marker: this neighbour gives no evidence at the pixel (too little of the
/// window warps into its image, or the plane is behind a camera). Never leaves the module.
const NO_EVIDENCE: f32 = f32::NAN;

/// Images prepared for matching: grey or colour, and the reference split by channel.
pub(super) struct Prepared {
    pub(super) width: usize,
    pub(super) height: usize,
    channels: usize,
    /// Reference, interleaved (also the aggregation guide).
    reference: ImageF32,
    /// Neighbours, same channel count as the reference.
    neighbours: Vec<ImageF32>,
    /// Reference-frame homographies are computed per plane; these are the views.
    ref_view: View,
    nbr_views: Vec<View>,
}

fn check_view_image(view: &View, image: &ImageF32) -> Result<(), PhotoError> {
    if view.camera.model.has_distortion() {
        return Err(PhotoError::Distorted(view.name.clone()));
    }
    let want = image.width as usize * image.height as usize * image.channels as usize;
    if image.width != view.camera.width
        || image.height != view.camera.height
        || !(image.channels == 1 || image.channels == 3)
        || image.data.len() != want
    {
        return Err(PhotoError::Size(format!(
            "image of view {:?} is {}×{}×{} ({} values), camera is {}×{} (1 or 3 channels expected)",
            view.name,
            image.width,
            image.height,
            image.channels,
            image.data.len(),
            view.camera.width,
            view.camera.height
        )));
    }
    Ok(())
}

pub(super) fn prepare(
    reference: &View,
    ref_image: &ImageF32,
    neighbours: &[(&View, &ImageF32)],
    planes: &[Plane],
    cfg: &PhotoConfig,
) -> Result<Prepared, PhotoError> {
    cfg.validate()?;
    if neighbours.is_empty() {
        return Err(PhotoError::InvalidInput(
            "plane sweep needs at least one neighbour view".into(),
        ));
    }
    if planes.is_empty() {
        return Err(PhotoError::InvalidInput(
            "no plane hypotheses to score".into(),
        ));
    }
    check_view_image(reference, ref_image)?;
    for (v, img) in neighbours {
        check_view_image(v, img)?;
    }
    let colour = cfg.color == ColorMode::Color
        && ref_image.channels == 3
        && neighbours.iter().all(|(_, img)| img.channels == 3);
    let convert = |img: &ImageF32| if colour { img.clone() } else { img.to_gray() };
    Ok(Prepared {
        width: ref_image.width as usize,
        height: ref_image.height as usize,
        channels: if colour { 3 } else { 1 },
        reference: convert(ref_image),
        neighbours: neighbours.iter().map(|(_, img)| convert(img)).collect(),
        ref_view: reference.clone(),
        nbr_views: neighbours.iter().map(|(v, _)| (*v).clone()).collect(),
    })
}

/// Most interleaved quantities of a [`Moments`] table: the mask and five per colour channel.
const MAX_MOMENTS: usize = 16;

/// Interleaved summed-area tables of `q` per-pixel quantities, `(width+1)·(height+1)·q`
/// `f64` values with a zero first row and column: the `q` sums of a rectangle are four
/// contiguous reads (one cache line each for grey NCC) instead of `q` scattered tables.
struct Moments {
    width: usize,
    height: usize,
    q: usize,
    table: Vec<f64>,
}

impl Moments {
    fn new(width: usize, height: usize, q: usize) -> Self {
        assert!(q <= MAX_MOMENTS, "at most {MAX_MOMENTS} quantities");
        Moments {
            width,
            height,
            q,
            table: vec![0.0; (width + 1) * (height + 1) * q],
        }
    }

    /// Fills the table; `fill(i, values)` writes the `q` quantities of pixel `i`.
    fn build(&mut self, mut fill: impl FnMut(usize, &mut [f64])) {
        let (w, q) = (self.width, self.q);
        let stride = (w + 1) * q;
        let mut vals = [0.0f64; MAX_MOMENTS];
        let mut row = [0.0f64; MAX_MOMENTS];
        for y in 0..self.height {
            row[..q].fill(0.0);
            let (above, here) = self.table[y * stride..(y + 2) * stride].split_at_mut(stride);
            for x in 0..w {
                fill(y * w + x, &mut vals[..q]);
                let at = (x + 1) * q;
                for k in 0..q {
                    row[k] += vals[k];
                    here[at + k] = above[at + k] + row[k];
                }
            }
        }
    }

    /// The `q` sums over the half-open rectangle `[x0, x1) × [y0, y1)`, into `out`.
    #[inline]
    fn rect(&self, x0: usize, y0: usize, x1: usize, y1: usize, out: &mut [f64]) {
        let (s, q) = ((self.width + 1) * self.q, self.q);
        let t = &self.table;
        let (a, b, c, d) = (
            y1 * s + x1 * q,
            y0 * s + x1 * q,
            y1 * s + x0 * q,
            y0 * s + x0 * q,
        );
        let (ta, tb, tc, td) = (&t[a..a + q], &t[b..b + q], &t[c..c + q], &t[d..d + q]);
        for k in 0..q {
            out[k] = ta[k] - tb[k] - tc[k] + td[k];
        }
    }
}

/// Adaptive support weights of every pixel's NCC window ([`PhotoConfig::support_sigma_color`]),
/// read off the reference image once per cost volume.
struct Support {
    /// Window offsets `(dx, dy)`, row-major over the window.
    offsets: Vec<(isize, isize)>,
    /// `weights[k·n + p]`: the weight of pixel `p + offsets[k]` in the window of `p` (0 where
    /// that pixel is outside the image).
    weights: Vec<f32>,
    /// Per centre pixel, the sum of its window's weights inside the image.
    total: Vec<f32>,
}

impl Support {
    fn new(guide: &ImageF32, radius: usize, sigma_color: f32, sigma_space: f32) -> Self {
        let (w, h, ch) = (
            guide.width as usize,
            guide.height as usize,
            guide.channels as usize,
        );
        let n = w * h;
        let r = radius as isize;
        let offsets: Vec<(isize, isize)> = (-r..=r)
            .flat_map(|dy| (-r..=r).map(move |dx| (dx, dy)))
            .collect();
        let kc = 1.0 / (2.0 * sigma_color * sigma_color);
        let ks = 1.0 / (2.0 * sigma_space * sigma_space);
        let g = &guide.data;
        let mut weights = vec![0.0f32; offsets.len() * n];
        weights
            .par_chunks_mut(n.max(1))
            .zip(&offsets)
            .for_each(|(wk, &(dx, dy))| {
                let spatial = (dx * dx + dy * dy) as f32 * ks;
                for y in 0..h {
                    let qy = y as isize + dy;
                    if qy < 0 || qy >= h as isize {
                        continue;
                    }
                    for x in 0..w {
                        let qx = x as isize + dx;
                        if qx < 0 || qx >= w as isize {
                            continue;
                        }
                        let (p, q) = (y * w + x, qy as usize * w + qx as usize);
                        let d2: f32 = (0..ch)
                            .map(|c| {
                                let d = g[p * ch + c] - g[q * ch + c];
                                d * d
                            })
                            .sum::<f32>()
                            / ch as f32;
                        wk[p] = (-d2 * kc - spatial).exp();
                    }
                }
            });
        let mut total = vec![0.0f32; n];
        for wk in weights.chunks_exact(n.max(1)) {
            for (t, &v) in total.iter_mut().zip(wk) {
                *t += v;
            }
        }
        Support {
            offsets,
            weights,
            total,
        }
    }
}

/// Per-worker buffers, reused across planes (never allocated per pixel).
pub(super) struct Scratch {
    /// Warped neighbour, channel-major `[c·n + p]`, `NaN` where unavailable.
    warped: Vec<f32>,
    /// Per-neighbour costs `[j·n + p]`.
    nbr_costs: Vec<f32>,
    /// Integral tables for the SSD / SAD box path.
    tables: Vec<Integral>,
    /// The fused NCC table (empty for other measures).
    moments: Moments,
    /// Window buffers for the generic path.
    patch_ref: Vec<f32>,
    patch_nbr: Vec<f32>,
    /// Sorted neighbour costs of one pixel.
    pixel_costs: Vec<f32>,
    /// Weighted NCC: the per-pixel terms `[t·n + p]` and one row of their window sums.
    terms: Vec<f32>,
    row_sums: Vec<f32>,
}

impl Scratch {
    pub(super) fn new(prep: &Prepared, cfg: &PhotoConfig) -> Self {
        let n = prep.width * prep.height;
        let side = 2 * cfg.window_radius as usize + 1;
        let moments = if cfg.measure == Measure::Ncc {
            Moments::new(prep.width, prep.height, 1 + 5 * prep.channels)
        } else {
            Moments::new(0, 0, 0)
        };
        let tables = if matches!(cfg.measure, Measure::Ssd | Measure::Sad) {
            (0..2)
                .map(|_| Integral::new(prep.width, prep.height))
                .collect()
        } else {
            Vec::new()
        };
        Scratch {
            warped: vec![f32::NAN; n * prep.channels],
            nbr_costs: vec![NO_EVIDENCE; n * prep.nbr_views.len()],
            tables,
            moments,
            patch_ref: vec![0.0; side * side * prep.channels],
            patch_nbr: vec![0.0; side * side * prep.channels],
            pixel_costs: Vec::with_capacity(prep.nbr_views.len()),
            terms: Vec::new(),
            row_sums: Vec::new(),
        }
    }
}

/// Warps neighbour `j` onto the reference grid through `h` (reference → neighbour image
/// coordinates). Pixels whose ray meets the plane behind the reference camera, or whose
/// point is behind the neighbour or projects outside its image, get `NaN`.
fn warp(prep: &Prepared, j: usize, h: &Matrix3<f64>, ref_plane: &Plane, warped: &mut [f32]) {
    let (w, hgt, ch) = (prep.width, prep.height, prep.channels);
    let n = w * hgt;
    let cam = &prep.ref_view.camera;
    let (fx, fy, cx, cy) = (cam.fx(), cam.fy(), cam.cx(), cam.cy());
    // The plane's depth along the reference ray of (u, v) has the sign of
    // d / (n · K⁻¹(u, v, 1)); the denominator is affine in (u, v).
    let (nx, ny, nz) = (ref_plane.normal.x, ref_plane.normal.y, ref_plane.normal.z);
    let (ra, rb, rc) = (nx / fx, ny / fy, nz - nx * cx / fx - ny * cy / fy);
    let img = &prep.neighbours[j];
    let mut px = [0.0f32; 3];
    for y in 0..hgt {
        let v = y as f64 + 0.5;
        for x in 0..w {
            let u = x as f64 + 0.5;
            let p = y * w + x;
            let ray_dot = ra * u + rb * v + rc;
            let in_front = ray_dot != 0.0 && ref_plane.offset / ray_dot > 0.0;
            let hz = h[(2, 0)] * u + h[(2, 1)] * v + h[(2, 2)];
            let ok = in_front
                && hz > 0.0
                && img.sample_bilinear(
                    (h[(0, 0)] * u + h[(0, 1)] * v + h[(0, 2)]) / hz,
                    (h[(1, 0)] * u + h[(1, 1)] * v + h[(1, 2)]) / hz,
                    &mut px[..ch],
                );
            for c in 0..ch {
                warped[c * n + p] = if ok { px[c] } else { f32::NAN };
            }
        }
    }
}

/// Shared, plane-independent reference data.
pub(super) struct Context<'a> {
    prep: &'a Prepared,
    cfg: &'a PhotoConfig,
    /// Reference channel-major `[c·n + p]`.
    ref_planar: Vec<f32>,
    /// Adaptive support weights (NCC with `support_sigma_color` > 0).
    support: Option<Support>,
}

impl<'a> Context<'a> {
    /// `guide` is the reference image as given (colour if it has colour): the support
    /// weights are read off it.
    pub(super) fn new(prep: &'a Prepared, cfg: &'a PhotoConfig, guide: &ImageF32) -> Self {
        let (n, ch) = (prep.width * prep.height, prep.channels);
        let mut ref_planar = vec![0.0f32; n * ch];
        for p in 0..n {
            for c in 0..ch {
                ref_planar[c * n + p] = prep.reference.data[p * ch + c];
            }
        }
        let support = (cfg.measure == Measure::Ncc && cfg.support_weighted()).then(|| {
            Support::new(
                guide,
                cfg.window_radius as usize,
                cfg.support_sigma_color as f32,
                cfg.support_sigma_space as f32,
            )
        });
        Context {
            prep,
            cfg,
            ref_planar,
            support,
        }
    }

    /// Costs in `[0, 1]` of the neighbour warped into `s.warped`, into `out` (one per
    /// pixel; [`NO_EVIDENCE`] where the window is not covered).
    fn neighbour_costs(&self, s: &mut Scratch, out: &mut [f32]) {
        match self.cfg.measure {
            Measure::Ncc => match &self.support {
                Some(support) => {
                    self.weighted_ncc_costs(support, &s.warped, &mut s.terms, &mut s.row_sums, out)
                }
                None => self.ncc_costs(&s.warped, &mut s.moments, out),
            },
            Measure::Ssd | Measure::Sad => self.box_costs(&s.warped, &mut s.tables, out),
            _ => self.window_costs(&s.warped, &mut s.patch_ref, &mut s.patch_nbr, out),
        }
    }

    /// SSD / SAD from integral images: O(1) per pixel whatever the window.
    fn box_costs(&self, warped: &[f32], tables: &mut [Integral], out: &mut [f32]) {
        let prep = self.prep;
        let (w, h, ch) = (prep.width, prep.height, prep.channels);
        let n = w * h;
        let r = self.cfg.window_radius as usize;
        let norm = self.cfg.effective_normalization();
        let min_frac = self.cfg.min_valid_fraction;
        let refp = &self.ref_planar;
        let valid = |p: usize| warped[p].is_finite();
        let wv = |c: usize, p: usize| {
            if valid(p) {
                warped[c * n + p] as f64
            } else {
                0.0
            }
        };
        let iv = |c: usize, p: usize| {
            if valid(p) {
                refp[c * n + p] as f64
            } else {
                0.0
            }
        };
        let (mask_t, rest) = tables.split_first_mut().expect("box path has tables");
        mask_t.build_with(|p| if valid(p) { 1.0 } else { 0.0 });
        match self.cfg.measure {
            Measure::Ssd | Measure::Sad => {
                let squared = self.cfg.measure == Measure::Ssd;
                rest[0].build_with(|p| {
                    (0..ch)
                        .map(|c| {
                            let d = iv(c, p) - wv(c, p);
                            if squared {
                                d * d
                            } else {
                                d.abs()
                            }
                        })
                        .sum()
                });
                let t = &rest[0];
                for y in 0..h {
                    let (y0, y1) = window(y, r, h);
                    for x in 0..w {
                        let (x0, x1) = window(x, r, w);
                        let area = ((x1 - x0) * (y1 - y0)) as f64;
                        let cnt = mask_t.rect_sum(x0, y0, x1, y1);
                        out[y * w + x] = if cnt >= 1.0 && cnt >= min_frac * area {
                            norm.apply((t.rect_sum(x0, y0, x1, y1) / (cnt * ch as f64)) as f32)
                        } else {
                            NO_EVIDENCE
                        };
                    }
                }
            }
            Measure::Ncc => unreachable!("NCC has its own fused path"),
            _ => unreachable!("only SSD, SAD and NCC are box-decomposable"),
        }
    }

    /// NCC from one fused, interleaved summed-area table of the mask and, per channel, the
    /// masked `I, I², W, W², I·W` (`I` reference, `W` warped neighbour): one pass to build,
    /// four contiguous reads per pixel whatever the window — O(1) per pixel.
    fn ncc_costs(&self, warped: &[f32], moments: &mut Moments, out: &mut [f32]) {
        let prep = self.prep;
        let (w, h, ch) = (prep.width, prep.height, prep.channels);
        let n = w * h;
        let r = self.cfg.window_radius as usize;
        let norm = self.cfg.effective_normalization();
        let min_frac = self.cfg.min_valid_fraction;
        let refp = &self.ref_planar;
        moments.build(|p, vals| {
            if warped[p].is_finite() {
                vals[0] = 1.0;
                for c in 0..ch {
                    let i = refp[c * n + p] as f64;
                    let v = warped[c * n + p] as f64;
                    let q = &mut vals[1 + 5 * c..6 + 5 * c];
                    q[0] = i;
                    q[1] = i * i;
                    q[2] = v;
                    q[3] = v * v;
                    q[4] = i * v;
                }
            } else {
                vals.fill(0.0);
            }
        });
        let mut sums = [0.0f64; MAX_MOMENTS];
        let sums = &mut sums[..moments.q];
        for y in 0..h {
            let (y0, y1) = window(y, r, h);
            let row = &mut out[y * w..(y + 1) * w];
            for (x, o) in row.iter_mut().enumerate() {
                let (x0, x1) = window(x, r, w);
                let area = ((x1 - x0) * (y1 - y0)) as f64;
                moments.rect(x0, y0, x1, y1, sums);
                let cnt = sums[0];
                if !(cnt >= 2.0 && cnt >= min_frac * area) {
                    *o = NO_EVIDENCE;
                    continue;
                }
                let inv = 1.0 / cnt;
                let (mut cov, mut va, mut vb) = (0.0, 0.0, 0.0);
                for m in sums[1..].chunks_exact(5) {
                    let (si, sii, sw, sww, siw) = (m[0], m[1], m[2], m[3], m[4]);
                    cov += siw - si * sw * inv;
                    va += sii - si * si * inv;
                    vb += sww - sw * sw * inv;
                }
                let score = ncc_from_moments(cov, va, vb, cnt as usize * ch);
                *o = norm.cost(score.map(|s| 1.0 - s));
            }
        }
    }

    /// NCC with adaptive support weights ([`Support`]), in two passes over one output row
    /// at a time, window offset by window offset (contiguous, vectorisable): the weighted
    /// means of the masked reference and warped neighbour per channel, then the weighted
    /// centred moments about them — centred in the sum, not as `E[x²] − E[x]²`, which in
    /// `f32` loses the faint variance of plain paint. Then the same joint-variance NCC and
    /// texture threshold as [`Self::ncc_costs`], per unit of weight. O(r²) per pixel.
    fn weighted_ncc_costs(
        &self,
        support: &Support,
        warped: &[f32],
        terms: &mut Vec<f32>,
        row_sums: &mut Vec<f32>,
        out: &mut [f32],
    ) {
        let prep = self.prep;
        let (w, h, ch) = (prep.width, prep.height, prep.channels);
        let n = w * h;
        let norm = self.cfg.effective_normalization();
        let min_frac = self.cfg.min_valid_fraction as f32;
        // terms: the mask, then per channel the reference and the warped neighbour, both 0
        // where the neighbour did not warp inside (such pixels count for neither mean).
        let nt = 1 + 2 * ch;
        terms.clear();
        terms.resize(nt * n, 0.0);
        for p in (0..n).filter(|&p| warped[p].is_finite()) {
            terms[p] = 1.0;
            for c in 0..ch {
                terms[(1 + 2 * c) * n + p] = self.ref_planar[c * n + p];
                terms[(2 + 2 * c) * n + p] = warped[c * n + p];
            }
        }
        // Row sums: weight, per channel the two means, then cov, var I, var W.
        let nr = 1 + 2 * ch + 3;
        row_sums.clear();
        row_sums.resize(nr * w, 0.0);
        let (sums, moments) = row_sums.split_at_mut((1 + 2 * ch) * w);
        // The in-image window offsets of row y: (weight row, first neighbour pixel, x range).
        let spans = |y: usize| {
            support
                .offsets
                .iter()
                .enumerate()
                .filter_map(move |(k, &(dx, dy))| {
                    let qy = y as isize + dy;
                    let x0 = (-dx).max(0) as usize;
                    let x1 = (w as isize - dx).clamp(0, w as isize) as usize;
                    (qy >= 0 && qy < h as isize && x0 < x1).then(|| {
                        let q0 = qy as usize * w + (x0 as isize + dx) as usize;
                        (k * n + y * w, q0, x0, x1)
                    })
                })
        };
        for y in 0..h {
            sums.fill(0.0);
            moments.fill(0.0);
            for (wk, q0, x0, x1) in spans(y) {
                let wrow = &support.weights[wk + x0..wk + x1];
                for t in 0..nt {
                    let src = &terms[t * n + q0..t * n + q0 + (x1 - x0)];
                    let dst = &mut sums[t * w + x0..t * w + x1];
                    for ((d, &v), &wt) in dst.iter_mut().zip(src).zip(wrow) {
                        *d += wt * v;
                    }
                }
            }
            // Weighted sums → weighted means.
            let (wsum, rest) = sums.split_at_mut(w);
            for pair in rest.chunks_exact_mut(2 * w) {
                for (x, &ws) in wsum.iter().enumerate() {
                    let inv = if ws > 0.0 { 1.0 / ws } else { 0.0 };
                    pair[x] *= inv;
                    pair[w + x] *= inv;
                }
            }
            let (cov, vars) = moments.split_at_mut(w);
            let (va, vb) = vars.split_at_mut(w);
            for (wk, q0, x0, x1) in spans(y) {
                let len = x1 - x0;
                let wrow = &support.weights[wk + x0..wk + x1];
                let mask = &terms[q0..q0 + len];
                for c in 0..ch {
                    let iq = &terms[(1 + 2 * c) * n + q0..(1 + 2 * c) * n + q0 + len];
                    let jq = &terms[(2 + 2 * c) * n + q0..(2 + 2 * c) * n + q0 + len];
                    let mi = &rest[2 * c * w + x0..2 * c * w + x1];
                    let mj = &rest[(2 * c + 1) * w + x0..(2 * c + 1) * w + x1];
                    for i in 0..len {
                        let wm = wrow[i] * mask[i];
                        let (di, dj) = (iq[i] - mi[i], jq[i] - mj[i]);
                        cov[x0 + i] += wm * di * dj;
                        va[x0 + i] += wm * di * di;
                        vb[x0 + i] += wm * dj * dj;
                    }
                }
            }
            for x in 0..w {
                let p = y * w + x;
                let ws = wsum[x];
                out[p] = if ws > 0.0 && ws >= min_frac * support.total[p] {
                    let score = ncc_from_weighted_moments(
                        cov[x] as f64,
                        va[x] as f64,
                        vb[x] as f64,
                        ws as f64 * ch as f64,
                    );
                    norm.cost(score.map(|s| 1.0 - s))
                } else {
                    NO_EVIDENCE
                };
            }
        }
    }

    /// Census / Rank / MI: gather each window and call the patch measure.
    fn window_costs(
        &self,
        warped: &[f32],
        patch_ref: &mut [f32],
        patch_nbr: &mut [f32],
        out: &mut [f32],
    ) {
        let prep = self.prep;
        let (w, h, ch) = (prep.width, prep.height, prep.channels);
        let n = w * h;
        let r = self.cfg.window_radius as isize;
        let norm = self.cfg.effective_normalization();
        let min_frac = self.cfg.min_valid_fraction as f32;
        let bins = self.cfg.mi_bins as usize;
        for y in 0..h {
            for x in 0..w {
                let (mut inside, mut both) = (0usize, 0usize);
                let mut k = 0usize;
                for dy in -r..=r {
                    for dx in -r..=r {
                        let (qx, qy) = (x as isize + dx, y as isize + dy);
                        let q_in = qx >= 0 && qy >= 0 && (qx as usize) < w && (qy as usize) < h;
                        let q = if q_in {
                            qy as usize * w + qx as usize
                        } else {
                            0
                        };
                        let ok = q_in && warped[q].is_finite();
                        inside += usize::from(q_in);
                        both += usize::from(ok);
                        for c in 0..ch {
                            patch_ref[k * ch + c] = if q_in {
                                self.ref_planar[c * n + q]
                            } else {
                                f32::NAN
                            };
                            patch_nbr[k * ch + c] = if ok { warped[c * n + q] } else { f32::NAN };
                        }
                        k += 1;
                    }
                }
                out[y * w + x] = if both >= 1 && both as f32 >= min_frac * inside as f32 {
                    norm.cost(raw_cost(self.cfg.measure, patch_ref, patch_nbr, ch, bins))
                } else {
                    NO_EVIDENCE
                };
            }
        }
    }

    /// The aggregated, neighbour-combined cost slice of one plane.
    pub(super) fn plane_slice(
        &self,
        plane: &Plane,
        s: &mut Scratch,
    ) -> Result<Vec<f32>, PhotoError> {
        let prep = self.prep;
        let n = prep.width * prep.height;
        let ref_plane = plane.in_camera(&prep.ref_view.cam_from_world);
        let num_nbrs = prep.nbr_views.len();
        // Taken out of the scratch for the loop so `neighbour_costs` can borrow the rest.
        let mut nbr_costs = std::mem::take(&mut s.nbr_costs);
        for (j, v) in prep.nbr_views.iter().enumerate() {
            let out = &mut nbr_costs[j * n..(j + 1) * n];
            let Some(h) = plane_homography(
                &prep.ref_view.camera,
                &prep.ref_view.cam_from_world,
                &v.camera,
                &v.cam_from_world,
                plane,
            ) else {
                out.fill(NO_EVIDENCE);
                continue;
            };
            warp(prep, j, &h, &ref_plane, &mut s.warped);
            self.neighbour_costs(s, out);
        }
        s.nbr_costs = nbr_costs;
        let k = self.cfg.best_k.min(num_nbrs);
        let min_evidence = self.cfg.min_evidence.clamp(1, k);
        let mut slice = vec![1.0f32; n];
        for (p, o) in slice.iter_mut().enumerate() {
            s.pixel_costs.clear();
            s.pixel_costs.extend(
                (0..num_nbrs)
                    .map(|j| s.nbr_costs[j * n + p])
                    .filter(|c| !c.is_nan()),
            );
            // Neighbours without evidence (window out of view, plane behind them) are left
            // out of the best-k mean; too few with evidence leaves the pixel at 1.
            *o = if s.pixel_costs.len() < min_evidence {
                1.0
            } else {
                s.pixel_costs.sort_by(f32::total_cmp);
                let m = k.min(s.pixel_costs.len());
                s.pixel_costs[..m].iter().sum::<f32>() / m as f32
            };
        }
        match self.cfg.aggregation {
            super::Aggregation::None => Ok(slice),
            // The guided filter's local linear model can overshoot: keep costs in [0, 1].
            agg => Ok(agg
                .apply(&slice, &prep.reference)?
                .into_iter()
                .map(|c| c.clamp(0.0, 1.0))
                .collect()),
        }
    }
}
