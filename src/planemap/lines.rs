//! Dominant lines: smoothness weights w_pq lowered where a depth discontinuity is expected.
//!
//! Furukawa et al. (2009) observe that boundaries between planes of a Manhattan scene are
//! mostly image edges pointing toward a vanishing point of a dominant direction d_k. The
//! vanishing point of d_k in the target view is the homogeneous image point v_k = K R d_k
//! (R = rotation of `cam_from_world`); at pixel x the direction toward it is
//! `(v.x − v.z·x, v.y − v.z·y)`, which is the projected direction itself when v.z = 0
//! (vanishing point at infinity). A pixel is on a dominant line when its Sobel gradient
//! magnitude exceeds a threshold (optionally a local maximum across the edge) and the edge
//! direction (perpendicular to the gradient) is within an angle tolerance of that direction
//! for some k. A pixel pair (p, q) straddles the line when one of them is such a pixel and
//! the line crosses the pair, i.e. makes at least 30° with the pair's direction; then
//! w_pq = `dominant_line_weight`, else 1.

use nalgebra::Vector3;
use rayon::prelude::*;

use super::{PlanemapConfig, PlanemapError};
use crate::geometry::{Camera, Rigid3};
use crate::raster::ImageF32;

/// A line crosses a pixel pair when the gradient component along the pair's direction is at
/// least this fraction of the gradient magnitude: sin(angle between line and pair) ≥ 0.5,
/// i.e. the line makes at least 30° with the pair. Every line crosses right or down pairs.
const CROSSING_MIN_SIN: f64 = 0.5;

/// Per-edge smoothness weights w_pq of a 4-connected `width × height` grid.
#[derive(Debug, Clone, PartialEq)]
pub struct EdgeWeights {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// `right[y·width + x]` is the weight of the pair (x, y)–(x+1, y); the last column is
    /// unused and holds 1.
    pub right: Vec<f32>,
    /// `down[y·width + x]` is the weight of the pair (x, y)–(x, y+1); the last row is unused
    /// and holds 1.
    pub down: Vec<f32>,
    /// Per pixel (row-major): whether an image edge of any direction passes through it
    /// (Sobel magnitude above `edge_gradient_threshold`); a label change between two
    /// pixels without one pays at least the crease cost ([`PlanemapConfig::crease_cost`]).
    pub image_edge: Vec<bool>,
}

impl EdgeWeights {
    /// All weights 1 (no dominant lines), an image edge at every pixel (no crease cost).
    pub fn uniform(width: u32, height: u32) -> Self {
        let n = width as usize * height as usize;
        EdgeWeights {
            width,
            height,
            right: vec![1.0; n],
            down: vec![1.0; n],
            image_edge: vec![true; n],
        }
    }

    /// The weights as one array of grid edge slots, `2·p` for the pair from pixel p to its
    /// right neighbour and `2·p + 1` to its lower neighbour (the layout of a 4-connected grid
    /// in `planemap-solvers`' `Mrf::with_edge_weights`).
    pub fn interleaved(&self) -> Vec<f32> {
        self.right
            .iter()
            .zip(&self.down)
            .flat_map(|(&r, &d)| [r, d])
            .collect()
    }

    /// Whether an image edge passes through `p` or `q` (row-major indices).
    #[inline]
    pub fn edge_between(&self, p: usize, q: usize) -> bool {
        self.image_edge[p] || self.image_edge[q]
    }

    /// w_pq for 4-neighbours `p`, `q` (row-major indices, either order); 1 for pixels that
    /// are not 4-neighbours.
    #[inline]
    pub fn between(&self, p: usize, q: usize) -> f32 {
        let (a, b) = if p < q { (p, q) } else { (q, p) };
        let w = self.width as usize;
        if b == a + 1 && a % w + 1 < w {
            self.right[a]
        } else if b == a + w {
            self.down[a]
        } else {
            1.0
        }
    }
}

/// Homogeneous vanishing points v_k = K R d_k of `directions` (world frame) in a view with
/// intrinsics `camera` (undistorted) and pose `cam_from_world`.
pub fn vanishing_points(
    camera: &Camera,
    cam_from_world: &Rigid3,
    directions: &[Vector3<f64>],
) -> Vec<Vector3<f64>> {
    let k = camera.k_matrix();
    directions
        .iter()
        .map(|d| k * (cam_from_world.rotation * d.normalize()))
        .collect()
}

