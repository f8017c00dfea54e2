//! Plane-sweep stereo (tutorial §3.1 "plane sweeping"; Collins 1996; Gallup et al. CVPR
//! 2007 for sweeps along the scene's dominant axes): winner-takes-all over a cost volume,
//! sub-plane refinement, and the sweep over several plane families at once.

use nalgebra::{Point3, Vector2, Vector3};
use rayon::prelude::*;

use super::families::{PlaneFamily, Spacing};
use super::sgm::semi_global;
use super::volume::{plane_cost_volume, CostVolume};
use super::{PhotoError, SweepConfig};
use crate::geometry::Plane;
use crate::raster::ImageF32;
use crate::scene::View;

/// Plane index of a pixel with no evidence for any plane (every cost was 1).
pub const NO_PLANE: u32 = u32::MAX;

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
/// family — [`super::fronto_parallel_planes`], [`super::axis_sweep_planes`], or given
/// hypotheses.
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
