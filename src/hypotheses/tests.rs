//! Tests of the point and sweep hypotheses.

use super::points::*;
use super::sweep::*;
use super::*;
use crate::axes::{dominant_axes, AxesConfig};
use crate::normals::tests::{scene_from, test_view};
use crate::normals::{estimate_normals, NormalsConfig};
use crate::raster::ImageF32;
use crate::scale::sampling_scale;
use crate::scene::{Scene, View};
use nalgebra::{Rotation3, Unit};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Points on the faces of a box with half-sizes `half`, rotated by `rot` and shifted by
/// `center`, with position noise `noise` and `outliers` random points. Returns positions
/// and the true face planes.
fn box_points(
    rng: &mut ChaCha8Rng,
    rot: &Rotation3<f64>,
    center: Vector3<f64>,
    half: Vector3<f64>,
    per_face: usize,
    noise: f64,
    outliers: usize,
) -> (Vec<Vector3<f64>>, Vec<Plane>) {
    let mut pts = Vec::new();
    let mut planes = Vec::new();
    for axis in 0..3 {
        for sign in [-1.0, 1.0] {
            let mut local_n = Vector3::zeros();
            local_n[axis] = sign;
            let n = rot * local_n;
            planes.push(Plane::through(&(center + n * half[axis]), &n));
            for _ in 0..per_face {
                let mut q = Vector3::zeros();
                for a in 0..3 {
                    q[a] = if a == axis {
                        sign * half[a] + rng.random_range(-noise..noise)
                    } else {
                        rng.random_range(-half[a]..half[a])
                    };
                }
                pts.push(center + rot * q);
            }
        }
    }
    for _ in 0..outliers {
        let q = Vector3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        pts.push(center + rot * q.component_mul(&half) * 1.5);
    }
    (pts, planes)
}

#[test]
fn box_faces_recovered_from_pca_normals() {
    let mut rng = ChaCha8Rng::seed_from_u64(42);
    let rot = Rotation3::from_axis_angle(&Unit::new_normalize(Vector3::new(0.3, 0.8, -0.4)), 0.7);
    let center = Vector3::new(0.3, -0.2, 0.1);
    let half = Vector3::new(1.0, 0.7, 0.5);
    let (pts, planes) = box_points(&mut rng, &rot, center, half, 1500, 0.004, 300);
    // Cameras all around, at ~6 units: R ≈ 6/500 = 0.012.
    let views: Vec<_> = (0..8)
        .map(|i| {
            let a = i as f64 * std::f64::consts::TAU / 8.0;
            let z = if i % 2 == 0 { 3.0 } else { -3.0 };
            test_view(i, Vector3::new(6.0 * a.cos(), 6.0 * a.sin(), z))
        })
        .collect();
    let scene = scene_from(views, pts);
    let r = sampling_scale(&scene).unwrap();
    assert!(r > 0.005 && r < 0.03, "R = {r}");
    let oc = estimate_normals(&scene, &NormalsConfig::default()).unwrap();
    let axes = dominant_axes(&oc, &AxesConfig::default()).unwrap();
    assert_eq!(axes.directions.len(), 3);
    for k in 0..3 {
        let truth = rot * Vector3::ith(k, 1.0);
        let e = axes
            .directions
            .iter()
            .map(|d| d.dot(&truth).abs().min(1.0).acos().to_degrees())
            .fold(f64::INFINITY, f64::min);
        assert!(e < 1.0, "axis {k} error {e}°");
    }
    let input = HypothesesInput {
        positions: &scene.cloud.positions,
        normals: &oc.normals,
        confidence: &oc.confidence,
        axes: &axes,
        scale: r,
    };
    let hyps = plane_hypotheses(&input, &HypothesesConfig::default()).unwrap();
    assert_eq!(hyps.len(), 6, "{hyps:#?}");
    for truth in &planes {
        let matched: Vec<_> = hyps
            .iter()
            .filter(|h| {
                let c = h.plane.normal.dot(&truth.normal);
                c.abs() > 0.999 && (h.plane.offset - c.signum() * truth.offset).abs() < r
            })
            .collect();
        assert_eq!(matched.len(), 1, "plane {truth:?}: {matched:?}");
        assert!(matched[0].support > 1000);
    }
    for (i, h) in hyps.iter().enumerate() {
        assert_eq!(h.id as usize, i);
    }
    // Stable order: by direction, then offset.
    for w in hyps.windows(2) {
        assert!(
            w[0].axis < w[1].axis
                || (w[0].axis == w[1].axis && w[0].plane.offset < w[1].plane.offset)
        );
    }
}

