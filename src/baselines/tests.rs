//! Tests of the sweep baseline and of the multi-family sweep setup it runs on.

use super::*;
use crate::config::with_overrides;
use crate::geometry::Plane;
use crate::photo::{family_step_px, sweep_setup, MultiSweepConfig};
use crate::photo::{fronto_parallel_planes, refine_subplane, Spacing, SweepResult, SweepSetup};
use crate::photo::{winner_takes_all, CostVolume};
use crate::scene::Scene;
use crate::scene::View;
use nalgebra::Vector3;

#[test]
fn overrides_reach_nested_fields_and_bad_ones_are_named() {
    let cfg = with_overrides(
        &MultiSweepConfig::default(),
        &[
            "photo.window_radius=5".into(),
            "axis_families=false".into(),
            "photo.neighbours=6".into(),
            "extra_directions=2".into(),
        ],
    )
    .unwrap();
    assert_eq!(cfg.photo.window_radius, 5);
    assert_eq!(cfg.extra_directions, 2);
    assert_eq!(MultiSweepConfig::default().extra_directions, 2);
    assert!(!cfg.axis_families);
    assert_eq!(cfg.photo.neighbours, 6);
    assert_eq!(cfg.planes, MultiSweepConfig::default().planes);
    let err = with_overrides(&MultiSweepConfig::default(), &["no_such_key=1".into()]).unwrap_err();
    assert!(err.to_string().contains("no_such_key"), "{err}");
    let err = with_overrides(&MultiSweepConfig::default(), &["photo.best_k=0".into()])
        .unwrap()
        .validate()
        .unwrap_err();
    assert!(err.to_string().contains("best_k"), "{err}");
    // Semi-global aggregation: on by default, off with paths = 0, bad counts named.
    assert_eq!(MultiSweepConfig::default().sgm.paths, 8);
    let off = with_overrides(&MultiSweepConfig::default(), &["sgm.paths=0".into()]).unwrap();
    assert!(!off.sgm.enabled());
    let err = with_overrides(&MultiSweepConfig::default(), &["sgm.paths=3".into()])
        .unwrap()
        .validate()
        .unwrap_err();
    assert!(err.to_string().contains("sgm.paths"), "{err}");
    // The sub-plane fit reads the aggregated costs unless told otherwise.
    assert!(!MultiSweepConfig::default().sgm.subplane_on_local);
    let local_fit = with_overrides(
        &MultiSweepConfig::default(),
        &["sgm.subplane_on_local=true".into()],
    )
    .unwrap();
    assert!(local_fit.sgm.subplane_on_local);
    assert!(with_overrides(&MultiSweepConfig::default(), &["planes".into()]).is_err());
}

/// Angle (degrees) between `d` and the nearest world axis, sign ignored.
fn off_axis_deg(d: &Vector3<f64>) -> f64 {
    let c = d.x.abs().max(d.y.abs()).max(d.z.abs()) / d.norm();
    c.min(1.0).acos().to_degrees()
}

/// `scenes/NAME.toml` rendered at its own size and read back from its COLMAP model on
/// disk, as `planemap sweep` reads it.
fn scene_through_colmap(name: &str) -> Scene {
    scene_through_colmap_with(name, &Default::default())
}

/// [`scene_through_colmap`] rendered with `opts` (another size, say).
fn scene_through_colmap_with(name: &str, opts: &crate::synth::RenderOptions) -> Scene {
    workspace_through_colmap(name, opts).0
}

/// [`scene_through_colmap_with`], with the workspace it was read from (ground truth in
/// `gt/`), deleted when the second value drops.
fn workspace_through_colmap(
    name: &str,
    opts: &crate::synth::RenderOptions,
) -> (Scene, tempfile::TempDir) {
    let spec = crate::synth::SceneSpec::from_path(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("scenes/{name}.toml")),
    )
    .unwrap();
    let dir = tempfile::tempdir().unwrap();
    crate::workspace::render_to_workspace(
        &spec,
        opts,
        dir.path(),
        &crate::progress::Progress::new(true),
    )
    .unwrap();
    let scene = crate::io::colmap::read_model(&dir.path().join("sparse"))
        .unwrap()
        .to_scene(None)
        .unwrap();
    (scene, dir)
}

