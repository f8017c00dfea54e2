//! Criterion benchmarks: BK max-flow on a synthetic segmentation grid (grid layout vs CSR
//! layout), α-expansion on a noisy piecewise-constant labelling grid, and the flat against
//! the coarse-to-fine solve at 640×480.
use criterion::{criterion_group, criterion_main, Criterion};
use planemap_solvers::maxflow::{GraphBuilder, GridMaxFlow, Topology};
use planemap_solvers::{
    CoarseToFine, Connectivity, DataCost, ExpansionConfig, MaxFlow, Mrf, Smoothness,
};

struct Rng(u64);
impl Rng {
    fn below(&mut self, n: u64) -> u64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 33) % n
    }
}

/// Two-tone blocks with noise: terminal capacities from intensities, contrast weights.
fn segmentation(w: usize, h: usize) -> (Vec<(i32, i32)>, Vec<[i32; 2]>) {
    let mut rng = Rng(1);
    let img: Vec<i32> = (0..w * h)
        .map(|p| {
            let (x, y) = (p % w, p / w);
            let fg = ((x / 37) + (y / 23)) % 3 == 0;
            (if fg { 70 } else { 30 }) + rng.below(50) as i32 - 25
        })
        .collect();
    let t = img
        .iter()
        .map(|&v| ((v - 30).abs(), (v - 70).abs()))
        .collect();
    let edges = (0..w * h)
        .map(|p| {
            let wt = |q: usize| 1 + 30 * (((img[p] - img[q]).abs() < 10) as i32);
            [
                if p % w + 1 < w { wt(p + 1) } else { 0 },
                if p + w < w * h { wt(p + w) } else { 0 },
            ]
        })
        .collect();
    (t, edges)
}

fn bench_maxflow(c: &mut Criterion) {
    let (w, h) = (512, 512);
    let (t, e) = segmentation(w, h);
    let mut g = c.benchmark_group("maxflow_512x512");
    g.sample_size(10);
    g.bench_function("grid_layout", |b| {
        b.iter(|| {
            let mut mf = MaxFlow::<i32, _>::grid(w, h, Connectivity::Four);
            for p in 0..w * h {
                mf.add_tweights(p as u32, t[p].1, t[p].0);
                mf.set_grid_edge(p as u32, 0, e[p][0], e[p][0]);
                mf.set_grid_edge(p as u32, 2, e[p][1], e[p][1]);
            }
            mf.maxflow()
        })
    });
    g.bench_function("grid4_specialised", |b| {
        b.iter(|| {
            let mut mf = GridMaxFlow::<i32>::new(w, h);
            for p in 0..w * h {
                mf.add_tweights(p as u32, t[p].1, t[p].0);
                mf.set_grid_edge(p as u32, 0, e[p][0], e[p][0]);
                mf.set_grid_edge(p as u32, 2, e[p][1], e[p][1]);
            }
            mf.maxflow()
        })
    });
    g.bench_function("csr_layout", |b| {
        b.iter(|| {
            let mut gb = GraphBuilder::<i32>::new(w * h);
            for p in 0..w * h {
                gb.add_tweights(p as u32, t[p].1, t[p].0);
                if p % w + 1 < w {
                    gb.add_edge(p as u32, p as u32 + 1, e[p][0], e[p][0]);
                }
                if p + w < w * h {
                    gb.add_edge(p as u32, (p + w) as u32, e[p][1], e[p][1]);
                }
            }
            let mut mf = gb.build();
            mf.maxflow()
        })
    });
    // Dynamic graph cuts: re-solve after a 64×64 local change of terminal capacities.
    g.bench_function("grid_reuse_after_64x64_change", |b| {
        let mut mf = MaxFlow::<i32, _>::grid(w, h, Connectivity::Four);
        for p in 0..w * h {
            mf.add_tweights(p as u32, t[p].1, t[p].0);
            mf.set_grid_edge(p as u32, 0, e[p][0], e[p][0]);
            mf.set_grid_edge(p as u32, 2, e[p][1], e[p][1]);
        }
        mf.maxflow();
        let mut sign = 1;
        b.iter(|| {
            sign = -sign;
            for y in 100..164 {
                for x in 100..164 {
                    mf.add_tweights((y * w + x) as u32, 20 * sign.max(0), 20 * (-sign).max(0));
                }
            }
            mf.maxflow()
        })
    });
    g.finish();
    let _ = MaxFlow::<i32, _>::grid(2, 2, Connectivity::Four)
        .topology()
        .num_arcs();
}