#[test]
fn house_with_roof_slopes_end_to_end() {
    // Walls x, y ∈ [-1, 1], z ∈ [0, 1], floor z = 0, gable roof at 30° over x.
    let mut rng = ChaCha8Rng::seed_from_u64(17);
    let slope = 30f64.to_radians();
    let mut pts = Vec::new();
    let mut u = |a: f64, b: f64| rng.random_range(a..b);
    let noise = 0.003;
    for _ in 0..2000 {
        for s in [-1.0, 1.0] {
            pts.push(Vector3::new(
                s + u(-noise, noise),
                u(-1.0, 1.0),
                u(0.0, 1.0),
            ));
            pts.push(Vector3::new(
                u(-1.0, 1.0),
                s + u(-noise, noise),
                u(0.0, 1.0),
            ));
        }
    }
    for _ in 0..2500 {
        pts.push(Vector3::new(u(-1.0, 1.0), u(-1.0, 1.0), u(-noise, noise)));
    }
    for _ in 0..1500 {
        for s in [-1.0, 1.0] {
            let x: f64 = u(0.0, 1.0);
            pts.push(Vector3::new(
                s * x,
                u(-1.0, 1.0),
                1.0 + (1.0 - x) * slope.tan() + u(-noise, noise),
            ));
        }
    }
    let truth = [
        Plane::new(Vector3::x(), 1.0),
        Plane::new(Vector3::x(), -1.0),
        Plane::new(Vector3::y(), 1.0),
        Plane::new(Vector3::y(), -1.0),
        Plane::new(Vector3::z(), 0.0),
        Plane::through(
            &Vector3::new(1.0, 0.0, 1.0),
            &Vector3::new(slope.sin(), 0.0, slope.cos()),
        ),
        Plane::through(
            &Vector3::new(-1.0, 0.0, 1.0),
            &Vector3::new(-slope.sin(), 0.0, slope.cos()),
        ),
    ];
    let views: Vec<_> = (0..8)
        .map(|i| {
            let a = i as f64 * std::f64::consts::TAU / 8.0 + 0.2;
            let z = if i % 2 == 0 { 4.0 } else { -3.0 };
            test_view(i, Vector3::new(6.0 * a.cos(), 6.0 * a.sin(), z))
        })
        .collect();
    let scene = scene_from(views, pts);
    let r = sampling_scale(&scene).unwrap();
    let oc = estimate_normals(&scene, &NormalsConfig::default()).unwrap();
    let with_extras = |max_extra_directions| {
        let cfg = AxesConfig {
            max_extra_directions,
            ..Default::default()
        };
        dominant_axes(&oc, &cfg).unwrap()
    };
    assert_eq!(with_extras(0).directions.len(), 3);
    let axes = with_extras(4);
    assert_eq!(axes.directions.len(), 5, "{:?}", axes.directions);
    let input = HypothesesInput {
        positions: &scene.cloud.positions,
        normals: &oc.normals,
        confidence: &oc.confidence,
        axes: &axes,
        scale: r,
    };
    let hyps = plane_hypotheses(&input, &HypothesesConfig::default()).unwrap();
    let mut matched_ids = Vec::new();
    for t in &truth {
        let m: Vec<_> = hyps
            .iter()
            .filter(|h| {
                let c = h.plane.normal.dot(&t.normal);
                c.abs() > 0.9995 && (h.plane.offset - c.signum() * t.offset).abs() < r
            })
            .collect();
        assert_eq!(m.len(), 1, "plane {t:?}: {m:?}");
        matched_ids.push(m[0].id);
    }
    // Anything else (e.g. the ridge line, whose PCA normals point up) is weakly supported.
    let weakest_true = matched_ids
        .iter()
        .map(|&i| hyps[i as usize].support)
        .min()
        .unwrap();
    for h in hyps.iter().filter(|h| !matched_ids.contains(&h.id)) {
        assert!(h.support * 4 < weakest_true, "spurious {h:?}");
    }
}

