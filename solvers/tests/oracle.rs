//! Max-flow against petgraph's Dinic max-flow (an exact, independent oracle) on random
//! general graphs (proptest) and small grids; cut validity checked from the original
//! capacities.
use petgraph::algo::dinics;
use petgraph::graph::{DiGraph, NodeIndex};
use planemap_solvers::maxflow::{Connectivity, GraphBuilder, GridMaxFlow, MaxFlow, Topology};
use proptest::prelude::*;

/// A network with non-negative terminal capacities (s→i, i→t) and directed edge pairs.
#[derive(Clone, Debug)]
struct Net {
    n: usize,
    s: Vec<i64>,
    t: Vec<i64>,
    edges: Vec<(u32, u32, i64, i64)>,
}

impl Net {
    fn oracle(&self) -> i64 {
        let mut g = DiGraph::<(), u64>::new();
        let nodes: Vec<NodeIndex> = (0..self.n + 2).map(|_| g.add_node(())).collect();
        let (src, snk) = (nodes[self.n], nodes[self.n + 1]);
        for (i, &node) in nodes.iter().enumerate().take(self.n) {
            if self.s[i] > 0 {
                g.add_edge(src, node, self.s[i] as u64);
            }
            if self.t[i] > 0 {
                g.add_edge(node, snk, self.t[i] as u64);
            }
        }
        for &(p, q, c, r) in &self.edges {
            if c > 0 {
                g.add_edge(nodes[p as usize], nodes[q as usize], c as u64);
            }
            if r > 0 {
                g.add_edge(nodes[q as usize], nodes[p as usize], r as u64);
            }
        }
        dinics(&g, src, snk).0 as i64
    }
    fn cut(&self, sink: &dyn Fn(usize) -> bool) -> i64 {
        let mut c = 0;
        for i in 0..self.n {
            c += if sink(i) { self.s[i] } else { self.t[i] };
        }
        for &(p, q, a, b) in &self.edges {
            let (sp, sq) = (sink(p as usize), sink(q as usize));
            if !sp && sq {
                c += a;
            }
            if sp && !sq {
                c += b;
            }
        }
        c
    }
}

