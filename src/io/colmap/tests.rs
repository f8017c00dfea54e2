use super::*;
use crate::geometry::{look_at, CameraModel};
use proptest::prelude::*;

/// A small model with awkward floats, a point with an invalid 2D observation, a
/// repeated-image track element and an image without points.
fn sample() -> ColmapModel {
    let cameras = vec![
        ColmapCamera {
            camera_id: 7,
            camera: Camera::new(
                CameraModel::Opencv,
                640,
                480,
                vec![500.1, 501.2, 320.5, 240.25, -0.1, 0.01, 1e-4, -3e-5],
            )
            .unwrap(),
        },
        ColmapCamera {
            camera_id: 2,
            camera: Camera::new(
                CameraModel::SimplePinhole,
                100,
                80,
                vec![0.1 + 0.2, 50.0, 40.0],
            )
            .unwrap(),
        },
    ];
    let images = vec![
        ColmapImage {
            image_id: 5,
            // Unit to rounding, with awkward digits.
            qvec: {
                let q = [0.9, 0.1, -0.3, std::f64::consts::PI / 10.0];
                let n = q.iter().map(|v| v * v).sum::<f64>().sqrt();
                q.map(|v| v / n)
            },
            tvec: [1e-300, -2.5e300, 0.30000000000000004],
            camera_id: 7,
            name: "b/img_5.png".into(),
            points2d: vec![
                Point2D {
                    x: 10.5,
                    y: 20.25,
                    point3d_id: Some(11),
                },
                Point2D {
                    x: 1.0 / 3.0,
                    y: 2.0,
                    point3d_id: None,
                },
                Point2D {
                    x: 30.0,
                    y: 40.0,
                    point3d_id: Some(12),
                },
            ],
        },
        ColmapImage {
            image_id: 1,
            qvec: [1.0, 0.0, 0.0, 0.0],
            tvec: [0.0, -0.0, 3.0],
            camera_id: 2,
            name: "a.png".into(),
            points2d: vec![Point2D {
                x: 5.0,
                y: 6.0,
                point3d_id: Some(11),
            }],
        },
        ColmapImage {
            image_id: 9,
            qvec: [0.5, 0.5, 0.5, 0.5],
            tvec: [1.0, 2.0, 3.0],
            camera_id: 2,
            name: "c.png".into(),
            points2d: vec![],
        },
    ];
    let points3d = vec![
        ColmapPoint3D {
            point3d_id: 12,
            xyz: [0.1, 0.2, 0.3],
            rgb: [255, 0, 17],
            error: 3.0,
            track: vec![TrackElement {
                image_id: 5,
                point2d_idx: 2,
            }],
        },
        ColmapPoint3D {
            point3d_id: 11,
            xyz: [-1.0, 2.0, 1e-9],
            rgb: [1, 2, 3],
            error: 0.5,
            track: vec![
                TrackElement {
                    image_id: 5,
                    point2d_idx: 0,
                },
                TrackElement {
                    image_id: 1,
                    point2d_idx: 0,
                },
                TrackElement {
                    image_id: 5,
                    point2d_idx: 1,
                },
            ],
        },
    ];
    ColmapModel {
        cameras,
        images,
        points3d,
    }
}

fn text_bytes(m: &ColmapModel) -> [Vec<u8>; 3] {
    let mut c = Vec::new();
    let mut i = Vec::new();
    let mut p = Vec::new();
    write_cameras_text(&mut c, &m.cameras).unwrap();
    write_images_text(&mut i, &m.images).unwrap();
    write_points3d_text(&mut p, &m.points3d).unwrap();
    [c, i, p]
}

fn from_bin(b: &[Vec<u8>; 3]) -> Result<ColmapModel, ColmapError> {
    Ok(ColmapModel {
        cameras: read_cameras_bin(&b[0][..])?,
        images: read_images_bin(&b[1][..])?,
        points3d: read_points3d_bin(&b[2][..])?,
    })
}

fn from_text(t: &[Vec<u8>; 3]) -> Result<ColmapModel, ColmapError> {
    Ok(ColmapModel {
        cameras: read_cameras_text(&t[0][..])?,
        images: read_images_text(&t[1][..])?,
        points3d: read_points3d_text(&t[2][..])?,
    })
}

