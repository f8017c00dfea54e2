//! Sky: pixels that see no surface get no depth.
//!
//! Every pixel of a planemap takes a plane, so without this stage the sky takes a wall's
//! plane extended upwards, or a horizontal plane at roof height, and the fused points and
//! depth maps carry it. A pixel is sky when all of these hold (each a cue the issue on real
//! photographs names, chosen because each alone fails somewhere):
//!
//! - **beyond the model**: no sparse point projects into its image column band at or above
//!   it ([`SkyConfig::point_margin`]): whatever the view sees there lies beyond everything
//!   structure-from-motion reconstructed;
//! - **above the horizon**: its ray rises at least [`SkyConfig::min_elevation_deg`] above the
//!   horizontal, for the vertical [`scene_vertical`] gives (off without one);
//! - **smooth and bright**: its 5×5 grey standard deviation is at most
//!   [`SkyConfig::max_std`], its grey level at least [`SkyConfig::min_brightness`] and it is
//!   bluer than red by [`SkyConfig::min_blueness`] (white and grey ceilings are neutral, so
//!   this is what keeps a room's plain ceiling: a grey overcast sky is missed, and keeps its
//!   depth as before);
//! - **connected to the image's top edge** through such pixels (4-neighbours): a plain wall
//!   enclosed by its windows and cornice is never reached, since the edges around it are
//!   not smooth.
//!
//! The labelling is left as it is elsewhere; sky pixels are relabelled "no plane" with depth
//! 0 ([`crate::nonplanar::NONPLANAR`] with no depth: label 0 in the planemap PNG, black in
//! its `_vis.png`, nothing in `fused.ply`).

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use crate::raster::ImageF32;
use crate::scene::{SparseCloud, View};

/// Settings of the sky stage (`[sky]` in the run's TOML config).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct SkyConfig {
    /// Give sky pixels no depth.
    pub enabled: bool,
    /// Largest 5×5 standard deviation of the grey image (`[0, 1]` scale) of a sky pixel,
    /// ≥ 0. Image noise alone gives about 0.007 on the synthetic scenes.
    pub max_std: f64,
    /// Least grey level of a sky pixel, in [0, 1].
    pub min_brightness: f64,
    /// Least grey level of a sky pixel as a fraction of the image's 99th-percentile grey
    /// level, in [0, 1]: the sky is the brightest part of an outdoor photograph, while a
    /// room's cool white ceiling, lit only indirectly, is near the image's median.
    pub min_relative_brightness: f64,
    /// How much bluer than red a sky pixel must be (`blue − red`, `[0, 1]` scale), in
    /// [-1, 1]. The skies of the real sets are 0.05–0.3 bluer than red at their top rows
    /// (castle-P19, Herz-Jesu-P8), the synthetic sky 0.3; neutral white or grey ceilings
    /// took up to 35 % of an interior's pixels for sky without this test (corridor).
    pub min_blueness: f64,
    /// Half-width of the image column band in which a projected sparse point blocks the
    /// pixels below it, and how far above the point the block reaches, as a fraction of
    /// the image width, ≥ 0.
    pub point_margin: f64,
    /// Least elevation of a sky pixel's ray above the horizontal, degrees in [-90, 90];
    /// −90 = off. Off by default: the background beyond a scene's ground is seen below the
    /// horizon from a raised camera (exterior: 47 % of its sky caught at 1°, 94 % off), and
    /// no surface was taken for sky without it on any scene.
    pub min_elevation_deg: f64,
    /// After the flood fill the sky grows into up to this many pixels beyond it (a count)
    /// wherever a pixel's colour is within `grow_tolerance` of the sky pixel beside it: the
    /// 5×5 texture window and the points' margin stop the fill a few pixels short of the
    /// skyline.
    pub grow_px: u32,
    /// Largest per-channel colour difference (`[0, 1]` scale) of that growth, ≥ 0.
    pub grow_tolerance: f64,
}