fn net_strategy() -> impl Strategy<Value = Net> {
    (2usize..14).prop_flat_map(|n| {
        (
            prop::collection::vec(0i64..20, n),
            prop::collection::vec(0i64..20, n),
            prop::collection::vec((0..n as u32, 0..n as u32, 0i64..15, 0i64..15), 0..4 * n),
        )
            .prop_map(move |(s, t, edges)| Net {
                n,
                s,
                t,
                edges: edges.into_iter().filter(|e| e.0 != e.1).collect(),
            })
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]

    #[test]
    fn bk_flow_and_cut_match_dinic(net in net_strategy()) {
        let mut b = GraphBuilder::<i32>::new(net.n);
        for i in 0..net.n {
            b.add_tweights(i as u32, net.s[i] as i32, net.t[i] as i32);
        }
        for &(p, q, c, r) in &net.edges {
            b.add_edge(p, q, c as i32, r as i32);
        }
        let mut mf = b.build();
        let flow = mf.maxflow();
        let want = net.oracle();
        prop_assert_eq!(flow, want);
        prop_assert_eq!(net.cut(&|i| mf.is_sink(i as u32)), want);
    }

    #[test]
    fn float_capacities_agree_within_tolerance(net in net_strategy()) {
        let mut b = GraphBuilder::<f32>::new(net.n);
        for i in 0..net.n {
            b.add_tweights(i as u32, net.s[i] as f32 * 0.1, net.t[i] as f32 * 0.1);
        }
        for &(p, q, c, r) in &net.edges {
            b.add_edge(p, q, c as f32 * 0.1, r as f32 * 0.1);
        }
        let mut mf = b.build();
        let flow = mf.maxflow();
        let want = net.oracle() as f64 * 0.1;
        prop_assert!((flow - want).abs() <= 1e-3 * (1.0 + want), "{} vs {}", flow, want);
    }
}

#[test]
fn grids_match_dinic() {
    let mut seed = 99u64;
    let mut rnd = |m: i64| {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((seed >> 33) % m as u64) as i64
    };
    for (w, h, conn) in [
        (8, 8, Connectivity::Four),
        (16, 12, Connectivity::Four),
        (9, 7, Connectivity::Eight),
        (32, 32, Connectivity::Four),
    ] {
        for _ in 0..5 {
            let n = w * h;
            let mut mf = MaxFlow::<i64, _>::grid(w, h, conn);
            let mut net = Net {
                n,
                s: vec![0; n],
                t: vec![0; n],
                edges: vec![],
            };
            for p in 0..n {
                let (s, t) = (rnd(30), rnd(30));
                net.s[p] = s;
                net.t[p] = t;
                mf.add_tweights(p as u32, s, t);
                for d in (0..conn.directions()).step_by(2) {
                    let (c, r) = (rnd(12), rnd(12));
                    if mf.set_grid_edge(p as u32, d, c, r) {
                        let q = mf.topology().head(mf.topology().arc(p as u32, d).unwrap());
                        net.edges.push((p as u32, q, c, r));
                    }
                }
            }
            let flow = mf.maxflow();
            let want = net.oracle();
            assert_eq!(flow, want, "{w}x{h}");
            assert_eq!(net.cut(&|i| mf.is_sink(i as u32)), want);
        }
    }
}

/// A random `w × h` 4-connected grid network for [`GridMaxFlow`]: terminal and edge
/// capacities with many zeros (free nodes, blocked arcs), as a `Net` for the oracle.
fn grid_net_strategy() -> impl Strategy<Value = (usize, usize, Net)> {
    (1usize..11, 1usize..9).prop_flat_map(|(w, h)| {
        let n = w * h;
        (
            prop::collection::vec(0i64..25, n),
            prop::collection::vec(0i64..25, n),
            prop::collection::vec((0i64..16, 0i64..16), 2 * n),
        )
            .prop_map(move |(s, t, caps)| {
                // Zero a third of everything: values below 8 become 0.
                let z = |v: i64| if v < 8 { 0 } else { v - 7 };
                let mut edges = Vec::new();
                for p in 0..n {
                    let (x, y) = (p % w, p / w);
                    if x + 1 < w {
                        edges.push((p as u32, p as u32 + 1, z(caps[2 * p].0), z(caps[2 * p].1)));
                    }
                    if y + 1 < h {
                        let (c, r) = caps[2 * p + 1];
                        edges.push((p as u32, (p + w) as u32, z(c), z(r)));
                    }
                }
                let net = Net {
                    n,
                    s: s.into_iter().map(z).collect(),
                    t: t.into_iter().map(z).collect(),
                    edges,
                };
                (w, h, net)
            })
    })
}

fn grid4_from(w: usize, h: usize, net: &Net) -> GridMaxFlow<i32> {
    let mut g = GridMaxFlow::<i32>::new(w, h);
    for i in 0..net.n {
        g.add_tweights(i as u32, net.s[i] as i32, net.t[i] as i32);
    }
    for &(p, q, c, r) in &net.edges {
        let dir = if q as usize == p as usize + w { 2 } else { 0 };
        assert!(g.set_grid_edge(p, dir, c as i32, r as i32));
    }
    g
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(500))]

    #[test]
    fn grid4_flow_and_cut_match_dinic((w, h, net) in grid_net_strategy()) {
        let mut g = grid4_from(w, h, &net);
        let flow = g.maxflow();
        let want = net.oracle();
        prop_assert_eq!(flow, want);
        prop_assert_eq!(net.cut(&|i| g.is_sink(i as u32)), want);
        // A second solve of the solved residual network adds nothing.
        prop_assert_eq!(g.maxflow(), want);
    }

    #[test]
    fn grid4_resolve_after_terminal_changes_matches_dinic(
        (w, h, net) in grid_net_strategy(),
        changes in prop::collection::vec((0usize..80, 0i64..9, 0i64..9), 1..6),
    ) {
        let mut g = grid4_from(w, h, &net);
        g.maxflow();
        let mut net = net;
        for &(i, ds, dt) in &changes {
            let i = i % net.n;
            net.s[i] += ds;
            net.t[i] += dt;
            g.add_tweights(i as u32, ds as i32, dt as i32);
        }
        let flow = g.maxflow();
        let want = net.oracle();
        prop_assert_eq!(flow, want);
        prop_assert_eq!(net.cut(&|i| g.is_sink(i as u32)), want);
    }
}

#[test]
fn grid4_segmentation_grids_match_dinic() {
    // Larger noisy two-region grids (the benchmark's structure): long augmenting paths,
    // many orphans, wrap-around of the active queue.
    let mut seed = 7u64;
    let mut rnd = |m: i64| {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((seed >> 33) % m as u64) as i64
    };
    for (w, h) in [(64, 48), (33, 70), (128, 9)] {
        for _ in 0..3 {
            let n = w * h;
            let mut net = Net {
                n,
                s: vec![0; n],
                t: vec![0; n],
                edges: vec![],
            };
            for p in 0..n {
                let (x, y) = (p % w, p / w);
                let fg = (x / 11 + y / 7) % 2 == 0;
                let v = if fg { 70 } else { 30 } + rnd(60) - 30;
                net.s[p] = (v - 30).abs();
                net.t[p] = (v - 70).abs();
                if x + 1 < w {
                    let c = 1 + rnd(30);
                    net.edges.push((p as u32, p as u32 + 1, c, c));
                }
                if y + 1 < h {
                    let c = 1 + rnd(30);
                    net.edges.push((p as u32, (p + w) as u32, c, c));
                }
            }
            let mut g = grid4_from(w, h, &net);
            let flow = g.maxflow();
            let want = net.oracle();
            assert_eq!(flow, want, "{w}x{h}");
            assert_eq!(net.cut(&|i| g.is_sink(i as u32)), want);
        }
    }
}
