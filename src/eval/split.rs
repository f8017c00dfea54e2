//! Depth accuracy split by texture (textured / plain pixels), and the pixels another view
//! also sees: the sweep baseline's scoring (`planemap sweep`).

use nalgebra::{Vector2, Vector3};
use rayon::prelude::*;
use serde::Serialize;

use crate::scene::View;

/// Depth accuracy of a depth map, split by texture.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct SplitScores {
    /// Textured pixels with ground-truth depth.
    pub textured: u64,
    /// Of those, within tolerance.
    pub textured_accurate: u64,
    /// Plain (untextured) pixels with ground-truth depth.
    pub plain: u64,
    /// Of those, within tolerance.
    pub plain_accurate: u64,
}

impl SplitScores {
    /// Adds another view's counts.
    pub fn add(&mut self, o: &SplitScores) {
        self.textured += o.textured;
        self.textured_accurate += o.textured_accurate;
        self.plain += o.plain;
        self.plain_accurate += o.plain_accurate;
    }

    /// Share of textured pixels within tolerance.
    pub fn textured_accuracy(&self) -> f64 {
        self.textured_accurate as f64 / self.textured.max(1) as f64
    }

    /// Share of plain pixels within tolerance.
    pub fn plain_accuracy(&self) -> f64 {
        self.plain_accurate as f64 / self.plain.max(1) as f64
    }
}

/// Which pixels of view `index` show a surface that some other view also sees: the pixel's
/// ground-truth point (`gt_depths[index]`, camera z; 0 = background) projects inside
/// another view, in front of it, within one pixel of a pixel whose ground-truth depth there
/// agrees within `tolerance` (relative). Stereo cannot measure a surface only one view
/// sees (outside every neighbour's frame, or hidden there): the benchmark reports the sweep
/// on these pixels beside all of them, so the two causes of error stay apart.
/// `gt_depths[j]` must hold `views[j]`'s width × height values.
pub fn covisible_mask(
    views: &[View],
    gt_depths: &[&[f32]],
    index: usize,
    tolerance: f64,
) -> Vec<bool> {
    let view = &views[index];
    let (w, h) = (view.camera.width as usize, view.camera.height as usize);
    let depth = gt_depths[index];
    let seen_in = |j: usize, x: &Vector3<f64>| -> bool {
        let other = &views[j];
        let Some((uv, z)) = other.project(x) else {
            return false;
        };
        if z <= 0.0 || !other.camera.contains(&uv) {
            return false;
        }
        let (ow, oh) = (other.camera.width as i64, other.camera.height as i64);
        let (cx, cy) = (uv.x.floor() as i64, uv.y.floor() as i64);
        (-1..=1).any(|dy| {
            (-1..=1).any(|dx| {
                let (px, py) = (cx + dx, cy + dy);
                if px < 0 || py < 0 || px >= ow || py >= oh {
                    return false;
                }
                let g = gt_depths[j][(py * ow + px) as usize] as f64;
                g > 0.0 && (g - z).abs() <= tolerance * z
            })
        })
    };
    (0..w * h)
        .into_par_iter()
        .map(|p| {
            let g = depth[p] as f64;
            if g <= 0.0 {
                return false;
            }
            let xy = Vector2::new((p % w) as f64 + 0.5, (p / w) as f64 + 0.5);
            let (origin, dir) = view.ray(&xy);
            let x = origin + dir * g;
            (0..views.len()).any(|j| j != index && seen_in(j, &x))
        })
        .collect()
}

/// Scores `depth` (NaN or ≤ 0 = no depth) against `gt_depth` (0 = background, not scored)
/// at relative `tolerance`, split by `textured`.
pub fn split_scores(
    depth: &[f32],
    gt_depth: &[f32],
    textured: &[bool],
    tolerance: f64,
) -> SplitScores {
    let mut s = SplitScores::default();
    for ((&z, &g), &t) in depth.iter().zip(gt_depth).zip(textured) {
        if g <= 0.0 {
            continue;
        }
        let ok = z.is_finite() && z > 0.0 && ((z - g).abs() as f64) <= tolerance * g as f64;
        if t {
            s.textured += 1;
            s.textured_accurate += ok as u64;
        } else {
            s.plain += 1;
            s.plain_accurate += ok as u64;
        }
    }
    s
}

/// A depth map's scores split by texture three ways, as `planemap sweep` reports them.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct TextureScores {
    /// Texture read off the image (grey std over 7×7 ≥ 0.02, [`crate::photo::texture_mask`]).
    pub image_texture: SplitScores,
    /// The renderer's textured surfaces (`gt/texture/NAME.png`), when the workspace has them.
    pub surfaces: Option<SplitScores>,
    /// The same, only where another view sees the surface unhidden ([`covisible_mask`]).
    pub covisible_surfaces: Option<SplitScores>,
}