/// A textured room corner (walls x = 0, y = 0, floor z = 0) seen by the corner views;
/// sparse points only on the floor and the wall y = 0 (plus 3 on x = 0, below any
/// support threshold): the sweep must propose x = 0, and nothing the points already give.
#[test]
fn sweep_proposes_the_textured_wall_the_points_miss() {
    use crate::planemap::testutil::corner_views;
    let views = corner_views();
    let texture = |p: &Vector3<f64>, face: usize| -> f32 {
        // Random grey per 0.15 m cell of the face's two in-plane coordinates.
        let (a, b) = match face {
            0 => (p.y, p.z),
            1 => (p.x, p.z),
            _ => (p.x, p.y),
        };
        let (i, j) = ((a / 0.15).floor() as i64, (b / 0.15).floor() as i64);
        let h =
            (i.wrapping_mul(73_856_093) ^ j.wrapping_mul(19_349_663) ^ (face as i64 * 83_492_791))
                .rem_euclid(1000);
        0.2 + 0.6 * h as f32 / 1000.0
    };
    let images = render_corner(&views, 1, |f, p| texture(p, f));
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let mut positions = Vec::new();
    for (face, count) in [(1usize, 150), (2, 150), (0, 3)] {
        for _ in 0..count {
            let mut p = Vector3::zeros();
            for k in 0..3 {
                if k != face {
                    p[k] = rng.random_range(0.1..3.9);
                }
            }
            positions.push(p);
        }
    }
    let n = positions.len();
    let mut normals = vec![Vector3::z(); n];
    for (i, nr) in normals.iter_mut().enumerate().take(150) {
        let _ = i;
        *nr = Vector3::y();
    }
    normals[300..].fill(Vector3::x());
    let confidence = vec![1.0; n];
    let scene = seen_by_every_view(views, &positions);
    let axes = manual_axes(vec![Vector3::x(), Vector3::y(), Vector3::z()]);
    let input = HypothesesInput {
        positions: &positions,
        normals: &normals,
        confidence: &confidence,
        axes: &axes,
        scale: 0.02,
    };
    let cfg = HypothesesConfig {
        sweep: SweepHypothesesConfig {
            max_planes_per_axis: 60,
            ..Default::default()
        },
        ..Default::default()
    };
    let existing = plane_hypotheses(&input, &cfg).unwrap();
    assert!(existing.iter().all(|h| h.axis != Some(0)), "{existing:?}");
    let (extra, votes) = sweep_hypotheses(&scene, &images, &input, &existing, &cfg).unwrap();
    assert_eq!(votes.step.len(), 3);
    let wall: Vec<_> = extra.iter().filter(|h| h.axis == Some(0)).collect();
    assert_eq!(wall.len(), 1, "{extra:?}");
    assert!(
        wall[0].plane.offset.abs() < 2.0 * votes.step[0],
        "{:?}",
        wall[0]
    );
    assert_eq!(wall[0].id as usize, existing.len());
    // Nothing within the merge tolerance of the floor or the wall y = 0.
    for h in &extra {
        for e in &existing {
            let same = h.plane.normal.dot(&e.plane.normal).abs() > 0.99;
            assert!(
                !same || (h.plane.offset - e.plane.offset).abs() > 0.02,
                "{h:?}"
            );
        }
    }
    // Bad input: image count.
    assert!(sweep_hypotheses(&scene, &images[..2], &input, &existing, &cfg).is_err());
}

