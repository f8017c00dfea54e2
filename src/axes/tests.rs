use super::*;
use crate::scene::View;
use nalgebra::{Rotation3, Unit};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A unit vector perturbed by roughly `sigma_deg` degrees.
pub(crate) fn jitter(rng: &mut ChaCha8Rng, n: Vector3<f64>, sigma_deg: f64) -> Vector3<f64> {
    let s = sigma_deg.to_radians();
    let mut g = || (0..6).map(|_| rng.random::<f64>()).sum::<f64>() - 3.0;
    let p = Vector3::new(g(), g(), g()) * s * 0.7;
    (n + p - n * n.dot(&p)).normalize()
}

fn random_unit(rng: &mut ChaCha8Rng) -> Vector3<f64> {
    loop {
        let v = Vector3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        let l = v.norm();
        if l > 0.1 && l <= 1.0 {
            return v / l;
        }
    }
}

fn cloud_of(normals: Vec<Vector3<f64>>) -> OrientedCloud {
    let n = normals.len();
    OrientedCloud {
        normals,
        confidence: vec![1.0; n],
        estimated: true,
    }
}

fn best_match(found: &[Vector3<f64>], truth: &Vector3<f64>) -> f64 {
    found
        .iter()
        .map(|d| axial_angle_deg(d, truth))
        .fold(f64::INFINITY, f64::min)
}

/// Parallel planes (x = 0, 1; y = 0, 2; z = 0, 0.5, 1) sampled with noise; the axes
/// start tilted by 6° and smeared normals: the refit recovers the true axes.
#[test]
fn refit_from_plane_points_removes_a_tilt() {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    let planes_true = [
        (0usize, 0.0),
        (0, 1.0),
        (1, 0.0),
        (1, 2.0),
        (2, 0.0),
        (2, 0.5),
        (2, 1.0),
    ];
    for &(axis, off) in &planes_true {
        for _ in 0..200 {
            let mut p = Vector3::new(
                rng.random_range(0.0..1.0),
                rng.random_range(0.0..2.0),
                rng.random_range(0.0..1.0),
            );
            p[axis] = off + rng.random_range(-0.002..0.002);
            positions.push(p);
            let mut n = Vector3::zeros();
            n[axis] = 1.0;
            normals.push(n);
        }
    }
    let tilt = 6.0f64.to_radians();
    let z_tilted = Vector3::new(0.0, -tilt.sin(), tilt.cos());
    let axes = DominantAxes {
        directions: vec![Vector3::x(), Vector3::y(), z_tilted],
        support: vec![0; 3],
        pairwise_angles_deg: vec![],
        num_manhattan: 3,
        warnings: vec![],
    };
    // The tilted axis' hypotheses: the mean offsets of the true planes along it.
    let planes: Vec<AxisPlane> = planes_true
        .iter()
        .map(|&(axis, off)| AxisPlane {
            axis,
            offset: if axis == 2 {
                off * tilt.cos() - 1.0 * tilt.sin()
            } else {
                off
            },
        })
        .collect();
    let cfg = AxisRefineConfig {
        inlier_r: 3.0,
        normal_tolerance_deg: 10.0,
        ..Default::default()
    };
    let mut refit = axes.clone();
    for _ in 0..4 {
        // Offsets along the current axis: the mean over each true plane's points.
        let d = refit.directions[2];
        let planes: Vec<AxisPlane> = planes_true
            .iter()
            .enumerate()
            .map(|(i, &(axis, off))| {
                if axis != 2 {
                    return AxisPlane { axis, offset: off };
                }
                let pts = &positions[i * 200..(i + 1) * 200];
                AxisPlane {
                    axis,
                    offset: pts.iter().map(|p| d.dot(p)).sum::<f64>() / 200.0,
                }
            })
            .collect();
        refit = refine_axes_from_planes(&refit, &positions, &normals, &planes, 0.05, &cfg);
    }
    let err = axial_angle_deg(&refit.directions[2], &Vector3::z());
    assert!(err < 0.5, "z still {err}° off: {:?}", refit.directions[2]);
    assert!(err < 0.5 * 6.0);
    // One refit from the tilted start already moves toward the truth.
    let once = refine_axes_from_planes(&axes, &positions, &normals, &planes, 0.05, &cfg);
    assert!(axial_angle_deg(&once.directions[2], &Vector3::z()) < 6.0);
    // Orthogonalised: exactly perpendicular axes.
    let ortho = refine_axes_from_planes(
        &refit,
        &positions,
        &normals,
        &planes,
        0.05,
        &AxisRefineConfig {
            orthogonalize: true,
            ..cfg
        },
    );
    for &(_, _, a) in &ortho.pairwise_angles_deg {
        assert!((a - 90.0).abs() < 1e-9, "{a}");
    }
    assert_eq!(ortho.pairwise_angles_deg.len(), 3);
}

