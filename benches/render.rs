//! Renderer throughput: one 640×480 view of the demo scene (2×2 antialiasing + ground
//! truth), single-threaded (rayon pool of 1) and with the default pool. Criterion reports
//! elements/s = pixels/s.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use planemap::synth::{render_views, RenderOptions, RigSpec, SceneSpec, ViewSpec};

fn one_view_demo() -> SceneSpec {
    let mut spec = SceneSpec::from_toml_str(include_str!("../scenes/demo.toml"), "demo.toml")
        .expect("demo parses");
    spec.rigs = vec![RigSpec::List {
        views: vec![ViewSpec {
            position: [0.8, 0.8, 1.5],
            target: [3.3, 2.6, 1.0],
        }],
        up: [0.0, 0.0, 1.0],
    }];
    spec
}

fn bench_render(c: &mut Criterion) {
    let spec = one_view_demo();
    let opts = RenderOptions {
        width: Some(640),
        height: Some(480),
        seed_override: None,
    };
    let mut group = c.benchmark_group("render_640x480");
    group.throughput(Throughput::Elements(640 * 480));
    group.sample_size(10);
    let single = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("pool");
    group.bench_function("threads_1", |b| {
        b.iter(|| single.install(|| render_views(&spec, &opts).expect("renders")))
    });
    group.bench_function("threads_default", |b| {
        b.iter(|| render_views(&spec, &opts).expect("renders"))
    });
    group.finish();
}

criterion_group!(benches, bench_render);
criterion_main!(benches);
