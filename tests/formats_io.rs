//! Integration tests of planemap's file formats through real files in a temporary directory:
//! round trips, and bad inputs whose errors must name the file and the line or byte offset.

use std::fs;
use std::path::Path;

use nalgebra::{Point3, Vector3};
use planemap::geometry::look_at;
use planemap::io::{dense, labelpng, pfm, ply, pmvs};
use planemap::{Camera, ImageF32, Scene, SparseCloud, View};

fn assert_names(err: &dyn std::fmt::Display, path: &Path, location: &str) {
    let msg = err.to_string();
    assert!(
        msg.contains(&path.display().to_string()),
        "error does not name {}: {msg}",
        path.display()
    );
    assert!(
        msg.contains(location),
        "error does not say {location:?}: {msg}"
    );
}

fn ramp(w: u32, h: u32, c: u32) -> ImageF32 {
    let mut img = ImageF32::filled(w, h, c, 0.0);
    for (i, v) in img.data.iter_mut().enumerate() {
        *v = (i as f32).sin() * 3.0 + 0.125;
    }
    img
}

#[test]
fn pfm_files() -> Result<(), Box<dyn std::error::Error>> {
    let dir = tempfile::tempdir()?;
    for c in [1, 3] {
        let path = dir.path().join(format!("img{c}.pfm"));
        let img = ramp(7, 5, c);
        pfm::write_pfm_path(&path, &img)?;
        let back = pfm::read_pfm_path(&path)?;
        assert_eq!(back, img);
        let again = dir.path().join("again.pfm");
        pfm::write_pfm_path(&again, &back)?;
        assert_eq!(fs::read(&again)?, fs::read(&path)?);
    }
    // Truncated: header "Pf\n7 5\n-1\n" is 10 bytes; cut 3 bytes into the data.
    let path = dir.path().join("img1.pfm");
    let bytes = fs::read(&path)?;
    let bad = dir.path().join("truncated.pfm");
    fs::write(&bad, &bytes[..13])?;
    assert_names(&pfm::read_pfm_path(&bad).unwrap_err(), &bad, "byte 13");
    fs::write(&bad, b"PF\n7 five\n-1\n")?;
    assert_names(&pfm::read_pfm_path(&bad).unwrap_err(), &bad, "byte 5");
    Ok(())
}

#[test]
fn colmap_dense_maps() -> Result<(), Box<dyn std::error::Error>> {
    let dir = tempfile::tempdir()?;
    let depth = ramp(6, 4, 1);
    let normals = ramp(6, 4, 3);
    let dpath = dir.path().join("img.png.geometric.bin");
    let npath = dir.path().join("normal.bin");
    dense::write_dense_map_path(&dpath, &depth)?;
    dense::write_dense_map_path(&npath, &normals)?;
    assert_eq!(dense::read_depth_map_path(&dpath)?, depth);
    assert_eq!(dense::read_normal_map_path(&npath)?, normals);
    let again = dir.path().join("again.bin");
    dense::write_dense_map_path(&again, &dense::read_dense_map_path(&npath)?)?;
    assert_eq!(fs::read(&again)?, fs::read(&npath)?);
    // A normal map is not a depth map.
    assert_names(
        &dense::read_depth_map_path(&npath).unwrap_err(),
        &npath,
        "1 channel",
    );
    // Truncation, garbled header, NaN.
    let bytes = fs::read(&dpath)?; // header "6&4&1&" = 6 bytes
    let bad = dir.path().join("bad.bin");
    fs::write(&bad, &bytes[..bytes.len() - 2])?;
    assert_names(
        &dense::read_dense_map_path(&bad).unwrap_err(),
        &bad,
        &format!("byte {}", bytes.len() - 2),
    );
    fs::write(&bad, b"6&4#1&")?;
    assert_names(
        &dense::read_dense_map_path(&bad).unwrap_err(),
        &bad,
        "byte 3",
    );
    let mut nan = bytes.clone();
    nan[6 + 4 * 5..6 + 4 * 6].copy_from_slice(&f32::NAN.to_le_bytes());
    fs::write(&bad, &nan)?;
    assert_names(
        &dense::read_dense_map_path(&bad).unwrap_err(),
        &bad,
        "byte 26",
    );
    Ok(())
}

