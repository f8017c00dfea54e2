//! Fused points: every view's depths back-projected and kept where other views agree.

use nalgebra::{Point3, Vector2, Vector3};
use rayon::prelude::*;

use super::{FusionConfig, PipelineError, ViewPlanemap};
use crate::io::ply::PlyPoints;
use crate::scene::Scene;

/// Back-projects every view's depth (every `stride`-th pixel), keeping points that at least
/// `min_consistent_views` other labelled views see at the same depth (relative tolerance).
/// Colours are black: fusion does not reload images.
pub fn fuse(
    scene: &Scene,
    views: &[ViewPlanemap],
    cfg: &FusionConfig,
) -> Result<PlyPoints, PipelineError> {
    let per_view: Vec<Vec<(Vector3<f64>, Vector3<f64>)>> = views
        .par_iter()
        .map(|vr| {
            let view = &scene.views[vr.view_index];
            let rot_inv = view.cam_from_world.rotation.inverse();
            let mut pts = Vec::new();
            for y in (0..vr.height).step_by(cfg.stride as usize) {
                for x in (0..vr.width).step_by(cfg.stride as usize) {
                    let p = (y * vr.width + x) as usize;
                    let z = vr.depth[p] as f64;
                    if z <= 0.0 {
                        continue;
                    }
                    let ray = view.camera.pixel_ray(x, y);
                    let x_cam = Point3::from(ray * z);
                    let x_world = view.cam_from_world.inverse_transform_point(&x_cam).coords;
                    let mut agree = 0usize;
                    for other in views.iter().filter(|o| o.view_index != vr.view_index) {
                        let ov = &scene.views[other.view_index];
                        if let Some((xy, oz)) = ov.project(&x_world) {
                            if ov.camera.contains(&xy) {
                                let (ox, oy) = (xy.x as u32, xy.y as u32);
                                let od = other.depth[(oy * other.width + ox) as usize] as f64;
                                if od > 0.0 && (od - oz).abs() <= cfg.depth_tolerance * oz {
                                    agree += 1;
                                }
                            }
                        }
                    }
                    if agree >= cfg.min_consistent_views {
                        let n = vr.normals[p];
                        let n_world = rot_inv * Vector3::new(n[0] as f64, n[1] as f64, n[2] as f64);
                        pts.push((x_world, n_world));
                    }
                }
            }
            pts
        })
        .collect();
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    for v in per_view {
        for (p, n) in v {
            positions.push(p);
            normals.push(n);
        }
    }
    let colors = vec![[200u8, 200, 200]; positions.len()];
    let _ = Vector2::<f64>::zeros;
    Ok(PlyPoints {
        positions,
        normals: Some(normals),
        colors: Some(colors),
    })
}
