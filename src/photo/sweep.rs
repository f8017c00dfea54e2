//! Plane-sweep stereo and the plane cost volume (tutorial §3.1 "plane sweeping"; Collins
//! 1996; Gallup et al. CVPR 2007 for sweeps along the scene's dominant axes).
//!
//! For every plane of a family and every neighbour view, the neighbour image is warped onto
//! the reference pixel grid through the plane-induced homography, once, into a flat buffer.
//! SSD, SAD and NCC are then evaluated from integral images of the reference, the warped
//! image and their products, so their cost per pixel does not depend on the window size;
//! Census, Rank and MI visit the window. Neighbour costs are combined by the mean of the
//! best k (occlusion), each plane's slice is aggregated, and the result is stored
//! pixel-major: exactly the `cost(pixel, plane)` the planemap data term consumes.

use super::aggregate::{window, Integral};
use super::measures::{ncc_from_moments, ncc_from_weighted_moments, raw_cost, Measure};
use super::sgm::semi_global;
use super::{ColorMode, PhotoConfig, PhotoError, SweepConfig};
use crate::geometry::{plane_homography, Plane};
use crate::raster::ImageF32;
use crate::scene::{Scene, View};
use nalgebra::{Matrix3, Point3, Vector2, Vector3};
use rayon::prelude::*;

/// Plane index of a pixel with no evidence for any plane (every cost was 1).
pub const NO_PLANE: u32 = u32::MAX;

/// Per-neighbour marker: this neighbour gives no evidence at the pixel (too little of the
/// window warps into its image, or the plane is behind a camera). Never leaves the module.
const NO_EVIDENCE: f32 = f32::NAN;

/// Photo-consistency cost of every pixel of a view on every plane hypothesis.
#[derive(Debug, Clone, PartialEq)]
pub struct CostVolume {
    /// Width of the reference view in pixels.
    pub width: usize,
    /// Height of the reference view in pixels.
    pub height: usize,
    /// Number of planes.
    pub num_planes: usize,
    /// Costs in `[0, 1]` (0 = photo-consistent), pixel-major:
    /// `costs[(y·width + x)·num_planes + plane]`. 1 also means "no evidence": the plane is
    /// behind the reference camera there, or no neighbour sees it.
    pub costs: Vec<f32>,
}

impl CostVolume {
    /// The costs of pixel `pixel = y·width + x` on all planes.
    pub fn pixel_costs(&self, pixel: usize) -> &[f32] {
        &self.costs[pixel * self.num_planes..(pixel + 1) * self.num_planes]
    }

    /// Cost of pixel `(x, y)` on plane `plane`.
    pub fn cost(&self, x: usize, y: usize, plane: usize) -> f32 {
        self.costs[(y * self.width + x) * self.num_planes + plane]
    }
}

/// Winner-takes-all plane-sweep output for one view.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepResult {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Depth (camera z, scene units) of the winning plane along each pixel's ray; `NaN`
    /// where no plane won.
    pub depth: Vec<f32>,
    /// Index of the winning plane in the plane list, [`NO_PLANE`] where none won.
    pub plane_index: Vec<u32>,
    /// The winning cost in `[0, 1]` (1 where none won).
    pub cost: Vec<f32>,
    /// Confidence in `[0, 1]`: second-best cost (away from the winner, see
    /// [`SweepConfig::confidence_exclusion`]) minus the best. Near 0 means ambiguous — the
    /// textureless-wall case planemaps exist for.
    pub confidence: Vec<f32>,
}

impl SweepResult {
    /// World-frame unit normal of the winning plane at `pixel`.
    pub fn normal(&self, pixel: usize, planes: &[Plane]) -> Option<Vector3<f64>> {
        let k = *self.plane_index.get(pixel)?;
        planes.get(k as usize).map(|p| p.normal)
    }
}

/// The depths of a fronto-parallel sweep: `n` depths from `near` to `far` (scene units)
/// spaced uniformly in inverse depth, so consecutive planes are about equally far apart in
/// disparity (pixels) in every neighbour. `n = 1` gives the inverse-depth midpoint.
pub fn fronto_parallel_depths(near: f64, far: f64, n: usize) -> Result<Vec<f64>, PhotoError> {
    if !(near.is_finite() && far.is_finite() && near > 0.0 && far > near) || n == 0 {
        return Err(PhotoError::InvalidInput(format!(
            "fronto-parallel sweep needs 0 < near < far and n ≥ 1, got near {near}, far {far}, n {n}"
        )));
    }
    let (a, b) = (1.0 / near, 1.0 / far);
    if n == 1 {
        return Ok(vec![2.0 / (a + b)]);
    }
    Ok((0..n)
        .map(|i| 1.0 / (a + (b - a) * i as f64 / (n - 1) as f64))
        .collect())
}

/// Fronto-parallel planes of `view` (normal = its optical axis, in world coordinates) at
/// the depths of [`fronto_parallel_depths`].
pub fn fronto_parallel_planes(
    view: &View,
    near: f64,
    far: f64,
    n: usize,
) -> Result<Vec<Plane>, PhotoError> {
    let axis = view.cam_from_world.rotation.inverse() * Vector3::z();
    // Camera z of X is axis·X + t_z, and axis·C = −t_z.
    let axis_dot_centre = axis.dot(&view.center());
    Ok(fronto_parallel_depths(near, far, n)?
        .into_iter()
        .map(|z| Plane {
            normal: axis,
            offset: axis_dot_centre + z,
        })
        .collect())
}

/// Planes `u·X = d` for every (unit) direction `u` and every offset `d` (scene units along
/// `u`), direction-major: planes of the dominant axes, or any given normals and offsets.
pub fn axis_planes(directions: &[Vector3<f64>], offsets: &[f64]) -> Result<Vec<Plane>, PhotoError> {
    let mut planes = Vec::with_capacity(directions.len() * offsets.len());
    for dir in directions {
        let len = dir.norm();
        if !(len.is_finite() && len > 1e-12) {
            return Err(PhotoError::InvalidInput(format!(
                "plane direction {dir:?} is not a usable normal"
            )));
        }
        for &d in offsets {
            if !d.is_finite() {
                return Err(PhotoError::InvalidInput(format!(
                    "plane offset {d} is not finite"
                )));
            }
            planes.push(Plane {
                normal: dir / len,
                offset: d,
            });
        }
    }
    Ok(planes)
}

/// Sweeps along each of `directions` (e.g. the three Manhattan axes, Gallup et al. 2007):
/// `n` planes per direction, offsets uniform over the range that the view's frustum between
/// depths `near` and `far` spans along that direction. Direction-major order, so the planes
/// of one sweep are consecutive.
pub fn axis_sweep_planes(
    view: &View,
    directions: &[Vector3<f64>],
    near: f64,
    far: f64,
    n: usize,
) -> Result<Vec<Plane>, PhotoError> {
    if !(near.is_finite() && far.is_finite() && near > 0.0 && far > near) || n == 0 {
        return Err(PhotoError::InvalidInput(format!(
            "axis sweep needs 0 < near < far and n ≥ 1, got near {near}, far {far}, n {n}"
        )));
    }
    let (w, h) = (view.camera.width as f64, view.camera.height as f64);
    let mut corners = Vec::with_capacity(8);
    for xy in [
        Vector2::new(0.0, 0.0),
        Vector2::new(w, 0.0),
        Vector2::new(0.0, h),
        Vector2::new(w, h),
    ] {
        let (origin, dir) = view.ray(&xy);
        corners.push(origin + dir * near);
        corners.push(origin + dir * far);
    }
    let mut planes = Vec::with_capacity(directions.len() * n);
    for dir in directions {
        let len = dir.norm();
        if !(len.is_finite() && len > 1e-12) {
            return Err(PhotoError::InvalidInput(format!(
                "plane direction {dir:?} is not a usable normal"
            )));
        }
        let u = dir / len;
        let (lo, hi) = corners
            .iter()
            .map(|c| u.dot(c))
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), d| {
                (lo.min(d), hi.max(d))
            });
        let offsets: Vec<f64> = if n == 1 {
            vec![0.5 * (lo + hi)]
        } else {
            (0..n)
                .map(|i| lo + (hi - lo) * i as f64 / (n - 1) as f64)
                .collect()
        };
        planes.extend(axis_planes(&[u], &offsets)?);
    }
    Ok(planes)
}

/// Triangulation angle (radians) below which a pair of rays gets reduced weight in
/// [`select_neighbours`]: Goesele et al. (ICCV 2007) use 10°.
pub const NEIGHBOUR_MIN_ANGLE: f64 = 10.0 * std::f64::consts::PI / 180.0;
/// Triangulation angle (radians) above which matching degrades (foreshortening,
/// occlusion) and a pair's weight falls off.
pub const NEIGHBOUR_MAX_ANGLE: f64 = 45.0 * std::f64::consts::PI / 180.0;

/// Weight of a triangulation angle: `(θ/θ_min)²` below `θ_min`, 1 up to `θ_max`, then a
/// Gaussian fall-off (σ = 10°).
fn angle_weight(theta: f64) -> f64 {
    if theta < NEIGHBOUR_MIN_ANGLE {
        (theta / NEIGHBOUR_MIN_ANGLE).powi(2)
    } else if theta <= NEIGHBOUR_MAX_ANGLE {
        1.0
    } else {
        let s = 10.0f64.to_radians();
        (-(theta - NEIGHBOUR_MAX_ANGLE).powi(2) / (2.0 * s * s)).exp()
    }
}

