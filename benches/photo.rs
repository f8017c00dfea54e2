//! Criterion benchmarks of the photo-consistency cost volume (issue 5).
//!
//! - `cost_volume`: a 640×480 reference view, 64 fronto-parallel planes, 4 neighbours, 7×7
//!   grey NCC, single-threaded (a rayon pool of 1) and on the default pool. Throughput is in
//!   pixel·plane per second (criterion's "elements").
//! - `ncc_window`: the same with 16 planes and 1 neighbour at 5×5 and 15×15 windows: the
//!   box-sum NCC costs the same whatever the window.
//! - `aggregation`: the same, 15×15 NCC against the sweep baseline's default, 5×5 NCC with
//!   each cost slice guided-filtered at radius 7 (what the edge-aware aggregation costs).
//! - `semi_global`: semi-global aggregation (4 and 8 paths) of the `cost_volume` benchmark's
//!   volume (640×480, 64 planes), single-threaded and on the default pool — to set beside the
//!   cost volume's own time.
//!
//! Images are synthetic value noise; the geometry is a small stereo rig so most warps land
//! inside the neighbour images (as in real sweeps, some do not).

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use nalgebra::Vector3;
use planemap::geometry::{look_at, Camera};
use planemap::photo::{
    fronto_parallel_planes, plane_cost_volume, semi_global, Aggregation, PhotoConfig, SgmConfig,
};
use planemap::{ImageF32, View};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::hint::black_box;

const W: u32 = 640;
const H: u32 = 480;

/// Blocky value noise smoothed by a 3×3 mean: texture at a scale of a few pixels.
fn noise_image(seed: u64) -> ImageF32 {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let coarse: Vec<f32> = (0..(W / 2 + 1) * (H / 2 + 1))
        .map(|_| rng.random())
        .collect();
    let mut img = ImageF32::filled(W, H, 3, 0.0);
    for y in 0..H {
        for x in 0..W {
            let v = coarse[((y / 2) * (W / 2 + 1) + x / 2) as usize];
            img.pixel_mut(x, y)
                .copy_from_slice(&[v, 0.8 * v + 0.1, v * v]);
        }
    }
    img
}

fn rig(n: usize) -> (Vec<View>, Vec<ImageF32>) {
    let cam = Camera::pinhole(W, H, 500.0, 500.0, W as f64 / 2.0, H as f64 / 2.0);
    let target = Vector3::new(0.0, 0.0, 5.0);
    let eyes = [
        Vector3::new(0.0, 0.0, 0.0),
        Vector3::new(0.4, 0.0, 0.0),
        Vector3::new(-0.4, 0.0, 0.0),
        Vector3::new(0.0, 0.3, 0.0),
        Vector3::new(0.0, -0.3, 0.0),
    ];
    let views = eyes[..=n]
        .iter()
        .enumerate()
        .map(|(i, eye)| View {
            id: i as u32,
            name: format!("v{i}"),
            camera: cam.clone(),
            cam_from_world: look_at(eye, &target, &Vector3::new(0.0, -1.0, 0.0)),
            image_path: None,
        })
        .collect();
    let images = (0..=n).map(|i| noise_image(i as u64)).collect();
    (views, images)
}

fn cost_volume(c: &mut Criterion) {
    let (views, images) = rig(4);
    let planes = fronto_parallel_planes(&views[0], 3.0, 10.0, 64).unwrap();
    let nbrs: Vec<(&View, &ImageF32)> = views[1..].iter().zip(&images[1..]).collect();
    let cfg = PhotoConfig::default(); // 7×7 grey NCC, best 2 of the neighbours
    let mut group = c.benchmark_group("cost_volume_640x480_64planes_4nbrs_ncc7x7");
    group.sample_size(10);
    group.throughput(Throughput::Elements((W * H) as u64 * planes.len() as u64));
    let default_threads = rayon::current_num_threads();
    for threads in [1, default_threads] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        group.bench_function(BenchmarkId::new("threads", threads), |b| {
            b.iter(|| {
                pool.install(|| {
                    black_box(
                        plane_cost_volume(&views[0], &images[0], &nbrs, &planes, &cfg).unwrap(),
                    )
                })
            })
        });
    }
    group.finish();
}