impl TextureScores {
    /// Adds another view's counts.
    pub fn add(&mut self, o: &TextureScores) {
        self.image_texture.add(&o.image_texture);
        for (mine, theirs) in [
            (&mut self.surfaces, &o.surfaces),
            (&mut self.covisible_surfaces, &o.covisible_surfaces),
        ] {
            if let Some(t) = theirs {
                mine.get_or_insert_with(SplitScores::default).add(t);
            }
        }
    }
}

/// Scores view `index`'s `depth` within 1 % against its ground truth (`gt_depths[index]`),
/// split by the texture of `image` and, when `gt_dir` holds `texture/STEM.png`, by the
/// renderer's textured surfaces, all of them and those another view also sees.
pub fn texture_scores(
    views: &[View],
    gt_depths: &[&[f32]],
    index: usize,
    image: &crate::raster::ImageF32,
    depth: &[f32],
    gt_dir: &std::path::Path,
) -> Result<TextureScores, crate::io::labelpng::LabelPngError> {
    const TOLERANCE: f64 = 0.01;
    let gt_depth = gt_depths[index];
    let mask = crate::photo::texture_mask(image, 3, 0.02);
    let mut scores = TextureScores {
        image_texture: split_scores(depth, gt_depth, &mask, TOLERANCE),
        ..Default::default()
    };
    let stem = crate::io::output_stem(&views[index].name);
    let surface = gt_dir.join("texture").join(format!("{stem}.png"));
    if surface.is_file() {
        let (_, _, textured) = crate::io::labelpng::read_label_png(&surface)?;
        let mask: Vec<bool> = textured.iter().map(|&t| t > 0).collect();
        scores.surfaces = Some(split_scores(depth, gt_depth, &mask, TOLERANCE));
        let seen = covisible_mask(views, gt_depths, index, TOLERANCE);
        // Pixels only this view sees count as background here.
        let gt_seen: Vec<f32> = gt_depth
            .iter()
            .zip(&seen)
            .map(|(&g, &s)| if s { g } else { 0.0 })
            .collect();
        scores.covisible_surfaces = Some(split_scores(depth, &gt_seen, &mask, TOLERANCE));
    }
    Ok(scores)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two views of the floor z = 0, the second shifted sideways: view 0's pixels whose
    /// floor point falls outside view 1 are not covisible, the rest are, unless view 1's
    /// depth there says something nearer hides the floor.
    #[test]
    fn covisible_pixels_are_seen_by_another_view_unhidden() {
        let cam = crate::geometry::Camera::pinhole(40, 30, 30.0, 30.0, 20.0, 15.0);
        let down = |x: f64| View {
            id: 1,
            name: "v".into(),
            camera: cam.clone(),
            cam_from_world: crate::geometry::look_at(
                &Vector3::new(x, 0.0, 4.0),
                &Vector3::new(x, 0.0, 0.0),
                &Vector3::y(),
            ),
            image_path: None,
        };
        let views = vec![down(0.0), down(2.0)];
        // Both look straight down from 4 m: the floor's depth is 4 everywhere.
        let floor = vec![4.0f32; 40 * 30];
        let mut hidden = floor.clone();
        let mask = covisible_mask(&views, &[&floor, &floor], 0, 0.01);
        let seen_x = |m: &[bool], x: usize| (0..30).all(|y| m[y * 40 + x]);
        let unseen_x = |m: &[bool], x: usize| (0..30).all(|y| !m[y * 40 + x]);
        // View 1 sees x ∈ [2 − 2.67, 2 + 2.67] m of the floor; view 0's column u shows
        // x = (u + 0.5 − 20) · 4 / 30, so columns from 15 on are seen by it.
        let (world_x, world_u) = (|u: usize| (u as f64 + 0.5 - 20.0) * 4.0 / 30.0, 15usize);
        assert!(world_x(world_u) > 2.0 - 2.67 && world_x(world_u - 1) < 2.0 - 2.67);
        assert!(unseen_x(&mask, 0) && unseen_x(&mask, 13));
        assert!(seen_x(&mask, 16) && seen_x(&mask, 39));
        // Something 1 m above the floor in view 1's left half hides view 0's middle.
        for y in 0..30 {
            for x in 0..20 {
                hidden[y * 40 + x] = 3.0;
            }
        }
        let mask = covisible_mask(&views, &[&floor, &hidden], 0, 0.01);
        assert!(unseen_x(&mask, 20) && unseen_x(&mask, 30));
        assert!(seen_x(&mask, 36) && seen_x(&mask, 39));
        // Background pixels (depth 0) never count.
        let mut sky = floor.clone();
        sky[0..40].fill(0.0);
        let mask = covisible_mask(&views, &[&sky, &floor], 0, 0.01);
        assert!(mask[..40].iter().all(|&m| !m) && mask[40 + 39]);
    }
}
