//! Criterion benchmarks of the stages around the photo term and the solver, at realistic
//! sizes (the timing checks that used to be `#[ignore]`d tests):
//!
//! - `normals`: PCA normals of 100k points (k-d tree, 16 neighbours);
//! - `hypotheses`: mean-shift plane hypotheses from 200k points on 40 parallel planes (flat
//!   and Gaussian kernels), which must stay near-linear;
//! - `energy`: building one view's planemap energy at 640×480 with 30 labels and 20k
//!   points tracked by 3 views (the data term's splatting, the smoothness weights);
//! - `colmap`: binary and text COLMAP models of 200k points with 4 observations each,
//!   written and read back;
//! - `ply`: a million-point binary PLY with normals and colours, written and read back.
//!
//! Run with `cargo bench --bench stages`; each group prints criterion's time per iteration.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use nalgebra::Vector3;
use planemap::axes::DominantAxes;
use planemap::geometry::{look_at, Camera, Plane};
use planemap::hypotheses::{plane_hypotheses, HypothesesConfig, HypothesesInput, Kernel};
use planemap::io::colmap::{
    read_model_bin, read_model_text, write_model_bin, write_model_text, ColmapCamera, ColmapImage,
    ColmapModel, ColmapPoint3D, Point2D, TrackElement,
};
use planemap::io::ply;
use planemap::normals::{estimate_normals_with_scale, NormalsConfig};
use planemap::planemap::{PlanemapConfig, PlanemapEnergy, ViewInputs};
use planemap::{ImageF32, Scene, SparseCloud, View};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::hint::black_box;

fn view(id: u32, cam: &Camera, eye: Vector3<f64>, target: Vector3<f64>) -> View {
    View {
        id,
        name: format!("v{id}"),
        camera: cam.clone(),
        cam_from_world: look_at(&eye, &target, &Vector3::z()),
        image_path: None,
    }
}

fn cloud(positions: Vec<Vector3<f64>>, tracks: Vec<Vec<u32>>, confidence: Vec<f64>) -> SparseCloud {
    let n = positions.len();
    SparseCloud {
        positions,
        colors: vec![[0; 3]; n],
        tracks,
        errors: vec![0.0; n],
        confidence,
        ..Default::default()
    }
}

fn normals(c: &mut Criterion) {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let pts: Vec<Vector3<f64>> = (0..100_000)
        .map(|_| Vector3::new(rng.random(), rng.random(), rng.random::<f64>() * 0.002))
        .collect();
    let cam = Camera::pinhole(640, 480, 500.0, 500.0, 320.0, 240.0);
    let views = vec![view(
        0,
        &cam,
        Vector3::new(0.5, 0.5, 6.0),
        Vector3::new(0.5, 0.5, 0.0),
    )];
    let tracks = vec![vec![0u32]; pts.len()];
    let scene = Scene {
        views,
        cloud: cloud(pts.clone(), tracks, vec![1.0; pts.len()]),
    };
    let mut g = c.benchmark_group("normals");
    g.sample_size(10);
    g.throughput(Throughput::Elements(pts.len() as u64));
    g.bench_function("pca_100k", |b| {
        b.iter(|| {
            let oc = estimate_normals_with_scale(&scene, 0.002, &NormalsConfig::default()).unwrap();
            black_box(oc.normals.len())
        })
    });
    g.finish();
}

fn hypotheses(c: &mut Criterion) {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let n = 200_000;
    let positions: Vec<Vector3<f64>> = (0..n)
        .map(|i| {
            Vector3::new(
                rng.random_range(0.0..10.0),
                rng.random_range(0.0..10.0),
                (i % 40) as f64 * 0.5 + rng.random_range(-0.01..0.01),
            )
        })
        .collect();
    let normals = vec![Vector3::z(); n];
    let confidence = vec![1.0; n];
    let axes = DominantAxes {
        directions: vec![Vector3::z()],
        support: vec![n],
        pairwise_angles_deg: Vec::new(),
        num_manhattan: 1,
        warnings: Vec::new(),
    };
    let input = HypothesesInput {
        positions: &positions,
        normals: &normals,
        confidence: &confidence,
        axes: &axes,
        scale: 0.01,
    };
    let mut g = c.benchmark_group("hypotheses");
    g.sample_size(10);
    g.throughput(Throughput::Elements(n as u64));
    for kernel in [Kernel::Flat, Kernel::Gaussian] {
        let cfg = HypothesesConfig {
            kernel,
            ..Default::default()
        };
        let found = plane_hypotheses(&input, &cfg).unwrap();
        assert_eq!(found.len(), 40, "{kernel:?}: {} planes", found.len());
        g.bench_function(format!("mean_shift_200k_{kernel:?}"), |b| {
            b.iter(|| black_box(plane_hypotheses(&input, &cfg).unwrap().len()))
        });
    }
    g.finish();
}

