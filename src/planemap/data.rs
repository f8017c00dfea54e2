//! Data term D_p(h): visibility conflicts between a plane label and the sparse points.
//!
//! For pixel p and plane h, X = X_p^h is where p's ray meets h. A sparse point P with
//! confidence C(P) conflicts with X in three cases (Furukawa et al. 2009, §5):
//!
//! 1. P is seen by the target view t and projects to p: X is more than γ in front of or
//!    behind P along the ray (the view sees P there, not X).
//! 2. P is not seen by t but projects to p: X is more than γ behind P. Then P would float
//!    in the free space between camera t and the surface t sees at p, hiding X; X cannot be
//!    what t sees there. X in front of P is fine: it may be what occludes P from t.
//! 3. P is seen by another view j: X lies on the segment from camera j's centre to P, more
//!    than γ before P (a surface there would block j's view of P).
//!
//! D_p(h) = min(trunc, Σ_conflicts max(0, C(P) − offset)); a plane behind the camera or
//! parallel to the ray at p costs `trunc`.
//!
//! Cost: cases 1–2 are tested once per (point, label) along the ray through P's exact
//! projection; case 3 once per (point, view of its track, label), since the segment c_j → P
//! meets plane h in at most one point Y, and Y = X_p^h exactly for the pixel p where Y
//! projects. Each conflict is splatted onto a small square of pixels. Work is
//! O(pixels × labels + points × track × labels), never pixels × labels × points.

use nalgebra::{Point3, Vector3};
use rayon::prelude::*;

use super::{pixel_of, Pinhole, PlanemapConfig, PlanemapError, ViewInputs};
use crate::geometry::Plane;

/// One conflict: the pixel it lands on (centre of the splat) and its weight C(P) − offset.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Conflict {
    pixel: u32,
    weight: f32,
}

/// A sparse point prepared for the target view.
struct PreparedPoint {
    /// Position in the target camera frame.
    cam: Vector3<f64>,
    /// Pixel index (y·width + x) of its projection into the target image, if inside.
    pixel: Option<u32>,
    /// Whether the target view is in its track.
    seen_by_target: bool,
    /// Weight C(P) − offset (> 0; points with no weight are dropped).
    weight: f32,
    /// Range into `PreparedCloud::centres` of the other views' centres (target frame).
    centres: std::ops::Range<usize>,
}

struct PreparedCloud {
    points: Vec<PreparedPoint>,
    centres: Vec<Vector3<f64>>,
}

fn prepare(inputs: &ViewInputs, config: &PlanemapConfig, pinhole: &Pinhole) -> PreparedCloud {
    let view = inputs.view();
    let (w, h) = (view.camera.width, view.camera.height);
    let centres_cam: Vec<Vector3<f64>> = inputs
        .views
        .iter()
        .map(|v| (view.cam_from_world * Point3::from(v.center())).coords)
        .collect();
    let cloud = inputs.cloud;
    let mut points = Vec::with_capacity(cloud.len());
    let mut centres = Vec::new();
    for i in 0..cloud.len() {
        let weight = cloud.confidence[i] - config.confidence_offset;
        if weight.is_nan() || weight <= 0.0 {
            continue;
        }
        let cam = (view.cam_from_world * Point3::from(cloud.positions[i])).coords;
        let pixel = pinhole
            .project(&cam)
            .and_then(|xy| pixel_of(&xy, w, h))
            .map(|(x, y)| y * w + x);
        let track = &cloud.tracks[i];
        let seen_by_target = track.iter().any(|&j| j as usize == inputs.view_index);
        let start = centres.len();
        centres.extend(
            track
                .iter()
                .filter(|&&j| j as usize != inputs.view_index)
                .map(|&j| centres_cam[j as usize]),
        );
        points.push(PreparedPoint {
            cam,
            pixel,
            seen_by_target,
            weight: weight as f32,
            centres: start..centres.len(),
        });
    }
    PreparedCloud { points, centres }
}

