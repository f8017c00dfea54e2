//! The `planemap` binary on malformed or hostile inputs (issue 42): every case must end with
//! a clear error naming the file and what was expected (or a warning from `info`), never a
//! panic, an abort or a silent run that writes garbage.

use std::path::{Path, PathBuf};
use std::process::Output;

mod common;
use common::{clean_failure, planemap, success, synth_tiny_demo};

/// The tiny demo with only the text model in `sparse/` (so edits to it are what is read).
fn text_demo(dir: &Path) -> PathBuf {
    synth_tiny_demo(dir);
    let sparse = dir.join("sparse");
    for stem in ["cameras", "images", "points3D"] {
        std::fs::remove_file(sparse.join(format!("{stem}.bin"))).unwrap();
    }
    sparse
}

fn edit(path: &Path, f: impl FnOnce(String) -> String) {
    let s = std::fs::read_to_string(path).unwrap();
    std::fs::write(path, f(s)).unwrap();
}

/// Applies `f` to the whitespace fields of the first data line (not `#`) of a text file.
fn edit_first_record(path: &Path, f: impl FnOnce(&mut Vec<String>)) {
    edit(path, |s| {
        let mut done = false;
        let mut f = Some(f);
        let lines: Vec<String> = s
            .lines()
            .map(|l| {
                if done || l.starts_with('#') || l.trim().is_empty() {
                    return l.to_string();
                }
                done = true;
                let mut fields: Vec<String> = l.split_whitespace().map(str::to_string).collect();
                (f.take().unwrap())(&mut fields);
                fields.join(" ")
            })
            .collect();
        lines.join("\n") + "\n"
    });
}

fn info(sparse: &Path, images: &Path) -> Output {
    planemap()
        .arg("info")
        .arg(sparse)
        .arg("--images")
        .arg(images)
        .output()
        .unwrap()
}

fn run_view0(dir: &Path, out: &Path) -> Output {
    planemap()
        .args(["-q", "run", "--views", "0", "--model"])
        .arg(dir.join("sparse"))
        .arg("--images")
        .arg(dir.join("images"))
        .arg("-o")
        .arg(out)
        .output()
        .unwrap()
}

// --- 6. quaternions --------------------------------------------------------------------

#[test]
fn scaled_or_zero_quaternion_is_an_error_naming_file_image_and_line() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("demo");
    let sparse = text_demo(&dir);
    let images_txt = sparse.join("images.txt");
    let original = std::fs::read_to_string(&images_txt).unwrap();
    // The first image record is on line 5, after COLMAP's four comment lines.
    assert_eq!(original.lines().nth(4).unwrap().split(' ').count(), 10);
    for scale in [2.0, 0.0] {
        std::fs::write(&images_txt, &original).unwrap();
        edit_first_record(&images_txt, |f| {
            for q in &mut f[1..5] {
                *q = format!("{:?}", q.parse::<f64>().unwrap() * scale);
            }
        });
        let err = clean_failure(&info(&sparse, &dir.join("images")));
        assert!(
            err.contains("images.txt: line 5: image 1 (view_0000.png): quaternion")
                && err.contains("expected a unit quaternion"),
            "{err}"
        );
        let err = clean_failure(&run_view0(&dir, &tmp.path().join("out")));
        assert!(err.contains("images.txt: line 5: image 1"), "{err}");
    }
}

#[test]
fn near_unit_quaternion_is_renormalised_with_a_warning() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("demo");
    let sparse = text_demo(&dir);
    edit_first_record(&sparse.join("images.txt"), |f| {
        for q in &mut f[1..5] {
            *q = format!("{:?}", q.parse::<f64>().unwrap() * 1.0004);
        }
    });
    let stdout = success(&info(&sparse, &dir.join("images")));
    assert!(
        stdout.contains("1 image(s) have a rotation quaternion that is not unit length")
            && stdout.contains("image 1 (view_0000.png)")
            && stdout.contains("renormalised"),
        "{stdout}"
    );
}

// --- 7. synth sizes --------------------------------------------------------------------

#[test]
fn synth_with_a_huge_width_is_an_error_not_an_abort() {
    let tmp = tempfile::tempdir().unwrap();
    let out = planemap()
        .args(["-q", "synth", "scenes/demo.toml", "--width", "100000", "-o"])
        .arg(tmp.path().join("out"))
        .output()
        .unwrap();
    let err = clean_failure(&out);
    assert!(
        err.contains("requested width 100000") && err.contains("limit of 16384"),
        "{err}"
    );
}

#[test]
fn synth_with_a_billion_cameras_is_an_error_not_an_abort() {
    let tmp = tempfile::tempdir().unwrap();
    let scene = tmp.path().join("many.toml");
    let text = std::fs::read_to_string("scenes/demo.toml").unwrap();
    std::fs::write(&scene, text.replacen("count = 7", "count = 1000000000", 1)).unwrap();
    let out = planemap()
        .args(["-q", "synth"])
        .arg(&scene)
        .arg("-o")
        .arg(tmp.path().join("out"))
        .output()
        .unwrap();
    let err = clean_failure(&out);
    assert!(
        err.contains("many.toml")
            && err.contains("rigs[0]")
            && err.contains("1000000000 views")
            && err.contains("limit of 10000"),
        "{err}"
    );
}

// --- 8. images: size from the header before decoding; format from the content (11) -----