#[test]
fn binary_write_read_write_is_byte_identical() {
    let m = sample();
    let b1 = model_to_bin_bytes(&m).unwrap();
    let back = from_bin(&b1).unwrap();
    assert_eq!(back, m);
    let b2 = model_to_bin_bytes(&back).unwrap();
    assert_eq!(b1, b2);
    // Spot-check the layout: count, then camera 7 = u32 id, i32 model 4 (OPENCV), u64 640.
    assert_eq!(&b1[0][..8], &2u64.to_le_bytes());
    assert_eq!(&b1[0][8..12], &7u32.to_le_bytes());
    assert_eq!(&b1[0][12..16], &4i32.to_le_bytes());
    assert_eq!(&b1[0][16..24], &640u64.to_le_bytes());
    // Invalid point3D id is u64::MAX: second 2D point of the first image.
    let name_end = 8 + 4 + 56 + 4 + "b/img_5.png".len() + 1;
    let p1 = name_end + 8 + 24;
    assert_eq!(&b1[1][p1 + 16..p1 + 24], &u64::MAX.to_le_bytes());
}

#[test]
fn text_write_read_is_bit_exact() {
    let m = sample();
    let t = text_bytes(&m);
    let back = from_text(&t).unwrap();
    // Byte equality of the binary encodings means every f64 came back bit for bit
    // (including -0.0, 1e-300 and 0.1 + 0.2).
    assert_eq!(
        model_to_bin_bytes(&back).unwrap(),
        model_to_bin_bytes(&m).unwrap()
    );
    let images = String::from_utf8(t[1].clone()).unwrap();
    assert!(images.contains(" -1"), "{images}");
    // The image without points has an empty second line.
    assert!(
        images.contains("c.png\n\n") || images.ends_with("c.png\n\n"),
        "{images}"
    );
}

#[test]
fn text_reader_accepts_colmap_style_input() {
    let cams = "# Camera list\n#   CAMERA_ID, ...\n\n1 PINHOLE 64 48 50 51.5 32 24\n";
    let ims = "# Image list\n# comment\n3 1 0 0 0 0.1 0.2 0.30000000000000004 1 x.png\n\n\
               4 1 0 0 0 0 0 1 1 y.png\n1.5 2.5 -1 3.5 4.5 8\n";
    let pts = "# points\n8 1 2 3 10 20 30 0.5 4 1\n";
    let m = ColmapModel {
        cameras: read_cameras_text(cams.as_bytes()).unwrap(),
        images: read_images_text(ims.as_bytes()).unwrap(),
        points3d: read_points3d_text(pts.as_bytes()).unwrap(),
    };
    m.validate(ModelFormat::Text).unwrap();
    assert_eq!(m.cameras[0].camera.params, vec![50.0, 51.5, 32.0, 24.0]);
    assert_eq!(m.images.len(), 2);
    assert!(m.images[0].points2d.is_empty());
    assert_eq!(m.images[1].points2d[0].point3d_id, None);
    assert_eq!(m.images[1].points2d[1].point3d_id, Some(8));
    assert_eq!(
        m.points3d[0].track,
        vec![TrackElement {
            image_id: 4,
            point2d_idx: 1
        }]
    );
}

#[test]
fn invalid_utf8_and_crlf_in_text() {
    let e = read_images_text(&b"# ok\n1 1 0 0 0 0 0 0 1 \xff.png\n\n"[..])
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("images.txt") && e.contains("line 2") && e.contains("UTF-8"),
        "{e}"
    );
    let cams = read_cameras_text(&b"# c\r\n1 PINHOLE 4 4 1 2 3 4\r\n"[..]).unwrap();
    assert_eq!(cams[0].camera.params, vec![1.0, 2.0, 3.0, 4.0]);
    let ims =
        read_images_text(&b"1 1 0 0 0 0 0 0 1 a.png\r\n\r\n2 1 0 0 0 0 0 0 1 b.png"[..]).unwrap();
    assert_eq!(ims.len(), 2);
    assert!(ims[1].points2d.is_empty());
}