/// Sobel gradients of a grey image (borders clamped), normalised by 1/8: a unit step between
/// two columns gives |g| = 0.5 on both.
fn sobel(gray: &ImageF32) -> (Vec<f32>, Vec<f32>) {
    let (w, h) = (gray.width as usize, gray.height as usize);
    let mut gx = vec![0.0f32; w * h];
    let mut gy = vec![0.0f32; w * h];
    let at = |x: usize, y: usize| gray.data[y * w + x];
    gx.par_chunks_mut(w)
        .zip(gy.par_chunks_mut(w))
        .enumerate()
        .for_each(|(y, (rx, ry))| {
            let ym = y.saturating_sub(1);
            let yp = (y + 1).min(h - 1);
            for x in 0..w {
                let xm = x.saturating_sub(1);
                let xp = (x + 1).min(w - 1);
                let sx = (at(xp, ym) + 2.0 * at(xp, y) + at(xp, yp))
                    - (at(xm, ym) + 2.0 * at(xm, y) + at(xm, yp));
                let sy = (at(xm, yp) + 2.0 * at(x, yp) + at(xp, yp))
                    - (at(xm, ym) + 2.0 * at(x, ym) + at(xp, ym));
                rx[x] = sx / 8.0;
                ry[x] = sy / 8.0;
            }
        });
    (gx, gy)
}

/// Per-pixel mask of dominant-line pixels (see the module doc), row-major.
pub fn dominant_line_mask(
    image: &ImageF32,
    camera: &Camera,
    cam_from_world: &Rigid3,
    directions: &[Vector3<f64>],
    config: &PlanemapConfig,
) -> Result<Vec<bool>, PlanemapError> {
    Ok(mask_and_gradients(image, camera, cam_from_world, directions, config)?.0)
}

type MaskAndGradients = (Vec<bool>, Vec<f32>, Vec<f32>);

fn mask_and_gradients(
    image: &ImageF32,
    camera: &Camera,
    cam_from_world: &Rigid3,
    directions: &[Vector3<f64>],
    config: &PlanemapConfig,
) -> Result<MaskAndGradients, PlanemapError> {
    config.validate()?;
    if image.width != camera.width || image.height != camera.height || image.len_pixels() == 0 {
        return Err(PlanemapError::Input(format!(
            "image is {}x{} but the camera is {}x{}",
            image.width, image.height, camera.width, camera.height
        )));
    }
    let gray = image.to_gray();
    let (gx, gy) = sobel(&gray);
    let (w, h) = (image.width as usize, image.height as usize);
    let vps = vanishing_points(camera, cam_from_world, directions);
    let threshold = config.edge_gradient_threshold;
    let sin_tol = config.edge_angle_tolerance_deg.to_radians().sin();
    let nms = config.edge_non_max_suppression;
    let mag = |x: usize, y: usize| {
        let i = y * w + x;
        (gx[i] as f64).hypot(gy[i] as f64)
    };
    let mut mask = vec![false; w * h];
    mask.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        for (x, m) in row.iter_mut().enumerate() {
            let i = y * w + x;
            let (gxi, gyi) = (gx[i] as f64, gy[i] as f64);
            let g = gxi.hypot(gyi);
            if g.is_nan() || g <= threshold {
                continue;
            }
            if nms {
                // Neighbours across the edge, along the gradient quantised to 45°.
                let (dx, dy): (i64, i64) = {
                    let a = gyi.atan2(gxi).to_degrees().rem_euclid(180.0);
                    if !(22.5..157.5).contains(&a) {
                        (1, 0)
                    } else if a < 67.5 {
                        (1, 1)
                    } else if a < 112.5 {
                        (0, 1)
                    } else {
                        (-1, 1)
                    }
                };
                let nb = |s: i64| {
                    let xx = (x as i64 + s * dx).clamp(0, w as i64 - 1) as usize;
                    let yy = (y as i64 + s * dy).clamp(0, h as i64 - 1) as usize;
                    mag(xx, yy)
                };
                if g < nb(1) || g < nb(-1) {
                    continue;
                }
            }
            // Edge direction ⟂ gradient: (−gy, gx)/g.
            let (ex, ey) = (-gyi / g, gxi / g);
            let (u, v) = (x as f64 + 0.5, y as f64 + 0.5);
            *m = vps.iter().any(|vp| {
                let (dx, dy) = (vp.x - vp.z * u, vp.y - vp.z * v);
                let len = dx.hypot(dy);
                len > 1e-9 * (vp.x.abs() + vp.y.abs() + vp.z.abs())
                    && (ex * dy - ey * dx).abs() <= sin_tol * len
            });
        }
    });
    Ok((mask, gx, gy))
}