#[test]
fn label_pngs() -> Result<(), Box<dyn std::error::Error>> {
    let dir = tempfile::tempdir()?;
    let path = dir.path().join("labels.png");
    let labels: Vec<u16> = (0..6 * 4).map(|i| (i * 2731) as u16).collect();
    labelpng::write_label_png(&path, 6, 4, &labels)?;
    assert_eq!(labelpng::read_label_png(&path)?, (6, 4, labels.clone()));
    let colors = labelpng::label_colors(&labels, 6, 4);
    assert_eq!(colors.get_pixel(0, 0).0, [0, 0, 0]);
    assert_eq!(colors.get_pixel(1, 0).0, labelpng::label_color(2731));
    let bad = dir.path().join("bad.png");
    fs::write(&bad, &fs::read(&path)?[..40])?;
    assert_names(&labelpng::read_label_png(&bad).unwrap_err(), &bad, "PNG");
    Ok(())
}

#[test]
fn ply_files() -> Result<(), Box<dyn std::error::Error>> {
    let dir = tempfile::tempdir()?;
    let points = ply::PlyPoints {
        positions: (0..50)
            .map(|i| Vector3::new(i as f64 * 0.5, -(i as f64), 0.25 * i as f64))
            .collect(),
        normals: Some(vec![Vector3::new(0.0, 1.0, 0.0); 50]),
        colors: Some((0..50).map(|i| [i as u8, 255 - i as u8, 3]).collect()),
    };
    let path = dir.path().join("fused.ply");
    ply::write_ply_points_path(&path, &points)?;
    assert_eq!(ply::read_ply_points_path(&path)?, points);
    let mesh = ply::PlyMesh {
        vertices: vec![
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(1.0, 0.0, 0.0),
            Vector3::new(0.0, 1.0, 0.0),
        ],
        faces: vec![[0, 1, 2]],
        vertex_colors: None,
    };
    let mpath = dir.path().join("mesh.ply");
    ply::write_ply_mesh_path(&mpath, &mesh)?;
    assert_eq!(ply::read_ply_mesh_path(&mpath)?, mesh);
    // `PLANEMAP_KEEP_PLY=dir` keeps copies for tools/check_ply.py (a real PLY client).
    if let Some(keep) = std::env::var_os("PLANEMAP_KEEP_PLY") {
        let keep = Path::new(&keep);
        fs::create_dir_all(keep)?;
        fs::copy(&path, keep.join("fused.ply"))?;
        fs::copy(&mpath, keep.join("mesh.ply"))?;
        let mut plain = points.clone();
        plain.normals = None;
        plain.colors = None;
        ply::write_ply_points_path(&keep.join("plain.ply"), &plain)?;
    }

    let bad = dir.path().join("bad.ply");
    let bytes = fs::read(&path)?;
    fs::write(&bad, &bytes[..bytes.len() - 10])?;
    let header = bytes.len() - 50 * 27;
    assert_names(
        &ply::read_ply_points_path(&bad).unwrap_err(),
        &bad,
        &format!("byte {}", header + 49 * 27 + 16),
    );
    fs::write(&bad, b"ply\nformat binary_middle_endian 1.0\nend_header\n")?;
    assert_names(
        &ply::read_ply_points_path(&bad).unwrap_err(),
        &bad,
        "line 2",
    );
    fs::write(
        &bad,
        b"ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nend_header\n1 2 3\nnan 0 0\n",
    )?;
    assert_names(
        &ply::read_ply_points_path(&bad).unwrap_err(),
        &bad,
        "line 9",
    );
    Ok(())
}

fn synthetic_scene() -> Scene {
    let target = Vector3::new(0.0, 0.0, 0.0);
    let up = Vector3::new(0.0, 0.0, 1.0);
    let views: Vec<View> = [
        (
            Vector3::new(4.0, 0.5, 1.0),
            Camera::pinhole(64, 48, 60.0, 61.5, 32.25, 23.75),
        ),
        (
            Vector3::new(0.3, 4.0, 1.5),
            Camera::pinhole(64, 48, 58.0, 58.0, 31.0, 24.5),
        ),
        (
            Vector3::new(-3.0, -2.5, 2.0),
            Camera::pinhole(80, 40, 70.0, 69.0, 40.5, 19.0),
        ),
    ]
    .into_iter()
    .enumerate()
    .map(|(i, (eye, camera))| View {
        id: i as u32,
        name: format!("{i:08}.png"),
        camera,
        cam_from_world: look_at(&eye, &target, &up),
        image_path: None,
    })
    .collect();
    let positions: Vec<Vector3<f64>> = (0..20)
        .map(|i| {
            let t = i as f64 * 0.37;
            Vector3::new(t.sin(), t.cos() * 0.7, (t * 1.3).sin() * 0.4)
        })
        .collect();
    let normals = positions.iter().map(|p| p.normalize()).collect();
    let tracks = (0..20u32)
        .map(|i| match i % 3 {
            0 => vec![0, 1, 2],
            1 => vec![0, 2],
            _ => vec![1],
        })
        .collect();
    Scene {
        views,
        cloud: SparseCloud {
            colors: vec![pmvs::PATCH_COLOR; 20],
            normals: Some(normals),
            tracks,
            errors: vec![0.0; 20],
            confidence: (0..20).map(|i| 0.5 + i as f64 * 0.02).collect(),
            positions,
        },
    }
}