#[test]
fn level_to_makes_walls_vertical_and_keeps_roof_slopes() {
    let tilt = 2.4f64.to_radians();
    let roof = Vector3::new(0.5, 0.0, 0.75f64.sqrt()); // a 30° pitch
    let mut axes = DominantAxes {
        directions: vec![
            Vector3::new(0.0, tilt.cos(), tilt.sin()), // a wall normal, tilted
            Vector3::new(1.0, 0.0, 0.02).normalize(),  // another, tilted less
            Vector3::new(0.01, 0.0, 1.0).normalize(),  // the vertical, 0.6° off
            roof,
        ],
        support: vec![1; 4],
        pairwise_angles_deg: vec![],
        num_manhattan: 3,
        warnings: vec![],
    };
    assert_eq!(axes.level_to(&Vector3::z(), 5.0), 3);
    assert!((axes.directions[0] - Vector3::y()).norm() < 1e-12);
    assert!((axes.directions[1] - Vector3::x()).norm() < 1e-12);
    assert!((axes.directions[2] - Vector3::z()).norm() < 1e-12);
    assert_eq!(axes.directions[3], roof, "a roof slope is not levelled");
    assert!(axes
        .pairwise_angles_deg
        .iter()
        .any(|&(i, j, a)| (i, j) == (0, 1) && (a - 90.0).abs() < 1e-9));
    // Beyond the largest move nothing changes.
    let mut far = axes.clone();
    far.directions[0] = Vector3::new(0.0, 0.9, 0.2).normalize(); // 12.5° tilt
    assert_eq!(far.level_to(&Vector3::z(), 5.0), 0);
}

/// A street: two facade axes with many points over wide patches, the ground seen as a
/// strip of ten points along the street that climbs 1 cm per metre (points of a kerb
/// and a balcony underside mixed in). Refit alone, the vertical tilts with the strip;
/// orthogonalized, the ground axis is the least determined (its points fit their plane
/// better than the facades' do, so a ranking by residual would keep it) and becomes the
/// facades' cross product.
#[test]
fn orthogonalize_keeps_the_best_determined_axes_and_rebuilds_a_strip_fitted_one() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    let mut planes = Vec::new();
    for (axis, off) in [(0usize, 0.0), (0, 3.0), (1, 5.0)] {
        planes.push(AxisPlane { axis, offset: off });
        for _ in 0..300 {
            let mut p = Vector3::new(
                rng.random_range(0.0..20.0),
                rng.random_range(0.0..8.0),
                rng.random_range(0.0..10.0),
            );
            p[axis] = off + rng.random_range(-0.003..0.003);
            positions.push(p);
            let mut n = Vector3::zeros();
            n[axis] = 1.0;
            normals.push(n);
        }
    }
    planes.push(AxisPlane {
        axis: 2,
        offset: 0.0,
    });
    for i in 0..10 {
        let x = 2.0 * i as f64;
        let z = 0.01 * x;
        positions.push(Vector3::new(x, 6.0 + rng.random_range(-0.2..0.2), z));
        normals.push(Vector3::z());
    }
    let axes = DominantAxes {
        directions: vec![Vector3::x(), Vector3::y(), Vector3::z()],
        support: vec![0; 3],
        pairwise_angles_deg: vec![],
        num_manhattan: 3,
        warnings: vec![],
    };
    let cfg = AxisRefineConfig {
        inlier_r: 3.0,
        ..Default::default()
    };
    let refit = refine_axes_from_planes(&axes, &positions, &normals, &planes, 0.1, &cfg);
    let tilt = axial_angle_deg(&refit.directions[2], &Vector3::z());
    assert!(tilt > 0.5, "the strip should tilt a free refit: {tilt}°");
    let ortho = refine_axes_from_planes(
        &axes,
        &positions,
        &normals,
        &planes,
        0.1,
        &AxisRefineConfig {
            orthogonalize: true,
            ..cfg
        },
    );
    let tilt = axial_angle_deg(&ortho.directions[2], &Vector3::z());
    assert!(tilt < 0.05, "vertical {tilt}° off after orthogonalizing");
}

