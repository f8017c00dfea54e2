//! The planar / non-planar classifier end to end: model files (round trip, damaged files) and
//! training + held-out scoring on two small rendered scenes.

use planemap::classify::{
    self, dataset::evaluate_workspace, format, knn::KnnClassifier, Classifier, ClassifyError,
    FeatureSpec, LogisticClassifier, Method, PlanarityModel, Standardizer, TrainConfig,
    FEATURE_DIM,
};
use planemap::progress::Progress;
use planemap::synth::{RenderOptions, SceneSpec};

fn standardizer() -> Standardizer {
    Standardizer {
        mean: (0..FEATURE_DIM).map(|i| i as f32 * 0.25 - 3.0).collect(),
        scale: (0..FEATURE_DIM).map(|i| 1.0 + i as f32 * 0.5).collect(),
    }
}

fn logistic_model() -> PlanarityModel {
    PlanarityModel {
        spec: FeatureSpec::default(),
        standardizer: standardizer(),
        threshold: 0.4,
        classifier: Classifier::Logistic(LogisticClassifier {
            weights: (0..FEATURE_DIM).map(|i| (i as f32).sin()).collect(),
            bias: -0.75,
        }),
    }
}

fn knn_model() -> PlanarityModel {
    let n = 37;
    let samples: Vec<f32> = (0..n * FEATURE_DIM)
        .map(|i| ((i * 7919) % 1000) as f32 / 250.0 - 2.0)
        .collect();
    let labels: Vec<u8> = (0..n).map(|i| (i % 3 == 1) as u8).collect();
    PlanarityModel {
        spec: FeatureSpec {
            cell: 16,
            margin: 2,
            ..Default::default()
        },
        standardizer: standardizer(),
        threshold: 0.5,
        classifier: Classifier::Knn(KnnClassifier::new(5, samples, labels).unwrap()),
    }
}

#[test]
fn model_files_round_trip_byte_for_byte() {
    let dir = tempfile::tempdir().unwrap();
    for model in [logistic_model(), knn_model()] {
        let bytes = format::model_to_bytes(&model);
        let path = dir.path().join("m.bin");
        classify::write_model_path(&path, &model).unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), bytes);
        let back = classify::read_model_path(&path).unwrap();
        assert_eq!(back, model);
        assert_eq!(format::model_to_bytes(&back), bytes);
        let from_stream = format::read_model(bytes.as_slice()).unwrap();
        assert_eq!(from_stream, model);
    }
    // Sizes follow the documented layout: 40-byte header, 2·d floats, then the method data.
    let header = 40 + 2 * 4 * FEATURE_DIM;
    assert_eq!(
        format::model_to_bytes(&logistic_model()).len(),
        header + 4 + 4 * FEATURE_DIM
    );
    assert_eq!(
        format::model_to_bytes(&knn_model()).len(),
        header + 8 + 37 + 37 * 4 * FEATURE_DIM
    );
}

fn format_error(bytes: &[u8]) -> (u64, String) {
    match classify::model_from_bytes(bytes) {
        Err(ClassifyError::Format {
            offset, message, ..
        }) => (offset, message),
        other => panic!("expected a format error, got {other:?}"),
    }
}

#[test]
fn damaged_model_files_name_the_byte_offset() {
    for model in [logistic_model(), knn_model()] {
        let bytes = format::model_to_bytes(&model);
        // Every truncation is an error at or before the cut, saying "truncated".
        for cut in 0..bytes.len() {
            let (offset, message) = format_error(&bytes[..cut]);
            assert!(offset as usize <= cut, "cut {cut}: offset {offset}");
            assert!(message.contains("truncated"), "cut {cut}: {message}");
        }
        // Trailing garbage: reported where the model ends.
        let mut long = bytes.clone();
        long.push(0);
        assert_eq!(format_error(&long).0, bytes.len() as u64);
    }
    let good = format::model_to_bytes(&logistic_model());
    let mut b = good.clone();
    b[0] = b'X';
    assert_eq!(format_error(&b).0, 0);
    let mut b = good.clone();
    b[8] = 99; // version
    let (off, msg) = format_error(&b);
    assert_eq!((off, msg.contains("version 99")), (8, true), "{msg}");
    let mut b = good.clone();
    b[10] = 7; // method
    assert_eq!(format_error(&b).0, 10);
    let mut b = good.clone();
    b[14] = 3; // feature dimension
    assert_eq!(format_error(&b).0, 14);
    let mut b = good.clone();
    b[36..40].copy_from_slice(&f32::NAN.to_le_bytes()); // threshold
    assert_eq!(format_error(&b).0, 36);
    // kNN label out of range: offset of that label.
    let knn = format::model_to_bytes(&knn_model());
    let labels_at = 40 + 2 * 4 * FEATURE_DIM + 8;
    let mut b = knn.clone();
    b[labels_at + 3] = 2;
    assert_eq!(format_error(&b).0, (labels_at + 3) as u64);
    // Files: the error names the file.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("broken.bin");
    std::fs::write(&path, &good[..20]).unwrap();
    let msg = classify::read_model_path(&path).unwrap_err().to_string();
    assert!(
        msg.contains("broken.bin") && msg.contains("byte 20"),
        "{msg}"
    );
}