/// Smoothness weights of the target view: `config.dominant_line_weight` on pixel pairs that
/// straddle a dominant line, 1 elsewhere (see the module doc).
pub fn dominant_line_weights(
    image: &ImageF32,
    camera: &Camera,
    cam_from_world: &Rigid3,
    directions: &[Vector3<f64>],
    config: &PlanemapConfig,
) -> Result<EdgeWeights, PlanemapError> {
    let (mask, gx, gy) = mask_and_gradients(image, camera, cam_from_world, directions, config)?;
    let (w, h) = (image.width as usize, image.height as usize);
    let low = config.dominant_line_weight as f32;
    // The line at pixel i crosses a pair along axis (gradient component along the axis).
    let crosses = |i: usize, along: f32| {
        let g = (gx[i] as f64).hypot(gy[i] as f64);
        mask[i] && (along as f64).abs() >= CROSSING_MIN_SIN * g
    };
    let mut weights = EdgeWeights::uniform(image.width, image.height);
    let threshold = config.edge_gradient_threshold;
    weights.image_edge = gx
        .iter()
        .zip(&gy)
        .map(|(&a, &b)| (a as f64).hypot(b as f64) > threshold)
        .collect();
    weights
        .right
        .par_chunks_mut(w)
        .zip(weights.down.par_chunks_mut(w))
        .enumerate()
        .for_each(|(y, (right, down))| {
            for x in 0..w {
                let p = y * w + x;
                if x + 1 < w && (crosses(p, gx[p]) || crosses(p + 1, gx[p + 1])) {
                    right[x] = low;
                }
                if y + 1 < h && (crosses(p, gy[p]) || crosses(p + w, gy[p + w])) {
                    down[x] = low;
                }
            }
        });
    Ok(weights)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::planemap::testutil::{cast, corner_scene, on_stripe, FACE};

    /// Fraction of sampled points along a 3D segment (a → b) whose straddling pair has a low
    /// weight, over samples whose projection is inside the image and away from its border.
    fn low_fraction(
        weights: &EdgeWeights,
        view: &crate::scene::View,
        a: Vector3<f64>,
        b: Vector3<f64>,
    ) -> (f64, usize) {
        let (w, h) = (weights.width as f64, weights.height as f64);
        let (pa, _) = view.project(&a).unwrap();
        let (pb, _) = view.project(&b).unwrap();
        let dir = pb - pa;
        let steep = dir.y.abs() >= dir.x.abs();
        let (mut low, mut n) = (0, 0);
        for i in 0..=200 {
            let x = a + (b - a) * (i as f64 / 200.0);
            let (xy, _) = view.project(&x).unwrap();
            if xy.x < 3.0 || xy.y < 3.0 || xy.x > w - 4.0 || xy.y > h - 4.0 {
                continue;
            }
            // The pair whose centres bracket the line point.
            let wgt = if steep {
                let x0 = (xy.x - 0.5).floor() as usize;
                weights.right[xy.y as usize * weights.width as usize + x0]
            } else {
                let y0 = (xy.y - 0.5).floor() as usize;
                weights.down[y0 * weights.width as usize + xy.x as usize]
            };
            n += 1;
            if wgt < 1.0 {
                low += 1;
            }
        }
        (low as f64 / n.max(1) as f64, n)
    }

    #[test]
    fn corner_creases_are_dominant_lines_and_a_stripe_is_not() {
        let scene = corner_scene();
        let view = &scene.views[0];
        let config = PlanemapConfig::default();
        let weights = dominant_line_weights(
            &scene.images[0],
            &view.camera,
            &view.cam_from_world,
            &scene.directions,
            &config,
        )
        .unwrap();
        // The three creases of the corner, each along one axis, away from the ends.
        let creases = [
            (
                Vector3::new(0.0, 0.0, 0.3),
                Vector3::new(0.0, 0.0, FACE - 0.3),
            ),
            (
                Vector3::new(0.3, 0.0, 0.0),
                Vector3::new(FACE - 0.3, 0.0, 0.0),
            ),
            (
                Vector3::new(0.0, 0.3, 0.0),
                Vector3::new(0.0, FACE - 0.3, 0.0),
            ),
        ];
        for (a, b) in creases {
            let (frac, n) = low_fraction(&weights, view, a, b);
            assert!(n > 20, "crease {a:?}: {n} samples");
            assert!(frac > 0.9, "crease {a:?}→{b:?}: only {frac} low");
        }
        // The painted stripe's two borders on the wall x = 0: not toward any vanishing point.
        let (cy, cz) = crate::planemap::testutil::STRIPE_CENTRE;
        let a = crate::planemap::testutil::STRIPE_ANGLE;
        let hw = crate::planemap::testutil::STRIPE_HALF_WIDTH;
        let (dy, dz) = (a.cos(), a.sin());
        let (ny, nz) = (-a.sin(), a.cos());
        for side in [-1.0, 1.0] {
            let c = Vector3::new(0.0, cy + side * hw * ny, cz + side * hw * nz);
            let p0 = c - Vector3::new(0.0, dy, dz) * 1.0;
            let p1 = c + Vector3::new(0.0, dy, dz) * 1.0;
            assert!(on_stripe(&(c - Vector3::new(0.0, ny, nz) * side * 0.01)));
            let (frac, n) = low_fraction(&weights, view, p0, p1);
            assert!(n > 20, "stripe: {n} samples");
            assert!(frac < 0.1, "stripe side {side}: {frac} low");
            // ...but it is an edge: with the angle tolerance at its maximum it would be low.
        }
        // Flat face interiors carry weight 1.
        let (xy, _) = view.project(&Vector3::new(2.5, 2.5, 0.0)).unwrap();
        let (o, d) = view.ray(&xy);
        assert_eq!(cast(&o, &d).map(|(face, _)| face), Some(2), "floor");
        let p = xy.y as usize * 160 + xy.x as usize;
        assert_eq!((weights.right[p], weights.down[p]), (1.0, 1.0));
        let lows = weights.right.iter().filter(|&&w| w < 1.0).count();
        assert!(lows < weights.right.len() / 10, "{lows} low weights");
    }

    #[test]
    fn stripe_edges_are_detected_as_edges() {
        // Guards the previous test: the stripe is missed for its orientation, not for being
        // too faint. With every direction allowed (no dominant directions needed: use the
        // stripe's own direction) its borders get low weights.
        let scene = corner_scene();
        let view = &scene.views[0];
        let a = crate::planemap::testutil::STRIPE_ANGLE;
        let stripe_dir = Vector3::new(0.0, a.cos(), a.sin());
        let weights = dominant_line_weights(
            &scene.images[0],
            &view.camera,
            &view.cam_from_world,
            &[stripe_dir],
            &PlanemapConfig::default(),
        )
        .unwrap();
        let (cy, cz) = crate::planemap::testutil::STRIPE_CENTRE;
        let hw = crate::planemap::testutil::STRIPE_HALF_WIDTH;
        let (ny, nz) = (-a.sin(), a.cos());
        let c = Vector3::new(0.0, cy + hw * ny, cz + hw * nz);
        let (frac, _) = low_fraction(&weights, view, c - stripe_dir, c + stripe_dir);
        assert!(frac > 0.8, "{frac}");
    }

    #[test]
    fn between_maps_pairs_to_the_right_arrays() {
        let mut w = EdgeWeights::uniform(4, 3);
        w.right[5] = 0.25; // (1,1)-(2,1)
        w.down[6] = 0.5; // (2,1)-(2,2)
        assert_eq!(w.between(5, 6), 0.25);
        assert_eq!(w.between(6, 5), 0.25);
        assert_eq!(w.between(6, 10), 0.5);
        assert_eq!(w.between(10, 6), 0.5);
        assert_eq!(w.between(3, 4), 1.0, "row wrap is not an edge");
        assert_eq!(w.between(0, 5), 1.0);
        let slots = w.interleaved();
        assert_eq!((slots.len(), slots[10], slots[13]), (24, 0.25, 0.5));
    }

    #[test]
    fn vanishing_point_at_infinity_gives_the_projected_direction() {
        let cam = Camera::pinhole(100, 80, 100.0, 100.0, 50.0, 40.0);
        let pose = Rigid3::identity();
        let v = vanishing_points(&cam, &pose, &[Vector3::new(2.0, 1.0, 0.0)]);
        assert!(v[0].z.abs() < 1e-15);
        assert!((v[0].y / v[0].x - 0.5).abs() < 1e-12);
        // A finite one: the optical axis vanishes at the principal point.
        let v = vanishing_points(&cam, &pose, &[Vector3::z()]);
        assert!((v[0].x / v[0].z - 50.0).abs() < 1e-12 && (v[0].y / v[0].z - 40.0).abs() < 1e-12);
    }

    #[test]
    fn weights_identical_across_thread_counts() {
        let scene = corner_scene();
        let view = &scene.views[1];
        let run = || {
            dominant_line_weights(
                &scene.images[1],
                &view.camera,
                &view.cam_from_world,
                &scene.directions,
                &PlanemapConfig::default(),
            )
            .unwrap()
        };
        let many = run();
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap()
            .install(run);
        assert_eq!(many, one);
    }
}