#[test]
fn rotated_manhattan_normals_with_outliers() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let rot = Rotation3::from_axis_angle(&Unit::new_normalize(Vector3::new(0.4, -0.7, 0.2)), 0.9);
    let truth: Vec<Vector3<f64>> = [Vector3::x(), Vector3::y(), Vector3::z()]
        .iter()
        .map(|a| rot * a)
        .collect();
    let mut normals = Vec::new();
    for (k, count) in [(0usize, 3000), (1, 2000), (2, 1200)] {
        for i in 0..count {
            let sign = if i % 2 == 0 { 1.0 } else { -1.0 };
            normals.push(jitter(&mut rng, truth[k] * sign, 3.0));
        }
    }
    for _ in 0..1500 {
        normals.push(random_unit(&mut rng));
    }
    let axes = dominant_axes(&cloud_of(normals), &AxesConfig::default()).unwrap();
    assert_eq!(axes.directions.len(), 3);
    assert!(axes.warnings.is_empty());
    for t in &truth {
        let e = best_match(&axes.directions, t);
        assert!(e < 1.0, "axis error {e}°");
    }
    assert!(
        best_match(&axes.directions[..1], &truth[0]) < 1.0,
        "d1 is the best supported"
    );
    for &(_, _, a) in &axes.pairwise_angles_deg {
        assert!((a - 90.0).abs() < 2.0, "{a}");
    }
    assert_eq!(axes.pairwise_angles_deg.len(), 3);
}

#[test]
fn single_plane_gives_one_axis_and_warning_or_error() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let n0 = Vector3::new(1.0, 1.0, 0.0).normalize(); // on the fold's rim
    let normals: Vec<_> = (0..2000).map(|_| jitter(&mut rng, n0, 2.0)).collect();
    let cloud = cloud_of(normals);
    let axes = dominant_axes(&cloud, &AxesConfig::default()).unwrap();
    assert_eq!(axes.directions.len(), 1);
    assert_eq!(axes.warnings, vec![AxesWarning::FewerThanThree(1)]);
    assert!(axial_angle_deg(&axes.directions[0], &n0) < 0.5);
    assert!(axes.directions[0].iter().all(|v| v.is_finite()));
    // The rim split must not halve the support.
    assert!(axes.support[0] > 1900, "{}", axes.support[0]);
    let cfg = AxesConfig {
        on_missing: MissingAxes::Error,
        snap_orthonormal: true,
        ..Default::default()
    };
    assert_eq!(
        dominant_axes(&cloud, &cfg),
        Err(AxesError::TooFewAxes { found: 1 })
    );
}