/// Plain walls and a textured floor with textured spheres and cylinders in front.
fn toy_scene(seed: u64, sphere_x: f64) -> SceneSpec {
    let text = format!(
        r#"
name = "toy"
seed = {seed}
[camera]
width = 128
height = 96
hfov_deg = 70.0
[materials.wall]
texture = "posters"
color = [0.85, 0.83, 0.78]
scale = 0.8
density = 0.5
[materials.floor]
texture = "bricks"
color = [0.6, 0.6, 0.6]
color2 = [0.4, 0.4, 0.4]
brick_size = [0.5, 0.5]
mortar = 0.02
row_offset = 0.0
[materials.leaves]
texture = "noise"
color = [0.25, 0.5, 0.2]
color2 = [0.05, 0.2, 0.05]
scale = 0.1
octaves = 5
[[objects]]
type = "box"
name = "room"
min = [-5.0, -5.0, 0.0]
max = [5.0, 5.0, 3.0]
material = "wall"
face_materials = {{ zmin = "floor" }}
inside = true
[[objects]]
type = "sphere"
name = "bush"
material = "leaves"
center = [{sphere_x}, 2.0, 1.0]
radius = 0.9
[[objects]]
type = "sphere"
name = "bush2"
material = "leaves"
center = [{x2}, -2.0, 0.8]
radius = 0.7
[[objects]]
type = "cylinder"
name = "trunk"
material = "leaves"
base = [2.5, 0.5, 0.0]
height = 2.0
radius = 0.3
[[rigs]]
type = "orbit"
center = [0.0, 0.0, 0.0]
radius = 1.0
height = 1.5
count = 5
look_at = [0.0, 0.0, 1.0]
"#,
        x2 = -sphere_x
    );
    SceneSpec::from_toml_str(&text, "toy").unwrap()
}

#[test]
fn both_classifiers_find_non_planar_regions_on_a_held_out_scene() {
    let dir = tempfile::tempdir().unwrap();
    let train_ws = dir.path().join("train");
    let test_ws = dir.path().join("test");
    let progress = Progress::hidden();
    planemap::workspace::render_to_workspace(
        &toy_scene(1, 1.5),
        &RenderOptions::default(),
        &train_ws,
        &progress,
    )
    .unwrap();
    planemap::workspace::render_to_workspace(
        &toy_scene(2, -1.0),
        &RenderOptions::default(),
        &test_ws,
        &progress,
    )
    .unwrap();
    let spec = FeatureSpec::default();
    let set = classify::workspace_samples(&train_ws, &spec).unwrap();
    assert!(set.nonplanar() > 20 && set.nonplanar() < set.len());
    for method in [Method::Logistic, Method::Knn] {
        let config = TrainConfig {
            method,
            k: 5,
            ..Default::default()
        };
        let model = classify::train(&set, spec, &config).unwrap();
        let scores = evaluate_workspace(&model, &test_ws).unwrap();
        let c = scores.cells;
        assert!(c.true_positive + c.false_negative > 20);
        assert!(
            c.precision() > 0.6 && c.recall() > 0.6,
            "{method:?}: precision {:.2} recall {:.2} ({c:?})",
            c.precision(),
            c.recall()
        );
        // The planarity map of a test view agrees with the cell decisions at cell centres.
        let ws = classify::dataset::Workspace::open(&test_ws).unwrap();
        let image = ws.image(0).unwrap();
        let points = classify::ViewPoints::from_scene(&ws.scene, 0);
        let map = model.planarity_map(&image, Some(&points)).unwrap();
        assert_eq!(map.planar.len(), (image.width * image.height) as usize);
        let features = classify::cell_features(&image, Some(&points), &spec).unwrap();
        let probs = model.cell_probabilities(&features);
        // Pixel (28, 20) (centre 28.5, 20.5) lies between the centres of cells (3..4, 2..3)
        // of the 16-column grid: its value must be within theirs.
        let p_map = 1.0 - map.planar[(20 * image.width + 28) as usize];
        let neighbours = [
            probs[2 * 16 + 3],
            probs[2 * 16 + 4],
            probs[3 * 16 + 3],
            probs[3 * 16 + 4],
        ];
        let lo = neighbours.iter().cloned().fold(f32::INFINITY, f32::min);
        let hi = neighbours.iter().cloned().fold(f32::NEG_INFINITY, f32::max);
        assert!(p_map >= lo - 1e-6 && p_map <= hi + 1e-6);
        // Round trip through the file format keeps the predictions bit-identical.
        let back = classify::model_from_bytes(&format::model_to_bytes(&model)).unwrap();
        assert_eq!(back.cell_probabilities(&features), probs);
    }
}