#[test]
fn pmvs_workspace_round_trip() -> Result<(), Box<dyn std::error::Error>> {
    let dir = tempfile::tempdir()?;
    let scene = synthetic_scene();
    pmvs::write_pmvs(dir.path(), &scene)?;
    for (i, v) in scene.views.iter().enumerate() {
        let img = image::GrayImage::new(v.camera.width, v.camera.height);
        img.save(dir.path().join("visualize").join(format!("{i:08}.png")))?;
    }
    let back = pmvs::read_pmvs(dir.path())?;
    assert_eq!(back.views.len(), 3);
    for (a, b) in scene.views.iter().zip(&back.views) {
        assert_eq!(
            (a.camera.width, a.camera.height),
            (b.camera.width, b.camera.height)
        );
        for p in &scene.cloud.positions {
            let (xa, da) = a.project(p).unwrap();
            let (xb, db) = b.project(p).unwrap();
            assert!((xa - xb).norm() < 1e-9, "{xa} vs {xb}");
            assert!((da - db).abs() < 1e-9);
        }
        let c = b.cam_from_world * Point3::from(a.center());
        assert!(c.coords.norm() < 1e-9);
    }
    let (ca, cb) = (&scene.cloud, &back.cloud);
    assert_eq!(ca.tracks, cb.tracks);
    assert_eq!(ca.confidence, cb.confidence);
    assert_eq!(ca.positions, cb.positions);
    for (na, nb) in ca
        .normals
        .as_ref()
        .unwrap()
        .iter()
        .zip(cb.normals.as_ref().unwrap())
    {
        assert!((na - nb).norm() < 1e-15);
    }
    cb.validate(back.views.len())?;
    Ok(())
}

#[test]
fn pmvs_bad_inputs() -> Result<(), Box<dyn std::error::Error>> {
    let dir = tempfile::tempdir()?;
    let scene = synthetic_scene();
    pmvs::write_pmvs(dir.path(), &scene)?;
    for (i, v) in scene.views.iter().enumerate() {
        let img = image::GrayImage::new(v.camera.width, v.camera.height);
        img.save(dir.path().join("visualize").join(format!("{i:08}.png")))?;
    }
    // A patch visible in an image without a camera.
    let patch = dir.path().join("models").join("option-0000.patch");
    let good = fs::read_to_string(&patch)?;
    fs::write(&patch, good.replacen("\n3\n0 1 2 \n", "\n3\n0 1 9 \n", 1))?;
    assert_names(&pmvs::read_pmvs(dir.path()).unwrap_err(), &patch, "line 3");
    // NaN in a position.
    let lines: Vec<&str> = good.lines().collect();
    let mut bad = lines.clone();
    bad[3] = "nan 0 0 1";
    fs::write(&patch, bad.join("\n"))?;
    assert_names(&pmvs::read_pmvs(dir.path()).unwrap_err(), &patch, "line 4");
    fs::write(&patch, &good)?;
    // A garbled camera file.
    let txt = dir.path().join("txt").join("00000001.txt");
    fs::write(&txt, "CONTOUR\n1 0 0 0\n0 1 x 0\n0 0 1 0\n")?;
    assert_names(&pmvs::read_pmvs(dir.path()).unwrap_err(), &txt, "line 3");
    fs::write(&txt, "CONTOUR\n1 0 0 0\n0 1 0 0\n")?;
    assert_names(&pmvs::read_pmvs(dir.path()).unwrap_err(), &txt, "line 3");
    Ok(())
}
