#!/usr/bin/env python3
"""Side-by-side benchmark of planemap-solvers' `gcsolve` against GCO (PyPI `gco-wrapper`
and `bkgco`) and BK max-flow (PyPI `PyMaxflow`) on the very same exchange-format instances.

    python3 solvers/bench/peers.py [--repeats 3] [--only NAME ...] [--no-build]

On first use it creates solvers/bench/.venv and installs numpy, gco-wrapper, bkgco and
PyMaxflow there, builds `gcsolve` in release mode, and generates the seeded instances into
solvers/bench/instances/ (gen_instances.py). Every solver runs in its own fresh process;
runs are interleaved (ours, gco-wrapper, bkgco, ... per repeat) so machine load hits all
alike; the table reports medians over the repeats. Energies are re-evaluated here with numpy
from each solver's labels. Times are the solve call only (files already in memory): for GCO
the `expansion()` call, for PyMaxflow the `maxflow()` call, for gcsolve its own `seconds`
(problem setup + solve; for max-flow also the graph build, reported separately). Beside the
wall times the table gives each solver's thread CPU time (Python `time.thread_time()`,
gcsolve `/proc/thread-self/schedstat`) and its ratio: on a shared, loaded machine wall times
include waiting for a core, CPU times do not.
Results are also written to solvers/bench/results/peers.json.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
VENV = os.path.join(HERE, ".venv")
VPY = os.path.join(VENV, "bin", "python")
PEER_PACKAGES = ["numpy", "gco-wrapper", "bkgco", "PyMaxflow"]


def ensure_venv():
    if os.path.realpath(sys.prefix) == os.path.realpath(VENV):
        return
    if not os.path.exists(VPY):
        print(f"creating {VENV} and installing {' '.join(PEER_PACKAGES)}", file=sys.stderr)
        subprocess.check_call([sys.executable, "-m", "venv", VENV])
        subprocess.check_call([VPY, "-m", "pip", "install", "-q"] + PEER_PACKAGES)
    os.execv(VPY, [VPY, os.path.abspath(__file__)] + sys.argv[1:])


def load(d):
    import numpy as np

    u = np.load(os.path.join(d, "unary.npy"))
    e = np.load(os.path.join(d, "edges.npy"))
    w = np.load(os.path.join(d, "edge_weights.npy"))
    pw = np.load(os.path.join(d, "pairwise.npy"))
    ip = os.path.join(d, "init_labels.npy")
    init = np.load(ip) if os.path.exists(ip) else np.zeros(u.shape[0], dtype=np.int32)
    return u, e, w, pw, init


def energy(d, labels):
    import numpy as np

    u, e, w, pw, _ = load(d)
    labels = labels.astype(np.int64)
    data = u[np.arange(u.shape[0]), labels].astype(np.int64).sum()
    smooth = (w.astype(np.int64) * pw[labels[e[:, 0]], labels[e[:, 1]]].astype(np.int64)).sum()
    return int(data + smooth)


# ---------------------------------------------------------------- workers (own process)
def worker_gco_wrapper(d):
    import numpy as np
    from gco import pygco

    u, e, w, pw, init = load(d)
    n, L = u.shape
    gc = pygco.GCO()
    gc.create_general_graph(n, L, False)
    gc.set_data_cost(u.astype(np.intc))
    gc.set_all_neighbors(e[:, 0], e[:, 1], w.astype(np.intc))
    gc.set_smooth_cost(pw.astype(np.intc))
    for i in range(n):
        gc.init_label_at_site(i, int(init[i]))
    t, c = time.perf_counter(), time.thread_time()
    gc.expansion(-1)
    dt, dc = time.perf_counter() - t, time.thread_time() - c
    labels = gc.get_labels()
    gc.destroy_graph()
    return {"seconds": dt, "cpu_seconds": dc, "energy": energy(d, labels)}


def worker_bkgco(d):
    import numpy as np
    import bkgco

    u, e, w, pw, init = load(d)
    n, L = u.shape
    g = bkgco.GCO(n, L, dtype=np.int32)
    g.set_data_cost(u).set_smooth_cost(pw).set_neighbors(e, w).set_labeling(init)
    t, c = time.perf_counter(), time.thread_time()
    g.expansion()
    dt, dc = time.perf_counter() - t, time.thread_time() - c
    labels = g.get_labeling()
    g.close()
    return {"seconds": dt, "cpu_seconds": dc, "energy": energy(d, labels)}


def worker_pymaxflow(d):
    import numpy as np
    import maxflow

    u, e, w, pw, _ = load(d)
    n = u.shape[0]
    width = int((e[:, 1] - e[:, 0]).max())
    h = n // width
    t0 = time.perf_counter()
    g = maxflow.Graph[int](n, 2 * n)
    nodes = g.add_grid_nodes((h, width))
    right = np.zeros((h, width), dtype=np.int64)
    down = np.zeros((h, width), dtype=np.int64)
    dlt = e[:, 1] - e[:, 0]
    r = dlt == 1
    right.ravel()[e[r, 0]] = w[r] * pw[0, 1]
    down.ravel()[e[~r, 0]] = w[~r] * pw[0, 1]
    g.add_grid_edges(nodes, weights=right, structure=np.array([[0, 0, 0], [0, 0, 1], [0, 0, 0]]), symmetric=True)
    g.add_grid_edges(nodes, weights=down, structure=np.array([[0, 0, 0], [0, 0, 0], [0, 1, 0]]), symmetric=True)
    g.add_grid_tedges(nodes, u[:, 1].reshape(h, width), u[:, 0].reshape(h, width))
    t1, c1 = time.perf_counter(), time.thread_time()
    flow = g.maxflow()
    t2, c2 = time.perf_counter(), time.thread_time()
    labels = g.get_grid_segments(nodes).ravel().astype(np.int32)
    return {"seconds": t2 - t1, "cpu_seconds": c2 - c1, "build_seconds": t1 - t0, "flow": float(flow),
            "energy": energy(d, labels)}


WORKERS = {"gco-wrapper": worker_gco_wrapper, "bkgco": worker_bkgco, "pymaxflow": worker_pymaxflow}


def run_worker(name, d):
    out = subprocess.run([VPY, os.path.abspath(__file__), "--worker", name, d], capture_output=True, text=True)
    if out.returncode != 0:
        return {"error": out.stderr.strip().splitlines()[-1] if out.stderr.strip() else "failed"}
    return json.loads(out.stdout.strip().splitlines()[-1])


def run_ours(gcsolve, d, algo):
    import numpy as np

    out = subprocess.run([gcsolve, d, "--algo", algo, "--threads", "1"], capture_output=True, text=True)
    if out.returncode != 0:
        return {"error": out.stderr.strip()}
    r = json.loads(out.stdout)
    r["energy_check"] = energy(d, np.load(r["labels_path"]))
    return r


def med(runs, key):
    vals = [r[key] for r in runs if key in r]
    return statistics.median(vals) if vals else float("nan")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--large-repeats", type=int, default=2,
                    help="repeats for instances with sites x labels >= 10M (GCO takes minutes there)")
    ap.add_argument("--only", nargs="*")
    ap.add_argument("--no-build", action="store_true")
    ap.add_argument("--instances", default=os.path.join(HERE, "instances"))
    ap.add_argument("--gcsolve", help="use this gcsolve binary (implies --no-build)")
    ap.add_argument("--worker", nargs=2, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.worker:
        print(json.dumps(WORKERS[args.worker[0]](args.worker[1])))
        return
    target = os.environ.get("CARGO_TARGET_DIR", os.path.join(REPO, "target"))
    gcsolve = args.gcsolve or os.path.join(target, "release", "gcsolve")
    if not (args.no_build or args.gcsolve):
        subprocess.check_call(["cargo", "build", "--release", "-p", "planemap-solvers", "--bin", "gcsolve"], cwd=REPO)
    sys.path.insert(0, HERE)
    import gen_instances

    names = args.only or list(gen_instances.INSTANCES)
    for name in names:
        if not os.path.exists(os.path.join(args.instances, name, "init_labels.npy")):
            gen_instances.INSTANCES[name](args.instances)
    load_avg = os.getloadavg()
    results = {}
    for name in names:
        d = os.path.join(args.instances, name)
        binary = name.startswith("seg")
        peers = ["pymaxflow"] if binary else ["gco-wrapper", "bkgco"]
        runs = {"ours": []} | {p: [] for p in peers}
        import numpy as np

        shape = np.load(os.path.join(d, "unary.npy"), mmap_mode="r").shape
        repeats = args.large_repeats if shape[0] * shape[1] >= 10_000_000 else args.repeats
        for rep in range(repeats):
            runs["ours"].append(run_ours(gcsolve, d, "maxflow" if binary else "expansion"))
            for p in peers:
                runs[p].append(run_worker(p, d))
            print(f"{name} repeat {rep + 1}/{repeats}: "
                  + ", ".join(f"{k} {v[-1].get('seconds', float('nan')):.3f}s"
                              f" (cpu {v[-1].get('cpu_seconds', float('nan')):.3f}s)" for k, v in runs.items()),
                  file=sys.stderr)
        results[name] = runs
    print(f"\nmedians over {args.repeats} interleaved runs ({args.large_repeats} for sites x labels >= 10M); "
          f"load average at start {load_avg[0]:.1f} (2 cores, shared)")
    print("seconds = wall time; cpu = CPU time of the solving thread (steadier on a shared machine)")
    print(f"{'instance':22} {'solver':12} {'energy':>12} {'dE vs ours':>11} {'seconds':>9} {'ours/peer':>10}"
          f" {'cpu s':>8} {'cpu ratio':>10}")
    for name, runs in results.items():
        ours_t = med(runs["ours"], "seconds")
        ours_e = med(runs["ours"], "energy_check")
        ours_c = med(runs["ours"], "cpu_seconds")
        for solver, rs in runs.items():
            errs = [r["error"] for r in rs if "error" in r]
            if errs:
                print(f"{name:22} {solver:12} ERROR {errs[0]}")
                continue
            e = med(rs, "energy_check" if solver == "ours" else "energy")
            t = med(rs, "seconds")
            c = med(rs, "cpu_seconds")
            de = "" if solver == "ours" else f"{100.0 * (ours_e - e) / max(abs(e), 1):+.3f}%"
            ratio = "" if solver == "ours" else f"{ours_t / t:.3f}"
            cratio = "" if solver == "ours" else f"{ours_c / c:.3f}"
            extra = ""
            if "flow" in rs[0]:
                extra = f" flow={med(rs, 'flow'):.0f}"
                if solver == "ours":
                    extra += (f" (build {med(rs, 'build_seconds'):.3f}s + maxflow {med(rs, 'maxflow_seconds'):.3f}s,"
                              f" maxflow cpu {med(rs, 'maxflow_cpu_seconds'):.3f}s)")
                else:
                    extra += (f"; maxflow-only ratio {med(runs['ours'], 'maxflow_seconds') / t:.3f},"
                              f" cpu {med(runs['ours'], 'maxflow_cpu_seconds') / c:.3f}")
            print(f"{name:22} {solver:12} {e:12.0f} {de:>11} {t:9.3f} {ratio:>10} {c:8.3f} {cratio:>10}{extra}")
    os.makedirs(os.path.join(HERE, "results"), exist_ok=True)
    with open(os.path.join(HERE, "results", "peers.json"), "w") as f:
        json.dump({"load_average": load_avg, "results": results}, f, indent=1)


if __name__ == "__main__":
    ensure_venv()
    main()
