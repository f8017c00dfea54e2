//! Interop with a real COLMAP client: the committed fixture `tests/fixtures/pycolmap_small`
//! was written by pycolmap (see tools/make_pycolmap_fixture.py; version in expected.json).
//! Our readers must reproduce exactly the values pycolmap reports, in both formats, and our
//! binary writer must reproduce pycolmap's binary files byte for byte.

use std::path::{Path, PathBuf};

use planemap::io::colmap::{
    model_to_bin_bytes, read_model, read_model_bin, read_model_text, write_model_bin,
    write_model_text, ColmapModel,
};
use serde_json::Value;

fn fixture() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/pycolmap_small")
}

fn expected() -> Value {
    let s = std::fs::read_to_string(fixture().join("expected.json")).unwrap();
    serde_json::from_str(&s).unwrap()
}

/// A float stored as a repr() string.
fn f(v: &Value) -> f64 {
    v.as_str().unwrap().parse().unwrap()
}

fn fs(v: &Value) -> Vec<f64> {
    v.as_array().unwrap().iter().map(f).collect()
}

fn u(v: &Value) -> u64 {
    v.as_u64().unwrap()
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol
}

/// Compares a model against expected.json. `exact` demands bit equality (binary files; text
/// written by COLMAP with 17 significant digits also round-trips exactly).
fn check_against_expected(m: &ColmapModel, exact: bool) {
    let exp = expected();
    let tol = if exact { 0.0 } else { 1e-12 };

    let cams = exp["cameras"].as_array().unwrap();
    assert_eq!(m.cameras.len(), cams.len());
    for (c, e) in m.cameras.iter().zip(cams) {
        assert_eq!(u64::from(c.camera_id), u(&e["camera_id"]));
        assert_eq!(c.camera.model.name(), e["model"].as_str().unwrap());
        assert_eq!(u64::from(c.camera.width), u(&e["width"]));
        assert_eq!(u64::from(c.camera.height), u(&e["height"]));
        let p = fs(&e["params"]);
        assert_eq!(c.camera.params.len(), p.len());
        for (a, b) in c.camera.params.iter().zip(&p) {
            assert!(
                close(*a, *b, tol * b.abs().max(1.0)),
                "camera {}: {a} vs {b}",
                c.camera_id
            );
        }
    }

    let ims = exp["images"].as_array().unwrap();
    assert_eq!(m.images.len(), ims.len());
    for (im, e) in m.images.iter().zip(ims) {
        assert_eq!(u64::from(im.image_id), u(&e["image_id"]));
        assert_eq!(u64::from(im.camera_id), u(&e["camera_id"]));
        assert_eq!(im.name, e["name"].as_str().unwrap());
        for (a, b) in im.qvec.iter().zip(fs(&e["qvec"])) {
            assert!(close(*a, b, 1e-12), "image {} qvec {a} vs {b}", im.image_id);
            if exact {
                assert_eq!(a.to_bits(), b.to_bits());
            }
        }
        for (a, b) in im.tvec.iter().zip(fs(&e["tvec"])) {
            assert!(close(*a, b, 1e-12), "image {} tvec {a} vs {b}", im.image_id);
            if exact {
                assert_eq!(a.to_bits(), b.to_bits());
            }
        }
        let pts = e["points2D"].as_array().unwrap();
        assert_eq!(im.points2d.len(), pts.len());
        for (p, q) in im.points2d.iter().zip(pts) {
            assert!(close(p.x, f(&q[0]), tol * 1e3));
            assert!(close(p.y, f(&q[1]), tol * 1e3));
            let id = q[2].as_i64().unwrap();
            assert_eq!(p.point3d_id, (id >= 0).then_some(id as u64));
        }
    }

    let pts = exp["points3D"].as_array().unwrap();
    assert_eq!(m.points3d.len(), pts.len());
    for (p, e) in m.points3d.iter().zip(pts) {
        assert_eq!(p.point3d_id, u(&e["point3D_id"]));
        for (a, b) in p.xyz.iter().zip(fs(&e["xyz"])) {
            assert!(close(*a, b, tol), "point {} xyz {a} vs {b}", p.point3d_id);
        }
        let rgb: Vec<u64> = e["rgb"].as_array().unwrap().iter().map(u).collect();
        assert_eq!(p.rgb.iter().map(|&v| u64::from(v)).collect::<Vec<_>>(), rgb);
        assert!(close(p.error, f(&e["error"]), tol));
        let track: Vec<(u64, u64)> = e["track"]
            .as_array()
            .unwrap()
            .iter()
            .map(|t| (u(&t[0]), u(&t[1])))
            .collect();
        let ours: Vec<(u64, u64)> = p
            .track
            .iter()
            .map(|t| (u64::from(t.image_id), u64::from(t.point2d_idx)))
            .collect();
        assert_eq!(ours, track);
    }
}

#[test]
fn reads_pycolmap_binary_exactly() {
    let m = read_model_bin(&fixture().join("bin")).unwrap();
    assert!(m.cameras.len() >= 3 && m.images.len() >= 5 && m.points3d.len() >= 40);
    check_against_expected(&m, true);
}

#[test]
fn reads_pycolmap_text_exactly() {
    let m = read_model_text(&fixture().join("txt")).unwrap();
    check_against_expected(&m, true);
    // COLMAP's 17-digit text and its binary hold the very same values.
    let b = read_model_bin(&fixture().join("bin")).unwrap();
    assert_eq!(
        model_to_bin_bytes(&m).unwrap(),
        model_to_bin_bytes(&b).unwrap()
    );
}