#[test]
fn garbled_text_names_line_and_field() {
    let ims = "# header\n3 1 0 0 0 0.1 zz 0.3 1 x.png\n\n";
    let e = read_images_text(ims.as_bytes()).unwrap_err().to_string();
    assert!(
        e.contains("images.txt") && e.contains("line 2") && e.contains("field 7"),
        "{e}"
    );
    assert!(e.contains("TY") && e.contains("\"zz\""), "{e}");

    let pts = "1 1 2 3 10 20 30 0.5 4\n";
    let e = read_points3d_text(pts.as_bytes()).unwrap_err().to_string();
    assert!(e.contains("line 1") && e.contains("TRACK"), "{e}");

    let pts = "1 1 2 3 300 20 30 0.5\n";
    let e = read_points3d_text(pts.as_bytes()).unwrap_err().to_string();
    assert!(e.contains("field 5") && e.contains("\"300\""), "{e}");
}

#[test]
fn unknown_model_and_param_count_are_reported() {
    let e = read_cameras_text("\n1 FISHEYE_42 10 10 1 2 3\n".as_bytes())
        .unwrap_err()
        .to_string();
    assert!(e.contains("line 2") && e.contains("FISHEYE_42"), "{e}");
    let e = read_cameras_text("1 RADIAL 10 10 1 2 3\n".as_bytes())
        .unwrap_err()
        .to_string();
    assert!(e.contains("RADIAL takes 5 parameters, got 3"), "{e}");

    let mut b = model_to_bin_bytes(&sample()).unwrap();
    b[0][12..16].copy_from_slice(&99i32.to_le_bytes());
    let e = read_cameras_bin(&b[0][..]).unwrap_err().to_string();
    assert!(
        e.contains("byte offset 8")
            && e.contains("unknown camera model id 99 (expected 0–4: 0 SIMPLE_PINHOLE")
            && !e.contains("model model"),
        "{e}"
    );
}

#[test]
fn utf8_byte_order_mark_is_accepted() {
    let m = sample();
    let t = text_bytes(&m);
    let with_bom = |b: &[u8]| [b"\xEF\xBB\xBF".as_slice(), b].concat();
    let cams = read_cameras_text(&with_bom(&t[0])[..]).unwrap();
    assert_eq!(cams, m.cameras);
    let images = read_images_text(&with_bom(&t[1])[..]).unwrap();
    assert_eq!(images, m.images);
    let points = read_points3d_text(&with_bom(&t[2])[..]).unwrap();
    assert_eq!(points, m.points3d);
    // Without a comment header the BOM sits right before the first record.
    let cams = read_cameras_text(&b"\xEF\xBB\xBF1 PINHOLE 10 10 5 5 5 5\n"[..]).unwrap();
    assert_eq!(cams[0].camera_id, 1);
    // A BOM elsewhere is still not a number.
    assert!(read_cameras_text(
        &b"1 PINHOLE 10 10 5 5 5 5\n\xEF\xBB\xBF2 PINHOLE 1 1 1 1 1 1\n"[..]
    )
    .is_err());
}