#[test]
fn third_axis_completed_from_the_cross_product_when_a_few_normals_confirm_it() {
    let mut rng = ChaCha8Rng::seed_from_u64(21);
    let a = Vector3::new(0.1, 0.2, 1.0).normalize();
    let b = a.cross(&Vector3::x()).normalize();
    let c = a.cross(&b);
    let mut normals: Vec<_> = (0..1500).map(|_| jitter(&mut rng, a, 1.0)).collect();
    normals.extend((0..1000).map(|_| jitter(&mut rng, b, 1.0)));
    // 30 normals on c: below the 2 % threshold (51), above the absolute 10.
    let few: Vec<_> = (0..30).map(|_| jitter(&mut rng, c, 1.0)).collect();
    let with = |k: usize, complete: bool| {
        let mut all = normals.clone();
        all.extend_from_slice(&few[..k]);
        dominant_axes(
            &cloud_of(all),
            &AxesConfig {
                complete_frame: complete,
                ..Default::default()
            },
        )
        .unwrap()
    };
    let axes = with(30, true);
    assert_eq!(axes.directions.len(), 3);
    assert_eq!(axes.num_manhattan, 3);
    assert!(
        axes.directions[2].dot(&c).abs() > 0.9998,
        "{:?}",
        axes.directions[2]
    );
    assert!(
        matches!(axes.warnings[..], [AxesWarning::CompletedThird(n)] if (25..=30).contains(&n))
    );
    // Off, or only 5 confirming normals: two directions and the usual warning.
    for axes in [with(30, false), with(5, true)] {
        assert_eq!(axes.directions.len(), 2);
        assert_eq!(axes.warnings, vec![AxesWarning::FewerThanThree(2)]);
    }
}

#[test]
fn two_planes_and_snapping() {
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let a = Vector3::new(0.2, 0.3, 0.9).normalize();
    // 86° from a: snapping must make it exactly perpendicular.
    let axis = a.cross(&Vector3::x()).normalize();
    let b = Rotation3::from_axis_angle(&Unit::new_normalize(axis), 86f64.to_radians()) * a;
    let mut normals: Vec<_> = (0..1500).map(|_| jitter(&mut rng, a, 1.0)).collect();
    normals.extend((0..1000).map(|_| jitter(&mut rng, b, 1.0)));
    let cloud = cloud_of(normals);
    let axes = dominant_axes(&cloud, &AxesConfig::default()).unwrap();
    assert_eq!(axes.directions.len(), 2);
    assert_eq!(axes.warnings, vec![AxesWarning::FewerThanThree(2)]);
    assert!((axes.pairwise_angles_deg[0].2 - 86.0).abs() < 0.5);
    let snapped = dominant_axes(
        &cloud,
        &AxesConfig {
            snap_orthonormal: true,
            ..Default::default()
        },
    )
    .unwrap();
    assert!((snapped.pairwise_angles_deg[0].2 - 90.0).abs() < 1e-9);
    // Symmetric polar snapping moves each axis by about half the defect.
    assert!(axial_angle_deg(&snapped.directions[0], &a) < 3.0);
    assert!(axial_angle_deg(&snapped.directions[1], &b) < 3.0);
}

#[test]
fn best_orthogonal_triple_beats_a_fuller_smeared_bin() {
    // The fullest bin is 15° off z (stair slope): greedily taken as d1 it leaves no
    // third axis within 80°–100°; the triple x, y, z has the larger total support.
    let mut rng = ChaCha8Rng::seed_from_u64(12);
    let tilt = Rotation3::from_axis_angle(&Vector3::x_axis(), 15f64.to_radians());
    let mut normals: Vec<_> = (0..1200)
        .map(|_| jitter(&mut rng, Vector3::x(), 1.0))
        .collect();
    normals.extend((0..700).map(|_| jitter(&mut rng, Vector3::y(), 1.0)));
    normals.extend((0..600).map(|_| jitter(&mut rng, Vector3::z(), 1.0)));
    normals.extend((0..2500).map(|_| jitter(&mut rng, tilt * Vector3::z(), 1.0)));
    let axes = dominant_axes(&cloud_of(normals), &AxesConfig::default()).unwrap();
    assert_eq!(axes.directions.len(), 3, "{:?}", axes.directions);
    for t in [Vector3::x(), Vector3::y(), Vector3::z()] {
        let e = best_match(&axes.directions, &t);
        assert!(e < 1.0, "axis error {e}° for {t:?}: {:?}", axes.directions);
    }
}