impl Default for SkyConfig {
    fn default() -> Self {
        SkyConfig {
            enabled: true,
            max_std: 0.02,
            min_brightness: 0.35,
            min_relative_brightness: 0.85,
            min_blueness: 0.03,
            point_margin: 0.01,
            min_elevation_deg: -90.0,
            grow_px: 3,
            grow_tolerance: 0.04,
        }
    }
}

impl SkyConfig {
    /// Checks ranges, naming the key at fault.
    pub fn validate(&self) -> Result<(), String> {
        let bad = |k: &str, v: f64, want: &str| Err(format!("sky.{k} must be {want}, got {v}"));
        if !(self.max_std >= 0.0 && self.max_std.is_finite()) {
            return bad("max_std", self.max_std, "finite and ≥ 0");
        }
        if !(0.0..=1.0).contains(&self.min_brightness) {
            return bad("min_brightness", self.min_brightness, "in [0, 1]");
        }
        if !(0.0..=1.0).contains(&self.min_relative_brightness) {
            return bad(
                "min_relative_brightness",
                self.min_relative_brightness,
                "in [0, 1]",
            );
        }
        if !(-1.0..=1.0).contains(&self.min_blueness) {
            return bad("min_blueness", self.min_blueness, "in [-1, 1]");
        }
        if !(self.point_margin >= 0.0 && self.point_margin.is_finite()) {
            return bad("point_margin", self.point_margin, "finite and ≥ 0");
        }
        if !(self.grow_tolerance >= 0.0 && self.grow_tolerance.is_finite()) {
            return bad("grow_tolerance", self.grow_tolerance, "finite and ≥ 0");
        }
        if !(-90.0..=90.0).contains(&self.min_elevation_deg) {
            return bad("min_elevation_deg", self.min_elevation_deg, "in [-90, 90]");
        }
        Ok(())
    }
}

/// The scene's vertical ("up", world frame): the cameras' common vertical
/// ([`crate::axes::camera_vertical`]) where their image rows pin one down, else the images'
/// mean "up" (tilted by the cameras' mean pitch); `None` without views.
pub fn scene_vertical(views: &[View]) -> Option<Vector3<f64>> {
    let mut mean_up = Vector3::zeros();
    for v in views {
        mean_up -= v
            .cam_from_world
            .rotation
            .inverse_transform_vector(&Vector3::y());
    }
    let up = crate::axes::camera_vertical(views).or_else(|| mean_up.try_normalize(1e-9))?;
    // camera_vertical's sign is arbitrary: make it agree with the images' "up".
    Some(if up.dot(&mean_up) < 0.0 { -up } else { up })
}