/// A PNG declaring `w`x`h` RGB whose pixel data is a few bytes of an unfinished zlib
/// stream: what a small file claiming a huge image looks like up to the first IDAT chunk.
fn png_header_only(w: u32, h: u32) -> Vec<u8> {
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut chunk = |kind: &[u8], data: &[u8]| {
        png.extend_from_slice(&(data.len() as u32).to_be_bytes());
        let body = [kind, data].concat();
        png.extend_from_slice(&body);
        png.extend_from_slice(&crc32fast::hash(&body).to_be_bytes());
    };
    let mut ihdr = w.to_be_bytes().to_vec();
    ihdr.extend_from_slice(&h.to_be_bytes());
    ihdr.extend_from_slice(&[8, 2, 0, 0, 0]);
    chunk(b"IHDR", &ihdr);
    chunk(b"IDAT", &[0x78, 0x9c, 0xed, 0xc1, 0x01, 0x0d]);
    chunk(b"IEND", &[]);
    png
}

#[test]
fn oversized_image_is_rejected_from_its_header() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("demo");
    synth_tiny_demo(&dir);
    let image = dir.join("images").join("view_0000.png");
    std::fs::write(&image, png_header_only(20_000, 12_000)).unwrap();
    let err = clean_failure(&run_view0(&dir, &tmp.path().join("out")));
    assert!(
        err.contains("view_0000.png: image is 20000x12000 but its camera says 96x72"),
        "{err}"
    );
}

#[test]
fn jpeg_named_png_is_read_by_its_content() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("demo");
    synth_tiny_demo(&dir);
    for entry in std::fs::read_dir(dir.join("images")).unwrap() {
        let path = entry.unwrap().path();
        let img = image::open(&path).unwrap();
        img.save_with_format(&path, image::ImageFormat::Jpeg)
            .unwrap();
        assert_eq!(&std::fs::read(&path).unwrap()[..2], &[0xFF, 0xD8]);
    }
    let out_dir = tmp.path().join("out");
    success(&run_view0(&dir, &out_dir));
    assert!(out_dir.join("planes.json").is_file());
}

// --- 11. reader details ------------------------------------------------------------------

#[test]
fn unknown_binary_model_id_is_named_once() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("demo");
    synth_tiny_demo(&dir);
    let cameras = dir.join("sparse").join("cameras.bin");
    let mut b = std::fs::read(&cameras).unwrap();
    // num_cameras (8 bytes), camera_id (4), then model_id.
    b[12..16].copy_from_slice(&99i32.to_le_bytes());
    std::fs::write(&cameras, b).unwrap();
    let err = clean_failure(
        &planemap()
            .arg("info")
            .arg(dir.join("sparse"))
            .output()
            .unwrap(),
    );
    assert!(
        err.contains("cameras.bin: byte offset 8: unknown camera model id 99 (expected 0–4: 0 SIMPLE_PINHOLE, 1 PINHOLE"),
        "{err}"
    );
    assert!(!err.contains("model model"), "{err}");
}

#[test]
fn text_model_with_a_byte_order_mark_is_read() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("demo");
    let sparse = text_demo(&dir);
    for stem in ["cameras", "images", "points3D"] {
        edit(&sparse.join(format!("{stem}.txt")), |s| {
            format!("\u{FEFF}{s}")
        });
    }
    let stdout = success(&info(&sparse, &dir.join("images")));
    assert!(stdout.contains("warnings: none"), "{stdout}");
}

#[test]
fn empty_model_is_warned_about() {
    let tmp = tempfile::tempdir().unwrap();
    for stem in ["cameras", "images", "points3D"] {
        std::fs::write(tmp.path().join(format!("{stem}.txt")), "# empty\n").unwrap();
    }
    let out = planemap().arg("info").arg(tmp.path()).output().unwrap();
    let stdout = success(&out);
    assert!(!stdout.contains("warnings: none"), "{stdout}");
    assert!(
        stdout.contains("the model has no images") && stdout.contains("the model has no 3D points"),
        "{stdout}"
    );
}

#[test]
fn absurd_principal_point_is_warned_about_and_refused_by_run() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("demo");
    let sparse = text_demo(&dir);
    edit_first_record(&sparse.join("cameras.txt"), |f| {
        // CAMERA_ID MODEL WIDTH HEIGHT then f cx cy (SIMPLE_*) or fx fy cx cy.
        let cx = if f[1].starts_with("SIMPLE") || f[1] == "RADIAL" {
            5
        } else {
            6
        };
        f[cx] = "1e300".into();
    });
    let stdout = success(&info(&sparse, &dir.join("images")));
    assert!(
        stdout.contains("camera 1 cannot be used for reconstruction: principal point (1e300,"),
        "{stdout}"
    );
    let err = clean_failure(&run_view0(&dir, &tmp.path().join("out")));
    assert!(
        err.contains("camera 1 (used by image 1, view_0000.png): principal point (1e300,"),
        "{err}"
    );
}

#[test]
fn non_positive_focal_length_is_refused_by_name() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("demo");
    let sparse = text_demo(&dir);
    edit_first_record(&sparse.join("cameras.txt"), |f| f[4] = "-250".into());
    let err = clean_failure(&info(&sparse, &dir.join("images")));
    assert!(
        err.contains("cameras.txt: line 4: camera 1: camera parameter 0")
            && err.contains("is -250.0, expected a positive, finite focal length"),
        "{err}"
    );
}