fn energy(c: &mut Criterion) {
    let cam = Camera::pinhole(640, 480, 520.0, 520.0, 320.0, 240.0);
    let target = Vector3::new(1.2, 1.2, 1.0);
    let views: Vec<View> = [
        Vector3::new(7.0, 5.5, 3.5),
        Vector3::new(5.0, 7.5, 3.0),
        Vector3::new(8.0, 4.0, 4.5),
    ]
    .iter()
    .enumerate()
    .map(|(i, eye)| view(i as u32, &cam, *eye, target))
    .collect();
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let mut positions = Vec::new();
    let mut confidence = Vec::new();
    for i in 0..20_000 {
        let mut p = Vector3::zeros();
        for k in 0..3 {
            if k != i % 3 {
                p[k] = rng.random_range(0.0..4.0);
            }
        }
        positions.push(p);
        confidence.push(rng.random_range(0.3..1.0));
    }
    let tracks = vec![vec![0, 1, 2]; positions.len()];
    let cloud = cloud(positions, tracks, confidence);
    let planes: Vec<Plane> = (0..30)
        .map(|k| Plane::new(Vector3::ith(k % 3, 1.0), (k / 3) as f64 * 0.4))
        .collect();
    let mut image = ImageF32::filled(640, 480, 1, 0.0);
    for (i, v) in image.data.iter_mut().enumerate() {
        *v = ((i % 640) as f32 / 640.0 + (i / 640 / 60) as f32 * 0.1).fract();
    }
    let dirs = [Vector3::x(), Vector3::y(), Vector3::z()];
    let inputs = ViewInputs {
        photo_planes: &[],
        view_index: 0,
        views: &views,
        image: &image,
        cloud: &cloud,
        planes: &planes,
        dominant_directions: &dirs,
        scale: 0.01,
    };
    let config = PlanemapConfig::default();
    let labels: Vec<u32> = (0..30).collect();
    let mut g = c.benchmark_group("energy");
    g.sample_size(10);
    g.throughput(Throughput::Elements(640 * 480 * 30));
    g.bench_function("build_640x480_30_labels", |b| {
        b.iter(|| black_box(PlanemapEnergy::with_labels(&inputs, &labels, &config).unwrap()))
    });
    g.finish();
}

fn colmap_model(n_images: u32, n_points: u64) -> ColmapModel {
    let mut m = ColmapModel {
        cameras: vec![ColmapCamera {
            camera_id: 1,
            camera: Camera::pinhole(1000, 800, 900.0, 900.0, 500.0, 400.0),
        }],
        ..Default::default()
    };
    for i in 0..n_images {
        m.images.push(ColmapImage {
            image_id: i + 1,
            qvec: [1.0, 0.0, 0.0, 0.0],
            tvec: [i as f64 * 0.1, 0.2, 0.3],
            camera_id: 1,
            name: format!("img_{i:04}.jpg"),
            points2d: Vec::new(),
        });
    }
    for p in 0..n_points {
        let mut track = Vec::new();
        for k in 0..4u64 {
            let im = &mut m.images[((p * 7 + k * 13) % n_images as u64) as usize];
            track.push(TrackElement {
                image_id: im.image_id,
                point2d_idx: im.points2d.len() as u32,
            });
            im.points2d.push(Point2D {
                x: p as f64 * 0.001,
                y: 1.0 / (p + 1) as f64,
                point3d_id: Some(p + 1),
            });
        }
        m.points3d.push(ColmapPoint3D {
            point3d_id: p + 1,
            xyz: [p as f64 * 1e-3, (p as f64).sqrt(), 1.0 / (p + 1) as f64],
            rgb: [1, 2, 3],
            error: 0.5,
            track,
        });
    }
    m
}

fn colmap(c: &mut Criterion) {
    let n_points = 200_000;
    let m = colmap_model(50, n_points);
    let dir = tempfile::tempdir().unwrap();
    let (bin, txt) = (dir.path().join("bin"), dir.path().join("txt"));
    std::fs::create_dir_all(&bin).unwrap();
    std::fs::create_dir_all(&txt).unwrap();
    write_model_bin(&bin, &m).unwrap();
    write_model_text(&txt, &m).unwrap();
    assert_eq!(read_model_bin(&bin).unwrap(), m);
    assert_eq!(read_model_text(&txt).unwrap(), m);
    let mut g = c.benchmark_group("colmap");
    g.sample_size(10);
    g.throughput(Throughput::Elements(n_points));
    g.bench_function("write_bin_200k", |b| {
        b.iter(|| write_model_bin(&bin, &m).unwrap())
    });
    g.bench_function("read_bin_200k", |b| {
        b.iter(|| black_box(read_model_bin(&bin).unwrap()))
    });
    g.bench_function("write_text_200k", |b| {
        b.iter(|| write_model_text(&txt, &m).unwrap())
    });
    g.bench_function("read_text_200k", |b| {
        b.iter(|| black_box(read_model_text(&txt).unwrap()))
    });
    g.finish();
}

fn ply_io(c: &mut Criterion) {
    let n = 1_000_000;
    let points = ply::PlyPoints {
        positions: (0..n)
            .map(|i| Vector3::new(i as f64 * 0.5, (i % 977) as f64, 0.25))
            .collect(),
        normals: Some(vec![Vector3::new(0.0, 0.0, 1.0); n]),
        colors: Some(vec![[10, 20, 30]; n]),
    };
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("big.ply");
    ply::write_ply_points_path(&path, &points).unwrap();
    assert_eq!(ply::read_ply_points_path(&path).unwrap(), points);
    let mut g = c.benchmark_group("ply");
    g.sample_size(10);
    g.throughput(Throughput::Elements(n as u64));
    g.bench_function("write_1m_points", |b| {
        b.iter(|| ply::write_ply_points_path(&path, &points).unwrap())
    });
    g.bench_function("read_1m_points", |b| {
        b.iter(|| black_box(ply::read_ply_points_path(&path).unwrap()))
    });
    g.finish();
}

criterion_group!(benches, normals, hypotheses, energy, colmap, ply_io);
criterion_main!(benches);