#[test]
fn our_binary_writer_reproduces_pycolmap_files() {
    let dir = fixture().join("bin");
    let m = read_model_bin(&dir).unwrap();
    let ours = model_to_bin_bytes(&m).unwrap();
    for (bytes, name) in ours
        .iter()
        .zip(["cameras.bin", "images.bin", "points3D.bin"])
    {
        let theirs = std::fs::read(dir.join(name)).unwrap();
        assert_eq!(bytes, &theirs, "{name} differs from pycolmap's");
    }
    // And our files re-read identically.
    let tmp = tempfile::tempdir().unwrap();
    write_model_bin(tmp.path(), &m).unwrap();
    assert_eq!(read_model(tmp.path()).unwrap(), m);
    write_model_text(&tmp.path().join("t"), &m).unwrap();
    assert_eq!(read_model_text(&tmp.path().join("t")).unwrap(), m);
}

#[test]
fn fixture_converts_to_a_consistent_scene() {
    let m = read_model(&fixture().join("bin")).unwrap();
    let scene = m.to_scene(Some(Path::new("images"))).unwrap();
    assert_eq!(scene.views.len(), m.images.len());
    assert!(scene.views.windows(2).all(|w| w[0].id < w[1].id));
    // Every observation lies within a few pixels of the projection of its 3D point: poses,
    // intrinsics (incl. distortion) and our camera models agree with pycolmap's.
    let mut worst: f64 = 0.0;
    for p in &m.points3d {
        for t in &p.track {
            let v = scene.view_index_by_id(t.image_id).unwrap();
            let im = m.image(t.image_id).unwrap();
            let obs = im.points2d[t.point2d_idx as usize];
            let (xy, depth) = scene.views[v]
                .project(&nalgebra::Vector3::from(p.xyz))
                .unwrap();
            assert!(depth > 0.0);
            worst = worst.max(((xy.x - obs.x).powi(2) + (xy.y - obs.y).powi(2)).sqrt());
        }
    }
    // The fixture adds N(0, 0.4 px) noise to each coordinate.
    assert!(worst < 3.0, "worst reprojection {worst}");
    let mean_err: f64 = scene.cloud.errors.iter().sum::<f64>() / scene.cloud.len() as f64;
    assert!(mean_err > 0.05 && mean_err < 2.0, "{mean_err}");
}

/// Writes a small planemap-made model (binary and text in one folder) for
/// `tools/check_pycolmap.py`. Run with
/// `PLANEMAP_PYCOLMAP_CHECK_DIR=/tmp/pm-check cargo test --test colmap_io -- --ignored`.
#[test]
#[ignore = "writes a model for tools/check_pycolmap.py"]
fn write_model_for_pycolmap_check() {
    use nalgebra::Vector3;
    use planemap::geometry::look_at;
    use planemap::{Camera, CameraModel, Scene, SparseCloud, View};

    let dir = PathBuf::from(
        std::env::var("PLANEMAP_PYCOLMAP_CHECK_DIR")
            .unwrap_or("/tmp/planemap-pycolmap-check".into()),
    );
    let cams = [
        Camera::new(
            CameraModel::Opencv,
            320,
            240,
            vec![250.0, 251.0, 160.0, 120.0, -0.05, 0.01, 1e-4, -2e-4],
        )
        .unwrap(),
        Camera::pinhole(300, 200, 240.0, 240.0, 150.0, 100.0),
    ];
    let views: Vec<View> = (0..6)
        .map(|i| {
            let a = i as f64 * 0.5;
            View {
                id: 100 + i,
                name: format!("view_{i:02}.png"),
                camera: cams[(i % 2) as usize].clone(),
                cam_from_world: look_at(
                    &Vector3::new(5.0 * a.cos(), 5.0 * a.sin(), 1.5),
                    &Vector3::zeros(),
                    &Vector3::z(),
                ),
                image_path: None,
            }
        })
        .collect();
    let n: u32 = 40;
    let positions: Vec<Vector3<f64>> = (0..n)
        .map(|k| {
            let t = k as f64;
            Vector3::new((t * 0.37).sin(), (t * 0.71).cos(), (t * 0.13).sin() * 0.5)
        })
        .collect();
    let tracks: Vec<Vec<u32>> = (0..n)
        .map(|k| (0..6).filter(|v| (k + v) % 3 != 0).collect())
        .collect();
    let scene = Scene {
        views,
        cloud: SparseCloud {
            positions,
            colors: (0..n)
                .map(|k| [k as u8, 2 * k as u8, 255 - k as u8])
                .collect(),
            normals: None,
            tracks,
            errors: vec![0.25; n as usize],
            confidence: vec![1.0; n as usize],
        },
    };
    let model = ColmapModel::from_scene(&scene, None).unwrap();
    write_model_bin(&dir, &model).unwrap();
    write_model_text(&dir, &model).unwrap();
    println!("wrote {}", dir.display());
}

#[test]
fn info_summarises_the_fixture() {
    use planemap::info::ModelInfo;
    let exp = expected();
    let info = ModelInfo::from_dir(&fixture().join("bin"), None).unwrap();
    let pts = exp["points3D"].as_array().unwrap();
    let obs: usize = pts
        .iter()
        .map(|p| p["track"].as_array().unwrap().len())
        .sum();
    assert_eq!(info.num_images, exp["images"].as_array().unwrap().len());
    assert_eq!(info.num_points, pts.len());
    assert_eq!(info.num_observations, obs);
    assert!((info.mean_track_length - obs as f64 / pts.len() as f64).abs() < 1e-12);
    let mean_err = pts.iter().map(|p| f(&p["error"])).sum::<f64>() / pts.len() as f64;
    assert!((info.mean_reprojection_error.unwrap() - mean_err).abs() < 1e-12);
    let text = info.to_string();
    assert!(text.contains("OPENCV 1024x768"), "{text}");
    println!("{text}");
}