#[test]
fn smeared_axis_fixed_by_the_two_sharp_ones() {
    // Stairs: x (walls) and y (risers) are crisp; z is smeared toward the stair slope
    // (normals spread 6° around a mean 8° off z), and the smeared bin is the fullest.
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let tilt = Rotation3::from_axis_angle(&Vector3::x_axis(), 8f64.to_radians());
    let mut normals: Vec<_> = (0..1200)
        .map(|_| jitter(&mut rng, Vector3::x(), 1.0))
        .collect();
    normals.extend((0..700).map(|_| jitter(&mut rng, Vector3::y(), 1.0)));
    normals.extend((0..2500).map(|_| jitter(&mut rng, tilt * Vector3::z(), 6.0)));
    let cloud = cloud_of(normals);
    let raw = dominant_axes(&cloud, &AxesConfig::default()).unwrap();
    assert_eq!(raw.directions.len(), 3);
    assert!(best_match(&raw.directions, &Vector3::z()) > 3.0);
    let snap = AxesConfig {
        snap_orthonormal: true,
        ..Default::default()
    };
    let axes = dominant_axes(&cloud, &snap).unwrap();
    for t in [Vector3::x(), Vector3::y(), Vector3::z()] {
        let e = best_match(&axes.directions, &t);
        assert!(e < 0.5, "axis error {e}° for {t:?}: {:?}", axes.directions);
    }
    // Polar snapping would split the 8° defect instead.
    let polar = AxesConfig {
        snap_orthonormal: true,
        snap_sharp_angle_deg: 0.0,
        ..Default::default()
    };
    let p = dominant_axes(&cloud, &polar).unwrap();
    assert!(best_match(&p.directions, &Vector3::z()) > 1.0);
}

#[test]
fn roof_slopes_found_as_extra_directions() {
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let slope = 30f64.to_radians();
    let roof_a = Vector3::new(slope.sin(), 0.0, slope.cos());
    let roof_b = Vector3::new(-slope.sin(), 0.0, slope.cos());
    let mut normals = Vec::new();
    for (d, c) in [
        (Vector3::x(), 1500),
        (Vector3::y(), 1500),
        (Vector3::z(), 800),
        (roof_a, 900),
        (roof_b, 900),
    ] {
        normals.extend((0..c).map(|_| jitter(&mut rng, d, 2.0)));
    }
    let cloud = cloud_of(normals);
    let manhattan_only = AxesConfig {
        max_extra_directions: 0,
        ..Default::default()
    };
    let plain = dominant_axes(&cloud, &manhattan_only).unwrap();
    assert_eq!(plain.directions.len(), 3);
    // The default takes up to two extras: both roof slopes.
    let by_default = dominant_axes(&cloud, &AxesConfig::default()).unwrap();
    assert_eq!(by_default.directions.len(), 5);
    let cfg = AxesConfig {
        max_extra_directions: 4,
        ..Default::default()
    };
    let axes = dominant_axes(&cloud, &cfg).unwrap();
    assert_eq!(axes.num_manhattan, 3);
    assert_eq!(axes.directions.len(), 5, "{:?}", axes.directions);
    for t in [roof_a, roof_b] {
        assert!(best_match(&axes.directions[3..], &t) < 1.0);
    }
}

#[test]
fn deterministic_and_validated() {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let normals: Vec<_> = (0..4000).map(|_| random_unit(&mut rng)).collect();
    let cloud = cloud_of(normals);
    let run = |t| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build()
            .unwrap()
            .install(|| dominant_axes(&cloud, &AxesConfig::default()))
    };
    assert_eq!(run(1), run(2));
    // Uniform normals: no direction reaches 2 % support within 5°.
    assert_eq!(run(1).unwrap().directions.len(), 0);
    assert!(AxesConfig {
        num_bins: 1,
        ..Default::default()
    }
    .validate()
    .is_err());
    assert_eq!(
        dominant_axes(&OrientedCloud::default(), &AxesConfig::default()),
        Err(AxesError::NoNormals(1e-3))
    );
}

/// A pinhole view at `eye` looking at `target` with image "up" towards `up`.
fn upright_view(eye: Vector3<f64>, target: Vector3<f64>, up: Vector3<f64>) -> View {
    View {
        id: 1,
        name: "v".into(),
        camera: crate::geometry::Camera::pinhole(100, 80, 100.0, 100.0, 50.0, 40.0),
        cam_from_world: crate::geometry::look_at(&eye, &target, &up),
        image_path: None,
    }
}

