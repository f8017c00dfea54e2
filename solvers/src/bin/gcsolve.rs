//! `gcsolve DIR --algo expansion|swap|icm|maxflow [--threads N]`: solves an exchange-format
//! instance (see `planemap_solvers::exchange`) and prints one JSON line
//! `{energy, seconds, cycles, labels_path, ...}`. `seconds` is the solve time after the files
//! are read (problem setup included). Integer-valued instances use `i32` capacities when
//! every term fits, else `i64`; other instances `f64`. A 4-connected grid is detected from
//! the edge list and solved on the grid layout.
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow_free::Result;
use clap::{Parser, ValueEnum};
use planemap_solvers::exchange::{read_instance, Instance};
use planemap_solvers::maxflow::{GraphBuilder, GridMaxFlow};
use planemap_solvers::npy::write_npy_path;
use planemap_solvers::{
    Connectivity, Cost, DataCost, ExpansionConfig, LabelOrder, Mrf, Smoothness,
};

mod anyhow_free {
    pub type Result<T> = std::result::Result<T, Box<dyn std::error::Error>>;
}

#[derive(Clone, Copy, Debug, ValueEnum, PartialEq)]
enum Algo {
    Expansion,
    Swap,
    Icm,
    /// Binary instances only: one max-flow, labels = sink side.
    Maxflow,
}

#[derive(Clone, Copy, Debug, ValueEnum, PartialEq)]
enum Order {
    Fixed,
    Adaptive,
}

#[derive(Parser, Debug)]
#[command(about = "Solve an exchange-format labelling instance (.npy directory)")]
struct Args {
    /// Instance directory (unary.npy, edges.npy, edge_weights.npy, pairwise.npy[, init_labels.npy]).
    dir: PathBuf,
    #[arg(long, value_enum, default_value = "expansion")]
    algo: Algo,
    /// Accepted for interface parity with the peers; the solvers are sequential, so the
    /// result is the same for every N.
    #[arg(long, default_value_t = 1)]
    threads: usize,
    /// Maximum cycles.
    #[arg(long, default_value_t = 100)]
    max_cycles: usize,
    #[arg(long, value_enum, default_value = "fixed")]
    order: Order,
    /// α-expansion warm-start sweeps (each site may take a neighbour's label if that lowers
    /// the energy) before the first cycle; 0 disables.
    #[arg(long, default_value_t = planemap_solvers::mrf::DEFAULT_WARM_SWEEPS)]
    warm_sweeps: usize,
    /// Solve on the general (CSR) layout even if the edges form a grid.
    #[arg(long)]
    no_grid: bool,
    /// Force the capacity type.
    #[arg(long)]
    cost_type: Option<String>,
    /// Where to write the labels (int32 .npy); default `DIR/labels_<algo>.npy`.
    #[arg(long)]
    out: Option<PathBuf>,
}

struct Outcome {
    labels: Vec<u32>,
    energy: f64,
    cycles: usize,
    seconds: f64,
    extra: Vec<(&'static str, serde_json::Value)>,
}

fn convert<T: Cost>(v: &[f64]) -> Vec<T> {
    v.iter().map(|&x| T::from_f64(x)).collect()
}

/// CPU time of the calling thread in seconds (Linux `/proc/thread-self/schedstat`, ns
/// resolution), or `None` elsewhere. On a shared machine it is a steadier measure than the
/// wall time (it excludes time spent waiting for a core).
fn thread_cpu_seconds() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    let ns: f64 = s.split_whitespace().next()?.parse().ok()?;
    Some(ns * 1e-9)
}