#[test]
fn near_unit_quaternions_are_renormalised_far_ones_rejected() {
    // Quarter turn about z, stored with norm 1.0004 (lost digits): read, and the scene's
    // pose is the quarter turn (so depths are right).
    let h = std::f64::consts::FRAC_1_SQRT_2 * 1.0004;
    let mut m = ColmapModel {
        cameras: vec![ColmapCamera {
            camera_id: 1,
            camera: Camera::pinhole(64, 48, 50.0, 50.0, 32.0, 24.0),
        }],
        images: vec![ColmapImage {
            image_id: 3,
            qvec: [h, 0.0, 0.0, h],
            tvec: [0.0, 0.0, 2.0],
            camera_id: 1,
            name: "c.png".into(),
            points2d: vec![],
        }],
        points3d: vec![],
    };
    for bytes in [text_bytes(&m), model_to_bin_bytes(&m).unwrap()] {
        let read = if bytes[1].starts_with(b"#") {
            from_text(&bytes)
        } else {
            from_bin(&bytes)
        };
        let read = read.unwrap();
        assert_eq!(read.images[0].qvec, m.images[0].qvec, "stored as read");
        let scene = read.to_scene(None).unwrap();
        let (_, depth) = scene.views[0]
            .project(&nalgebra::Vector3::new(0.0, 1.0, 3.0))
            .unwrap();
        assert!((depth - 5.0).abs() < 1e-12, "depth {depth}");
        let x = scene.views[0].cam_from_world * nalgebra::Point3::new(1.0, 0.0, 0.0);
        assert!((x.coords - nalgebra::Vector3::new(0.0, 1.0, 2.0)).norm() < 1e-12);
    }

    // Zero, scaled and NaN-free garbage: errors naming file, image id, name and place.
    for q in [[0.0; 4], [2.0, 0.0, 0.0, 0.0], [0.5, 0.5, 0.5, 0.4]] {
        m.images[0].qvec = q;
        let mut text = Vec::new();
        // Not through write_images_text, which validates nothing but is fine; build by hand
        // to place the image on line 2.
        text.extend_from_slice(b"# header\n");
        text.extend_from_slice(
            format!("3 {} {} {} {} 0 0 2 1 c.png\n\n", q[0], q[1], q[2], q[3]).as_bytes(),
        );
        let e = read_images_text(&text[..]).unwrap_err().to_string();
        assert!(
            e.contains("images.txt: line 2: image 3 (c.png): quaternion")
                && e.contains("expected a unit quaternion"),
            "{e}"
        );
        let mut b = Vec::new();
        write_images_bin(&mut b, &m.images).unwrap();
        let e = read_images_bin(&b[..]).unwrap_err().to_string();
        assert!(
            e.contains("images.bin: byte offset 12: image 3 (c.png): quaternion")
                && e.contains("has norm"),
            "{e}"
        );
        // A model built in memory is checked too.
        let e = m.validate(ModelFormat::Text).unwrap_err().to_string();
        assert!(
            e.contains("image 3 (c.png)") && e.contains("quaternion"),
            "{e}"
        );
        assert!(m.to_scene(None).is_err());
    }
}

#[test]
fn to_scene_rejects_an_absurd_principal_point_by_camera() {
    let mut m = sample();
    m.cameras[1].camera.params[1] = 1e300;
    // The reader accepts the record (info shows and warns about it) ...
    let t = text_bytes(&m);
    let read = from_text(&t).unwrap();
    // ... but building a scene refuses it, naming the camera and the image using it.
    let e = read.to_scene(None).unwrap_err().to_string();
    assert!(
        e.contains("camera 2 (used by image 1, a.png)")
            && e.contains("principal point (1e300, 40.0)"),
        "{e}"
    );
}

#[test]
fn non_finite_values_are_rejected() {
    let e = read_images_text("1 nan 0 0 0 0 0 0 1 a.png\n\n".as_bytes())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("QW") && e.contains("NaN") && e.contains("line 1"),
        "{e}"
    );
    let e = read_points3d_text("1 1 inf 3 1 2 3 0.5\n".as_bytes())
        .unwrap_err()
        .to_string();
    assert!(e.contains("Y") && e.contains("inf"), "{e}");
    let e = read_cameras_text("1 PINHOLE 10 10 1 NaN 3 4\n".as_bytes())
        .unwrap_err()
        .to_string();
    assert!(e.contains("fy"), "{e}");

    let mut b = model_to_bin_bytes(&sample()).unwrap();
    // tx of the first image: count 8 + id 4 + qvec 32.
    b[1][44..52].copy_from_slice(&f64::INFINITY.to_le_bytes());
    let e = read_images_bin(&b[1][..]).unwrap_err().to_string();
    assert!(
        e.contains("byte offset 44") && e.contains("tx") && e.contains("inf"),
        "{e}"
    );
}