#[test]
fn thin_sweeps_its_lawn_with_the_cameras_vertical() {
    // On thin the lawn, seen at grazing angles, holds one sparse point: the points give
    // the back wall's normal alone, and without the cameras' vertical no family is
    // horizontal (the sweep got 27 % of thin's textured surfaces within 1 %, 82 % with it).
    let scene = scene_through_colmap("thin");
    let mut points_only = crate::pipeline::Config::default();
    points_only.axes.camera_vertical = false;
    let from_points = crate::pipeline::sparse_stages(&scene, &points_only)
        .unwrap()
        .axes
        .directions;
    assert!(
        from_points.iter().all(|d| d.z.abs() < 0.9),
        "{from_points:?}"
    );
    let axes = scene_axes(&scene, &MultiSweepConfig::default());
    assert_eq!(axes.len(), 3, "{axes:?}");
    assert!(
        axes.iter().any(|d| d.z.abs() > (0.5f64).to_radians().cos()),
        "{axes:?}"
    );
    assert!(axes.iter().all(|d| off_axis_deg(d) < 3.0), "{axes:?}");
}

#[test]
fn axis_families_reach_a_floor_with_few_points() {
    // tiny at 320×240: the floor (z = 0) and the table top (z = 0.75) hold a handful of
    // the 138 sparse points, seen at grazing angles. A range cut at the 2nd and 98th
    // percentiles of each view's own points left the floor unswept (textured surfaces
    // within 1 %: 61.5 %); even all but two of view 1's own points span only z = 0.10
    // to 1.99. The range of every point in the frustum, less two at each end, covers
    // the floor in every view.
    let scene = scene_through_colmap_with(
        "tiny",
        &crate::synth::RenderOptions {
            width: Some(320),
            height: Some(240),
            seed_override: None,
        },
    );
    let cfg = MultiSweepConfig::default();
    let axes = scene_axes(&scene, &cfg);
    for v in 0..scene.views.len() {
        let setup = sweep_setup(&scene, v, &axes, &cfg).unwrap();
        let vertical = setup.families[1..]
            .iter()
            .find(|f| f.planes[0].normal.z.abs() > 0.99)
            .unwrap_or_else(|| panic!("view {v}: no horizontal family"));
        // Offsets along ±z, in sweep order; the plane z = h has offset ±h.
        let height = |p: &Plane| p.offset * p.normal.z.signum();
        let (a, b) = (
            height(&vertical.planes[0]),
            height(&vertical.planes[vertical.planes.len() - 1]),
        );
        let (lo, hi) = (a.min(b), a.max(b));
        assert!(
            lo < -0.01 && hi > 0.76,
            "view {v}: heights {lo:.3}..{hi:.3}"
        );
    }
    let bad = MultiSweepConfig {
        axis_margin: -0.1,
        ..cfg
    };
    let err = bad.validate().unwrap_err().to_string();
    assert!(err.contains("axis_margin"), "{err}");
}

#[test]
fn depth_range_reaches_a_pillar_beside_the_camera() {
    // occlusion: the pillar at the left edge of views 0, 1 and 4 stands nearer than the
    // 2nd percentile of those views' own sparse points (view 4: 1.78 m against 2.42 m),
    // so the fronto-parallel family began behind it: 3.6 % of the scene's textured
    // surfaces were never swept. Other views tracked points on it; with every point in
    // the image, less two at each end, the range covers the pillar.
    let (scene, dir) = workspace_through_colmap("occlusion", &Default::default());
    let cfg = MultiSweepConfig::default();
    for (v, view) in scene.views.iter().enumerate() {
        let setup = sweep_setup(&scene, v, &[], &cfg).unwrap();
        let centre = view.center();
        let depths: Vec<f64> = setup.families[0]
            .planes
            .iter()
            .map(|p| p.offset - p.normal.dot(&centre))
            .collect();
        let (near, far) = (
            depths[0].min(depths[depths.len() - 1]),
            depths[0].max(depths[depths.len() - 1]),
        );
        let stem = std::path::Path::new(&view.name).with_extension("pfm");
        let gt = crate::io::pfm::read_pfm_path(&dir.path().join("gt/depth").join(&stem)).unwrap();
        let seen: Vec<f32> = gt.data.iter().copied().filter(|&z| z > 0.0).collect();
        let outside = seen
            .iter()
            .filter(|&&z| (z as f64) < near || (z as f64) > far)
            .count();
        assert!(
            outside * 200 <= seen.len(),
            "view {v}: {outside} of {} pixels outside the swept depths {near:.2}..{far:.2}",
            seen.len()
        );
    }
}