/// The sky pixels of one view (row-major), for its undistorted `image`, the sparse `cloud`
/// and the scene's vertical `up` ([`scene_vertical`]). All `false` when disabled.
pub fn sky_mask(
    view: &View,
    image: &ImageF32,
    cloud: &SparseCloud,
    up: Option<&Vector3<f64>>,
    cfg: &SkyConfig,
) -> Vec<bool> {
    let (w, h) = (view.camera.width as usize, view.camera.height as usize);
    let n = w * h;
    if !cfg.enabled || image.width as usize != w || image.height as usize != h || n == 0 {
        return vec![false; n];
    }
    // Beyond the model: per column, the highest row any point (2 px footprint) blocks; a
    // pixel is free when it lies above every point of its column band by the margin.
    let margin = (cfg.point_margin * w as f64).round() as i64;
    let mut top = vec![i64::MAX; w];
    for x in &cloud.positions {
        let Some((xy, z)) = view.project(x) else {
            continue;
        };
        if z <= 0.0 || !view.camera.contains(&xy) {
            continue;
        }
        let (px, py) = (xy.x as i64, xy.y as i64);
        for c in (px - margin).max(0)..=(px + margin).min(w as i64 - 1) {
            top[c as usize] = top[c as usize].min(py - margin);
        }
    }
    let std = crate::photo::local_std(image, 2);
    let grey_of = |px: &[f32]| match px.len() {
        0 => 0.0,
        1 | 2 => px[0],
        _ => 0.299 * px[0] + 0.587 * px[1] + 0.114 * px[2],
    };
    let c = image.channels.max(1) as usize;
    let mut greys: Vec<f32> = image.data.chunks_exact(c).map(grey_of).collect();
    let k = (greys.len() - 1) * 99 / 100;
    let p99 = *greys.select_nth_unstable_by(k, f32::total_cmp).1 as f64;
    let min_grey = cfg.min_brightness.max(cfg.min_relative_brightness * p99);
    let cos_min = (90.0 - cfg.min_elevation_deg).to_radians().cos();
    let up_cam = up.map(|u| view.cam_from_world.rotation * u);
    let candidate: Vec<bool> = (0..n)
        .map(|p| {
            let (x, y) = (p % w, p / w);
            if (y as i64) >= top[x] || std[p] > cfg.max_std {
                return false;
            }
            let px = image.pixel(x as u32, y as u32);
            let (r, g, b) = match px.len() {
                0 => return false,
                1 | 2 => (px[0], px[0], px[0]),
                _ => (px[0], px[1], px[2]),
            };
            let grey = 0.299 * r + 0.587 * g + 0.114 * b;
            if (grey as f64) < min_grey || ((b - r) as f64) < cfg.min_blueness {
                return false;
            }
            match &up_cam {
                Some(u) => {
                    let ray = view.camera.pixel_ray(x as u32, y as u32).normalize();
                    // Elevation above the horizontal: sin = ray · up.
                    ray.dot(u) >= cos_min
                }
                None => true,
            }
        })
        .collect();
    // Flood fill from the top row through candidates.
    let mut sky = vec![false; n];
    let mut stack: Vec<usize> = (0..w).filter(|&x| candidate[x]).collect();
    for &p in &stack {
        sky[p] = true;
    }
    while let Some(p) = stack.pop() {
        let (x, y) = (p % w, p / w);
        let mut visit = |q: usize| {
            if candidate[q] && !sky[q] {
                sky[q] = true;
                stack.push(q);
            }
        };
        if x > 0 {
            visit(p - 1);
        }
        if x + 1 < w {
            visit(p + 1);
        }
        if y > 0 {
            visit(p - w);
        }
        if y + 1 < h {
            visit(p + w);
        }
    }
    grow(&mut sky, image, w, h, cfg);
    sky
}