#[test]
fn the_vertical_is_read_off_upright_cameras() {
    // A world whose "up" is tilted off every axis; cameras around a point, pitched up
    // and down by up to 27°, never rolled.
    let up = Vector3::new(0.3, -0.2, 0.93).normalize();
    let (a, b) = (
        up.cross(&Vector3::x()).normalize(),
        up.cross(&up.cross(&Vector3::x())).normalize(),
    );
    let eye = |i: usize| {
        let yaw = i as f64 * 0.7;
        (a * yaw.cos() + b * yaw.sin()) * 10.0 + up * (i as f64 - 3.0)
    };
    let views: Vec<View> = (0..7).map(|i| upright_view(eye(i), up * 2.0, up)).collect();
    let found = camera_vertical(&views).expect("upright cameras give a vertical");
    assert!(
        found.dot(&up) > (0.1f64).to_radians().cos(),
        "{found:?} vs {up:?}"
    );
    // Upside-down images give the opposite sign.
    let flipped: Vec<View> = (0..7)
        .map(|i| upright_view(eye(i), up * 2.0, -up))
        .collect();
    assert!(camera_vertical(&flipped).unwrap().dot(&up) < -0.999);
    // Rolled cameras (each about its viewing axis by 20°): no common vertical.
    let rolled: Vec<View> = views
        .iter()
        .map(|v| {
            let roll = nalgebra::UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 0.35);
            View {
                cam_from_world: nalgebra::Isometry3::from_parts(
                    nalgebra::Translation3::identity(),
                    roll,
                ) * v.cam_from_world,
                ..v.clone()
            }
        })
        .collect();
    assert_eq!(camera_vertical(&rolled), None);
    // All looking the same way (a facade walk): the rows are parallel, no answer.
    let walk: Vec<View> = (0..5)
        .map(|i| {
            let eye = a * i as f64;
            upright_view(eye, eye + b * 10.0 - up * 3.0, up)
        })
        .collect();
    assert_eq!(camera_vertical(&walk), None);
    assert_eq!(camera_vertical(&views[..1]), None);
}

#[test]
fn a_walk_gets_its_vertical_from_the_rows_and_a_wall_normal() {
    // A tilted world; a forward walk along `fwd` pitched down 12°, panning by at most
    // 8° (tiny's cameras): too little spread in the rows for camera_vertical alone.
    let up = Vector3::new(0.2, 0.1, 0.97).normalize();
    let side = up.cross(&Vector3::x()).normalize();
    let fwd = side.cross(&up).normalize();
    let walk: Vec<View> = (0..5)
        .map(|i| {
            let yaw = (i as f64 - 2.0) * 0.07;
            let look = fwd * yaw.cos() + side * yaw.sin();
            let eye = fwd * (0.5 * i as f64) + up * 1.5;
            upright_view(eye, eye + look * 10.0 - up * 2.1, up)
        })
        .collect();
    assert_eq!(
        camera_vertical(&walk),
        None,
        "the pan is too narrow on its own"
    );
    // Only the back wall's normal (the walk's direction) is known: the vertical follows.
    let v = camera_vertical_given(&walk, &[-fwd]).expect("rows × wall normal");
    assert!(v.dot(&up) > (0.01f64).to_radians().cos(), "{v:?} vs {up:?}");
    // A side wall's normal, nearly along the rows, gives nothing; with both, the back
    // wall's decides.
    assert_eq!(camera_vertical_given(&walk, &[side]), None);
    let both = camera_vertical_given(&walk, &[side, fwd]).unwrap();
    assert!(both.dot(&up) > 0.9999);
    // The floor's normal is known already: nothing to add (corridor: completing the
    // walk's own direction from it made ghost planes).
    assert_eq!(camera_vertical_given(&walk, &[up, side]), None);
    // A 40° roof slope across the walk is not a wall: its vertical would pitch the
    // cameras 40° and tilt their rows; no answer.
    let slope = (fwd * 40f64.to_radians().sin() + up * 40f64.to_radians().cos()).normalize();
    assert_eq!(camera_vertical_given(&walk, &[slope]), None);
    // Cameras rolled by ±20° in turn: the rows are not horizontal for any such
    // vertical. (One common roll cannot be told from a tilted world; upright cameras
    // are the assumption.)
    let rolled: Vec<View> = walk
        .iter()
        .enumerate()
        .map(|(i, v)| View {
            cam_from_world: nalgebra::Isometry3::from_parts(
                nalgebra::Translation3::identity(),
                nalgebra::UnitQuaternion::from_axis_angle(
                    &Vector3::z_axis(),
                    if i % 2 == 0 { 0.35 } else { -0.35 },
                ),
            ) * v.cam_from_world,
            ..v.clone()
        })
        .collect();
    assert_eq!(camera_vertical_given(&rolled, &[-fwd]), None);
    // Where camera_vertical answers, that answer stands.
    let orbit: Vec<View> = (0..6)
        .map(|i| {
            let a = i as f64 * 1.0;
            upright_view(
                (fwd * a.cos() + side * a.sin()) * 10.0,
                Vector3::zeros(),
                up,
            )
        })
        .collect();
    assert_eq!(
        camera_vertical_given(&orbit, &[fwd]),
        camera_vertical(&orbit)
    );
    assert!(camera_vertical(&orbit).is_some());
}