/// Conflicts of one label (camera-frame plane `plane`) with every prepared point, in point
/// order (so the later accumulation is deterministic).
fn label_conflicts(
    plane: &Plane,
    cloud: &PreparedCloud,
    pinhole: &Pinhole,
    width: u32,
    height: u32,
    margin: f64,
) -> Vec<Conflict> {
    let mut out = Vec::new();
    for pt in &cloud.points {
        // Cases 1 and 2: along the ray through P's own projection.
        if let Some(pixel) = pt.pixel {
            let ray = pt.cam / pt.cam.z;
            // Signed distance along the ray, positive when X is behind P. A plane missing
            // the ray (parallel, or met behind the camera) counts as infinitely far behind:
            // at P's own pixel it costs the truncation anyway, but the splat's other pixels
            // may see the plane far away on the other side of its horizon.
            let behind = plane
                .depth_along(&ray)
                .map_or(f64::INFINITY, |depth| (depth - pt.cam.z) * ray.norm());
            let conflict = if pt.seen_by_target {
                behind.abs() > margin
            } else {
                behind > margin
            };
            if conflict {
                out.push(Conflict {
                    pixel,
                    weight: pt.weight,
                });
            }
        }
        // Case 3: X would block P from another view j.
        let n_dot_p = plane.normal.dot(&pt.cam);
        for c in &cloud.centres[pt.centres.clone()] {
            let seg = pt.cam - c;
            let len = seg.norm();
            if len.is_nan() || len <= margin {
                continue;
            }
            let denom = plane.normal.dot(&seg);
            if denom.abs() <= 1e-12 * len {
                continue;
            }
            // Y = c + s·(P − c) on the plane.
            let s = (plane.offset - (n_dot_p - denom)) / denom;
            if !(s > 0.0 && s < 1.0 - margin / len) {
                continue;
            }
            let y = c + seg * s;
            if let Some((px, py)) = pinhole
                .project(&y)
                .and_then(|xy| pixel_of(&xy, width, height))
            {
                out.push(Conflict {
                    pixel: py * width + px,
                    weight: pt.weight,
                });
            }
        }
    }
    out
}

/// Data costs of the target view for the labels `labels` (global plane indices): a dense
/// `Vec<f32>` indexed `pixel * labels.len() + local_label`, pixels row-major
/// (`pixel = y·width + x`). Values are in `[0, data_truncation]`.
///
/// Bit-identical for any rayon thread count: conflicts are gathered per label in point
/// order and summed in that order.
pub fn data_costs(
    inputs: &ViewInputs,
    labels: &[u32],
    config: &PlanemapConfig,
) -> Result<Vec<f32>, PlanemapError> {
    config.validate()?;
    inputs.validate()?;
    if let Some(&bad) = labels.iter().find(|&&l| l as usize >= inputs.planes.len()) {
        return Err(PlanemapError::Input(format!(
            "label {bad} but there are {} planes",
            inputs.planes.len()
        )));
    }
    let view = inputs.view();
    let (width, height) = (view.camera.width, view.camera.height);
    let pinhole = Pinhole::of(&view.camera);
    let num_labels = labels.len();
    let trunc = config.data_truncation as f32;
    let margin = config.margin_factor * inputs.scale;
    let planes_cam: Vec<Plane> = labels
        .iter()
        .map(|&l| inputs.planes[l as usize].in_camera(&view.cam_from_world))
        .collect();

    let mut costs = vec![0.0f32; width as usize * height as usize * num_labels];
    if num_labels == 0 {
        return Ok(costs);
    }

    let cloud = prepare(inputs, config, &pinhole);
    let per_label: Vec<Vec<Conflict>> = planes_cam
        .par_iter()
        .map(|plane| label_conflicts(plane, &cloud, &pinhole, width, height, margin))
        .collect();

    // Bucket the conflicts by the image row of their centre (counting sort, stable: within a
    // row, by label then point order), so each output row can gather its splats on its own
    // and every (pixel, label) sum runs in the same order for any thread count.
    let w = width as usize;
    let mut row_start = vec![0usize; height as usize + 1];
    for c in per_label.iter().flatten() {
        row_start[(c.pixel / width) as usize + 1] += 1;
    }
    for y in 0..height as usize {
        row_start[y + 1] += row_start[y];
    }
    let mut next = row_start.clone();
    // (x, local label, weight)
    let mut bucketed = vec![(0u32, 0u32, 0.0f32); row_start[height as usize]];
    for (label, conflicts) in per_label.iter().enumerate() {
        for c in conflicts {
            let row = (c.pixel / width) as usize;
            bucketed[next[row]] = (c.pixel % width, label as u32, c.weight);
            next[row] += 1;
        }
    }
    drop(per_label);

    // The vertical bound: (v in the camera frame, v · camera centre, lowest, highest).
    let vertical = if config.vertical_extent {
        vertical_extent(inputs, config.vertical_extent_margin)
    } else {
        None
    };
    let r = config.splat_radius as usize;
    let planes_flat: Vec<[f64; 4]> = planes_cam
        .iter()
        .map(|p| [p.normal.x, p.normal.y, p.normal.z, p.offset])
        .collect();
    costs
        .par_chunks_mut(w * num_labels)
        .enumerate()
        .for_each(|(y, row)| {
            let cy0 = y.saturating_sub(r);
            let cy1 = (y + r).min(height as usize - 1);
            for &(cx, label, weight) in &bucketed[row_start[cy0]..row_start[cy1 + 1]] {
                let x0 = (cx as usize).saturating_sub(r);
                let x1 = (cx as usize + r).min(w - 1);
                for x in x0..=x1 {
                    row[x * num_labels + label as usize] += weight;
                }
            }
            // Truncate; planes behind the camera or parallel to the ray: maximal cost.
            // (Scalar form of `Plane::depth_along`, same tests, for the hot loop.)
            let ry = (y as f64 + 0.5 - pinhole.cy) / pinhole.fy;
            for (x, px) in row.chunks_exact_mut(num_labels).enumerate() {
                let rx = (x as f64 + 0.5 - pinhole.cx) / pinhole.fx;
                // Height gained per unit of depth along this pixel's ray.
                let rise = vertical.map(|(v, ..)| v.x * rx + v.y * ry + v.z);
                for (c, &[nx, ny, nz, d]) in px.iter_mut().zip(&planes_flat) {
                    let denom = nx * rx + ny * ry + nz;
                    let z = d / denom;
                    let mut valid = denom.abs() > 1e-12 && z.is_finite() && z > 0.0;
                    if let (Some(rise), Some((_, base, lo, hi))) = (rise, vertical) {
                        let height = base + z * rise;
                        valid &= height >= lo && height <= hi;
                    }
                    *c = if valid { c.min(trunc) } else { trunc };
                }
            }
        });
    Ok(costs)
}

