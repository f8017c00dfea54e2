//! Times `maxflow()` alone on a binary exchange-format grid instance, several runs on fresh
//! copies of the built network: `cargo run --release -p planemap-solvers --example mfprof DIR [RUNS]`.
use planemap_solvers::exchange::read_instance;
use planemap_solvers::maxflow::GridMaxFlow;
use planemap_solvers::{Connectivity, MaxFlow};
use std::time::Instant;

fn main() {
    let mut args = std::env::args().skip(1);
    let dir = args.next().expect("instance dir");
    let runs: usize = args.next().map(|s| s.parse().unwrap()).unwrap_or(5);
    let inst = read_instance(std::path::Path::new(&dir)).expect("read");
    assert_eq!(inst.num_labels, 2);
    let (w, h, slots) = inst.detect_grid4().expect("4-connected grid");
    let u: Vec<i32> = inst.unary.iter().map(|&x| x as i32).collect();
    let (v01, v10) = (inst.pairwise[1] as i32, inst.pairwise[2] as i32);
    let mut mf = MaxFlow::<i32, _>::grid(w, h, Connectivity::Four);
    let mut g4 = GridMaxFlow::<i32>::new(w, h);
    for p in 0..inst.num_sites {
        mf.add_tweights(p as u32, u[2 * p + 1], u[2 * p]);
        g4.add_tweights(p as u32, u[2 * p + 1], u[2 * p]);
    }
    for (e, &s) in slots.iter().enumerate() {
        let [p, _] = inst.edges[e];
        let we = inst.edge_weights[e] as i32;
        let (a, dir) = (s / 2, if s % 2 == 0 { 0 } else { 2 });
        let (f, r) = if p as usize == a {
            (we * v01, we * v10)
        } else {
            (we * v10, we * v01)
        };
        mf.set_grid_edge(a as u32, dir, f, r);
        g4.set_grid_edge(a as u32, dir, f, r);
    }
    let which = std::env::var("MF").unwrap_or_default();
    let mut times = Vec::new();
    let mut flow = 0;
    for _ in 0..runs {
        if which == "bk" {
            let mut m = mf.clone();
            let t = Instant::now();
            flow = m.maxflow();
            times.push(t.elapsed().as_secs_f64());
        } else {
            let mut m = g4.clone();
            let t = Instant::now();
            flow = m.maxflow();
            times.push(t.elapsed().as_secs_f64());
        }
    }
    times.sort_by(|a, b| a.partial_cmp(b).unwrap());
    println!(
        "flow {flow} min {:.4} median {:.4}",
        times[0],
        times[times.len() / 2]
    );
}