#[test]
fn fewer_than_three_axes_are_completed_with_the_vertical() {
    let (x, y, z) = (Vector3::x(), Vector3::y(), Vector3::z());
    let parallel = |a: &Vector3<f64>, b: &Vector3<f64>| a.dot(b).abs() > 0.9999;
    // One wall direction: the vertical and the horizontal across both join it.
    let added = vertical_completion(&[y], &z);
    assert_eq!(added.len(), 2);
    assert!(parallel(&added[0], &z) && parallel(&added[1], &x));
    // A near-vertical axis (5° off) stands for the vertical; its horizontal partner is
    // crossed with the cameras' vertical.
    let tilted = (z + x * 5f64.to_radians().tan()).normalize();
    let added = vertical_completion(&[tilted, y], &z);
    assert_eq!(added.len(), 1);
    assert!(parallel(&added[0], &x));
    // Three directions (a non-Manhattan scene's included) are kept as they are.
    let roof = (y + z).normalize();
    assert!(vertical_completion(&[x, y, roof], &z).is_empty());
    // A lone slanted direction gains the vertical only: nothing horizontal to cross.
    assert_eq!(vertical_completion(&[roof], &z), vec![z]);
    assert_eq!(vertical_completion(&[], &z), vec![z]);

    // On the axes: inserted after the Manhattan directions, before the extras, in the
    // canonical sign, with their support and angles, and a warning.
    let mut axes = DominantAxes {
        directions: vec![y, roof],
        support: vec![40, 9],
        pairwise_angles_deg: vec![(0, 1, 45.0)],
        num_manhattan: 1,
        warnings: vec![],
    };
    let normals = [z, -z, x, y];
    assert_eq!(axes.complete_with_vertical(&-z, &normals, 5.0), 2);
    assert_eq!(axes.num_manhattan, 3);
    assert_eq!(axes.directions.len(), 4);
    assert_eq!(axes.directions[1], z);
    assert!(parallel(&axes.directions[2], &x) && axes.directions[2].x > 0.0);
    assert_eq!(axes.directions[3], roof);
    assert_eq!(axes.support, vec![40, 2, 1, 9]);
    assert_eq!(axes.pairwise_angles_deg.len(), 6);
    assert!(axes
        .pairwise_angles_deg
        .iter()
        .all(
            |&(i, j, a)| (a - axial_angle_deg(&axes.directions[i], &axes.directions[j])).abs()
                < 1e-12
        ));
    assert_eq!(axes.warnings, vec![AxesWarning::CompletedWithVertical(2)]);
    // Already three: nothing changes.
    let before = axes.clone();
    assert_eq!(axes.complete_with_vertical(&z, &normals, 5.0), 0);
    assert_eq!(axes, before);
}