#[test]
fn gable_sweeps_its_roof_slopes() {
    // The house's 45° roofs have normals (0, ±1, 1)/√2; its Manhattan axes are the
    // vertical and the turned wing's two horizontals. Only the extra directions give
    // the roofs a family of their own.
    let scene = scene_through_colmap("gable");
    let roof = |axes: &[Vector3<f64>]| {
        axes.iter().any(|d| {
            let d = d.normalize();
            d.x.abs() < 0.1 && (d.y.abs() - d.z.abs()).abs() < 0.1
        })
    };
    let manhattan = MultiSweepConfig {
        extra_directions: 0,
        ..Default::default()
    };
    let axes = scene_axes(&scene, &manhattan);
    assert!(!roof(&axes), "{axes:?}");
    let axes = scene_axes(&scene, &MultiSweepConfig::default());
    assert!(axes.len() > 3 && roof(&axes[3..]), "{axes:?}");
}

#[test]
fn sweep_directions_of_the_stairs_are_the_world_axes() {
    // The stairs are axis-aligned; at their own 320×240 the normals of their points
    // alone mix treads, risers and nosings and put one "axis" about 11° off, so the
    // tread family matched no tread. The pipeline's refit from the plane hypotheses
    // corrects it.
    let scene = scene_through_colmap("stairs");
    let unrefined = crate::axes::dominant_axes(
        &crate::normals::estimate_normals(&scene, &Default::default()).unwrap(),
        &Default::default(),
    )
    .unwrap();
    let worst_unrefined = unrefined
        .directions
        .iter()
        .map(off_axis_deg)
        .fold(0.0, f64::max);
    // The three Manhattan axes come first; a non-Manhattan extra (the flight's slope,
    // `extra_directions`) may follow them.
    let axes = scene_axes(&scene, &MultiSweepConfig::default());
    assert!(axes.len() >= 3, "{axes:?}");
    let worst = axes[..3].iter().map(off_axis_deg).fold(0.0, f64::max);
    assert!(
        worst < 1.0,
        "a sweep direction is {worst:.2}° off its world axis"
    );
    assert!(
        worst_unrefined > 3.0 * worst.max(0.5),
        "the refit should matter here: {worst_unrefined:.2}° before, {worst:.2}° after"
    );
}

#[test]
fn family_step_is_the_disparity_between_consecutive_planes() {
    // A neighbour shifted sideways by b: a fronto-parallel plane at depth z moves every
    // pixel by the disparity f·b/z, and planes evenly spaced in inverse depth by the
    // same f·b·Δ(1/z) everywhere.
    use crate::geometry::{Camera, Rigid3};
    let (f, b) = (200.0, 0.3);
    let view = |x: f64| View {
        id: 0,
        name: "v".into(),
        camera: Camera::pinhole(320, 240, f, f, 160.0, 120.0),
        cam_from_world: Rigid3::translation(-x, 0.0, 0.0),
        image_path: None,
    };
    let (reference, neighbour) = (view(0.0), view(b));
    let (near, far, n) = (2.0, 20.0, 64);
    let planes = fronto_parallel_planes(&reference, near, far, n).unwrap();
    let expected = f * b * (1.0 / near - 1.0 / far) / (n - 1) as f64;
    for q in [0.0, 0.5, 1.0] {
        let step = family_step_px(&reference, &[&neighbour], &planes, q).unwrap();
        assert!(
            (step - expected).abs() < 1e-6 * expected,
            "q {q}: {step} vs {expected}"
        );
    }
    // Twice the planes, half the step; no neighbour sees anything: None.
    let fine = fronto_parallel_planes(&reference, near, far, 2 * n - 1).unwrap();
    let half = family_step_px(&reference, &[&neighbour], &fine, 0.5).unwrap();
    assert!((half - expected / 2.0).abs() < 1e-6 * expected);
    let behind = View {
        cam_from_world: Rigid3::translation(0.0, 0.0, -100.0),
        ..view(0.0)
    };
    assert_eq!(family_step_px(&reference, &[&behind], &planes, 0.5), None);
}