/// Grows `sky` by up to `cfg.grow_px` pixels into 4-neighbours whose colour is within
/// `cfg.grow_tolerance` (every channel) of the sky pixel beside them.
fn grow(sky: &mut [bool], image: &ImageF32, w: usize, h: usize, cfg: &SkyConfig) {
    let c = image.channels as usize;
    let tol = cfg.grow_tolerance as f32;
    let close = |p: usize, q: usize| {
        (0..c).all(|k| (image.data[p * c + k] - image.data[q * c + k]).abs() <= tol)
    };
    let mut front: Vec<usize> = (0..w * h).filter(|&p| sky[p]).collect();
    for _ in 0..cfg.grow_px {
        let mut next = Vec::new();
        for &p in &front {
            let (x, y) = (p % w, p / w);
            let neighbours = [
                (x > 0).then(|| p - 1),
                (x + 1 < w).then(|| p + 1),
                (y > 0).then(|| p - w),
                (y + 1 < h).then(|| p + w),
            ];
            for q in neighbours.into_iter().flatten() {
                if !sky[q] && close(p, q) {
                    sky[q] = true;
                    next.push(q);
                }
            }
        }
        if next.is_empty() {
            break;
        }
        front = next;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{look_at, Camera};

    /// A camera at the origin looking along +x, z up; an image whose top third is a smooth
    /// blue sky, the rest a textured wall; sparse points on the wall.
    fn setup() -> (View, ImageF32, SparseCloud) {
        let (w, h) = (60u32, 45u32);
        let view = View {
            id: 1,
            name: "v".into(),
            camera: Camera::pinhole(w, h, 50.0, 50.0, 30.0, 22.5),
            cam_from_world: look_at(
                &Vector3::zeros(),
                &Vector3::new(1.0, 0.0, 0.0),
                &Vector3::z(),
            ),
            image_path: None,
        };
        let mut img = ImageF32::filled(w, h, 3, 0.0);
        for y in 0..h {
            for x in 0..w {
                let c = if y < 15 {
                    [0.6, 0.75, 0.92]
                } else {
                    let t = ((x * 7 + y * 13) % 5) as f32 * 0.1;
                    [0.5 + t, 0.4 + t, 0.3]
                };
                img.pixel_mut(x, y).copy_from_slice(&c);
            }
        }
        // Wall points at x = 10, heights −2..1.5 (row of z = 1.5: 22.5 − 50·0.15 = 15).
        let mut cloud = SparseCloud::default();
        for k in 0..12 {
            for j in 0..8 {
                let p = Vector3::new(10.0, -3.0 + 0.5 * k as f64, -2.0 + 0.5 * j as f64);
                cloud.positions.push(p);
            }
        }
        (view, img, cloud)
    }

    #[test]
    fn the_smooth_top_above_every_point_is_sky_and_the_wall_is_not() {
        let (view, img, cloud) = setup();
        let up = Vector3::z();
        let sky = sky_mask(&view, &img, &cloud, Some(&up), &SkyConfig::default());
        let w = 60;
        // Rows 0..12 (clear of the 5×5 window's reach into the wall and the points' margin).
        for y in 0..11 {
            for x in 3..57 {
                assert!(sky[y * w + x], "({x}, {y}) should be sky");
            }
        }
        assert!(sky[15 * w..].iter().all(|&s| !s), "the wall is not sky");
        // Disabled: nothing.
        let off = SkyConfig {
            enabled: false,
            ..SkyConfig::default()
        };
        assert!(sky_mask(&view, &img, &cloud, Some(&up), &off)
            .iter()
            .all(|&s| !s));
    }

    #[test]
    fn a_point_in_the_sky_blocks_its_column_and_warm_plaster_is_not_sky() {
        let (view, mut img, mut cloud) = setup();
        let up = Vector3::z();
        // A point high up at the image's centre column: rows below it are blocked there.
        cloud.positions.push(Vector3::new(10.0, 0.0, 3.5)); // row 22.5 − 50·0.35 = 5
        let no_growth = SkyConfig {
            grow_px: 0,
            ..SkyConfig::default()
        };
        let sky = sky_mask(&view, &img, &cloud, Some(&up), &no_growth);
        assert!(!sky[8 * 60 + 30], "below a point is not beyond the model");
        assert!(sky[8 * 60 + 10]);
        // The growth refills a band as narrow as the point's where the colour is the sky's.
        let sky = sky_mask(&view, &img, &cloud, Some(&up), &SkyConfig::default());
        assert!(sky[8 * 60 + 30]);
        // Warm, smooth plaster in the top rows is not sky.
        for y in 0..15 {
            for x in 0..60 {
                img.pixel_mut(x, y).copy_from_slice(&[0.85, 0.75, 0.6]);
            }
        }
        let sky = sky_mask(&view, &img, &cloud, Some(&up), &SkyConfig::default());
        assert!(sky.iter().all(|&s| !s));
    }

    #[test]
    fn below_the_horizon_is_never_sky() {
        let (view, img, _) = setup();
        // No points at all, a smooth bright image: only the horizon bounds the sky.
        let mut flat = img.clone();
        for v in flat.data.chunks_exact_mut(3) {
            v.copy_from_slice(&[0.6, 0.75, 0.92]);
        }
        let up = Vector3::z();
        let cfg = SkyConfig {
            min_elevation_deg: 1.0,
            grow_px: 0,
            ..SkyConfig::default()
        };
        let sky = sky_mask(&view, &flat, &SparseCloud::default(), Some(&up), &cfg);
        // The horizon is row 22.5; 1° above it is about row 21.6.
        assert!(sky[20 * 60 + 30]);
        assert!(!sky[23 * 60 + 30]);
        assert!(!sky[40 * 60 + 30]);
    }

    #[test]
    fn the_vertical_agrees_with_the_images_up() {
        let (view, _, _) = setup();
        let up = scene_vertical(&[view.clone(), view]).unwrap();
        assert!(up.dot(&Vector3::z()) > 0.99, "{up}");
    }
}
