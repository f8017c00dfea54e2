//! The plane cost volume: the photo-consistency cost of every pixel of a view on every plane
//! hypothesis, pixel-major — exactly the `cost(pixel, plane)` the planemap data term
//! consumes.

use rayon::prelude::*;

use super::cost::{prepare, Context, Scratch};
use super::{PhotoConfig, PhotoError};
use crate::geometry::Plane;
use crate::raster::ImageF32;
use crate::scene::View;

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