#[test]
fn truncation_names_the_offset() {
    let b = model_to_bin_bytes(&sample()).unwrap();
    for (k, file) in b.iter().enumerate() {
        for len in 0..file.len() {
            let cut = &file[..len];
            let r = match k {
                0 => read_cameras_bin(cut).map(|_| ()),
                1 => read_images_bin(cut).map(|_| ()),
                _ => read_points3d_bin(cut).map(|_| ()),
            };
            let e = r.expect_err("a truncated file must not parse");
            match e {
                ColmapError::Truncated { offset, .. } => assert!(offset <= len as u64),
                ColmapError::BadCount { offset, .. } => assert!(offset < len as u64),
                other => panic!("unexpected error for length {len}: {other}"),
            }
        }
    }
    let e = read_points3d_bin(&b[2][..20]).unwrap_err().to_string();
    assert!(e.contains("points3D.bin"), "{e}");
}

#[test]
fn absurd_counts_are_errors_not_allocations() {
    let mut bytes = u64::MAX.to_le_bytes().to_vec();
    bytes.extend_from_slice(&[0; 100]);
    let e = read_points3d_bin(&bytes[..]).unwrap_err().to_string();
    assert!(
        e.contains("byte offset 0") && e.contains("number of 3D points"),
        "{e}"
    );
    let mut b = model_to_bin_bytes(&sample()).unwrap();
    // Track length of the first point: 8 + id 8 + xyz 24 + rgb 3 + error 8 = 51.
    b[2][51..59].copy_from_slice(&(1u64 << 40).to_le_bytes());
    let e = read_points3d_bin(&b[2][..]).unwrap_err().to_string();
    assert!(
        e.contains("byte offset 51") && e.contains("track length"),
        "{e}"
    );
}

#[test]
fn dangling_references_are_errors() {
    let mut m = sample();
    m.points3d[1].track.push(TrackElement {
        image_id: 77,
        point2d_idx: 0,
    });
    let e = m.validate(ModelFormat::Binary).unwrap_err().to_string();
    assert!(e.contains("points3D.bin") && e.contains("image 77"), "{e}");

    let mut m = sample();
    m.points3d[1].track[1].point2d_idx = 4;
    let e = m.validate(ModelFormat::Text).unwrap_err().to_string();
    assert!(
        e.contains("points3D.txt") && e.contains("2D point 4 of image 1"),
        "{e}"
    );

    let mut m = sample();
    m.images[2].camera_id = 3;
    let e = m.validate(ModelFormat::Binary).unwrap_err().to_string();
    assert!(e.contains("images.bin") && e.contains("camera 3"), "{e}");

    let dir = tempfile::tempdir().unwrap();
    let mut m = sample();
    write_model_bin(dir.path(), &m).unwrap();
    m.images[0].camera_id = 3;
    let b = model_to_bin_bytes(&m).unwrap();
    std::fs::write(dir.path().join("images.bin"), &b[1]).unwrap();
    let e = read_model(dir.path()).unwrap_err().to_string();
    assert!(
        e.contains(&dir.path().join("images.bin").display().to_string()),
        "{e}"
    );
}