fn solve<T: Cost>(inst: &Instance, args: &Args) -> Result<Outcome> {
    let start = Instant::now();
    let cpu_start = thread_cpu_seconds();
    let (n, l) = (inst.num_sites, inst.num_labels);
    let unary: Vec<T> = convert(&inst.unary);
    let pairwise: Vec<T> = convert(&inst.pairwise);
    let grid = if args.no_grid {
        None
    } else {
        inst.detect_grid4()
    };
    let mut extra = vec![("grid", serde_json::Value::Bool(grid.is_some()))];
    if args.algo == Algo::Maxflow {
        if l != 2 {
            return Err(format!("--algo maxflow needs 2 labels, instance has {l}").into());
        }
        // E(x) = Σ D_p(x_p) + Σ w_pq V(x_p, x_q); requires V(0,0) = V(1,1) = 0.
        let (v01, v10) = (pairwise[1], pairwise[2]);
        let build_seconds: f64;
        let maxflow_seconds: f64;
        let (flow, labels): (T::Acc, Vec<u32>) = if let Some((w, h, slots)) = &grid {
            let mut mf = GridMaxFlow::<T>::new(*w, *h);
            for p in 0..n {
                mf.add_tweights(p as u32, unary[2 * p + 1], unary[2 * p]);
            }
            for (e, &s) in slots.iter().enumerate() {
                let [p, q] = inst.edges[e];
                let we = T::from_f64(inst.edge_weights[e]);
                let (a, dir) = (s / 2, if s % 2 == 0 { 0 } else { 2 });
                // The grid arc runs a → neighbour; orient the capacities accordingly.
                let (c_fwd, c_rev) = if p as usize == a {
                    (we * v01, we * v10)
                } else {
                    (we * v10, we * v01)
                };
                debug_assert!(p.min(q) as usize == a);
                mf.set_grid_edge(a as u32, dir, c_fwd, c_rev);
            }
            build_seconds = start.elapsed().as_secs_f64();
            let c0 = thread_cpu_seconds();
            let f = mf.maxflow();
            maxflow_seconds = start.elapsed().as_secs_f64() - build_seconds;
            if let (Some(a), Some(b)) = (c0, thread_cpu_seconds()) {
                extra.push(("maxflow_cpu_seconds", serde_json::json!(b - a)));
            }
            (f, (0..n as u32).map(|p| mf.is_sink(p) as u32).collect())
        } else {
            let mut b = GraphBuilder::<T>::new(n);
            for p in 0..n {
                b.add_tweights(p as u32, unary[2 * p + 1], unary[2 * p]);
            }
            for (e, &[p, q]) in inst.edges.iter().enumerate() {
                let we = T::from_f64(inst.edge_weights[e]);
                b.add_edge(p, q, we * v01, we * v10);
            }
            let mut mf = b.build();
            build_seconds = start.elapsed().as_secs_f64();
            let c0 = thread_cpu_seconds();
            let f = mf.maxflow();
            maxflow_seconds = start.elapsed().as_secs_f64() - build_seconds;
            if let (Some(a), Some(b)) = (c0, thread_cpu_seconds()) {
                extra.push(("maxflow_cpu_seconds", serde_json::json!(b - a)));
            }
            (f, (0..n as u32).map(|p| mf.is_sink(p) as u32).collect())
        };
        let seconds = start.elapsed().as_secs_f64();
        if let (Some(a), Some(b)) = (cpu_start, thread_cpu_seconds()) {
            extra.push(("cpu_seconds", serde_json::json!(b - a)));
        }
        let energy = energy_general::<T>(inst, &unary, &pairwise, &labels)?;
        extra.push(("flow", serde_json::json!(T::acc_to_f64(flow))));
        extra.push(("build_seconds", serde_json::json!(build_seconds)));
        extra.push(("maxflow_seconds", serde_json::json!(maxflow_seconds)));
        return Ok(Outcome {
            labels,
            energy,
            cycles: 1,
            seconds,
            extra,
        });
    }
    let weights_grid: Vec<T>;
    let weights_general: Vec<T>;
    let mrf = if let Some((w, h, slots)) = &grid {
        let mut wg = vec![T::ZERO; 2 * n];
        for (e, &s) in slots.iter().enumerate() {
            wg[s] = T::from_f64(inst.edge_weights[e]);
        }
        weights_grid = wg;
        Mrf::grid(*w, *h, Connectivity::Four, l, DataCost::Dense(&unary))?
            .with_smoothness(Smoothness::Table(&pairwise))?
            .with_edge_weights(&weights_grid)?
            .with_warm_start(args.warm_sweeps)
    } else {
        weights_general = convert(&inst.edge_weights);
        Mrf::general(n, &inst.edges, l, DataCost::Dense(&unary))?
            .with_smoothness(Smoothness::Table(&pairwise))?
            .with_edge_weights(&weights_general)?
            .with_warm_start(args.warm_sweeps)
    };
    let cfg = ExpansionConfig {
        max_cycles: args.max_cycles,
        order: match args.order {
            Order::Fixed => LabelOrder::Fixed,
            Order::Adaptive => LabelOrder::Adaptive,
        },
    };
    let init = inst.initial.as_deref();
    let sol = match args.algo {
        Algo::Expansion => mrf.expansion(&cfg, init)?,
        Algo::Swap => mrf.swap(&cfg, init)?,
        Algo::Icm => mrf.icm(args.max_cycles, init)?,
        Algo::Maxflow => unreachable!(),
    };
    let seconds = start.elapsed().as_secs_f64();
    if let (Some(a), Some(b)) = (cpu_start, thread_cpu_seconds()) {
        extra.push(("cpu_seconds", serde_json::json!(b - a)));
    }
    let per_cycle: Vec<serde_json::Value> = sol
        .cycles
        .iter()
        .map(|c| {
            serde_json::json!({"energy": T::acc_to_f64(c.energy), "seconds": c.seconds,
                "moves_tried": c.moves_tried, "moves_accepted": c.moves_accepted,
                "sites_changed": c.sites_changed})
        })
        .collect();
    extra.push((
        "initial_energy",
        serde_json::json!(T::acc_to_f64(sol.initial_energy)),
    ));
    extra.push(("converged", serde_json::json!(sol.converged)));
    extra.push(("per_cycle", serde_json::Value::Array(per_cycle)));
    // Independent evaluation on the general path.
    let energy = energy_general::<T>(inst, &unary, &pairwise, &sol.labels)?;
    if T::EXACT && energy != T::acc_to_f64(sol.energy) {
        return Err(format!(
            "solver energy {} != evaluated {energy}",
            T::acc_to_f64(sol.energy)
        )
        .into());
    }
    Ok(Outcome {
        labels: sol.labels,
        energy,
        cycles: sol.cycles.len(),
        seconds,
        extra,
    })
}

