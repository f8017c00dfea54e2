//! Max-flow against petgraph's Dinic max-flow (an exact, independent oracle) on random
//! general graphs (proptest) and small grids; cut validity checked from the original
//! capacities.
use petgraph::algo::dinics;
use petgraph::graph::{DiGraph, NodeIndex};
use planemap_solvers::maxflow::{Connectivity, GraphBuilder, MaxFlow, Topology};
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