/// The `k` best neighbours of view `view_index` for matching (indices into `scene.views`),
/// best first. A candidate scores `Σ w(θ)` over the sparse points both views see, `θ` the
/// triangulation angle at the point (Goesele et al. 2007's global view selection without
/// the scale term): many shared points seen at a useful angle. Views sharing no point are
/// left out, unless the cloud has no tracks at all, in which case the angle between optical
/// axes stands in (weighted the same way). Ties go to the lower index.
pub fn select_neighbours(
    scene: &Scene,
    view_index: usize,
    k: usize,
) -> Result<Vec<usize>, PhotoError> {
    let count = scene.views.len();
    if view_index >= count {
        return Err(PhotoError::ViewIndex {
            index: view_index,
            count,
        });
    }
    let centres: Vec<Vector3<f64>> = scene.views.iter().map(|v| v.center()).collect();
    let mut score = vec![0.0f64; count];
    let mut any_track = false;
    let me = view_index as u32;
    for (point, track) in scene.cloud.positions.iter().zip(&scene.cloud.tracks) {
        if !track.contains(&me) {
            continue;
        }
        any_track = true;
        let ray_ref = centres[view_index] - point;
        for &j in track {
            let j = j as usize;
            if j == view_index || j >= count {
                continue;
            }
            let ray_j = centres[j] - point;
            score[j] += angle_weight(ray_ref.angle(&ray_j));
        }
    }
    if !any_track {
        let axis = |v: &View| v.cam_from_world.rotation.inverse() * Vector3::z();
        let ref_axis = axis(&scene.views[view_index]);
        for (j, v) in scene.views.iter().enumerate() {
            if j != view_index {
                // Optical axes nearly parallel but offset still see the same scene, so a
                // floor keeps them ranked behind useful angles rather than excluded.
                score[j] = angle_weight(ref_axis.angle(&axis(v))).max(1e-3);
            }
        }
    }
    let mut order: Vec<usize> = (0..count)
        .filter(|&j| j != view_index && score[j] > 0.0)
        .collect();
    order.sort_by(|&a, &b| score[b].total_cmp(&score[a]).then(a.cmp(&b)));
    order.truncate(k);
    Ok(order)
}

