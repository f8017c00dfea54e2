//! SfM-like sparse points: corner features on textured surfaces, matched by visibility into
//! every view that could see them, with pixel noise, outliers and optional PMVS-like normals.
//!
//! Features come only from textured surfaces: a pixel must be a Shi–Tomasi corner of the
//! noise-free image *and* its surface texture must have contrast at that view's pixel scale,
//! so plain paint (and corners made only by geometry or shading) gets no points — as with
//! real SfM on blank walls.
//!
//! Detection is scale-invariant, like SIFT's octaves in real SfM: an image wider than
//! [`DETECTION_WIDTH`] is box-reduced by the integer factor [`detection_factor`] before the
//! corner response, and the texture-contrast tests use the reduced pixel scale. The same
//! scene rendered at 320×240 and at 1280×960 then yields nearly the same points (on the same
//! surfaces, in the same number), instead of only the finest textures surviving at high
//! resolution. Images up to 1.5 × [`DETECTION_WIDTH`] are detected at full resolution.

use nalgebra::{Vector2, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use super::render::{gaussian, ViewRender};
use super::spec::SparseSpec;
use super::texture::mix64;
use super::world::World;
use crate::scene::{SparseCloud, View};

type V3 = Vector3<f64>;

/// Sparse points and their per-point truth.
pub(crate) struct SparseOut {
    pub cloud: SparseCloud,
    pub observations: Vec<Vec<[f64; 2]>>,
    pub plane_ids: Vec<u16>,
    pub outlier: Vec<bool>,
    pub true_positions: Vec<V3>,
}

/// A detected feature, back-projected onto the true surface.
struct Candidate {
    pixel: usize,
    point: V3,
    normal: V3,
    prim: u32,
    color: [u8; 3],
    /// Views (indices) that match it, sorted; includes the detecting view.
    track: Vec<u32>,
}

/// Smaller eigenvalue of the 5×5 structure tensor of `gray` (Sobel gradients / 8).
fn shi_tomasi(gray: &[f32], w: usize, h: usize) -> Vec<f32> {
    let mut gxx = vec![0.0f32; w * h];
    let mut gyy = vec![0.0f32; w * h];
    let mut gxy = vec![0.0f32; w * h];
    for y in 1..h.saturating_sub(1) {
        for x in 1..w - 1 {
            let p = |dx: isize, dy: isize| {
                gray[(y as isize + dy) as usize * w + (x as isize + dx) as usize]
            };
            let gx =
                (p(1, -1) + 2.0 * p(1, 0) + p(1, 1) - p(-1, -1) - 2.0 * p(-1, 0) - p(-1, 1)) / 8.0;
            let gy =
                (p(-1, 1) + 2.0 * p(0, 1) + p(1, 1) - p(-1, -1) - 2.0 * p(0, -1) - p(1, -1)) / 8.0;
            let i = y * w + x;
            gxx[i] = gx * gx;
            gyy[i] = gy * gy;
            gxy[i] = gx * gy;
        }
    }
    const R: usize = 2;
    let mut out = vec![0.0f32; w * h];
    for y in R + 1..h.saturating_sub(R + 1) {
        for x in R + 1..w.saturating_sub(R + 1) {
            let (mut a, mut b, mut c) = (0.0f32, 0.0f32, 0.0f32);
            for yy in y - R..=y + R {
                let row = yy * w;
                for xx in x - R..=x + R {
                    a += gxx[row + xx];
                    b += gxy[row + xx];
                    c += gyy[row + xx];
                }
            }
            let half_trace = 0.5 * (a + c);
            let d = (0.25 * (a - c) * (a - c) + b * b).sqrt();
            out[y * w + x] = half_trace - d;
        }
    }
    out
}

/// Pixel footprint (metres per pixel at depth `z`).
#[inline]
fn footprint(view: &View, z: f64) -> f64 {
    z / view.camera.fx()
}

/// Image width at which features are detected (see the module doc).
pub(crate) const DETECTION_WIDTH: u32 = 320;

/// Integer reduction factor of `view`'s image for feature detection: the nearest integer to
/// width / [`DETECTION_WIDTH`], at least 1.
pub(crate) fn detection_factor(view: &View) -> usize {
    ((view.camera.width as f64 / DETECTION_WIDTH as f64).round() as usize).max(1)
}

/// `gray` (w × h) box-averaged over f × f blocks; the partial blocks at the right and bottom
/// edges are dropped. Returns the reduced image and its size.
fn reduce(gray: &[f32], w: usize, h: usize, f: usize) -> (Vec<f32>, usize, usize) {
    let (rw, rh) = (w / f, h / f);
    let inv = 1.0 / (f * f) as f32;
    let mut out = vec![0.0f32; rw * rh];
    for (ry, row) in out.chunks_exact_mut(rw.max(1)).enumerate().take(rh) {
        for (rx, o) in row.iter_mut().enumerate() {
            let mut acc = 0.0f32;
            for y in ry * f..(ry + 1) * f {
                acc += gray[y * w + rx * f..y * w + (rx + 1) * f]
                    .iter()
                    .sum::<f32>();
            }
            *o = acc * inv;
        }
    }
    (out, rw, rh)
}

/// Everything the matcher checks for point `x` (normal `n`) in view `j`: in the image, facing and not too oblique, not occluded,
/// scale compatible and textured at j's pixel scale.
#[allow(clippy::too_many_arguments)]
fn matches_in_view(
    world: &World,
    view: &View,
    cfg: &SparseSpec,
    x: &V3,
    n: &V3,
    ref_footprint: f64,
    cos_max: f64,
) -> bool {
    let Some((xy, z)) = view.project(x) else {
        return false;
    };
    let margin = 2.0;
    let cam = &view.camera;
    if xy.x < margin
        || xy.y < margin
        || xy.x > cam.width as f64 - margin
        || xy.y > cam.height as f64 - margin
    {
        return false;
    }
    let c = view.center();
    let to_cam = c - x;
    let dist = to_cam.norm();
    if n.dot(&to_cam) < cos_max * dist {
        return false;
    }
    let fp = footprint(view, z);
    let ratio = fp / ref_footprint;
    if ratio > cfg.max_scale_ratio || ratio < 1.0 / cfg.max_scale_ratio {
        return false;
    }
    // Occlusion: the first surface along the ray from j's centre must be this point. The ray
    // is scaled to unit depth so `t` is comparable with `z`.
    let (origin, dir) = view.ray(&xy);
    let Some(hit) = world.trace(&origin, &dir) else {
        return false;
    };
    if (hit.t - z).abs() > 1e-5 * z.max(1.0) {
        return false;
    }
    let surf = world.surface(&hit, &origin, &dir);
    let m = &world.materials[world.prims[hit.prim as usize].material];
    let detect_fp = fp * detection_factor(view) as f64;
    m.contrast(surf.s, surf.t, 2.0 * detect_fp) >= cfg.min_texture_contrast
}

/// Detects candidates in view `vi` and finds their tracks.
fn detect(
    world: &World,
    views: &[View],
    renders: &[ViewRender],
    vi: usize,
    cfg: &SparseSpec,
) -> Vec<Candidate> {
    let view = &views[vi];
    let r = &renders[vi];
    let (w, h) = (view.camera.width as usize, view.camera.height as usize);
    // Detection on the reduced image (f = 1: the image itself); a reduced pixel maps to the
    // full-resolution pixel at its block's centre.
    let f = detection_factor(view);
    let (resp, dw, dh) = if f == 1 {
        (shi_tomasi(&r.clean_gray, w, h), w, h)
    } else {
        let (g, rw, rh) = reduce(&r.clean_gray, w, h, f);
        (shi_tomasi(&g, rw, rh), rw, rh)
    };
    let full = |i: usize| ((i / dw) * f + f / 2) * w + (i % dw) * f + f / 2;
    let cell = cfg.cell_px as usize;
    let cos_max = cfg.max_view_angle_deg.to_radians().cos();
    let mut picks: Vec<(f32, usize)> = Vec::new();
    for cy in (0..dh).step_by(cell) {
        for cx in (0..dw).step_by(cell) {
            let mut best: Option<(f32, usize)> = None;
            for y in cy..(cy + cell).min(dh) {
                for x in cx..(cx + cell).min(dw) {
                    let i = y * dw + x;
                    if resp[i] as f64 >= cfg.min_corner_response
                        && r.prim[full(i)] != u32::MAX
                        && best.is_none_or(|(b, _)| resp[i] > b)
                    {
                        best = Some((resp[i], full(i)));
                    }
                }
            }
            if let Some(b) = best {
                picks.push(b);
            }
        }
    }
    // Strongest first; pixel index breaks ties so the order is total.
    picks.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    let mut out = Vec::new();
    for (_, i) in picks {
        if out.len() >= cfg.max_features_per_view {
            break;
        }
        let (x, y) = ((i % w) as u32, (i / w) as u32);
        let (origin, dir) = view.ray(&Vector2::new(x as f64 + 0.5, y as f64 + 0.5));
        let Some(hit) = world.trace(&origin, &dir) else {
            continue;
        };
        let surf = world.surface(&hit, &origin, &dir);
        let fp = footprint(view, hit.t);
        let m = &world.materials[world.prims[hit.prim as usize].material];
        if m.contrast(surf.s, surf.t, 2.0 * fp * f as f64) < cfg.min_texture_contrast {
            continue;
        }
        let track: Vec<u32> = (0..views.len())
            .filter(|&j| {
                j == vi
                    || matches_in_view(
                        world,
                        &views[j],
                        cfg,
                        &surf.point,
                        &surf.normal,
                        fp,
                        cos_max,
                    )
            })
            .map(|j| j as u32)
            .collect();
        if track.len() < cfg.min_track {
            continue;
        }
        let to_u8 = |v: f32| (v.clamp(0.0, 1.0) * 255.0).round() as u8;
        out.push(Candidate {
            pixel: i,
            point: surf.point,
            normal: surf.normal,
            prim: hit.prim,
            color: [
                to_u8(r.clean_rgb[3 * i]),
                to_u8(r.clean_rgb[3 * i + 1]),
                to_u8(r.clean_rgb[3 * i + 2]),
            ],
            track,
        });
    }
    out
}

/// Confidence from track length: 1 − exp(−(n − 1)/2.5) (0.33 for 2 views, 0.8 for 5).
fn confidence(track_len: usize) -> f64 {
    1.0 - (-((track_len as f64) - 1.0) / 2.5).exp()
}

/// A unit vector near `n`: tangent Gaussian perturbation with σ `sigma_rad` per axis.
fn perturb_normal(n: &V3, sigma_rad: f64, rng: &mut ChaCha8Rng) -> V3 {
    let helper = if n.x.abs() < 0.9 { V3::x() } else { V3::y() };
    let a = n.cross(&helper).normalize();
    let b = n.cross(&a);
    (n + a * (sigma_rad * gaussian(rng)) + b * (sigma_rad * gaussian(rng))).normalize()
}

/// Samples the sparse cloud from rendered views.
pub(crate) fn sample(
    world: &World,
    views: &[View],
    renders: &[ViewRender],
    cfg: &SparseSpec,
    seed: u64,
    progress: &(dyn Fn(usize) + Sync),
) -> SparseOut {
    let per_view: Vec<Vec<Candidate>> = (0..views.len())
        .into_par_iter()
        .map(|vi| {
            let c = detect(world, views, renders, vi, cfg);
            progress(vi);
            c
        })
        .collect();

    // Merge duplicates sequentially (views in order): a candidate is dropped when its
    // detecting view already holds an accepted point within DEDUP_PX detection pixels
    // (DEDUP_PX × the view's detection factor at full resolution).
    const DEDUP_PX: f64 = 3.0;
    let mut taken: Vec<Vec<Vector2<f64>>> = vec![Vec::new(); views.len()];
    // Buckets of 8 detection pixels: the ±1 bucket search below covers the dedup radius.
    let bucket_px = |v: &View| 8 * detection_factor(v);
    let grid = |v: &View| {
        let b = bucket_px(v);
        (v.camera.width as usize).div_ceil(b) * (v.camera.height as usize).div_ceil(b)
    };
    let mut buckets: Vec<Vec<Vec<u32>>> = views.iter().map(|v| vec![Vec::new(); grid(v)]).collect();
    let bucket_of = |v: &View, xy: &Vector2<f64>| -> Option<usize> {
        let b = bucket_px(v);
        let (bx, by) = ((xy.x / b as f64).floor(), (xy.y / b as f64).floor());
        let bw = (v.camera.width as usize).div_ceil(b);
        let bh = (v.camera.height as usize).div_ceil(b);
        (bx >= 0.0 && by >= 0.0 && (bx as usize) < bw && (by as usize) < bh)
            .then(|| by as usize * bw + bx as usize)
    };
    let mut accepted: Vec<Candidate> = Vec::new();
    for (vi, cands) in per_view.into_iter().enumerate() {
        let view = &views[vi];
        let w = view.camera.width as usize;
        let dedup_px = DEDUP_PX * detection_factor(view) as f64;
        let b = bucket_px(view);
        for c in cands {
            let xy = Vector2::new((c.pixel % w) as f64 + 0.5, (c.pixel / w) as f64 + 0.5);
            let bw = (view.camera.width as usize).div_ceil(b) as isize;
            let bh = (view.camera.height as usize).div_ceil(b) as isize;
            let (bx, by) = ((xy.x / b as f64) as isize, (xy.y / b as f64) as isize);
            let mut dup = false;
            'search: for dy in -1..=1 {
                for dx in -1..=1 {
                    let (x, y) = (bx + dx, by + dy);
                    if x < 0 || y < 0 || x >= bw || y >= bh {
                        continue;
                    }
                    for &k in &buckets[vi][(y * bw + x) as usize] {
                        if (taken[vi][k as usize] - xy).norm() < dedup_px {
                            dup = true;
                            break 'search;
                        }
                    }
                }
            }
            if dup {
                continue;
            }
            for &j in &c.track {
                let vj = &views[j as usize];
                if let Some((p, _)) = vj.project(&c.point) {
                    if let Some(b) = bucket_of(vj, &p) {
                        buckets[j as usize][b].push(taken[j as usize].len() as u32);
                        taken[j as usize].push(p);
                    }
                }
            }
            accepted.push(c);
        }
    }

    // Noise, per point from its own seeded generator.
    let n_in = accepted.len();
    let mut out = SparseOut {
        cloud: SparseCloud::default(),
        observations: Vec::with_capacity(n_in),
        plane_ids: Vec::with_capacity(n_in),
        outlier: Vec::with_capacity(n_in),
        true_positions: Vec::with_capacity(n_in),
    };
    let mut normals = Vec::with_capacity(n_in);
    let sigma_n = cfg.normal_noise_deg.to_radians();
    for (pi, c) in accepted.iter().enumerate() {
        let mut rng = ChaCha8Rng::seed_from_u64(mix64(seed ^ mix64(0x5EED_0000 + pi as u64)));
        // 3D error consistent with the pixel noise: σ_px × footprint, reduced by √(track).
        let mean_fp = c
            .track
            .iter()
            .filter_map(|&j| {
                views[j as usize]
                    .project(&c.point)
                    .map(|(_, z)| footprint(&views[j as usize], z))
            })
            .sum::<f64>()
            / c.track.len() as f64;
        let sigma3 = cfg.pixel_noise * mean_fp / (c.track.len() as f64).sqrt();
        let noisy =
            c.point + V3::new(gaussian(&mut rng), gaussian(&mut rng), gaussian(&mut rng)) * sigma3;
        let mut obs = Vec::with_capacity(c.track.len());
        let mut err = 0.0;
        for &j in &c.track {
            let v = &views[j as usize];
            let (p, _) = v.project(&c.point).expect("matched views see the point");
            let o = Vector2::new(
                p.x + cfg.pixel_noise * gaussian(&mut rng),
                p.y + cfg.pixel_noise * gaussian(&mut rng),
            );
            if let Some((q, _)) = v.project(&noisy) {
                err += (q - o).norm();
            }
            obs.push([o.x, o.y]);
        }
        let prim = &world.prims[c.prim as usize];
        out.cloud.positions.push(noisy);
        out.cloud.colors.push(c.color);
        out.cloud.errors.push(err / c.track.len() as f64);
        out.cloud.confidence.push(confidence(c.track.len()));
        out.cloud.tracks.push(c.track.clone());
        out.observations.push(obs);
        out.plane_ids.push(prim.plane.map_or(0, |i| (i + 1) as u16));
        out.outlier.push(false);
        out.true_positions.push(c.point);
        normals.push(perturb_normal(&c.normal, sigma_n, &mut rng));
    }

    // Outliers: points floating in free space in front of a surface seen by one view, with
    // tracks over views where they project into the image (plausible mismatches).
    let f = cfg.outlier_fraction;
    let n_out = if n_in == 0 || f <= 0.0 {
        0
    } else {
        ((n_in as f64) * f / (1.0 - f)).round() as usize
    };
    let mut made = 0;
    let mut attempt = 0u64;
    while made < n_out && attempt < 50 * n_out as u64 + 100 {
        let mut rng = ChaCha8Rng::seed_from_u64(mix64(seed ^ mix64(0x0071_1E00_0000 + attempt)));
        attempt += 1;
        let a = rng.random_range(0..views.len());
        let va = &views[a];
        let (w, h) = (va.camera.width as usize, va.camera.height as usize);
        let i = rng.random_range(0..w * h);
        let z = renders[a].depth[i] as f64;
        if z <= 0.0 {
            continue;
        }
        let (origin, dir) = va.ray(&Vector2::new((i % w) as f64 + 0.5, (i / w) as f64 + 0.5));
        let x = origin + dir * (z * rng.random_range(0.55..0.9));
        let mut seen: Vec<u32> = (0..views.len())
            .filter(|&j| {
                j != a
                    && views[j]
                        .project(&x)
                        .is_some_and(|(p, d)| d > 0.0 && views[j].camera.contains(&p))
            })
            .map(|j| j as u32)
            .collect();
        if seen.is_empty() {
            continue;
        }
        // Keep 1–3 random other views.
        let keep = rng.random_range(1..=3usize).min(seen.len());
        for k in 0..keep {
            let r = rng.random_range(k..seen.len());
            seen.swap(k, r);
        }
        seen.truncate(keep);
        seen.push(a as u32);
        seen.sort_unstable();
        let obs: Vec<[f64; 2]> = seen
            .iter()
            .map(|&j| {
                let (p, _) = views[j as usize].project(&x).expect("checked");
                [
                    p.x + cfg.pixel_noise * gaussian(&mut rng),
                    p.y + cfg.pixel_noise * gaussian(&mut rng),
                ]
            })
            .collect();
        let rgb = &renders[a].clean_rgb[3 * i..3 * i + 3];
        let to_u8 = |v: f32| (v.clamp(0.0, 1.0) * 255.0).round() as u8;
        let towards = (va.center() - x).normalize();
        out.cloud.positions.push(x);
        out.cloud
            .colors
            .push([to_u8(rgb[0]), to_u8(rgb[1]), to_u8(rgb[2])]);
        out.cloud
            .errors
            .push(cfg.pixel_noise * std::f64::consts::FRAC_PI_2.sqrt());
        out.cloud.confidence.push(confidence(seen.len()));
        out.cloud.tracks.push(seen);
        out.observations.push(obs);
        out.plane_ids.push(0);
        out.outlier.push(true);
        out.true_positions.push(x);
        normals.push(perturb_normal(&towards, sigma_n.max(0.2), &mut rng));
        made += 1;
    }
    if cfg.normals {
        out.cloud.normals = Some(normals);
    }
    out
}