fn energy_general<T: Cost>(
    inst: &Instance,
    unary: &[T],
    pairwise: &[T],
    labels: &[u32],
) -> Result<f64> {
    let w: Vec<T> = convert(&inst.edge_weights);
    let mrf = Mrf::general(
        inst.num_sites,
        &inst.edges,
        inst.num_labels,
        DataCost::Dense(unary),
    )?
    .with_smoothness(Smoothness::Table(pairwise))?
    .with_edge_weights(&w)?;
    Ok(T::acc_to_f64(mrf.energy(labels)?.total))
}

fn main() -> Result<()> {
    let args = Args::parse();
    let inst = read_instance(&args.dir)?;
    let max_term = inst
        .unary
        .iter()
        .chain(&inst.pairwise)
        .fold(0f64, |m, v| m.max(v.abs()))
        * inst.edge_weights.iter().fold(1f64, |m, v| m.max(v.abs()));
    let ty = args.cost_type.clone().unwrap_or_else(|| {
        // One node collects its data term and up to 8 pair terms twice over.
        if inst.is_integral(2f64.powi(31)) && max_term * 20.0 < 2f64.powi(31) {
            "i32".into()
        } else if inst.is_integral(2f64.powi(52)) {
            "i64".into()
        } else {
            "f64".into()
        }
    });
    let out = match ty.as_str() {
        "i32" => solve::<i32>(&inst, &args)?,
        "i64" => solve::<i64>(&inst, &args)?,
        "f32" => solve::<f32>(&inst, &args)?,
        "f64" => solve::<f64>(&inst, &args)?,
        other => return Err(format!("unknown cost type {other}").into()),
    };
    let algo = format!("{:?}", args.algo).to_lowercase();
    let labels_path = args
        .out
        .clone()
        .unwrap_or_else(|| args.dir.join(format!("labels_{algo}.npy")));
    let lab: Vec<i32> = out.labels.iter().map(|&x| x as i32).collect();
    write_npy_path(Path::new(&labels_path), &[lab.len()], &lab)?;
    let mut obj = serde_json::json!({
        "energy": out.energy,
        "seconds": out.seconds,
        "cycles": out.cycles,
        "labels_path": labels_path,
        "algo": algo,
        "threads": args.threads,
        "cost_type": ty,
    });
    for (k, v) in out.extra {
        obj[k] = v;
    }
    println!("{obj}");
    Ok(())
}