#[test]
fn coarse_families_are_densified_to_the_step_target() {
    // Two cameras 1 m apart sideways, f = 200 px, points between 2 and 20 m: 16
    // fronto-parallel planes move a pixel by about 6 px each; the sweep densifies them
    // to a median step of 1 px, up to the cap, and leaves them alone when told to.
    use crate::geometry::{Camera, Rigid3};
    use crate::scene::SparseCloud;
    let view = |x: f64, id: u32| View {
        id,
        name: format!("v{id}"),
        camera: Camera::pinhole(320, 240, 200.0, 200.0, 160.0, 120.0),
        cam_from_world: Rigid3::translation(-x, 0.0, 0.0),
        image_path: None,
    };
    let positions: Vec<Vector3<f64>> = (0..40)
        .map(|i| {
            let z = 2.0 + 18.0 * i as f64 / 39.0;
            Vector3::new(0.5 + 0.1 * (i % 5) as f64, 0.1 * (i % 7) as f64 - 0.3, z)
        })
        .collect();
    let n = positions.len();
    let scene = Scene {
        views: vec![view(0.0, 1), view(1.0, 2)],
        cloud: SparseCloud {
            positions,
            colors: vec![[0; 3]; n],
            normals: None,
            tracks: vec![vec![0, 1]; n],
            errors: vec![0.0; n],
            confidence: vec![1.0; n],
        },
    };
    let coarse = MultiSweepConfig {
        planes: 16,
        axis_families: false,
        max_step_px: 1.0,
        ..Default::default()
    };
    let step = |setup: &SweepSetup| {
        family_step_px(
            &scene.views[0],
            &[&scene.views[1]],
            &setup.families[0].planes,
            0.5,
        )
        .unwrap()
    };
    let off = sweep_setup(
        &scene,
        0,
        &[],
        &MultiSweepConfig {
            max_step_px: 0.0,
            ..coarse.clone()
        },
    )
    .unwrap();
    assert_eq!(off.families[0].planes.len(), 16);
    assert!(step(&off) > 4.0, "coarse step {}", step(&off));
    let dense = sweep_setup(&scene, 0, &[], &coarse).unwrap();
    let planes = dense.families[0].planes.len();
    assert!((60..=130).contains(&planes), "{planes} planes");
    assert!(step(&dense) <= 1.0 + 1e-9, "dense step {}", step(&dense));
    let default_step = MultiSweepConfig::default().max_step_px;
    let finer = sweep_setup(
        &scene,
        0,
        &[],
        &MultiSweepConfig {
            max_step_px: default_step,
            ..coarse.clone()
        },
    )
    .unwrap();
    assert!(finer.families[0].planes.len() > planes);
    assert!(
        step(&finer) <= default_step + 1e-9,
        "finer step {}",
        step(&finer)
    );
    let capped = sweep_setup(
        &scene,
        0,
        &[],
        &MultiSweepConfig {
            max_family_planes: 40,
            ..coarse.clone()
        },
    )
    .unwrap();
    assert_eq!(capped.families[0].planes.len(), 40);
    let bad = MultiSweepConfig {
        max_step_px: f64::NAN,
        ..coarse
    };
    let err = sweep_setup(&scene, 0, &[], &bad).unwrap_err().to_string();
    assert!(err.contains("max_step_px"), "{err}");
}

/// A cost that is a parabola in inverse depth with its minimum between two planes:
/// WTA is off by up to half a plane step, the refinement recovers the true depth.
#[test]
fn subplane_refinement_recovers_depth_between_planes() {
    use crate::geometry::{Camera, CameraModel, Rigid3};
    let camera = Camera::new(CameraModel::Pinhole, 4, 1, vec![100.0, 100.0, 2.0, 0.5])
        .expect("valid camera");
    let view = View {
        id: 0,
        name: "v".into(),
        camera,
        cam_from_world: Rigid3::identity(),
        image_path: None,
    };
    let planes = fronto_parallel_planes(&view, 2.0, 10.0, 9).expect("planes");
    let inv: Vec<f64> = planes.iter().map(|p| 1.0 / p.offset).collect();
    let true_depth = [3.1, 4.4, 5.05, 7.7];
    let (w, np) = (4, planes.len());
    let mut costs = vec![0.0f32; w * np];
    for (px, &z) in true_depth.iter().enumerate() {
        for k in 0..np {
            let d = (inv[k] - 1.0 / z) / (inv[0] - inv[1]);
            costs[px * np + k] = (0.1 + 0.05 * d * d).min(0.99) as f32;
        }
    }
    let volume = CostVolume {
        width: w,
        height: 1,
        num_planes: np,
        costs,
    };
    let mut result = winner_takes_all(&volume, &view, &planes, 1).expect("wta");
    let wta_err = |r: &SweepResult| {
        r.depth
            .iter()
            .zip(&true_depth)
            .map(|(&d, &z)| ((d as f64 - z) / z).abs())
            .fold(0.0f64, f64::max)
    };
    let before = wta_err(&result);
    assert!(before > 0.02, "WTA should be quantised, error {before}");
    refine_subplane(&volume, &mut result, &view, &planes, Spacing::InverseDepth);
    let after = wta_err(&result);
    assert!(after < 1e-5, "refined error {after}");
}
