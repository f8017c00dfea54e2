//! Replays the committed fuzz corpus and crashers (`fuzz/corpus/<target>/`,
//! `fuzz/artifacts/<target>/`) through the same reader entry points the fuzz targets drive
//! (`fuzz/src/readers.rs`), so that CI guards every input the fuzzers found or started from
//! without running a fuzzer: each file must be read or refused with a message, never panic.
//!
//! `cargo test --test fuzz_corpus -- --ignored regenerate_seed_corpus` rewrites the seed
//! files (`seed-*`) from the project's own writers and fixtures.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};

#[allow(dead_code)]
#[path = "../fuzz/src/readers.rs"]
mod readers;

fn fuzz_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz")
}

fn files_in(dir: &Path) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = match std::fs::read_dir(dir) {
        Ok(entries) => entries
            .map(|e| e.unwrap().path())
            .filter(|p| p.is_file())
            .collect(),
        Err(_) => Vec::new(),
    };
    files.sort();
    files
}

#[test]
fn every_corpus_and_crasher_file_is_read_or_refused_without_panic() {
    let prev = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let mut failures = Vec::new();
    let mut counts = Vec::new();
    for &(name, reader) in readers::TARGETS {
        let corpus = files_in(&fuzz_dir().join("corpus").join(name));
        let crashers = files_in(&fuzz_dir().join("artifacts").join(name));
        assert!(!corpus.is_empty(), "no seed corpus for {name}");
        let (mut ok, mut refused) = (0, 0);
        for file in corpus.iter().chain(&crashers) {
            let data = std::fs::read(file).unwrap();
            match catch_unwind(AssertUnwindSafe(|| reader(&data))) {
                Ok(Ok(())) => ok += 1,
                Ok(Err(message)) => {
                    refused += 1;
                    if message.trim().is_empty() {
                        failures.push(format!("{}: refused with an empty message", file.display()));
                    }
                }
                Err(panic) => {
                    let what = panic
                        .downcast_ref::<String>()
                        .cloned()
                        .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                        .unwrap_or_default();
                    failures.push(format!("{}: panicked: {what}", file.display()));
                }
            }
        }
        counts.push(format!(
            "{name}: {} files ({} crashers), {ok} read, {refused} refused",
            corpus.len() + crashers.len(),
            crashers.len()
        ));
    }
    std::panic::set_hook(prev);
    println!("{}", counts.join("\n"));
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Every seed must be accepted by its reader: they are valid files written by the project's
/// writers (a seed the reader refuses would start the fuzzer from the error paths only).
#[test]
fn every_seed_is_accepted() {
    for &(name, reader) in readers::TARGETS {
        for file in files_in(&fuzz_dir().join("corpus").join(name)) {
            let is_seed = file
                .file_name()
                .is_some_and(|n| n.to_string_lossy().starts_with("seed-"));
            if is_seed {
                let data = std::fs::read(&file).unwrap();
                if let Err(e) = reader(&data) {
                    panic!("{}: seed refused: {e}", file.display());
                }
            }
        }
    }
}

mod seeds {
    use std::path::Path;

    use nalgebra::{Matrix3x4, Vector3};
    use planemap::geometry::{look_at, Camera, CameraModel};
    use planemap::io::colmap::{
        write_cameras_bin, write_cameras_text, write_images_bin, write_images_text,
        write_points3d_bin, write_points3d_text, ColmapCamera, ColmapImage, ColmapModel,
        ColmapPoint3D, Point2D, TrackElement,
    };
    use planemap::ImageF32;

    /// A small model with every camera model, a point without a track element on one image,
    /// and an image without points.
    pub fn model() -> ColmapModel {
        let params = |m: CameraModel| -> Vec<f64> {
            match m {
                CameraModel::SimplePinhole => vec![50.0, 32.0, 24.0],
                CameraModel::Pinhole => vec![50.0, 51.0, 32.5, 23.5],
                CameraModel::SimpleRadial => vec![50.0, 32.0, 24.0, -0.05],
                CameraModel::Radial => vec![50.0, 32.0, 24.0, -0.05, 0.01],
                CameraModel::Opencv => vec![50.0, 51.0, 32.0, 24.0, -0.05, 0.01, 1e-3, -2e-3],
            }
        };
        let cameras = CameraModel::ALL
            .iter()
            .enumerate()
            .map(|(i, &m)| ColmapCamera {
                camera_id: i as u32 + 1,
                camera: Camera::new(m, 64, 48, params(m)).unwrap(),
            })
            .collect();
        let pose = |eye: [f64; 3]| {
            let p = look_at(&Vector3::from(eye), &Vector3::zeros(), &Vector3::z());
            planemap::geometry::rigid_to_colmap(&p)
        };
        let (q1, t1) = pose([3.0, -4.0, 1.5]);
        let (q2, t2) = pose([-2.0, -4.5, 1.0]);
        let images = vec![
            ColmapImage {
                image_id: 1,
                qvec: q1,
                tvec: t1,
                camera_id: 2,
                name: "a.png".into(),
                points2d: vec![
                    Point2D {
                        x: 10.5,
                        y: 20.25,
                        point3d_id: Some(1),
                    },
                    Point2D {
                        x: 30.0,
                        y: 4.0,
                        point3d_id: None,
                    },
                ],
            },
            ColmapImage {
                image_id: 7,
                qvec: q2,
                tvec: t2,
                camera_id: 5,
                name: "sub/b.jpg".into(),
                points2d: vec![Point2D {
                    x: 40.0,
                    y: 22.0,
                    point3d_id: Some(1),
                }],
            },
            ColmapImage {
                image_id: 9,
                qvec: [1.0, 0.0, 0.0, 0.0],
                tvec: [0.0, 0.0, 5.0],
                camera_id: 1,
                name: "c.png".into(),
                points2d: vec![],
            },
        ];
        let points3d = vec![
            ColmapPoint3D {
                point3d_id: 1,
                xyz: [0.1, 0.2, 0.3],
                rgb: [10, 200, 30],
                error: 0.75,
                track: vec![
                    TrackElement {
                        image_id: 1,
                        point2d_idx: 0,
                    },
                    TrackElement {
                        image_id: 7,
                        point2d_idx: 0,
                    },
                ],
            },
            ColmapPoint3D {
                point3d_id: 2,
                xyz: [-1.0, 0.5, 2.0],
                rgb: [0, 0, 0],
                error: -1.0,
                track: vec![],
            },
        ];
        ColmapModel {
            cameras,
            images,
            points3d,
        }
    }

    fn write(dir: &Path, target: &str, name: &str, bytes: &[u8]) {
        let d = dir.join("corpus").join(target);
        std::fs::create_dir_all(&d).unwrap();
        std::fs::write(d.join(format!("seed-{name}")), bytes).unwrap();
    }

    fn buf(f: impl FnOnce(&mut Vec<u8>)) -> Vec<u8> {
        let mut b = Vec::new();
        f(&mut b);
        b
    }

    pub fn regenerate(dir: &Path) {
        let m = model();
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        let fixture = root.join("tests/fixtures/pycolmap_small");
        for (target, file, bytes) in [
            (
                "colmap_bin_cameras",
                "small",
                buf(|b| write_cameras_bin(b, &m.cameras).unwrap()),
            ),
            (
                "colmap_bin_images",
                "small",
                buf(|b| write_images_bin(b, &m.images).unwrap()),
            ),
            (
                "colmap_bin_points3d",
                "small",
                buf(|b| write_points3d_bin(b, &m.points3d).unwrap()),
            ),
            (
                "colmap_text_cameras",
                "small",
                buf(|b| write_cameras_text(b, &m.cameras).unwrap()),
            ),
            (
                "colmap_text_images",
                "small",
                buf(|b| write_images_text(b, &m.images).unwrap()),
            ),
            (
                "colmap_text_points3d",
                "small",
                buf(|b| write_points3d_text(b, &m.points3d).unwrap()),
            ),
        ] {
            write(dir, target, file, &bytes);
        }
        for (target, file) in [
            ("colmap_bin_cameras", "bin/cameras.bin"),
            ("colmap_bin_images", "bin/images.bin"),
            ("colmap_bin_points3d", "bin/points3D.bin"),
            ("colmap_text_cameras", "txt/cameras.txt"),
            ("colmap_text_images", "txt/images.txt"),
            ("colmap_text_points3d", "txt/points3D.txt"),
        ] {
            let bytes = std::fs::read(fixture.join(file)).unwrap();
            write(dir, target, "pycolmap", &bytes);
        }

        // PMVS.
        let patches = planemap::io::pmvs::read_patches(
            &b"PATCHES\n2\nPATCHS\n1 2 3 1\n0 0 2 0\n0.9 0.1 0.2\n2\n4 1 \n1\n7 \n\n\
               PATCHA\n2 4 6 2\n1 0 0 0\n0.5 0 0\n3 1 0 0 1\n1\n3\n0\n\n"[..],
        )
        .unwrap();
        write(
            dir,
            "pmvs_patch",
            "written",
            &buf(|b| planemap::io::pmvs::write_patches(b, &patches).unwrap()),
        );
        write(
            dir,
            "pmvs_patch",
            "patcha",
            b"PATCHES\n1\nPATCHA\n2 4 6 2\n1 0 0 0\n0.5 0 0\n3 1 0 0 1\n1\n3\n0\n\n",
        );
        let camera = Camera::pinhole(640, 480, 510.0, 495.0, 321.7, 243.2);
        let pose = look_at(
            &Vector3::new(3.0, -1.0, 2.0),
            &Vector3::new(0.1, 0.2, -0.3),
            &Vector3::z(),
        );
        let p: Matrix3x4<f64> = planemap::io::pmvs::projection_from_camera(&camera, &pose).unwrap();
        write(
            dir,
            "pmvs_camera",
            "written",
            &buf(|b| planemap::io::pmvs::write_projection(b, &p).unwrap()),
        );
        let mut png = Vec::new();
        image::RgbImage::from_fn(5, 3, |x, y| image::Rgb([x as u8 * 40, y as u8 * 80, 7]))
            .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
            .unwrap();
        write(dir, "pmvs_image_header", "png", &png);
        let mut jpeg = Vec::new();
        image::RgbImage::from_fn(8, 8, |x, y| image::Rgb([x as u8 * 30, y as u8 * 30, 90]))
            .write_to(
                &mut std::io::Cursor::new(&mut jpeg),
                image::ImageFormat::Jpeg,
            )
            .unwrap();
        write(dir, "pmvs_image_header", "jpeg", &jpeg);
        write(
            dir,
            "pmvs_image_header",
            "ppm",
            b"P6\n# written by hand\n4 2\n255\n012345678901234567890123",
        );
        write(
            dir,
            "pmvs_image_header",
            "pgm",
            b"P2\n3 2\n255\n1 2 3\n4 5 6\n",
        );

        // PLY: the writers (binary little-endian) and an ASCII mesh by hand.
        let points = planemap::io::ply::PlyPoints {
            positions: vec![Vector3::new(0.0, 1.0, 2.0), Vector3::new(-1.5, 0.25, 3.0)],
            normals: Some(vec![
                Vector3::new(0.0, 0.0, 1.0),
                Vector3::new(1.0, 0.0, 0.0),
            ]),
            colors: Some(vec![[255, 0, 0], [0, 128, 255]]),
        };
        write(
            dir,
            "ply",
            "points",
            &buf(|b| planemap::io::ply::write_ply_points(b, &points).unwrap()),
        );
        let mesh = planemap::io::ply::PlyMesh {
            vertices: vec![
                Vector3::new(0.0, 0.0, 0.0),
                Vector3::new(1.0, 0.0, 0.0),
                Vector3::new(0.0, 1.0, 0.0),
                Vector3::new(1.0, 1.0, 0.5),
            ],
            faces: vec![[0, 1, 2], [1, 3, 2]],
            vertex_colors: Some(vec![[1, 2, 3], [4, 5, 6], [7, 8, 9], [10, 11, 12]]),
        };
        write(
            dir,
            "ply",
            "mesh",
            &buf(|b| planemap::io::ply::write_ply_mesh(b, &mesh).unwrap()),
        );
        write(
            dir,
            "ply",
            "ascii-mesh",
            b"ply\nformat ascii 1.0\ncomment by hand\nelement vertex 3\nproperty float x\n\
              property float y\nproperty float z\nproperty uchar red\nproperty uchar green\n\
              property uchar blue\nelement face 1\nproperty list uchar int vertex_indices\n\
              end_header\n0 0 0 255 0 0\n1 0 0 0 255 0\n0 1 0 0 0 255\n3 0 1 2\n",
        );

        // PFM and COLMAP dense maps, 1 and 3 channels.
        let img = |w: u32, h: u32, c: u32| ImageF32 {
            width: w,
            height: h,
            channels: c,
            data: (0..w * h * c).map(|i| i as f32 * 0.25 - 1.0).collect(),
        };
        write(
            dir,
            "pfm",
            "gray",
            &buf(|b| planemap::io::pfm::write_pfm(b, &img(3, 2, 1)).unwrap()),
        );
        write(
            dir,
            "pfm",
            "rgb",
            &buf(|b| planemap::io::pfm::write_pfm(b, &img(2, 2, 3)).unwrap()),
        );
        write(
            dir,
            "pfm",
            "big-endian",
            &[
                &b"Pf\n2 1\n1.0\n"[..],
                &1.5f32.to_be_bytes(),
                &(-2f32).to_be_bytes(),
            ]
            .concat(),
        );
        write(
            dir,
            "dense_map",
            "depth",
            &buf(|b| planemap::io::dense::write_dense_map(b, &img(3, 2, 1)).unwrap()),
        );
        write(
            dir,
            "dense_map",
            "normal",
            &buf(|b| planemap::io::dense::write_dense_map(b, &img(2, 2, 3)).unwrap()),
        );

        // Label PNGs: 16-bit and 8-bit greyscale.
        let labels: Vec<u16> = (0..12).map(|i| i * 700).collect();
        write(
            dir,
            "label_png",
            "16bit",
            &buf(|b| planemap::io::labelpng::write_label_png_to(b, 4, 3, &labels).unwrap()),
        );
        let mut gray8 = Vec::new();
        image::GrayImage::from_fn(3, 2, |x, y| image::Luma([(x + 3 * y) as u8]))
            .write_to(
                &mut std::io::Cursor::new(&mut gray8),
                image::ImageFormat::Png,
            )
            .unwrap();
        write(dir, "label_png", "8bit", &gray8);

        // Scene TOML: the demo scene and a minimal one with every object and rig kind.
        let demo = std::fs::read(root.join("scenes/demo.toml")).unwrap();
        write(dir, "scene_toml", "demo.toml", &demo);
        write(dir, "scene_toml", "kinds.toml", KINDS_TOML.as_bytes());

        // Config TOML: the default, written out, and a short override file.
        let cfg = toml::to_string(&planemap::pipeline::Config::default()).unwrap();
        write(dir, "config_toml", "default.toml", cfg.as_bytes());
        write(
            dir,
            "config_toml",
            "short.toml",
            b"[planemap]\nlambda = 0.5\n\n[solver]\n",
        );

        // Classifier: the built-in logistic model and a tiny kNN model.
        let logistic = std::fs::read(root.join("src/classify/default_model.bin")).unwrap();
        write(dir, "classifier_model", "logistic", &logistic);
        let d = planemap::classify::FEATURE_DIM;
        let header_len = 40 + 8 * d;
        let mut knn = logistic[..header_len].to_vec();
        knn[10] = 1; // method: kNN
        knn.extend_from_slice(&1u32.to_le_bytes()); // k
        knn.extend_from_slice(&2u32.to_le_bytes()); // n
        knn.extend_from_slice(&[0, 1]); // labels
        for i in 0..2 * d {
            knn.extend_from_slice(&(i as f32 * 0.1).to_le_bytes());
        }
        write(dir, "classifier_model", "knn", &knn);
    }

    const KINDS_TOML: &str = r#"name = "kinds"
seed = 3
[camera]
width = 32
height = 24
focal_px = 30.0
radial_k = -0.02
[materials.m]
color = [0.5, 0.5, 0.5]
[materials.b]
texture = "bricks"
color = [0.6, 0.3, 0.2]
[[objects]]
type = "box"
material = "m"
min = [-5.0, -5.0, 0.0]
max = [5.0, 5.0, 3.0]
inside = true
face_materials = { zmin = "b" }
[[objects]]
type = "box"
material = "b"
center = [1.0, 1.0, 0.5]
size = [0.5, 0.5, 1.0]
rotation_deg = [0.0, 0.0, 30.0]
[[objects]]
type = "quad"
material = "m"
center = [0.0, 4.9, 1.5]
size = [1.0, 0.8]
normal = [0.0, -1.0, 0.0]
[[objects]]
type = "sphere"
material = "m"
center = [-1.0, 0.0, 1.0]
radius = 0.3
[[objects]]
type = "cylinder"
material = "b"
base = [2.0, -2.0, 0.0]
height = 1.0
radius = 0.2
[[rigs]]
type = "orbit"
center = [0.0, 0.0, 0.0]
radius = 3.0
height = 1.6
count = 3
[[rigs]]
type = "walk"
path = [[-3.0, -3.0, 1.5], [3.0, -3.0, 1.5]]
count = 2
target = [0.0, 0.0, 1.0]
[[rigs]]
type = "facade"
start = [-2.0, -4.0, 1.5]
end = [2.0, -4.0, 1.5]
count = 2
facing = [0.0, 1.0, 0.0]
[[rigs]]
type = "list"
views = [{ position = [0.0, -4.0, 1.5], target = [0.0, 0.0, 1.0] }]
"#;
}

/// Rewrites the `seed-*` files of `fuzz/corpus/` (run with `--ignored`).
#[test]
#[ignore]
fn regenerate_seed_corpus() {
    seeds::regenerate(&fuzz_dir());
}