#[test]
fn read_model_finds_sparse_dirs_and_prefers_binary() {
    let dir = tempfile::tempdir().unwrap();
    let m = sample();
    let sub = dir.path().join("sparse").join("0");
    write_model_text(&sub, &m).unwrap();
    assert_eq!(
        find_model(dir.path()).unwrap(),
        (sub.clone(), ModelFormat::Text)
    );
    assert_eq!(read_model(dir.path()).unwrap(), m);
    let mut m2 = m.clone();
    m2.points3d.pop();
    write_model_bin(&sub, &m2).unwrap();
    assert_eq!(find_model(dir.path()).unwrap().1, ModelFormat::Binary);
    assert_eq!(read_model(dir.path()).unwrap(), m2);
    // rigs/frames from newer COLMAP are ignored.
    std::fs::write(sub.join("rigs.bin"), b"junk").unwrap();
    std::fs::write(sub.join("frames.txt"), b"junk").unwrap();
    assert_eq!(read_model(dir.path()).unwrap(), m2);
    // No temporary files left behind.
    let names: Vec<_> = std::fs::read_dir(&sub)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(names.iter().all(|n| !n.contains(".tmp")), "{names:?}");
    let e = read_model(&dir.path().join("nothing"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("no COLMAP model"), "{e}");
}

#[test]
fn to_scene_sorts_views_and_maps_tracks() {
    let m = sample();
    let scene = m.to_scene(Some(Path::new("/imgs"))).unwrap();
    let ids: Vec<u32> = scene.views.iter().map(|v| v.id).collect();
    assert_eq!(ids, vec![1, 5, 9]);
    assert_eq!(
        scene.views[1].image_path.as_deref(),
        Some(Path::new("/imgs/b/img_5.png"))
    );
    assert_eq!(scene.views[1].camera.model, CameraModel::Opencv);
    // Point 11 is seen by images 5, 1, 5 → views [0, 1].
    assert_eq!(scene.cloud.tracks[1], vec![0, 1]);
    assert_eq!(scene.cloud.tracks[0], vec![1]);
    assert_eq!(scene.cloud.errors, vec![3.0, 0.5]);
    assert!(scene.cloud.normals.is_none());
    // Confidence: one view → 0; two views, 0.5 px → 1/4 · 1/(1 + 0.25) = 0.2.
    assert_eq!(scene.cloud.confidence[0], 0.0);
    assert!((scene.cloud.confidence[1] - 0.2).abs() < 1e-15);
    // Pose is carried bit-exactly.
    let (q, t) = rigid_to_colmap(&scene.views[1].cam_from_world);
    assert_eq!(q, m.images[0].qvec);
    assert_eq!(t, m.images[0].tvec);
}

#[test]
fn confidence_is_monotone_and_bounded() {
    assert_eq!(point_confidence(0, 0.0), 0.0);
    assert_eq!(point_confidence(1, 0.0), 0.0);
    assert_eq!(point_confidence(CONFIDENCE_FULL_TRACK, 0.0), 1.0);
    assert_eq!(point_confidence(50, 0.0), 1.0);
    assert_eq!(point_confidence(50, -1.0), 1.0);
    assert!((point_confidence(50, 1.0) - 0.5).abs() < 1e-15);
    let mut prev = 1.0;
    for k in 0..100 {
        let c = point_confidence(6, k as f64 * 0.1);
        assert!(c <= prev && (0.0..=1.0).contains(&c));
        prev = c;
    }
}

fn synthetic_scene() -> Scene {
    let cam_a = Camera::new(
        CameraModel::Radial,
        64,
        48,
        vec![50.0, 32.0, 24.0, -0.05, 0.01],
    )
    .unwrap();
    let cam_b = Camera::pinhole(80, 60, 70.0, 71.0, 40.0, 30.0);
    let eyes = [
        Vector3::new(4.0, 0.5, 1.0),
        Vector3::new(3.0, 3.0, 1.5),
        Vector3::new(-1.0, 4.0, 0.5),
    ];
    let views: Vec<View> = eyes
        .iter()
        .enumerate()
        .map(|(i, e)| View {
            id: 10 + 3 * i as u32,
            name: format!("v{i}.png"),
            camera: if i == 1 { cam_b.clone() } else { cam_a.clone() },
            cam_from_world: look_at(e, &Vector3::zeros(), &Vector3::z()),
            image_path: None,
        })
        .collect();
    let positions = vec![
        Vector3::new(0.1, 0.2, 0.3),
        Vector3::new(-0.2, 0.1, 0.0),
        Vector3::new(0.3, -0.1, 0.2),
    ];
    let tracks = vec![vec![0, 1, 2], vec![1, 2], vec![0, 2]];
    let n = positions.len();
    Scene {
        views,
        cloud: SparseCloud {
            positions,
            colors: vec![[1, 2, 3], [4, 5, 6], [7, 8, 9]],
            normals: None,
            tracks: tracks.clone(),
            errors: vec![0.0, 0.25, 1.0],
            confidence: vec![0.0; n],
        },
    }
}

#[test]
fn from_scene_projects_dedupes_cameras_and_round_trips() {
    let scene = synthetic_scene();
    let m = ColmapModel::from_scene(&scene, None).unwrap();
    assert_eq!(m.cameras.len(), 2);
    assert_eq!(m.images[0].camera_id, m.images[2].camera_id);
    assert_ne!(m.images[0].camera_id, m.images[1].camera_id);
    assert_eq!(
        m.images.iter().map(|i| i.image_id).collect::<Vec<_>>(),
        vec![10, 13, 16]
    );
    assert_eq!(
        m.points3d.iter().map(|p| p.point3d_id).collect::<Vec<_>>(),
        vec![1, 2, 3]
    );
    // Every track element points at a 2D point that points back and sits at the projection.
    for p in &m.points3d {
        for t in &p.track {
            let im = m.image(t.image_id).unwrap();
            let p2 = im.points2d[t.point2d_idx as usize];
            assert_eq!(p2.point3d_id, Some(p.point3d_id));
            let v = scene.view_index_by_id(t.image_id).unwrap();
            let (xy, _) = scene.views[v].project(&Vector3::from(p.xyz)).unwrap();
            assert!((xy.x - p2.x).abs() < 1e-12 && (xy.y - p2.y).abs() < 1e-12);
        }
    }
    assert_eq!(m.images[2].points2d.len(), 3);
    let back = m.to_scene(None).unwrap();
    assert_eq!(back.cloud.tracks, scene.cloud.tracks);
    assert_eq!(back.cloud.positions, scene.cloud.positions);
    for (a, b) in back.views.iter().zip(&scene.views) {
        assert_eq!(a.camera, b.camera);
        assert_eq!(a.cam_from_world, b.cam_from_world);
    }
}

#[test]
fn from_scene_uses_given_observations_and_checks_them() {
    let scene = synthetic_scene();
    let obs: Vec<Vec<[f64; 2]>> = scene
        .cloud
        .tracks
        .iter()
        .enumerate()
        .map(|(i, t)| {
            t.iter()
                .enumerate()
                .map(|(k, _)| [i as f64, k as f64 + 0.5])
                .collect()
        })
        .collect();
    let m = ColmapModel::from_scene(&scene, Some(&obs)).unwrap();
    let p = &m.points3d[2];
    let im = m.image(p.track[1].image_id).unwrap();
    assert_eq!(im.points2d[p.track[1].point2d_idx as usize].x, 2.0);
    assert_eq!(im.points2d[p.track[1].point2d_idx as usize].y, 1.5);
    let e = ColmapModel::from_scene(&scene, Some(&obs[..2]))
        .unwrap_err()
        .to_string();
    assert!(e.contains("observations"), "{e}");
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]
    /// Random byte edits and truncations of a valid model never panic the readers.
    #[test]
    fn mutated_binary_never_panics(
        which in 0usize..3,
        edits in proptest::collection::vec((any::<usize>(), any::<u8>()), 1..8),
        cut in any::<usize>(),
        truncate in any::<bool>(),
    ) {
        let mut b = model_to_bin_bytes(&sample()).unwrap();
        let f = &mut b[which];
        for (pos, byte) in edits {
            let n = f.len();
            f[pos % n] = byte;
        }
        if truncate {
            let n = f.len();
            f.truncate(cut % n);
        }
        match from_bin(&b) {
            Ok(m) => {
                let _ = m.validate(ModelFormat::Binary);
                let _ = m.to_scene(None);
            }
            // Every binary error is located at a byte offset.
            Err(e) => prop_assert!(e.to_string().contains("byte offset"), "{}", e),
        }
    }

    /// Random byte edits of valid text never panic the readers.
    #[test]
    fn mutated_text_never_panics(
        which in 0usize..3,
        edits in proptest::collection::vec((any::<usize>(), any::<u8>()), 1..8),
    ) {
        let mut t = text_bytes(&sample());
        let f = &mut t[which];
        for (pos, byte) in edits {
            let n = f.len();
            f[pos % n] = byte;
        }
        match from_text(&t) {
            Ok(m) => {
                let _ = m.to_scene(None);
            }
            // Every text error is located at a line.
            Err(e) => prop_assert!(e.to_string().contains("line "), "{}", e),
        }
    }
}