/// The scene's vertical extent for [`PlanemapConfig::vertical_extent`]: the vertical `v`
/// in the target camera's frame, `v · c` for its centre `c`, and the lowest and highest
/// allowed `v · X` (the sparse points' and camera centres' range, widened by `margin` of
/// it on each side). `None` when no dominant direction lies within 25° of the cameras'
/// mean "up" (their image −y axes), or the range is empty.
fn vertical_extent(inputs: &ViewInputs, margin: f64) -> Option<(Vector3<f64>, f64, f64, f64)> {
    let up: Vector3<f64> = inputs
        .views
        .iter()
        .map(|v| {
            -v.cam_from_world
                .rotation
                .inverse_transform_vector(&Vector3::y())
        })
        .sum();
    let up = up.try_normalize(1e-12)?;
    let (v, cos) = inputs
        .dominant_directions
        .iter()
        .filter_map(|d| d.try_normalize(1e-12))
        .map(|d| {
            let c = d.dot(&up);
            (if c < 0.0 { -d } else { d }, c.abs())
        })
        .max_by(|a, b| a.1.total_cmp(&b.1))?;
    if cos < 25f64.to_radians().cos() {
        return None;
    }
    let heights = inputs
        .cloud
        .positions
        .iter()
        .copied()
        .chain(inputs.views.iter().map(|w| w.center()))
        .map(|p| v.dot(&p));
    let (lo, hi) = heights.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), h| {
        (lo.min(h), hi.max(h))
    });
    if hi.partial_cmp(&lo) != Some(std::cmp::Ordering::Greater) {
        return None;
    }
    let pad = margin * (hi - lo);
    let view = inputs.view();
    let v_cam = view.cam_from_world.rotation * v;
    Some((v_cam, v.dot(&view.center()), lo - pad, hi + pad))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Camera, Rigid3};
    use crate::planemap::testutil::{corner_scene, CornerScene};
    use crate::raster::ImageF32;
    use crate::scene::{SparseCloud, View};

    /// Target camera at the origin looking down +z (100×100, f = 100), candidate planes
    /// z = 3, 5, 7, one point P at (0, 0, 5) projecting to pixel (50, 50).
    struct Line {
        views: Vec<View>,
        planes: Vec<Plane>,
        image: ImageF32,
    }

    fn line_setup(other_centre: Vector3<f64>) -> Line {
        let cam = Camera::pinhole(100, 100, 100.0, 100.0, 50.0, 50.0);
        let target = View {
            id: 0,
            name: "t".into(),
            camera: cam.clone(),
            cam_from_world: Rigid3::identity(),
            image_path: None,
        };
        let other = View {
            id: 1,
            name: "j".into(),
            camera: cam,
            cam_from_world: crate::geometry::look_at(
                &other_centre,
                &Vector3::new(0.0, 0.0, 5.0),
                &Vector3::new(0.0, -1.0, 0.0),
            ),
            image_path: None,
        };
        Line {
            views: vec![target, other],
            planes: [3.0, 5.0, 7.0]
                .iter()
                .map(|&d| Plane::new(Vector3::z(), d))
                .collect(),
            image: ImageF32::filled(100, 100, 1, 0.0),
        }
    }

    fn one_point(track: Vec<u32>, confidence: f64) -> SparseCloud {
        SparseCloud {
            positions: vec![Vector3::new(0.0, 0.0, 5.0)],
            colors: vec![[0; 3]],
            normals: None,
            tracks: vec![track],
            errors: vec![0.0],
            confidence: vec![confidence],
        }
    }

    fn costs_for(line: &Line, cloud: &SparseCloud, config: &PlanemapConfig) -> Vec<f32> {
        let inputs = ViewInputs {
            photo_planes: &[],
            view_index: 0,
            views: &line.views,
            image: &line.image,
            cloud,
            planes: &line.planes,
            dominant_directions: &[],
            scale: 0.01,
        };
        data_costs(&inputs, &[0, 1, 2], config).unwrap()
    }

    fn at(costs: &[f32], x: usize, y: usize, label: usize) -> f32 {
        costs[(y * 100 + x) * 3 + label]
    }

    #[test]
    fn case1_point_seen_by_target_rejects_front_and_back() {
        let line = line_setup(Vector3::new(0.0, 0.0, 20.0));
        // An offset, so the test sees it subtracted (the weight stays under the truncation).
        let config = PlanemapConfig {
            splat_radius: 0,
            confidence_offset: 0.2,
            ..Default::default()
        };
        let cloud = one_point(vec![0], 0.6);
        let c = costs_for(&line, &cloud, &config);
        let w = (0.6 - config.confidence_offset) as f32;
        assert_eq!(at(&c, 50, 50, 0), w);
        assert_eq!(at(&c, 50, 50, 1), 0.0);
        assert_eq!(at(&c, 50, 50, 2), w);
        // Nothing elsewhere (radius 0).
        let total: f32 = c.iter().sum();
        assert!((total - 2.0 * w).abs() < 1e-6, "{total}");
        // Within the margin γ = 10R = 0.1: a plane at 5.05 does not conflict, 5.2 does.
        let mut near = line_setup(Vector3::new(0.0, 0.0, 20.0));
        near.planes = vec![
            Plane::new(Vector3::z(), 5.05),
            Plane::new(Vector3::z(), 4.95),
            Plane::new(Vector3::z(), 5.2),
        ];
        let c = costs_for(&near, &cloud, &config);
        assert_eq!(
            [at(&c, 50, 50, 0), at(&c, 50, 50, 1), at(&c, 50, 50, 2)],
            [0.0, 0.0, w]
        );
    }

    #[test]
    fn case2_unseen_point_rejects_only_planes_behind_it() {
        let line = line_setup(Vector3::new(0.0, 0.0, 20.0));
        let config = PlanemapConfig {
            splat_radius: 1,
            ..Default::default()
        };
        let cloud = one_point(vec![], 0.9);
        let c = costs_for(&line, &cloud, &config);
        let w = (0.9 - config.confidence_offset) as f32;
        for (x, y) in [(49, 49), (50, 50), (51, 51), (51, 49)] {
            assert_eq!(at(&c, x, y, 0), 0.0, "front plane is allowed");
            assert_eq!(at(&c, x, y, 1), 0.0, "P's own plane is allowed");
            assert_eq!(
                at(&c, x, y, 2),
                w.min(config.data_truncation as f32),
                "behind"
            );
        }
        // Outside the 3×3 splat: nothing.
        assert_eq!(at(&c, 52, 50, 2), 0.0);
    }

    #[test]
    fn case3_plane_blocking_another_view_conflicts_where_it_blocks() {
        // View j at (2, 0, 0): segment to P crosses z = 3 at Y = (0.8, 0, 3), which projects
        // to image x = 0.8/3·100 + 50 ≈ 76.7 in the target, pixel (76, 50).
        let line = line_setup(Vector3::new(2.0, 0.0, 0.0));
        let config = PlanemapConfig {
            splat_radius: 0,
            confidence_offset: 0.3,
            ..Default::default()
        };
        let w = (0.7 - config.confidence_offset) as f32;
        let cloud = one_point(vec![1], 0.7);
        let c = costs_for(&line, &cloud, &config);
        assert_eq!(at(&c, 76, 50, 0), w);
        assert_eq!(at(&c, 76, 50, 1), 0.0);
        assert_eq!(at(&c, 76, 50, 2), 0.0);
        // Case 2 also fires at P's pixel for the plane behind P (P not seen by the target).
        assert_eq!(at(&c, 50, 50, 2), w);
        let total: f32 = c.iter().sum();
        assert!((total - 2.0 * w).abs() < 1e-6, "{total}");

        // Consistent configuration: camera j between the planes z = 3 and P: no blocking.
        let line = line_setup(Vector3::new(2.0, 0.0, 4.0));
        let c = costs_for(&line, &cloud, &config);
        assert_eq!(at(&c, 76, 50, 0), 0.0);
        let total: f32 = c.iter().sum();
        assert!((total - w).abs() < 1e-6, "only case 2 remains: {total}");
    }

    #[test]
    fn low_confidence_points_do_not_count_and_costs_are_truncated() {
        let line = line_setup(Vector3::new(0.0, 0.0, 20.0));
        let config = PlanemapConfig::default();
        let weak = one_point(vec![0], config.confidence_offset - 0.05);
        assert!(costs_for(&line, &weak, &config).iter().all(|&c| c == 0.0));
        let mut many = one_point(vec![0], 1.0);
        for _ in 0..3 {
            many.positions.push(many.positions[0]);
            many.colors.push([0; 3]);
            many.tracks.push(vec![0]);
            many.errors.push(0.0);
            many.confidence.push(1.0);
        }
        let c = costs_for(&line, &many, &config);
        assert_eq!(at(&c, 50, 50, 0), config.data_truncation as f32);
    }

    #[test]
    fn true_plane_minimises_data_cost_at_points() {
        let CornerScene {
            views,
            images,
            cloud,
            planes,
            true_label,
            scale,
            ..
        } = corner_scene();
        let config = PlanemapConfig::default();
        let t = 0;
        let inputs = ViewInputs {
            photo_planes: &[],
            view_index: t,
            views: &views,
            image: &images[t],
            cloud: &cloud,
            planes: &planes,
            dominant_directions: &[],
            scale,
        };
        let labels: Vec<u32> = (0..planes.len() as u32).collect();
        let costs = data_costs(&inputs, &labels, &config).unwrap();
        let l = labels.len();
        let w = views[t].camera.width;
        let mut checked = 0;
        for (i, p) in cloud.positions.iter().enumerate() {
            if !cloud.tracks[i].contains(&(t as u32)) {
                continue;
            }
            // Away from every other candidate plane, so no other label can tie.
            let own = true_label[i];
            let clear = planes
                .iter()
                .enumerate()
                .all(|(k, pl)| k == own || pl.signed_distance(p).abs() > 0.5);
            if !clear {
                continue;
            }
            let (xy, _) = views[t].project(p).unwrap();
            // The pixel of P and the 3×3 splat footprint around it.
            for (dx, dy) in (-1i64..=1).flat_map(|dx| (-1i64..=1).map(move |dy| (dx, dy))) {
                let (x, y) = (xy.x as i64 + dx, xy.y as i64 + dy);
                if x < 0 || y < 0 || x >= w as i64 || y >= views[t].camera.height as i64 {
                    continue;
                }
                let pix = (y as usize * w as usize + x as usize) * l;
                let row = &costs[pix..pix + l];
                for (k, &c) in row.iter().enumerate() {
                    if k != own {
                        assert!(
                            c > row[own],
                            "point {i}: label {k} {c} vs true {}",
                            row[own]
                        );
                    }
                }
            }
            checked += 1;
        }
        assert!(checked > 30, "only {checked} points checked");
    }

    #[test]
    fn no_nan_for_parallel_and_behind_planes() {
        let line = line_setup(Vector3::new(2.0, 0.0, 0.0));
        let planes = vec![
            Plane::new(Vector3::z(), -5.0),                 // behind the camera
            Plane::new(Vector3::x(), 0.0),                  // through the centre, contains rays
            Plane::new(Vector3::y(), 1.0),                  // parallel to the central row's rays
            Plane::new(Vector3::new(0.0, 1.0, 1e-14), 0.0), // nearly through the centre
            Plane::new(Vector3::z(), 5.0),
        ];
        let cloud = one_point(vec![0, 1], 0.9);
        let inputs = ViewInputs {
            photo_planes: &[],
            view_index: 0,
            views: &line.views,
            image: &line.image,
            cloud: &cloud,
            planes: &planes,
            dominant_directions: &[],
            scale: 0.01,
        };
        let config = PlanemapConfig::default();
        let labels: Vec<u32> = (0..planes.len() as u32).collect();
        let c = data_costs(&inputs, &labels, &config).unwrap();
        let trunc = config.data_truncation as f32;
        assert!(c.iter().all(|v| v.is_finite() && *v >= 0.0 && *v <= trunc));
        for p in 0..100 * 100 {
            assert_eq!(c[p * 5], trunc, "behind the camera");
            assert_eq!(c[p * 5 + 1], trunc, "through the centre");
        }
        // y = 1 is in front only for rays pointing down (image y > cy = 50).
        assert_eq!(c[(10 * 100 + 50) * 5 + 2], trunc);
        assert!(c[(90 * 100 + 50) * 5 + 2] < trunc);
    }

    /// Camera at eye height looking along a room (+z, image "up" = world −y): floor points
    /// 1.6 below, ceiling points 1.4 above. Low in the image, a far wall (z = 20) would be
    /// met 10 below the floor: free of conflicts, but out of the scene's vertical extent.
    #[test]
    fn vertical_extent_rules_out_a_wall_continued_below_the_floor() {
        let line = line_setup(Vector3::new(2.0, 0.0, 0.0));
        let planes = vec![
            Plane::new(Vector3::z(), 20.0), // the far wall
            Plane::new(Vector3::y(), 1.6),  // the floor (y points down)
        ];
        let mut cloud = one_point(vec![0, 1], 0.9);
        for (y, z) in [(1.6, 3.0), (1.6, 4.0), (-1.4, 3.0), (-1.4, 4.0)] {
            cloud.positions.push(Vector3::new(0.3, y, z));
            cloud.colors.push([0; 3]);
            cloud.tracks.push(vec![1]);
            cloud.errors.push(0.0);
            cloud.confidence.push(0.9);
        }
        let directions = [Vector3::x(), Vector3::y(), Vector3::z()];
        let inputs = ViewInputs {
            photo_planes: &[],
            view_index: 0,
            views: &line.views,
            image: &line.image,
            cloud: &cloud,
            planes: &planes,
            dominant_directions: &directions,
            scale: 0.01,
        };
        let labels = [0u32, 1];
        let trunc = PlanemapConfig::default().data_truncation as f32;
        let bottom = (99 * 100 + 50) * 2; // ray 0.49 down per unit depth
        let centre = (50 * 100 + 50) * 2;
        let off = data_costs(&inputs, &labels, &PlanemapConfig::default()).unwrap();
        assert!(
            off[bottom] < trunc,
            "without the bound the wall is free there"
        );
        let on = PlanemapConfig {
            vertical_extent: true,
            ..PlanemapConfig::default()
        };
        let c = data_costs(&inputs, &labels, &on).unwrap();
        assert_eq!(c[bottom], trunc, "wall met 9.8 below the floor");
        assert!(c[bottom + 1] < trunc, "the floor itself is inside");
        assert_eq!(c[centre], off[centre], "the wall at eye height is inside");
        // A margin as tall as the scene takes the wall back in.
        let wide = PlanemapConfig {
            vertical_extent_margin: 4.0,
            ..on
        };
        assert!(data_costs(&inputs, &labels, &wide).unwrap()[bottom] < trunc);
    }

    #[test]
    fn data_costs_identical_across_thread_counts() {
        let scene = corner_scene();
        let inputs = ViewInputs {
            photo_planes: &[],
            view_index: 1,
            views: &scene.views,
            image: &scene.images[1],
            cloud: &scene.cloud,
            planes: &scene.planes,
            dominant_directions: &[],
            scale: scene.scale,
        };
        let labels: Vec<u32> = (0..scene.planes.len() as u32).collect();
        let config = PlanemapConfig::default();
        let many = data_costs(&inputs, &labels, &config).unwrap();
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let one = pool.install(|| data_costs(&inputs, &labels, &config).unwrap());
        assert!(many.iter().any(|&c| c > 0.0));
        let bits = |v: &[f32]| v.iter().map(|c| c.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&many), bits(&one));
    }
}