/// A textured lawn z = 0 seen from eye height at grazing angles and a back wall y = 8
/// that holds every sparse point (thin's garden in miniature). A step of a few R moves
/// lawn pixels by several pixels in the neighbours, wider than the 5×5 NCC basin: no
/// offset matched, nothing voted for the lawn. With the step refined to the pixels
/// (`max_step_px`), the sweep proposes z = 0.
#[test]
fn sweep_refines_its_step_until_a_grazing_lawn_votes() {
    use crate::geometry::{look_at, Camera};
    let value = |a: f64, b: f64, salt: i64| -> f32 {
        let (i, j) = ((a / 0.2).floor() as i64, (b / 0.2).floor() as i64);
        let h = (i.wrapping_mul(73_856_093) ^ j.wrapping_mul(19_349_663) ^ salt).rem_euclid(1000);
        0.2 + 0.6 * h as f32 / 1000.0
    };
    let shade = |o: &Vector3<f64>, d: &Vector3<f64>| -> f32 {
        let t_wall = if d.y > 1e-9 {
            (8.0 - o.y) / d.y
        } else {
            f64::INFINITY
        };
        let t_lawn = if d.z < -1e-9 {
            -o.z / d.z
        } else {
            f64::INFINITY
        };
        if t_lawn < t_wall {
            let p = o + d * t_lawn;
            value(p.x, p.y, 11)
        } else if t_wall.is_finite() {
            let p = o + d * t_wall;
            value(p.x, p.z, 29)
        } else {
            0.9
        }
    };
    let cam = Camera::pinhole(120, 90, 100.0, 100.0, 60.0, 45.0);
    let views: Vec<View> = [-1.2, -0.4, 0.4, 1.2]
        .iter()
        .enumerate()
        .map(|(i, &x)| View {
            id: i as u32 + 1,
            name: format!("v{i}.png"),
            camera: cam.clone(),
            cam_from_world: look_at(
                &Vector3::new(x, 0.0, 1.5),
                &Vector3::new(0.3 * x, 8.0, 0.4),
                &Vector3::z(),
            ),
            image_path: None,
        })
        .collect();
    let images: Vec<ImageF32> = views
        .iter()
        .map(|v| {
            let mut img = ImageF32::filled(120, 90, 1, 0.0);
            for y in 0..90 {
                for x in 0..120 {
                    let (o, d) = v.ray(&nalgebra::Vector2::new(x as f64 + 0.5, y as f64 + 0.5));
                    img.pixel_mut(x, y)[0] = shade(&o, &d);
                }
            }
            img
        })
        .collect();
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    let positions: Vec<Vector3<f64>> = (0..150)
        .map(|_| Vector3::new(rng.random_range(-3.0..3.0), 8.0, rng.random_range(0.1..3.0)))
        .collect();
    let n = positions.len();
    let (normals, confidence) = (vec![Vector3::y(); n], vec![1.0; n]);
    let scene = seen_by_every_view(views, &positions);
    let axes = manual_axes(vec![Vector3::y(), Vector3::z(), Vector3::x()]);
    let input = HypothesesInput {
        positions: &positions,
        normals: &normals,
        confidence: &confidence,
        axes: &axes,
        scale: 0.02,
    };
    let coarse = HypothesesConfig {
        sweep: SweepHypothesesConfig {
            downsample: 1,
            max_planes_per_axis: 40,
            max_fine_planes: 400,
            max_step_px: 0.0,
            ..Default::default()
        },
        ..Default::default()
    };
    let existing = plane_hypotheses(&input, &coarse).unwrap();
    assert!(existing.iter().all(|h| h.axis == Some(0)), "{existing:?}");
    let lawn = |extra: &[PlaneHypothesis]| {
        extra
            .iter()
            .filter(|h| h.axis == Some(1) && h.plane.offset.abs() < 0.02)
            .count()
    };
    let (extra, votes) = sweep_hypotheses(&scene, &images, &input, &existing, &coarse).unwrap();
    assert_eq!(lawn(&extra), 0, "step {:?}: {extra:?}", votes.step);
    let mut fine = coarse.clone();
    fine.sweep.max_step_px = SweepHypothesesConfig::default().max_step_px;
    let (extra, fine_votes) = sweep_hypotheses(&scene, &images, &input, &existing, &fine).unwrap();
    assert_eq!(lawn(&extra), 1, "step {:?}: {extra:?}", fine_votes.step);
    assert_eq!(votes.sub_planes, vec![1; 3]);
    assert!(fine_votes.sub_planes[1] >= 2, "{fine_votes:?}");
}