/// Images prepared for matching: grey or colour, and the reference split by channel.
struct Prepared {
    width: usize,
    height: usize,
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

fn prepare(
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
struct Scratch {
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
    fn new(prep: &Prepared, cfg: &PhotoConfig) -> Self {
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
struct Context<'a> {
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
    fn new(prep: &'a Prepared, cfg: &'a PhotoConfig, guide: &ImageF32) -> Self {
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
                cfg.support_sigma_color,
                cfg.support_sigma_space,
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
        let min_frac = self.cfg.min_valid_fraction as f64;
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
        let min_frac = self.cfg.min_valid_fraction as f64;
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
        let min_frac = self.cfg.min_valid_fraction;
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
        let min_frac = self.cfg.min_valid_fraction;
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
    fn plane_slice(&self, plane: &Plane, s: &mut Scratch) -> Result<Vec<f32>, PhotoError> {
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

/// The photo-consistency cost of every pixel of `reference` on every plane of `planes`:
/// for each plane, each neighbour is warped onto the reference grid by the plane's
/// homography and scored with `cfg.measure` over the support window, the best
/// `cfg.best_k` neighbour costs are averaged (occlusion), and the slice is aggregated.
/// Views must be undistorted pinhole cameras with images of their size (1 or 3 channels).
/// Planes are processed in parallel (rayon); the result does not depend on the thread count.
pub fn plane_cost_volume(
    reference: &View,
    ref_image: &ImageF32,
    neighbours: &[(&View, &ImageF32)],
    planes: &[Plane],
    cfg: &PhotoConfig,
) -> Result<CostVolume, PhotoError> {
    let prep = prepare(reference, ref_image, neighbours, planes, cfg)?;
    let ctx = Context::new(&prep, cfg, ref_image);
    let slices: Vec<Vec<f32>> = planes
        .par_iter()
        .map_init(
            || Scratch::new(&prep, cfg),
            |s, plane| ctx.plane_slice(plane, s),
        )
        .collect::<Result<_, _>>()?;
    let (n, np) = (prep.width * prep.height, planes.len());
    let mut costs = vec![0.0f32; n * np];
    const PIXELS_PER_TASK: usize = 4096;
    costs
        .par_chunks_mut(PIXELS_PER_TASK * np)
        .enumerate()
        .for_each(|(chunk, block)| {
            let p0 = chunk * PIXELS_PER_TASK;
            for (i, px) in block.chunks_exact_mut(np).enumerate() {
                for (k, v) in px.iter_mut().enumerate() {
                    *v = slices[k][p0 + i];
                }
            }
        });
    Ok(CostVolume {
        width: prep.width,
        height: prep.height,
        num_planes: np,
        costs,
    })
}

/// Winner-takes-all over a cost volume: each pixel takes its cheapest plane (the lowest
/// index on ties), its depth along the pixel's ray, and the confidence
/// `second-best − best` with the second best taken over planes more than
/// `confidence_exclusion` indices away. A pixel whose best cost is 1 (no evidence) gets
/// [`NO_PLANE`], depth `NaN`, confidence 0.
pub fn winner_takes_all(
    volume: &CostVolume,
    reference: &View,
    planes: &[Plane],
    confidence_exclusion: usize,
) -> Result<SweepResult, PhotoError> {
    if planes.len() != volume.num_planes
        || volume.costs.len() != volume.width * volume.height * volume.num_planes
    {
        return Err(PhotoError::Size(format!(
            "cost volume {}×{}×{} with {} values for {} planes",
            volume.width,
            volume.height,
            volume.num_planes,
            volume.costs.len(),
            planes.len()
        )));
    }
    let cam_planes: Vec<Plane> = planes
        .iter()
        .map(|p| p.in_camera(&reference.cam_from_world))
        .collect();
    let n = volume.width * volume.height;
    let mut depth = vec![f32::NAN; n];
    let mut plane_index = vec![NO_PLANE; n];
    let mut cost = vec![1.0f32; n];
    let mut confidence = vec![0.0f32; n];
    let w = volume.width;
    depth
        .par_chunks_mut(w.max(1))
        .zip(plane_index.par_chunks_mut(w.max(1)))
        .zip(cost.par_chunks_mut(w.max(1)))
        .zip(confidence.par_chunks_mut(w.max(1)))
        .enumerate()
        .for_each(|(y, (((d_row, i_row), c_row), f_row))| {
            for x in 0..w {
                let costs = volume.pixel_costs(y * w + x);
                let (best, best_cost) =
                    costs
                        .iter()
                        .enumerate()
                        .fold((0usize, f32::INFINITY), |acc, (k, &c)| {
                            if c < acc.1 {
                                (k, c)
                            } else {
                                acc
                            }
                        });
                if best_cost >= 1.0 {
                    continue;
                }
                let second = costs
                    .iter()
                    .enumerate()
                    .filter(|(k, _)| k.abs_diff(best) > confidence_exclusion)
                    .map(|(_, &c)| c)
                    .fold(1.0f32, f32::min);
                let ray = reference.camera.pixel_ray(x as u32, y as u32);
                d_row[x] = cam_planes[best]
                    .depth_along(&ray)
                    .map_or(f32::NAN, |z| z as f32);
                i_row[x] = best as u32;
                c_row[x] = best_cost;
                f_row[x] = (second - best_cost).clamp(0.0, 1.0);
            }
        });
    Ok(SweepResult {
        width: volume.width,
        height: volume.height,
        depth,
        plane_index,
        cost,
        confidence,
    })
}

/// Plane-sweep stereo: [`plane_cost_volume`] then [`winner_takes_all`]. `planes` is any
/// family — [`fronto_parallel_planes`], [`axis_sweep_planes`], or given hypotheses.
pub fn plane_sweep(
    reference: &View,
    ref_image: &ImageF32,
    neighbours: &[(&View, &ImageF32)],
    planes: &[Plane],
    cfg: &SweepConfig,
) -> Result<SweepResult, PhotoError> {
    cfg.validate()?;
    let mut volume = plane_cost_volume(reference, ref_image, neighbours, planes, &cfg.photo)?;
    if cfg.sgm.enabled() {
        volume = semi_global(&volume, ref_image, &cfg.sgm)?;
    }
    winner_takes_all(&volume, reference, planes, cfg.confidence_exclusion)
}

/// How the consecutive planes of one sweep family are spaced, which fixes how a fractional
/// plane index maps to a depth along a pixel's ray.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Spacing {
    /// Parallel planes evenly spaced in inverse depth ([`fronto_parallel_planes`]): the
    /// inverse depth is interpolated linearly in the index.
    InverseDepth,
    /// Parallel planes evenly spaced in offset ([`axis_sweep_planes`]): the
    /// depth along a ray is `d / (n·ray)`, so it is interpolated linearly in the index.
    Offset,
}

/// Sub-plane refinement of a winner-takes-all result (in place). For a pixel whose winning
/// plane `k` has both neighbours `k ± 1` with evidence (cost < 1), the parabola through
/// `(k−1, c₋), (k, c₀), (k+1, c₊)` has its minimum at `k + δ`,
/// `δ = (c₋ − c₊) / (2 (c₋ − 2c₀ + c₊))`, clamped to `[−½, ½]`; the depth becomes the
/// interpolation (see [`Spacing`]) between the depths of planes `k` and `k ± 1` along the
/// pixel's ray. `planes` must be one family of parallel planes in sweep order; pixels at
/// the ends of the sweep or on a non-convex cost keep the plane's depth. `plane_index` and
/// `cost` are left as WTA chose them.
pub fn refine_subplane(
    volume: &CostVolume,
    result: &mut SweepResult,
    reference: &View,
    planes: &[Plane],
    spacing: Spacing,
) {
    let np = volume.num_planes;
    if np < 3 || planes.len() != np || result.depth.len() != volume.width * volume.height {
        return;
    }
    let cam_planes: Vec<Plane> = planes
        .iter()
        .map(|p| p.in_camera(&reference.cam_from_world))
        .collect();
    let w = volume.width;
    for (i, z) in result.depth.iter_mut().enumerate() {
        let k = result.plane_index[i];
        if k == NO_PLANE || k == 0 || k as usize + 1 >= np {
            continue;
        }
        let k = k as usize;
        let c = volume.pixel_costs(i);
        let (cm, c0, cp) = (c[k - 1] as f64, c[k] as f64, c[k + 1] as f64);
        if cm >= 1.0 || cp >= 1.0 {
            continue;
        }
        let curvature = cm - 2.0 * c0 + cp;
        if curvature <= 0.0 {
            continue;
        }
        let delta = (0.5 * (cm - cp) / curvature).clamp(-0.5, 0.5);
        if delta == 0.0 {
            continue;
        }
        let j = if delta < 0.0 { k - 1 } else { k + 1 };
        let t = delta.abs();
        let ray = reference.camera.pixel_ray((i % w) as u32, (i / w) as u32);
        let (Some(zk), Some(zj)) = (
            cam_planes[k].depth_along(&ray),
            cam_planes[j].depth_along(&ray),
        ) else {
            continue;
        };
        let refined = match spacing {
            Spacing::InverseDepth => 1.0 / ((1.0 - t) / zk + t / zj),
            Spacing::Offset => (1.0 - t) * zk + t * zj,
        };
        if refined.is_finite() && refined > 0.0 {
            *z = refined as f32;
        }
    }
}

/// One family of parallel planes in sweep order, with how they are spaced: what
/// [`refine_subplane`] needs to interpolate between neighbouring planes.
#[derive(Debug, Clone, PartialEq)]
pub struct PlaneFamily {
    /// The planes, consecutive in sweep order.
    pub planes: Vec<Plane>,
    /// Their spacing.
    pub spacing: Spacing,
}

/// Winner over several plane families (see [`multi_family_sweep`]).
#[derive(Debug, Clone, PartialEq)]
pub struct FamilySweepResult {
    /// The winner per pixel; `plane_index` indexes the families' planes concatenated in
    /// order, `confidence` is the winning family's (second best within that family).
    pub sweep: SweepResult,
    /// Index of the winning family per pixel (`u32::MAX` where none won).
    pub family: Vec<u32>,
}

/// Plane sweep along several families at once — typically fronto-parallel plus one family
/// per dominant axis (Gallup et al. CVPR 2007): a surface aligned with an axis is matched
/// with a correctly slanted window by that axis's family, anything else by the
/// fronto-parallel one. Each family is swept ([`plane_cost_volume`], [`winner_takes_all`],
/// and [`refine_subplane`] when `subplane`), one family's volume at a time so the memory
/// is that of the largest family; each pixel then keeps the family whose winner has the
/// lowest cost (the earlier family on ties).
pub fn multi_family_sweep(
    reference: &View,
    ref_image: &ImageF32,
    neighbours: &[(&View, &ImageF32)],
    families: &[PlaneFamily],
    cfg: &SweepConfig,
    subplane: bool,
) -> Result<FamilySweepResult, PhotoError> {
    cfg.validate()?;
    if families.is_empty() {
        return Err(PhotoError::InvalidInput("no plane family to sweep".into()));
    }
    let mut best: Option<FamilySweepResult> = None;
    let mut offset = 0u32;
    for (f, family) in families.iter().enumerate() {
        let raw = plane_cost_volume(reference, ref_image, neighbours, &family.planes, &cfg.photo)?;
        let aggregated = if cfg.sgm.enabled() {
            Some(semi_global(&raw, ref_image, &cfg.sgm)?)
        } else {
            None
        };
        let volume = aggregated.as_ref().unwrap_or(&raw);
        let mut r = winner_takes_all(volume, reference, &family.planes, cfg.confidence_exclusion)?;
        if subplane {
            refine_subplane(volume, &mut r, reference, &family.planes, family.spacing);
            if aggregated.is_some() && cfg.sgm.subplane_on_local {
                // Where the local costs allow a fit (evidence and a convex minimum about the
                // winner) it replaces the aggregated one; elsewhere that one stays.
                refine_subplane(&raw, &mut r, reference, &family.planes, family.spacing);
            }
        }
        match &mut best {
            None => {
                let family_index = r
                    .plane_index
                    .iter()
                    .map(|&k| if k == NO_PLANE { u32::MAX } else { f as u32 })
                    .collect();
                best = Some(FamilySweepResult {
                    sweep: r,
                    family: family_index,
                });
            }
            Some(b) => {
                for p in 0..r.cost.len() {
                    if r.plane_index[p] != NO_PLANE && r.cost[p] < b.sweep.cost[p] {
                        b.sweep.cost[p] = r.cost[p];
                        b.sweep.depth[p] = r.depth[p];
                        b.sweep.confidence[p] = r.confidence[p];
                        b.sweep.plane_index[p] = r.plane_index[p] + offset;
                        b.family[p] = f as u32;
                    }
                }
            }
        }
        offset += family.planes.len() as u32;
    }
    Ok(best.expect("at least one family"))
}

/// World point where the ray through the centre of pixel `(x, y)` of `view` meets `plane`.
pub fn pixel_on_plane(view: &View, x: u32, y: u32, plane: &Plane) -> Option<Vector3<f64>> {
    let (origin, dir) = view.ray(&Vector2::new(x as f64 + 0.5, y as f64 + 0.5));
    let t = plane.intersect_ray(&origin, &dir)?;
    (t > 0.0).then(|| (Point3::from(origin) + dir * t).coords)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{look_at, Camera};
    use crate::photo::Aggregation;
    use crate::scene::SparseCloud;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    const WIDTH: u32 = 160;
    const HEIGHT: u32 = 120;
    const FOCAL: f64 = 150.0;

    /// Deterministic hash of a lattice point to `[0, 1)`.
    fn lattice(i: i64, j: i64, salt: u64) -> f64 {
        let mut h = (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
            ^ (j as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F)
            ^ salt.wrapping_mul(0x1656_67B1_9E37_79F9);
        h ^= h >> 33;
        h = h.wrapping_mul(0xFF51_AFD7_ED55_8CCD);
        h ^= h >> 33;
        (h >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Smoothly interpolated value noise with lattice spacing `cell` (scene units).
    fn value_noise(s: f64, t: f64, cell: f64, salt: u64) -> f64 {
        let (fs, ft) = (s / cell, t / cell);
        let (i, j) = (fs.floor() as i64, ft.floor() as i64);
        let smooth = |a: f64| a * a * (3.0 - 2.0 * a);
        let (a, b) = (smooth(fs - i as f64), smooth(ft - j as f64));
        let top = lattice(i, j, salt) * (1.0 - a) + lattice(i + 1, j, salt) * a;
        let bottom = lattice(i, j + 1, salt) * (1.0 - a) + lattice(i + 1, j + 1, salt) * a;
        top * (1.0 - b) + bottom * b
    }

    /// Camera `i` of the test rigs: a `WIDTH`×`HEIGHT` pinhole at `eye` looking at `target`.
    fn test_view(i: usize, eye: &Vector3<f64>, target: &Vector3<f64>) -> View {
        View {
            id: i as u32 + 1,
            name: format!("cam{i}"),
            camera: Camera::pinhole(
                WIDTH,
                HEIGHT,
                FOCAL,
                FOCAL,
                WIDTH as f64 / 2.0,
                HEIGHT as f64 / 2.0,
            ),
            cam_from_world: look_at(eye, target, &Vector3::z()),
            image_path: None,
        }
    }

    /// Ray-cast render of `view` (RGB) with 2×2 supersampling, ±0.5/255 noise and 8-bit
    /// quantisation; `shade` gives the colour seen along a ray (origin, direction).
    fn ray_cast(
        view: &View,
        seed: u64,
        shade: impl Fn(&Vector3<f64>, &Vector3<f64>) -> [f32; 3],
    ) -> ImageF32 {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut img = ImageF32::filled(WIDTH, HEIGHT, 3, 0.0);
        for y in 0..HEIGHT {
            for x in 0..WIDTH {
                let mut acc = [0.0f32; 3];
                for (ox, oy) in [(0.25, 0.25), (0.75, 0.25), (0.25, 0.75), (0.75, 0.75)] {
                    let (o, d) = view.ray(&Vector2::new(x as f64 + ox, y as f64 + oy));
                    let c = shade(&o, &d);
                    for k in 0..3 {
                        acc[k] += 0.25 * c[k];
                    }
                }
                for (k, out) in img.pixel_mut(x, y).iter_mut().enumerate() {
                    let noisy = acc[k] + (rng.random::<f32>() - 0.5) / 255.0;
                    *out = (noisy.clamp(0.0, 1.0) * 255.0).round() / 255.0;
                }
            }
        }
        img
    }

    /// A plane textured on its `s < 0` half and plain paint on `s ≥ 0`, seen by a reference
    /// camera and two neighbours ~11° to either side.
    struct TestScene {
        plane: Plane,
        u: Vector3<f64>,
        v: Vector3<f64>,
        views: Vec<View>,
        images: Vec<ImageF32>,
    }

    impl TestScene {
        fn texture(&self, x: &Vector3<f64>) -> [f32; 3] {
            let (s, t) = (self.u.dot(x), self.v.dot(x));
            if s >= 0.0 {
                return [0.55, 0.5, 0.45];
            }
            let g = 0.15 + 0.5 * value_noise(s, t, 0.06, 1) + 0.3 * value_noise(s, t, 0.21, 2);
            [g as f32, (0.9 * g + 0.05) as f32, (g * g + 0.1) as f32]
        }

        /// [`ray_cast`] of the plane.
        fn render(&self, view: &View, seed: u64) -> ImageF32 {
            ray_cast(view, seed, |o, d| {
                let t = self
                    .plane
                    .intersect_ray(o, d)
                    .expect("plane fills the view");
                self.texture(&(o + d * t))
            })
        }

        fn new() -> Self {
            let normal = Vector3::new(0.15, -1.0, 0.1).normalize();
            let plane = Plane::through(&Vector3::zeros(), &normal);
            let u = normal.cross(&Vector3::z()).normalize();
            let v = normal.cross(&u);
            let eyes = [
                Vector3::new(0.0, -5.0, 0.2),
                Vector3::new(-1.0, -5.1, 0.35),
                Vector3::new(1.0, -4.9, 0.0),
            ];
            let views = eyes
                .iter()
                .enumerate()
                .map(|(i, eye)| test_view(i, eye, &Vector3::new(0.0, 0.0, 0.1)))
                .collect();
            let mut scene = TestScene {
                plane,
                u,
                v,
                views,
                images: Vec::new(),
            };
            scene.images = (0..3)
                .map(|i| scene.render(&scene.views[i], 100 + i as u64))
                .collect();
            scene
        }

        fn neighbours(&self) -> Vec<(&View, &ImageF32)> {
            vec![
                (&self.views[1], &self.images[1]),
                (&self.views[2], &self.images[2]),
            ]
        }

        /// The homography of `plane` from the reference to neighbour 1 (pixel coordinates).
        fn homography(&self, plane: &Plane) -> Matrix3<f64> {
            let (a, b) = (&self.views[0], &self.views[1]);
            plane_homography(
                &a.camera,
                &a.cam_from_world,
                &b.camera,
                &b.cam_from_world,
                plane,
            )
            .unwrap()
        }

        /// Ground-truth depth and the in-plane `s` coordinate of a reference pixel.
        fn truth(&self, x: u32, y: u32) -> (f64, f64) {
            let view = &self.views[0];
            let xw = pixel_on_plane(view, x, y, &self.plane).unwrap();
            (view.project(&xw).unwrap().1, self.u.dot(&xw))
        }
    }

    /// Fraction of pixels within 1% of the true depth and median confidence, over the
    /// textured (`s < −margin`) and plain (`s > margin`) parts away from the image border.
    fn score(scene: &TestScene, result: &SweepResult, margin: f64) -> ((f64, f32), (f64, f32)) {
        let border = 8;
        let mut stats = [(0usize, 0usize, Vec::new()), (0usize, 0usize, Vec::new())];
        for y in border..HEIGHT - border {
            for x in border..WIDTH - border {
                let (z, s) = scene.truth(x, y);
                let which = if s < -margin {
                    0
                } else if s > margin {
                    1
                } else {
                    continue;
                };
                let p = (y * WIDTH + x) as usize;
                let d = result.depth[p] as f64;
                let st = &mut stats[which];
                st.0 += usize::from(d.is_finite() && ((d - z) / z).abs() <= 0.01);
                st.1 += 1;
                st.2.push(result.confidence[p]);
            }
        }
        let summarise = |st: &mut (usize, usize, Vec<f32>)| {
            st.2.sort_by(f32::total_cmp);
            (st.0 as f64 / st.1 as f64, st.2[st.2.len() / 2])
        };
        let [mut a, mut b] = stats;
        (summarise(&mut a), summarise(&mut b))
    }

    #[test]
    fn fronto_parallel_sweep_finds_textured_depth_and_fails_on_plain_paint() {
        let scene = TestScene::new();
        // True depths span about 4.6–5.4 here; 96 planes over [4, 6.5] are ~0.5% apart.
        let planes = fronto_parallel_planes(&scene.views[0], 4.0, 6.5, 96).unwrap();
        let cfg = SweepConfig::default();
        let result = plane_sweep(
            &scene.views[0],
            &scene.images[0],
            &scene.neighbours(),
            &planes,
            &cfg,
        )
        .unwrap();
        let ((tex_ok, tex_conf), (plain_ok, plain_conf)) = score(&scene, &result, 0.15);
        eprintln!("fronto NCC 7x7: textured {:.1}% within 1% (median conf {tex_conf:.3}); plain {:.1}% (median conf {plain_conf:.3})", 100.0 * tex_ok, 100.0 * plain_ok);
        assert!(tex_ok >= 0.9, "textured: {tex_ok}");
        assert!(
            plain_ok < 0.3,
            "plain paint should defeat photo-consistency: {plain_ok}"
        );
        assert!(
            plain_conf < 0.05 && tex_conf > 0.1,
            "confidence {plain_conf} vs {tex_conf}"
        );
    }

    #[test]
    fn sweep_along_the_plane_normal_recovers_the_plane() {
        let scene = TestScene::new();
        let offsets: Vec<f64> = (-20..=20).map(|i| i as f64 * 0.02).collect();
        let planes = axis_planes(&[scene.plane.normal], &offsets).unwrap();
        let cfg = SweepConfig {
            photo: PhotoConfig {
                color: ColorMode::Color,
                ..Default::default()
            },
            ..Default::default()
        };
        let result = plane_sweep(
            &scene.views[0],
            &scene.images[0],
            &scene.neighbours(),
            &planes,
            &cfg,
        )
        .unwrap();
        let (mut exact, mut total) = (0, 0);
        for y in 8..HEIGHT - 8 {
            for x in 8..WIDTH - 8 {
                if scene.truth(x, y).1 < -0.15 {
                    total += 1;
                    exact += usize::from(result.plane_index[(y * WIDTH + x) as usize] == 20);
                }
            }
        }
        let frac = exact as f64 / total as f64;
        eprintln!(
            "axis sweep, colour NCC: {:.1}% pick the true plane",
            100.0 * frac
        );
        assert!(frac > 0.9, "{frac}");
        let winner = result.plane_index.iter().position(|&k| k == 20).unwrap();
        let n = result.normal(winner, &planes).unwrap();
        assert!((n - scene.plane.normal).norm() < 1e-12);
        let none = result
            .plane_index
            .iter()
            .position(|&k| k == NO_PLANE)
            .unwrap();
        assert!(result.normal(none, &planes).is_none() && result.depth[none].is_nan());
    }

    /// Fronto-parallel planes (a wrong slant for this tilted surface) plus a family along
    /// the true normal: the slanted family must win on the textured half, the result must
    /// be the per-pixel minimum over the two families, and the plane index must point into
    /// the concatenated list.
    #[test]
    fn multi_family_sweep_keeps_the_cheaper_family_per_pixel() {
        let scene = TestScene::new();
        let fronto = PlaneFamily {
            planes: fronto_parallel_planes(&scene.views[0], 4.0, 6.5, 32).unwrap(),
            spacing: Spacing::InverseDepth,
        };
        let offsets: Vec<f64> = (-16..=16).map(|i| i as f64 * 0.025 + 0.005).collect();
        let slanted = PlaneFamily {
            planes: axis_planes(&[scene.plane.normal], &offsets).unwrap(),
            spacing: Spacing::Offset,
        };
        let cfg = SweepConfig::default();
        let nbrs = scene.neighbours();
        let families = [fronto.clone(), slanted.clone()];
        let multi = multi_family_sweep(
            &scene.views[0],
            &scene.images[0],
            &nbrs,
            &families,
            &cfg,
            true,
        )
        .unwrap();
        let single = |f: &PlaneFamily| {
            let v = plane_cost_volume(
                &scene.views[0],
                &scene.images[0],
                &nbrs,
                &f.planes,
                &cfg.photo,
            )
            .unwrap();
            let mut r =
                winner_takes_all(&v, &scene.views[0], &f.planes, cfg.confidence_exclusion).unwrap();
            refine_subplane(&v, &mut r, &scene.views[0], &f.planes, f.spacing);
            r
        };
        let (a, b) = (single(&fronto), single(&slanted));
        let (mut slanted_wins, mut textured) = (0, 0);
        for p in 0..multi.family.len() {
            let want = if b.plane_index[p] != NO_PLANE && b.cost[p] < a.cost[p] {
                1
            } else {
                0
            };
            let from = if want == 1 { &b } else { &a };
            if from.plane_index[p] == NO_PLANE {
                assert_eq!(multi.family[p], u32::MAX);
                continue;
            }
            assert_eq!(multi.family[p], want, "pixel {p}");
            assert_eq!(multi.sweep.cost[p].to_bits(), from.cost[p].to_bits());
            assert_eq!(multi.sweep.depth[p].to_bits(), from.depth[p].to_bits());
            assert_eq!(
                multi.sweep.plane_index[p],
                from.plane_index[p] + want * fronto.planes.len() as u32
            );
            let (x, y) = ((p % WIDTH as usize) as u32, (p / WIDTH as usize) as u32);
            if x >= 8 && y >= 8 && x < WIDTH - 8 && y < HEIGHT - 8 && scene.truth(x, y).1 < -0.15 {
                textured += 1;
                slanted_wins += want as usize;
            }
        }
        let share = slanted_wins as f64 / textured as f64;
        let ((acc, _), _) = score(&scene, &multi.sweep, 0.15);
        eprintln!(
            "slanted family wins on {:.1}% of textured pixels; {acc:.3} within 1%",
            100.0 * share
        );
        assert!(share > 0.6, "{share}");
        assert!(acc > 0.9, "{acc}");
        assert!(
            multi_family_sweep(&scene.views[0], &scene.images[0], &nbrs, &[], &cfg, true).is_err()
        );
    }

    /// With the semi-global paths on, the sub-plane fit on the local costs
    /// (`sgm.subplane_on_local`) lands nearer the true depth than the fit on the aggregated
    /// sums, whose min-plus-penalty flattens the curve about the winner; the winners are the
    /// same either way.
    #[test]
    fn subplane_fit_on_local_costs_beats_the_aggregated_fit() {
        let scene = TestScene::new();
        let family = PlaneFamily {
            planes: fronto_parallel_planes(&scene.views[0], 4.0, 6.5, 24).unwrap(),
            spacing: Spacing::InverseDepth,
        };
        let nbrs = scene.neighbours();
        let run = |local: bool| {
            let cfg = SweepConfig {
                sgm: crate::photo::SgmConfig {
                    paths: 8,
                    subplane_on_local: local,
                    ..Default::default()
                },
                ..Default::default()
            };
            let families = [family.clone()];
            multi_family_sweep(
                &scene.views[0],
                &scene.images[0],
                &nbrs,
                &families,
                &cfg,
                true,
            )
            .unwrap()
        };
        let (local, aggregated) = (run(true), run(false));
        assert_eq!(local.sweep.plane_index, aggregated.sweep.plane_index);
        let errors = |r: &FamilySweepResult| {
            let mut e = Vec::new();
            for y in 8..HEIGHT - 8 {
                for x in 8..WIDTH - 8 {
                    let (z, s) = scene.truth(x, y);
                    if s < -0.15 {
                        let d = r.sweep.depth[(y * WIDTH + x) as usize] as f64;
                        e.push(((d - z) / z).abs());
                    }
                }
            }
            e.sort_by(f64::total_cmp);
            (e[e.len() / 2], e.iter().sum::<f64>() / e.len() as f64)
        };
        let ((lm, la), (am, aa)) = (errors(&local), errors(&aggregated));
        eprintln!("relative depth error median / mean: local fit {lm:.5} / {la:.5}, aggregated fit {am:.5} / {aa:.5}");
        assert!(lm < am && la < aa, "{lm} {la} vs {am} {aa}");
    }

    /// A neighbour that looks away from the surface gives no evidence: with
    /// `min_evidence = 1` the cost is the seeing neighbour's alone; requiring two leaves
    /// every pixel at 1.
    #[test]
    fn neighbours_without_evidence_are_left_out_of_best_k() {
        let scene = TestScene::new();
        let mut away = scene.views[2].clone();
        let eye = away.center();
        away.cam_from_world = look_at(&eye, &(eye * 2.0), &Vector3::z());
        let planes = fronto_parallel_planes(&scene.views[0], 4.5, 5.5, 4).unwrap();
        let run = |nbrs: &[(&View, &ImageF32)], best_k: usize, min_evidence: usize| {
            let cfg = PhotoConfig {
                best_k,
                min_evidence,
                ..Default::default()
            };
            plane_cost_volume(&scene.views[0], &scene.images[0], nbrs, &planes, &cfg).unwrap()
        };
        let one = run(&[(&scene.views[1], &scene.images[1])], 1, 1);
        let pair = [
            (&scene.views[1], &scene.images[1]),
            (&away, &scene.images[2]),
        ];
        let lenient = run(&pair, 2, 1);
        assert_eq!(one.costs, lenient.costs);
        assert!(one.costs.iter().filter(|&&c| c < 0.5).count() > 1000);
        let strict = run(&pair, 2, 2);
        assert!(strict.costs.iter().all(|&c| c == 1.0));
    }

    #[test]
    fn every_measure_and_aggregation_sweeps_the_texture() {
        let scene = TestScene::new();
        // 24 planes ~1.2% apart over the true range (4.6–5.4): debug builds stay quick.
        let planes = fronto_parallel_planes(&scene.views[0], 4.4, 5.8, 24).unwrap();
        let cases: Vec<(Measure, Aggregation, f64)> = vec![
            (Measure::Sad, Aggregation::Box { radius: 3 }, 0.95),
            (
                Measure::Ssd,
                Aggregation::Guided {
                    radius: 3,
                    eps: 1e-3,
                },
                0.95,
            ),
            (Measure::Census, Aggregation::None, 0.95),
            (Measure::Rank, Aggregation::None, 0.95),
            (
                Measure::MutualInformation,
                Aggregation::Bilateral {
                    radius: 3,
                    sigma_space: 2.0,
                    sigma_color: 0.1,
                },
                0.9,
            ),
            (
                Measure::Ncc,
                Aggregation::WeightedMedian {
                    radius: 2,
                    sigma_space: 2.0,
                    sigma_color: 0.1,
                },
                0.95,
            ),
        ];
        for (measure, aggregation, want) in cases {
            let cfg = SweepConfig {
                photo: PhotoConfig {
                    measure,
                    aggregation,
                    window_radius: if measure == Measure::MutualInformation {
                        5
                    } else {
                        3
                    },
                    ..Default::default()
                },
                ..Default::default()
            };
            let result = plane_sweep(
                &scene.views[0],
                &scene.images[0],
                &scene.neighbours(),
                &planes,
                &cfg,
            )
            .unwrap();
            // Within 2%: the nearest plane or its neighbour.
            let (mut ok, mut total) = (0, 0);
            for y in (8..HEIGHT - 8).step_by(2) {
                for x in (8..WIDTH - 8).step_by(2) {
                    let (z, s) = scene.truth(x, y);
                    if s < -0.15 {
                        let d = result.depth[(y * WIDTH + x) as usize] as f64;
                        ok += usize::from(((d - z) / z).abs() <= 0.02);
                        total += 1;
                    }
                }
            }
            let frac = ok as f64 / total as f64;
            eprintln!(
                "{measure:?} + {aggregation:?}: {:.1}% within 2%",
                100.0 * frac
            );
            assert!(frac >= want, "{measure:?}: {frac}");
        }
    }

    /// The box-sum NCC path against the patch function on explicitly warped windows,
    /// including windows that reach outside either image.
    #[test]
    fn box_sum_costs_match_patch_measures() {
        let scene = TestScene::new();
        let planes = fronto_parallel_planes(&scene.views[0], 4.5, 5.5, 3).unwrap();
        let nbr = [(&scene.views[1], &scene.images[1])];
        for (measure, color) in [
            (Measure::Ncc, ColorMode::Color),
            (Measure::Ncc, ColorMode::Gray),
            (Measure::Sad, ColorMode::Color),
            (Measure::Ssd, ColorMode::Gray),
        ] {
            let cfg = PhotoConfig {
                measure,
                color,
                best_k: 1,
                window_radius: 2,
                ..Default::default()
            };
            let volume =
                plane_cost_volume(&scene.views[0], &scene.images[0], &nbr, &planes, &cfg).unwrap();
            let (r, ch) = (2i64, if color == ColorMode::Color { 3 } else { 1 });
            let ref_img = if ch == 3 {
                scene.images[0].clone()
            } else {
                scene.images[0].to_gray()
            };
            let nbr_img = if ch == 3 {
                scene.images[1].clone()
            } else {
                scene.images[1].to_gray()
            };
            let norm = cfg.effective_normalization();
            let mut checked_partial = 0;
            for (k, plane) in planes.iter().enumerate() {
                let h = scene.homography(plane);
                for &(x, y) in &[
                    (0i64, 0i64),
                    (1, 60),
                    (80, 60),
                    (159, 119),
                    (158, 3),
                    (5, 117),
                    (40, 20),
                ] {
                    let (mut a, mut b) = (Vec::new(), Vec::new());
                    let (mut inside, mut both) = (0, 0);
                    for qy in y - r..=y + r {
                        for qx in x - r..=x + r {
                            let q_in =
                                qx >= 0 && qy >= 0 && qx < WIDTH as i64 && qy < HEIGHT as i64;
                            let mut px = [f32::NAN; 3];
                            let mut ok = false;
                            if q_in {
                                let hx = h * Vector3::new(qx as f64 + 0.5, qy as f64 + 0.5, 1.0);
                                ok = hx.z > 0.0
                                    && nbr_img.sample_bilinear(
                                        hx.x / hx.z,
                                        hx.y / hx.z,
                                        &mut px[..ch],
                                    );
                            }
                            inside += usize::from(q_in);
                            both += usize::from(ok);
                            for (c, &v) in px.iter().enumerate().take(ch) {
                                a.push(if q_in {
                                    ref_img.get(qx as u32, qy as u32, c as u32)
                                } else {
                                    f32::NAN
                                });
                                b.push(if ok { v } else { f32::NAN });
                            }
                        }
                    }
                    checked_partial += usize::from(both < inside && both > 0);
                    let want = if both as f32 >= 0.5 * inside as f32 && both >= 2 {
                        norm.cost(raw_cost(measure, &a, &b, ch, 8))
                    } else {
                        1.0
                    };
                    let got = volume.cost(x as usize, y as usize, k);
                    assert!(
                        (got - want).abs() < 1e-4,
                        "{measure:?} {color:?} plane {k} ({x},{y}): {got} vs {want}"
                    );
                }
            }
            assert!(
                checked_partial > 0,
                "no window was partly outside the neighbour"
            );
        }
    }

    /// A neighbour at the reference pose warps every pixel (identity homography): the box
    /// path then reuses the reference's own integral tables; it must still match the patch
    /// measure, window clipping at the image border included.
    #[test]
    fn fully_visible_warp_matches_patch_measures() {
        let scene = TestScene::new();
        let planes = fronto_parallel_planes(&scene.views[0], 4.5, 5.5, 2).unwrap();
        // The reference under a gain, a bias and noise: NCC costs land on the ramp.
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let mut noisy = scene.images[0].clone();
        noisy
            .data
            .iter_mut()
            .for_each(|v| *v = 0.7 * *v + 0.1 + 0.04 * rng.random::<f32>());
        let other = &noisy;
        let nbr = [(&scene.views[0], other)];
        let mut on_ramp = 0;
        // Border pixels (clipped windows) and four pixels on the textured half.
        let mut pixels = vec![(0i64, 0i64), (2, 50), (159, 119), (100, 118)];
        let textured = (10..110)
            .step_by(23)
            .flat_map(|y| (10..150).step_by(31).map(move |x| (x, y)))
            .filter(|&(x, y)| scene.truth(x, y).1 < -0.2)
            .take(4);
        pixels.extend(textured.map(|(x, y)| (x as i64, y as i64)));
        assert_eq!(pixels.len(), 8);
        for color in [ColorMode::Gray, ColorMode::Color] {
            let cfg = PhotoConfig {
                color,
                best_k: 1,
                ..Default::default()
            };
            let volume =
                plane_cost_volume(&scene.views[0], &scene.images[0], &nbr, &planes, &cfg).unwrap();
            let ch = if color == ColorMode::Color { 3 } else { 1 };
            let (a_img, b_img) = if ch == 3 {
                (scene.images[0].clone(), other.clone())
            } else {
                (scene.images[0].to_gray(), other.to_gray())
            };
            let r = cfg.window_radius as i64;
            for &(x, y) in &pixels {
                let (mut a, mut b) = (Vec::new(), Vec::new());
                for qy in y - r..=y + r {
                    for qx in x - r..=x + r {
                        let inside = qx >= 0 && qy >= 0 && qx < WIDTH as i64 && qy < HEIGHT as i64;
                        for c in 0..ch as u32 {
                            let get = |img: &ImageF32| {
                                if inside {
                                    img.get(qx as u32, qy as u32, c)
                                } else {
                                    f32::NAN
                                }
                            };
                            a.push(get(&a_img));
                            b.push(get(&b_img));
                        }
                    }
                }
                let want =
                    cfg.effective_normalization()
                        .cost(raw_cost(Measure::Ncc, &a, &b, ch, 8));
                on_ramp += usize::from(want > 0.0 && want < 1.0);
                for k in 0..planes.len() {
                    let got = volume.cost(x as usize, y as usize, k);
                    assert!(
                        (got - want).abs() < 1e-4,
                        "{color:?} ({x},{y}): {got} vs {want}"
                    );
                }
            }
        }
        assert!(on_ramp >= 8, "only {on_ramp} costs strictly inside (0, 1)");
    }

    #[test]
    fn cost_volume_is_bit_identical_across_thread_counts() {
        let scene = TestScene::new();
        let planes = fronto_parallel_planes(&scene.views[0], 4.0, 6.5, 8).unwrap();
        let cfg = PhotoConfig {
            aggregation: Aggregation::Guided {
                radius: 2,
                eps: 1e-3,
            },
            ..Default::default()
        };
        let run = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| {
                    plane_cost_volume(
                        &scene.views[0],
                        &scene.images[0],
                        &scene.neighbours(),
                        &planes,
                        &cfg,
                    )
                    .unwrap()
                })
        };
        let one = run(1);
        let three = run(3);
        assert_eq!(one.costs.len(), (WIDTH * HEIGHT) as usize * 8);
        assert!(one
            .costs
            .iter()
            .zip(&three.costs)
            .all(|(a, b)| a.to_bits() == b.to_bits()));
        assert!(one.costs.iter().all(|c| (0.0..=1.0).contains(c)));
    }

    #[test]
    fn best_k_ignores_an_occluded_neighbour() {
        let scene = TestScene::new();
        // A third "neighbour" whose image shows something else entirely (an occluder in
        // front of the whole surface).
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let mut junk = scene.images[2].clone();
        junk.data.iter_mut().for_each(|v| *v = rng.random());
        let mut nbrs = scene.neighbours();
        nbrs.push((&scene.views[2], &junk));
        let planes = fronto_parallel_planes(&scene.views[0], 4.0, 6.5, 64).unwrap();
        let run = |nbrs: &[(&View, &ImageF32)], best_k: usize| {
            let cfg = SweepConfig {
                photo: PhotoConfig {
                    best_k,
                    ..Default::default()
                },
                ..Default::default()
            };
            let r = plane_sweep(&scene.views[0], &scene.images[0], nbrs, &planes, &cfg).unwrap();
            let mut costs: Vec<f32> = Vec::new();
            for y in 8..HEIGHT - 8 {
                for x in 8..WIDTH - 8 {
                    if scene.truth(x, y).1 < -0.15 {
                        costs.push(r.cost[(y * WIDTH + x) as usize]);
                    }
                }
            }
            costs.sort_by(f32::total_cmp);
            (score(&scene, &r, 0.15).0 .0, costs[costs.len() / 2])
        };
        let (clean_ok, clean_cost) = run(&scene.neighbours(), 2);
        let (robust_ok, robust_cost) = run(&nbrs, 2);
        let (all_ok, all_cost) = run(&nbrs, 3);
        eprintln!(
            "occluded neighbour: clean {clean_ok:.3}/{clean_cost:.3}, best-2 of 3 \
             {robust_ok:.3}/{robust_cost:.3}, all 3 {all_ok:.3}/{all_cost:.3}"
        );
        // Best-2 keeps the matching cost of the clean pair; averaging all three inflates
        // it by the occluded view's outlier cost (what the planemap data term would see).
        assert!(robust_ok >= 0.9, "{robust_ok}");
        assert!(
            (robust_cost - clean_cost).abs() < 0.02,
            "{robust_cost} vs {clean_cost}"
        );
        assert!(all_cost > clean_cost + 0.2, "{all_cost} vs {clean_cost}");
    }

    #[test]
    fn plane_families_have_the_requested_geometry() {
        let scene = TestScene::new();
        let view = &scene.views[0];
        let depths = fronto_parallel_depths(2.0, 8.0, 5).unwrap();
        assert!((depths[0] - 2.0).abs() < 1e-12 && (depths[4] - 8.0).abs() < 1e-12);
        let inv: Vec<f64> = depths.iter().map(|d| 1.0 / d).collect();
        for w in inv.windows(3) {
            assert!(((w[0] - w[1]) - (w[1] - w[2])).abs() < 1e-12);
        }
        let planes = fronto_parallel_planes(view, 2.0, 8.0, 5).unwrap();
        for (plane, &z) in planes.iter().zip(&depths) {
            for (x, y) in [(0, 0), (80, 60), (159, 5)] {
                let xw = pixel_on_plane(view, x, y, plane).unwrap();
                assert!((view.project(&xw).unwrap().1 - z).abs() < 1e-9);
            }
        }
        assert!(fronto_parallel_depths(3.0, 2.0, 4).is_err());
        assert!(fronto_parallel_depths(1.0, 2.0, 0).is_err());
        let axes = [Vector3::x(), Vector3::y(), Vector3::z()];
        let sweep = axis_sweep_planes(view, &axes, 4.0, 6.0, 10).unwrap();
        assert_eq!(sweep.len(), 30);
        // The y sweep (roughly the viewing direction) covers the depth range −6..−4.
        let ys: Vec<f64> = sweep[10..20].iter().map(|p| p.offset).collect();
        assert!(
            ys[0] < -0.3 && ys[9] > 1.0 && ys.windows(2).all(|w| w[1] > w[0]),
            "{ys:?}"
        );
        assert!(axis_planes(&[Vector3::zeros()], &[1.0]).is_err());
    }

    #[test]
    fn neighbours_prefer_shared_points_at_useful_angles() {
        let cam = Camera::pinhole(64, 48, 60.0, 60.0, 32.0, 24.0);
        let target = Vector3::zeros();
        let view = |i: u32, eye: Vector3<f64>| View {
            id: i,
            name: format!("v{i}"),
            camera: cam.clone(),
            cam_from_world: look_at(&eye, &target, &Vector3::z()),
            image_path: None,
        };
        let views = vec![
            view(0, Vector3::new(0.0, -5.0, 0.0)),
            view(1, Vector3::new(0.05, -5.0, 0.0)), // almost no baseline
            view(2, Vector3::new(1.5, -5.0, 0.0)),  // ~17°: good
            view(3, Vector3::new(-1.5, -5.0, 0.0)), // good, but shares fewer points
            view(4, Vector3::new(-5.0, 0.0, 0.0)),  // 90°: too wide
            view(5, Vector3::new(0.0, -6.0, 0.0)),  // shares nothing
        ];
        let mut cloud = SparseCloud::default();
        for i in 0..40 {
            let p = Vector3::new((i % 7) as f64 * 0.1, 0.0, (i / 7) as f64 * 0.1);
            let track: Vec<u32> = if i < 25 {
                vec![0, 1, 2, 3, 4]
            } else {
                vec![0, 1, 2, 4]
            };
            cloud.positions.push(p);
            cloud.colors.push([0; 3]);
            cloud.tracks.push(track);
            cloud.errors.push(0.0);
            cloud.confidence.push(1.0);
        }
        let scene = Scene { views, cloud };
        assert_eq!(select_neighbours(&scene, 0, 3).unwrap(), vec![2, 3, 1]);
        assert_eq!(select_neighbours(&scene, 0, 10).unwrap(), vec![2, 3, 1, 4]);
        assert!(matches!(
            select_neighbours(&scene, 6, 2),
            Err(PhotoError::ViewIndex { index: 6, count: 6 })
        ));
        // Without tracks the optical-axis angle decides: view 4 (90°) comes last.
        let no_cloud = Scene {
            views: scene.views.clone(),
            cloud: SparseCloud::default(),
        };
        let order = select_neighbours(&no_cloud, 0, 5).unwrap();
        assert_eq!(order.len(), 5);
        // 2 and 3 (~17°) first, then the near-zero baseline 1; the 90° view 4 and the
        // same-axis view 5 both sit on the floor weight, tied, lower index first.
        assert_eq!(order, vec![2, 3, 1, 4, 5]);
    }

    #[test]
    fn bad_inputs_are_errors() {
        let scene = TestScene::new();
        let planes = fronto_parallel_planes(&scene.views[0], 4.0, 6.0, 4).unwrap();
        let cfg = PhotoConfig::default();
        assert!(plane_cost_volume(&scene.views[0], &scene.images[0], &[], &planes, &cfg).is_err());
        assert!(plane_cost_volume(
            &scene.views[0],
            &scene.images[0],
            &scene.neighbours(),
            &[],
            &cfg
        )
        .is_err());
        let small = ImageF32::filled(10, 10, 3, 0.5);
        let err = plane_cost_volume(&scene.views[0], &small, &scene.neighbours(), &planes, &cfg)
            .unwrap_err();
        assert!(err.to_string().contains("cam0"), "{err}");
        let mut distorted = scene.views[1].clone();
        distorted.camera = Camera::new(
            crate::geometry::CameraModel::SimpleRadial,
            WIDTH,
            HEIGHT,
            vec![FOCAL, 80.0, 60.0, 0.1],
        )
        .unwrap();
        let err = plane_cost_volume(
            &scene.views[0],
            &scene.images[0],
            &[(&distorted, &scene.images[1])],
            &planes,
            &cfg,
        )
        .unwrap_err();
        assert!(matches!(err, PhotoError::Distorted(_)));
        let volume = plane_cost_volume(
            &scene.views[0],
            &scene.images[0],
            &scene.neighbours(),
            &planes,
            &cfg,
        )
        .unwrap();
        assert!(winner_takes_all(&volume, &scene.views[0], &planes[..2], 1).is_err());
    }

    /// A textured foreground half-plane (depth 4, bright) in front of a textured background
    /// plane (depth 6, dark), seen by a reference camera and two neighbours 0.6 m to either
    /// side; returns the views, images and the reference's true depth per pixel.
    fn depth_edge_scene() -> (Vec<View>, Vec<ImageF32>, Vec<f64>) {
        occluder_scene(|x| x < 0.0)
    }

    /// [`depth_edge_scene`] with the foreground (plane y = −1, depth 4) where `front(x)`.
    fn occluder_scene(front: impl Fn(f64) -> bool) -> (Vec<View>, Vec<ImageF32>, Vec<f64>) {
        let views: Vec<View> = [-0.6, 0.0, 0.6]
            .iter()
            .enumerate()
            .map(|(i, &dx)| {
                let eye = Vector3::new(dx, -5.0, 0.0);
                test_view(i, &eye, &(eye + Vector3::y()))
            })
            .collect();
        // (grey level, depth along +y from the cameras' plane y = −5) of what a ray sees.
        let hit = |o: &Vector3<f64>, d: &Vector3<f64>| -> (f64, f64) {
            let near = o + d * ((-1.0 - o.y) / d.y);
            if front(near.x) {
                let g = 0.55 + 0.4 * value_noise(near.x, near.z, 0.05, 3);
                return (g, near.y + 5.0);
            }
            let back = o + d * ((1.0 - o.y) / d.y);
            (0.05 + 0.4 * value_noise(back.x, back.z, 0.05, 4), 6.0)
        };
        let images: Vec<ImageF32> = views
            .iter()
            .enumerate()
            .map(|(i, view)| ray_cast(view, 7 + i as u64, |o, d| [hit(o, d).0 as f32; 3]))
            .collect();
        let reference = &views[1];
        let truth = (0..HEIGHT * WIDTH)
            .map(|p| {
                let (o, d) = reference.ray(&Vector2::new(
                    (p % WIDTH) as f64 + 0.5,
                    (p / WIDTH) as f64 + 0.5,
                ));
                hit(&o, &d).1
            })
            .collect();
        (views, images, truth)
    }

    /// The sweep baseline's aggregation (5×5 NCC, guided filter over 15×15) against a plain
    /// 15×15 NCC window at a depth edge: both are accurate away from it, but the big window
    /// drags the foreground's depth over the background beside the edge (fattening) and the
    /// edge-aware filter much less.
    #[test]
    fn guided_aggregation_fattens_depth_edges_less_than_a_big_window() {
        let (views, images, truth) = depth_edge_scene();
        let nbrs = [(&views[0], &images[0]), (&views[2], &images[2])];
        let planes = fronto_parallel_planes(&views[1], 3.5, 7.0, 96).unwrap();
        // Pixels within 7 px (horizontally) of a depth jump, and the rest; border excluded.
        let w = WIDTH as usize;
        let near_edge = |p: usize| {
            let (x, y) = (p % w, p / w);
            (x.saturating_sub(7)..(x + 8).min(w)).any(|q| (truth[y * w + q] - truth[p]).abs() > 0.5)
        };
        let score = |cfg: &PhotoConfig| {
            let sweep = SweepConfig {
                photo: *cfg,
                ..Default::default()
            };
            let r = plane_sweep(&views[1], &images[1], &nbrs, &planes, &sweep).unwrap();
            let (mut near, mut far) = ((0usize, 0usize), (0usize, 0usize));
            for y in 10..HEIGHT as usize - 10 {
                for x in 10..w - 10 {
                    let p = y * w + x;
                    let ok = ((r.depth[p] as f64 - truth[p]) / truth[p]).abs() <= 0.01;
                    let slot = if near_edge(p) { &mut near } else { &mut far };
                    slot.0 += usize::from(ok);
                    slot.1 += 1;
                }
            }
            (near.0 as f64 / near.1 as f64, far.0 as f64 / far.1 as f64)
        };
        let window = score(&PhotoConfig {
            window_radius: 7,
            ..Default::default()
        });
        let guided = score(&PhotoConfig {
            window_radius: 2,
            aggregation: Aggregation::Guided {
                radius: 7,
                eps: 1e-3,
            },
            ..Default::default()
        });
        eprintln!("near / away from the edge within 1%: 15x15 NCC {window:.3?}, 5x5 + guided {guided:.3?}");
        assert!(
            window.1 >= 0.95 && guided.1 >= 0.95,
            "away from the edge: {window:?} {guided:?}"
        );
        assert!(
            guided.0 >= window.0 + 0.3,
            "near the edge: guided {} vs window {}",
            guided.0,
            window.0
        );
    }

    /// The window samples of reference pixel `(x, y)` against neighbour `j` on `plane`: the
    /// reference's grey value, the warped neighbour's (`NaN` where it does not warp inside)
    /// and the support weight, for every window pixel inside the image.
    fn window_samples(
        scene: &TestScene,
        plane: &Plane,
        (x, y): (i64, i64),
        r: i64,
        (sigma_color, sigma_space): (f32, f32),
    ) -> Vec<(f32, f32, f32)> {
        let (ref_grey, nbr_grey) = (scene.images[0].to_gray(), scene.images[1].to_gray());
        let h = scene.homography(plane);
        let colour = |qx: i64, qy: i64| scene.images[0].pixel(qx as u32, qy as u32).to_vec();
        let centre = colour(x, y);
        let mut out = Vec::new();
        for qy in (y - r).max(0)..=(y + r).min(HEIGHT as i64 - 1) {
            for qx in (x - r).max(0)..=(x + r).min(WIDTH as i64 - 1) {
                let d2: f32 = colour(qx, qy)
                    .iter()
                    .zip(&centre)
                    .map(|(a, b)| (a - b) * (a - b))
                    .sum::<f32>()
                    / 3.0;
                let s2 = ((qx - x) * (qx - x) + (qy - y) * (qy - y)) as f32;
                let weight = (-d2 / (2.0 * sigma_color * sigma_color)
                    - s2 / (2.0 * sigma_space * sigma_space))
                    .exp();
                let hx = h * Vector3::new(qx as f64 + 0.5, qy as f64 + 0.5, 1.0);
                let mut px = [f32::NAN];
                let ok = hx.z > 0.0 && nbr_grey.sample_bilinear(hx.x / hx.z, hx.y / hx.z, &mut px);
                let v = if ok { px[0] } else { f32::NAN };
                out.push((ref_grey.get(qx as u32, qy as u32, 0), v, weight));
            }
        }
        out
    }

    /// The support-weighted NCC path against a naive weighted NCC (weighted means, weighted
    /// centred moments, per-weight texture threshold), windows partly outside the neighbour
    /// included; and with huge σ it is the box NCC.
    #[test]
    fn support_weighted_ncc_matches_a_naive_weighted_ncc() {
        let scene = TestScene::new();
        let planes = fronto_parallel_planes(&scene.views[0], 4.5, 5.5, 3).unwrap();
        let nbr = [(&scene.views[1], &scene.images[1])];
        let sigmas = (0.1f32, 2.0f32);
        let cfg = PhotoConfig {
            best_k: 1,
            window_radius: 2,
            support_sigma_color: sigmas.0,
            support_sigma_space: sigmas.1,
            ..Default::default()
        };
        let volume =
            plane_cost_volume(&scene.views[0], &scene.images[0], &nbr, &planes, &cfg).unwrap();
        let norm = cfg.effective_normalization();
        let mut partial = 0;
        for (k, plane) in planes.iter().enumerate() {
            for &(x, y) in &[
                (0i64, 0i64),
                (1, 60),
                (80, 60),
                (159, 119),
                (158, 3),
                (40, 20),
                (75, 61),
            ] {
                let samples = window_samples(&scene, plane, (x, y), 2, sigmas);
                let total: f64 = samples.iter().map(|s| s.2 as f64).sum();
                let valid: Vec<_> = samples.iter().filter(|s| s.1.is_finite()).collect();
                partial += usize::from(valid.len() < samples.len() && !valid.is_empty());
                let wsum: f64 = valid.iter().map(|s| s.2 as f64).sum();
                let want = if wsum > 0.0 && wsum >= 0.5 * total {
                    let mean = |f: &dyn Fn(&(f32, f32, f32)) -> f32| {
                        valid.iter().map(|s| s.2 as f64 * f(s) as f64).sum::<f64>() / wsum
                    };
                    let (mi, mv) = (mean(&|s| s.0), mean(&|s| s.1));
                    let (mut cov, mut va, mut vb) = (0.0, 0.0, 0.0);
                    for s in &valid {
                        let (di, dv) = (s.0 as f64 - mi, s.1 as f64 - mv);
                        cov += s.2 as f64 * di * dv;
                        va += s.2 as f64 * di * di;
                        vb += s.2 as f64 * dv * dv;
                    }
                    let min = crate::photo::measures::NCC_MIN_VARIANCE * wsum;
                    let score = (va > min && vb > min)
                        .then(|| (cov / (va * vb).sqrt()).clamp(-1.0, 1.0) as f32);
                    norm.cost(score.map(|s| 1.0 - s))
                } else {
                    1.0
                };
                let got = volume.cost(x as usize, y as usize, k);
                assert!(
                    (got - want).abs() < 2e-4,
                    "plane {k} ({x},{y}): weighted path {got} vs naive {want}"
                );
            }
        }
        assert!(partial > 0, "no window was partly outside the neighbour");
        // σ → ∞: every weight 1, the box NCC.
        let flat = PhotoConfig {
            support_sigma_color: 1e6,
            support_sigma_space: 1e6,
            ..cfg
        };
        let boxed = PhotoConfig {
            support_sigma_color: 0.0,
            ..cfg
        };
        let a = plane_cost_volume(&scene.views[0], &scene.images[0], &nbr, &planes, &flat).unwrap();
        let b =
            plane_cost_volume(&scene.views[0], &scene.images[0], &nbr, &planes, &boxed).unwrap();
        let worst = a
            .costs
            .iter()
            .zip(&b.costs)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0f32, f32::max);
        assert!(
            worst < 1e-4,
            "uniform weights differ from the box NCC by {worst}"
        );
    }

    /// Weighted NCC keeps NCC's invariance: a gain and a bias on the neighbour change no cost.
    #[test]
    fn support_weighted_ncc_ignores_gain_and_bias() {
        let scene = TestScene::new();
        let planes = fronto_parallel_planes(&scene.views[0], 4.5, 5.5, 4).unwrap();
        let cfg = PhotoConfig {
            best_k: 1,
            window_radius: 2,
            support_sigma_color: 0.08,
            support_sigma_space: 2.0,
            ..Default::default()
        };
        let mut dimmed = scene.images[1].clone();
        for v in &mut dimmed.data {
            *v = 0.6 * *v + 0.2;
        }
        let volume = |img: &ImageF32| {
            plane_cost_volume(
                &scene.views[0],
                &scene.images[0],
                &[(&scene.views[1], img)],
                &planes,
                &cfg,
            )
            .unwrap()
        };
        let (a, b) = (volume(&scene.images[1]), volume(&dimmed));
        // On the textured half (on plain paint the gain moves the variance across NCC's
        // texture threshold, as it does for the box NCC).
        let mut checked = 0;
        let mut worst = 0.0f32;
        for y in 0..HEIGHT {
            for x in 0..WIDTH {
                if scene.truth(x, y).1 > -0.1 {
                    continue;
                }
                for k in 0..planes.len() {
                    let (ca, cb) = (
                        a.cost(x as usize, y as usize, k),
                        b.cost(x as usize, y as usize, k),
                    );
                    worst = worst.max((ca - cb).abs());
                    checked += usize::from(ca < 1.0);
                }
            }
        }
        assert!(checked > 2_000, "{checked} costs checked");
        assert!(worst < 1e-3, "gain and bias moved a cost by {worst}");
    }

    /// Bright pickets 0.1 m wide every 0.5 m (about 4 px, every 19 px) in front of a dark
    /// textured wall 2 m behind them: with box-weighted 5×5 NCC (then the guided filter, as
    /// the sweep baseline) the wall between the pickets takes their depth; with adaptive
    /// support weights the wall's pixels match the wall.
    #[test]
    fn support_weights_keep_a_picket_fence_depth_off_the_wall_behind() {
        let picket = |x: f64| x.rem_euclid(0.5) < 0.1;
        let (views, images, truth) = occluder_scene(picket);
        let nbrs = [(&views[0], &images[0]), (&views[2], &images[2])];
        let planes = fronto_parallel_planes(&views[1], 3.5, 7.0, 96).unwrap();
        let w = WIDTH as usize;
        // Wall pixels within 4 px (horizontally) of a picket, away from the border.
        let beside: Vec<usize> = (10..HEIGHT as usize - 10)
            .flat_map(|y| (10..w - 10).map(move |x| y * w + x))
            .filter(|&p| {
                let (x, y) = (p % w, p / w);
                truth[p] > 5.0 && (x - 4..=x + 4).any(|q| truth[y * w + q] < 5.0)
            })
            .collect();
        let score = |sigma_color: f32| {
            let sweep = SweepConfig {
                photo: PhotoConfig {
                    window_radius: 2,
                    aggregation: Aggregation::Guided {
                        radius: 7,
                        eps: 1e-3,
                    },
                    support_sigma_color: sigma_color,
                    support_sigma_space: 3.0,
                    ..Default::default()
                },
                ..Default::default()
            };
            let r = plane_sweep(&views[1], &images[1], &nbrs, &planes, &sweep).unwrap();
            beside
                .iter()
                .filter(|&&p| ((r.depth[p] as f64 - truth[p]) / truth[p]).abs() <= 0.01)
                .count() as f64
                / beside.len() as f64
        };
        let (boxed, weighted) = (score(0.0), score(0.05));
        eprintln!(
            "wall beside the pickets within 1%: box {boxed:.3}, weighted {weighted:.3} ({} px)",
            beside.len()
        );
        assert!(
            beside.len() > 1000,
            "{} wall pixels beside pickets",
            beside.len()
        );
        assert!(
            weighted >= boxed + 0.2,
            "weighted {weighted} vs box {boxed}"
        );
    }
}