/// Data costs of a noisy labelling of `block`-pixel squares (label `(bx + per_row · by) mod
/// l`), 10 % of the pixels observing a random label; truncated-linear in the label distance.
fn blocks(w: usize, h: usize, l: usize, block: usize, per_row: usize, seed: u64) -> Vec<i32> {
    let mut rng = Rng(seed);
    (0..w * h)
        .flat_map(|p| {
            let truth = ((p % w) / block + per_row * ((p / w) / block)) as i64 % l as i64;
            let obs = if rng.below(10) == 0 {
                rng.below(l as u64) as i64
            } else {
                truth
            };
            (0..l as i64).map(move |k| (10 * (k - obs).abs().min(4)) as i32)
        })
        .collect()
}

fn bench_expansion(c: &mut Criterion) {
    let (w, h, l) = (160, 120, 16);
    let data = blocks(w, h, l, 40, 4, 2);
    let mut g = c.benchmark_group("expansion_160x120_L16");
    g.sample_size(10);
    for (name, smooth) in [("potts", 0), ("truncated_linear", 1)] {
        g.bench_function(name, |b| {
            b.iter(|| {
                let s = if smooth == 0 {
                    Smoothness::Potts(6)
                } else {
                    Smoothness::TruncatedLinear {
                        scale: 3,
                        truncation: 12,
                    }
                };
                let mrf = Mrf::grid(w, h, Connectivity::Four, l, DataCost::Dense(&data))
                    .unwrap()
                    .with_smoothness(s)
                    .unwrap();
                mrf.expansion(&ExpansionConfig::default(), None)
                    .unwrap()
                    .energy
            })
        });
    }
    g.finish();
}

/// Flat α-expansion against the coarse-to-fine solve (one coarser level, band 2, with and
/// without the polishing cycle) on the same 640×480 problem: blocks of 80 pixels, 16
/// labels, 10 % outliers, truncated-linear smoothness.
fn bench_coarse_to_fine(c: &mut Criterion) {
    let (w, h, l) = (640, 480, 16);
    let data = blocks(w, h, l, 80, 3, 3);
    let mrf = || {
        Mrf::grid(w, h, Connectivity::Four, l, DataCost::Dense(&data))
            .unwrap()
            .with_smoothness(Smoothness::TruncatedLinear {
                scale: 3,
                truncation: 12,
            })
            .unwrap()
    };
    let mut g = c.benchmark_group("coarse_to_fine_640x480_L16");
    g.sample_size(10);
    g.bench_function("flat", |b| {
        b.iter(|| {
            mrf()
                .expansion(&ExpansionConfig::default(), None)
                .unwrap()
                .energy
        })
    });
    for polish in [false, true] {
        let name = if polish {
            "one_level_polish"
        } else {
            "one_level"
        };
        let pyramid = CoarseToFine {
            levels: 1,
            band: 2,
            min_sites: 1024,
            polish,
        };
        g.bench_function(name, |b| {
            b.iter(|| {
                mrf()
                    .expansion_coarse_to_fine(&ExpansionConfig::default(), &pyramid, None)
                    .unwrap()
                    .0
                    .energy
            })
        });
    }
    g.finish();
}

criterion_group!(
    benches,
    bench_maxflow,
    bench_expansion,
    bench_coarse_to_fine
);
criterion_main!(benches);