/// Single-threaded cost volumes of 16 fronto-parallel planes against 1 neighbour, one
/// benchmark per `(name, config)` of `configs`, in the group `group_name`.
fn single_thread_configs(c: &mut Criterion, group_name: &str, configs: &[(String, PhotoConfig)]) {
    let (views, images) = rig(1);
    let planes = fronto_parallel_planes(&views[0], 3.0, 10.0, 16).unwrap();
    let nbrs = [(&views[1], &images[1])];
    let mut group = c.benchmark_group(group_name);
    group.sample_size(10);
    group.throughput(Throughput::Elements((W * H) as u64 * planes.len() as u64));
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    for (name, cfg) in configs {
        group.bench_function(name.as_str(), |b| {
            b.iter(|| {
                pool.install(|| {
                    black_box(
                        plane_cost_volume(&views[0], &images[0], &nbrs, &planes, cfg).unwrap(),
                    )
                })
            })
        });
    }
    group.finish();
}

fn ncc_window(c: &mut Criterion) {
    let configs: Vec<(String, PhotoConfig)> = [2u32, 7]
        .iter()
        .map(|&radius| {
            let side = 2 * radius + 1;
            let cfg = PhotoConfig {
                window_radius: radius,
                ..Default::default()
            };
            (format!("window/{side}x{side}"), cfg)
        })
        .collect();
    single_thread_configs(c, "ncc_window_640x480_16planes_1nbr", &configs);
}

/// The sweep baseline's scoring before and after 2 Dec: 15×15 NCC alone against 5×5 NCC whose
/// cost slices are then guided-filtered over 15×15 (radius 7) with the reference as guide.
fn aggregation(c: &mut Criterion) {
    let configs = [
        (
            "ncc15x15".to_string(),
            PhotoConfig {
                window_radius: 7,
                ..Default::default()
            },
        ),
        (
            "ncc5x5_guided15x15".to_string(),
            PhotoConfig {
                window_radius: 2,
                aggregation: Aggregation::Guided {
                    radius: 7,
                    eps: 1e-3,
                },
                ..Default::default()
            },
        ),
    ];
    single_thread_configs(c, "aggregation_640x480_16planes_1nbr", &configs);
}

/// Box-weighted NCC (O(1) per pixel) against adaptive support weights (O(r²)), 5×5 and 7×7.
fn support_weights(c: &mut Criterion) {
    let configs: Vec<(String, PhotoConfig)> = [2u32, 3]
        .iter()
        .flat_map(|&radius| {
            let side = 2 * radius + 1;
            [0.0f64, 0.15].into_iter().map(move |sigma| {
                let cfg = PhotoConfig {
                    window_radius: radius,
                    support_sigma_color: sigma,
                    ..Default::default()
                };
                let kind = if sigma > 0.0 { "weighted" } else { "box" };
                (format!("{kind}/{side}x{side}"), cfg)
            })
        })
        .collect();
    single_thread_configs(c, "support_weights_640x480_16planes_1nbr", &configs);
}

fn sgm(c: &mut Criterion) {
    let (views, images) = rig(4);
    let planes = fronto_parallel_planes(&views[0], 3.0, 10.0, 64).unwrap();
    let nbrs: Vec<(&View, &ImageF32)> = views[1..].iter().zip(&images[1..]).collect();
    let volume = plane_cost_volume(
        &views[0],
        &images[0],
        &nbrs,
        &planes,
        &PhotoConfig::default(),
    )
    .unwrap();
    let mut group = c.benchmark_group("semi_global_640x480_64planes");
    group.sample_size(10);
    group.throughput(Throughput::Elements((W * H) as u64 * planes.len() as u64));
    let default_threads = rayon::current_num_threads();
    for threads in [1, default_threads] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        for paths in [4usize, 8] {
            let cfg = SgmConfig {
                paths,
                ..Default::default()
            };
            group.bench_function(format!("paths{paths}/threads{threads}"), |b| {
                b.iter(|| {
                    pool.install(|| black_box(semi_global(&volume, &images[0], &cfg).unwrap()))
                })
            });
        }
    }
    group.finish();
}

criterion_group!(
    benches,
    cost_volume,
    ncc_window,
    aggregation,
    support_weights,
    sgm
);
criterion_main!(benches);