/// A scene of `views` whose sparse points are all seen by every view.
fn seen_by_every_view(views: Vec<View>, positions: &[Vector3<f64>]) -> Scene {
    let n = positions.len();
    let track: Vec<u32> = (0..views.len() as u32).collect();
    Scene {
        views,
        cloud: crate::scene::SparseCloud {
            tracks: vec![track; n],
            colors: vec![[128; 3]; n],
            errors: vec![0.5; n],
            confidence: vec![1.0; n],
            normals: None,
            positions: positions.to_vec(),
        },
    }
}

fn manual_axes(dirs: Vec<Vector3<f64>>) -> DominantAxes {
    let m = dirs.len();
    DominantAxes {
        support: vec![0; m],
        directions: dirs,
        pairwise_angles_deg: vec![],
        num_manhattan: m,
        warnings: vec![],
    }
}

/// A flight of ten treads (points with vertical normals) whose nosings (40 points each on
/// the tread's front edge, normals smeared to the flight's slope) line up on one slanted
/// plane, and a roof along a second extra direction: the slope's hypothesis, whose
/// points all lie on tread planes, is dropped; the roof's is kept; with
/// `max_shared_fraction` = 1 both are proposed.
#[test]
fn a_slope_through_stair_nosings_is_not_a_plane_but_a_roof_is() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let slope = Vector3::new(0.0, -0.2, 0.3).normalize();
    let roof_n = Vector3::new(1.0, 0.0, 1.0).normalize();
    let (mut positions, mut normals) = (Vec::new(), Vec::new());
    for k in 0..10 {
        let (y0, z) = (0.3 * k as f64, 0.2 * k as f64);
        for _ in 0..60 {
            positions.push(Vector3::new(
                rng.random(),
                y0 + 0.3 * rng.random::<f64>(),
                z,
            ));
            normals.push(Vector3::z());
        }
        for _ in 0..40 {
            positions.push(Vector3::new(rng.random(), y0, z));
            normals.push(slope);
        }
    }
    let (e1, e2) = (Vector3::y(), Vector3::new(-1.0, 0.0, 1.0).normalize());
    for _ in 0..300 {
        let (u, v): (f64, f64) = (rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
        positions.push(Vector3::new(5.0, 0.0, 5.0) + e1 * u + e2 * v);
        normals.push(roof_n);
    }
    let mut axes = manual_axes(vec![
        Vector3::x(),
        Vector3::y(),
        Vector3::z(),
        slope,
        roof_n,
    ]);
    axes.num_manhattan = 3;
    let confidence = vec![1.0; positions.len()];
    let input = HypothesesInput {
        positions: &positions,
        normals: &normals,
        confidence: &confidence,
        axes: &axes,
        scale: 0.01,
    };
    let along =
        |hyps: &[PlaneHypothesis], k: usize| hyps.iter().filter(|h| h.axis == Some(k)).count();
    let all = plane_hypotheses(
        &input,
        &HypothesesConfig {
            max_shared_fraction: 1.0,
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(along(&all, 2), 10, "one per tread");
    assert_eq!(along(&all, 3), 1, "the nosings' plane is proposed");
    assert_eq!(along(&all, 4), 1, "the roof");
    let kept = plane_hypotheses(&input, &HypothesesConfig::default()).unwrap();
    assert_eq!(along(&kept, 2), 10);
    assert_eq!(along(&kept, 3), 0, "its points all lie on tread planes");
    assert_eq!(along(&kept, 4), 1, "the roof meets no tread plane");
    assert!(kept.iter().enumerate().all(|(i, h)| h.id == i as u32));
}

/// A riser's points at y = 2.10 (±4 mm) next to tread points spread over y ∈ [2.10, 2.40]:
/// a sweep plane 2 cm off snaps to the riser; without the concentration it stays put.
#[test]
fn sweep_planes_snap_to_a_concentration_of_points_only() {
    let mut rng = ChaCha8Rng::seed_from_u64(21);
    let d = Vector3::y();
    let riser: Vec<Vector3<f64>> = (0..40)
        .map(|_| Vector3::new(rng.random(), 2.10 + rng.random_range(-0.004..0.004), 1.4))
        .collect();
    let tread: Vec<Vector3<f64>> = (0..150)
        .map(|_| Vector3::new(rng.random(), rng.random_range(2.10..2.40), 1.44))
        .collect();
    let all: Vec<Vector3<f64>> = riser.iter().chain(&tread).copied().collect();
    let (reach, window) = (0.045, 0.0138);
    let snapped = snap_to_points(&all, &d, 2.12, reach, window, 4.0);
    assert!((snapped - 2.10).abs() < 0.003, "{snapped}");
    // The tread alone is a uniform spread: no snap.
    assert_eq!(snap_to_points(&tread, &d, 2.25, reach, window, 4.0), 2.25);
    // Too few points, or the snap off: no snap.
    assert_eq!(
        snap_to_points(&riser[..5], &d, 2.12, reach, window, 4.0),
        2.12
    );
    assert_eq!(snap_to_points(&all, &d, 2.12, reach, 0.0, 4.0), 2.12);
    // Nothing within reach: unchanged; non-finite points are ignored.
    let mut far = all.clone();
    far.push(Vector3::new(f64::NAN, 0.0, 0.0));
    assert_eq!(snap_to_points(&far, &d, 3.5, reach, window, 4.0), 3.5);
    assert!((snap_to_points(&far, &d, 2.12, reach, window, 4.0) - 2.10).abs() < 0.003);
}

#[test]
fn parallel_planes_gaussian_and_flat_agree_and_small_clouds() {
    let mut rng = ChaCha8Rng::seed_from_u64(8);
    let d = Vector3::new(0.0, 0.6, 0.8);
    let r = 0.01;
    // Three parallel planes 10R apart, 200 / 80 / 30 points, σ ≈ R/3, plus spread noise.
    let mut pts = Vec::new();
    for (off, c) in [(0.5, 200), (0.6, 80), (0.7, 30)] {
        for _ in 0..c {
            let e = rng.random_range(-0.005..0.005);
            let t =
                Vector3::new(rng.random_range(-1.0..1.0), 0.8, -0.6) * rng.random_range(-1.0..1.0);
            pts.push(
                d * (off + e) + Vector3::new(t.x, 0.0, 0.0) + Vector3::new(0.0, 0.8, -0.6) * t.y,
            );
        }
    }
    for _ in 0..100 {
        pts.push(d * rng.random_range(-2.0..2.0));
    }
    let n = pts.len();
    let normals = vec![d; n];
    let conf = vec![1.0; n];
    let axes = manual_axes(vec![d]);
    let input = HypothesesInput {
        positions: &pts,
        normals: &normals,
        confidence: &conf,
        axes: &axes,
        scale: r,
    };
    let cfg = HypothesesConfig::default();
    // 410 points: effective minimum min(50, max(10, ceil(4.1))) = 10.
    assert_eq!(cfg.effective_min_support(n), MIN_SUPPORT_FLOOR);
    let flat = plane_hypotheses(&input, &cfg).unwrap();
    let offs: Vec<f64> = flat.iter().map(|h| h.plane.offset).collect();
    assert_eq!(offs.len(), 3, "{flat:?}");
    for (o, t) in offs.iter().zip([0.5, 0.6, 0.7]) {
        assert!((o - t).abs() < r, "{o} vs {t}");
    }
    let gauss = plane_hypotheses(
        &input,
        &HypothesesConfig {
            kernel: Kernel::Gaussian,
            bandwidth_r: 1.0,
            ..cfg.clone()
        },
    )
    .unwrap();
    assert_eq!(gauss.len(), 3, "{gauss:?}");
    for (g, f) in gauss.iter().zip(&flat) {
        assert!((g.plane.offset - f.plane.offset).abs() < r);
    }
    // Paper threshold 50 without the relative rule drops the 30-point plane.
    let strict = plane_hypotheses(
        &input,
        &HypothesesConfig {
            min_support_fraction: 1.0,
            ..cfg.clone()
        },
    )
    .unwrap();
    assert_eq!(strict.len(), 2);
}

#[test]
fn duplicate_directions_merge_and_bad_input_errors() {
    let d = Vector3::z();
    let d2 = Vector3::new(0.001, 0.0, 1.0).normalize();
    let pts: Vec<_> = (0..100)
        .map(|i| Vector3::new(i as f64 * 0.01, 0.0, 1.0))
        .collect();
    let normals = vec![d; 100];
    let conf = vec![1.0; 100];
    let axes = manual_axes(vec![d, d2]);
    let mut input = HypothesesInput {
        positions: &pts,
        normals: &normals,
        confidence: &conf,
        axes: &axes,
        scale: 0.01,
    };
    let hyps = plane_hypotheses(&input, &HypothesesConfig::default()).unwrap();
    assert_eq!(hyps.len(), 1, "{hyps:?}");
    assert_eq!(hyps[0].support, 100);
    assert!((hyps[0].plane.offset - 1.0).abs() < 1e-12);
    input.scale = 0.0;
    assert!(plane_hypotheses(&input, &HypothesesConfig::default()).is_err());
    input.scale = 0.01;
    input.confidence = &conf[..3];
    assert!(plane_hypotheses(&input, &HypothesesConfig::default()).is_err());
    assert!(HypothesesConfig {
        bandwidth_r: -1.0,
        ..Default::default()
    }
    .validate()
    .is_err());
}

#[test]
fn deterministic_across_thread_counts() {
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    let rot = Rotation3::from_axis_angle(&Vector3::z_axis(), 0.3);
    let (pts, _) = box_points(
        &mut rng,
        &rot,
        Vector3::zeros(),
        Vector3::new(1.0, 1.0, 1.0),
        400,
        0.01,
        200,
    );
    let normals: Vec<_> = pts
        .iter()
        .map(|p| (rot.inverse() * p).map(|v| if v.abs() > 0.98 { v.signum() } else { 0.0 }))
        .map(|v| {
            if v.norm() == 1.0 {
                rot * v
            } else {
                Vector3::x()
            }
        })
        .collect();
    let conf = vec![1.0; pts.len()];
    let axes = manual_axes(vec![rot * Vector3::x(), rot * Vector3::y(), Vector3::z()]);
    let input = HypothesesInput {
        positions: &pts,
        normals: &normals,
        confidence: &conf,
        axes: &axes,
        scale: 0.01,
    };
    let run = |t| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build()
            .unwrap()
            .install(|| plane_hypotheses(&input, &HypothesesConfig::default()).unwrap())
    };
    let a = run(1);
    assert_eq!(a, run(2));
    assert_eq!(a.len(), 6, "{a:?}");
}

/// Issue 37's test: the wall x = 0 of a room corner is plain paint, with no sparse point
/// and no texture, seen by three views; the points (on the other wall and the floor)
/// propose no plane for it. Its edges — the corner, the floor crease and its outline
/// against the sky — are image lines; triangulated, they span its plane, with no other
/// source of hypotheses involved.
#[test]
fn a_plain_wall_without_points_gets_its_plane_from_its_edges() {
    use crate::lines::{triangulate_lines, LinesConfig};
    use crate::planemap::testutil::{corner_views, FACE};
    let views = corner_views();
    // Plain faces (grey 0.3, 0.55, 0.8), sky 0.05, 4×4 supersampling.
    let images = render_corner(&views, 4, |f, _| [0.3, 0.55, 0.8][f]);
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    for face in [1usize, 2] {
        for _ in 0..150 {
            let mut p = Vector3::zeros();
            for k in (0..3).filter(|&k| k != face) {
                p[k] = rng.random_range(0.1..FACE - 0.1);
            }
            positions.push(p);
            let mut n = Vector3::zeros();
            n[face] = 1.0;
            normals.push(n);
        }
    }
    let confidence = vec![1.0; positions.len()];
    let scene = seen_by_every_view(views, &positions);
    let axes = manual_axes(vec![Vector3::x(), Vector3::y(), Vector3::z()]);
    let input = HypothesesInput {
        positions: &positions,
        normals: &normals,
        confidence: &confidence,
        axes: &axes,
        // R: a pixel is 6 cm at the views' 8 m.
        scale: 0.06,
    };
    let mut cfg = HypothesesConfig::default();
    cfg.lines.enabled = false;
    let existing = plane_hypotheses(&input, &cfg).unwrap();
    assert!(existing.iter().all(|h| h.axis != Some(0)), "{existing:?}");
    // Three views see the wall: a line needs all three.
    let lines_cfg = LinesConfig {
        min_views: 3,
        ..LinesConfig::default()
    };
    let set = triangulate_lines(&scene, &images, &axes.directions, 0.06, &lines_cfg);
    assert!(set.lines.len() >= 3, "{set:?}");
    // Lines off: nothing.
    assert!(line_plane_hypotheses(&input, &set.lines, &existing, &cfg)
        .unwrap()
        .is_empty());
    cfg.lines.enabled = true;
    let planes = line_plane_hypotheses(&input, &set.lines, &existing, &cfg).unwrap();
    // The wall, within half a pixel's size (R = 6 cm). (The far outlines of the other two
    // faces, against the sky, also span a plane x = 4 that no surface fills.)
    let wall: Vec<_> = planes
        .iter()
        .filter(|h| h.axis == Some(0) && h.plane.offset.abs() < 0.5)
        .collect();
    assert_eq!(wall.len(), 1, "{planes:?}");
    assert!(wall[0].plane.offset.abs() < 0.03, "{:?}", wall[0]);
    assert!(planes[0].id as usize == existing.len());
}

/// Grey images of the room corner of `planemap::testutil` seen by `views`: `shade(face,
/// point)` on its faces, 0.05 for the sky, the mean of `grid`×`grid` rays per pixel.
fn render_corner(
    views: &[View],
    grid: u32,
    shade: impl Fn(usize, &Vector3<f64>) -> f32,
) -> Vec<ImageF32> {
    use crate::planemap::testutil::cast;
    views
        .iter()
        .map(|v| {
            let (w, h) = (v.camera.width, v.camera.height);
            let mut img = ImageF32::filled(w, h, 1, 0.0);
            let step = 1.0 / grid as f64;
            for y in 0..h {
                for x in 0..w {
                    let mut sum = 0.0;
                    for s in 0..grid * grid {
                        let xy = nalgebra::Vector2::new(
                            x as f64 + ((s % grid) as f64 + 0.5) * step,
                            y as f64 + ((s / grid) as f64 + 0.5) * step,
                        );
                        let (o, d) = v.ray(&xy);
                        sum += cast(&o, &d).map_or(0.05, |(f, p)| shade(f, &p));
                    }
                    img.pixel_mut(x, y)[0] = sum / (grid * grid) as f32;
                }
            }
            img
        })
        .collect()
}
