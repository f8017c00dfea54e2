use super::*;

/// Tiny deterministic generator (tests only; keeps the crate free of rand).
pub(crate) struct Lcg(pub u64);
impl Lcg {
    pub fn next(&mut self) -> u64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        self.0 >> 33
    }
    pub fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }
}

struct Net {
    n: usize,
    edges: Vec<(u32, u32, i64, i64)>,
    s: Vec<i64>,
    t: Vec<i64>,
}

impl Net {
    fn random(rng: &mut Lcg, n: usize, m: usize) -> Net {
        let mut edges = Vec::new();
        for _ in 0..m {
            let p = rng.below(n as u64) as u32;
            let mut q = rng.below(n as u64) as u32;
            if q == p {
                q = (q + 1) % n as u32;
            }
            edges.push((p, q, rng.below(10) as i64, rng.below(4) as i64));
        }
        let s = (0..n).map(|_| rng.below(12) as i64 - 3).collect();
        let t = (0..n).map(|_| rng.below(12) as i64 - 3).collect();
        Net { n, edges, s, t }
    }
    fn cut(&self, in_sink: &dyn Fn(usize) -> bool) -> i64 {
        let mut c = 0;
        for i in 0..self.n {
            c += if in_sink(i) { self.s[i] } else { self.t[i] };
        }
        for &(p, q, a, b) in &self.edges {
            let (sp, sq) = (in_sink(p as usize), in_sink(q as usize));
            if !sp && sq {
                c += a;
            }
            if sp && !sq {
                c += b;
            }
        }
        c
    }
    fn brute(&self) -> i64 {
        (0..1u32 << self.n)
            .map(|m| self.cut(&|i| m >> i & 1 == 1))
            .min()
            .unwrap()
    }
    fn builder<T: Cost>(&self) -> GraphBuilder<T> {
        let mut b = GraphBuilder::new(self.n);
        for &(p, q, a, c) in &self.edges {
            b.add_edge(p, q, T::from_f64(a as f64), T::from_f64(c as f64));
        }
        for i in 0..self.n {
            b.add_tweights(
                i as u32,
                T::from_f64(self.s[i] as f64),
                T::from_f64(self.t[i] as f64),
            );
        }
        b
    }
}

#[test]
fn bk_matches_brute_force_on_random_graphs() {
    let mut rng = Lcg(7);
    for trial in 0..400 {
        let n = 2 + (trial % 9);
        let net = Net::random(&mut rng, n, n * 2);
        let best = net.brute();
        let mut mf = net.builder::<i32>().build();
        let f = mf.maxflow();
        mf.check_invariants();
        assert_eq!(f, best, "trial {trial}");
        assert_eq!(
            net.cut(&|i| mf.is_sink(i as u32)),
            best,
            "cut of trial {trial}"
        );
        let mut mf = net.builder::<f64>().build();
        assert!((mf.maxflow() - best as f64).abs() < 1e-9);
    }
}

#[test]
fn tree_reuse_after_terminal_changes_matches_fresh_solve() {
    let mut rng = Lcg(11);
    for trial in 0..300 {
        let n = 3 + (trial % 8);
        let mut net = Net::random(&mut rng, n, n * 2);
        let mut mf = net.builder::<i64>().build();
        mf.maxflow();
        mf.check_invariants();
        for _round in 0..3 {
            for _ in 0..1 + rng.below(3) {
                let i = rng.below(n as u64) as usize;
                let (ds, dt) = (rng.below(9) as i64 - 4, rng.below(9) as i64 - 4);
                net.s[i] += ds;
                net.t[i] += dt;
                mf.add_tweights(i as u32, ds, dt);
            }
            for _ in 0..rng.below(2) {
                let e = rng.below(net.edges.len() as u64) as usize;
                let d = rng.below(5) as i64;
                net.edges[e].2 += d;
                // Parallel edges share nothing: find this edge's forward arc by rebuilding
                // the index the builder used (edge e keeps index e).
                let (topo, fwd) = CsrTopology::from_edges(
                    n,
                    &net.edges.iter().map(|e| [e.0, e.1]).collect::<Vec<_>>(),
                );
                drop(topo);
                mf.add_arc_capacity(fwd[e], d);
            }
            let f = mf.maxflow();
            mf.check_invariants();
            let best = net.brute();
            assert_eq!(f, best, "trial {trial}");
            assert_eq!(
                net.cut(&|i| mf.is_sink(i as u32)),
                best,
                "cut of trial {trial}"
            );
        }
    }
}

#[test]
fn grid_layout_matches_csr_layout() {
    let mut rng = Lcg(3);
    for conn in [Connectivity::Four, Connectivity::Eight] {
        for _ in 0..20 {
            let (w, h) = (1 + rng.below(9) as usize, 1 + rng.below(7) as usize);
            let mut grid = MaxFlow::<i32, _>::grid(w, h, conn);
            let mut b = GraphBuilder::<i32>::new(w * h);
            for n in 0..(w * h) as u32 {
                let (s, t) = (rng.below(20) as i32, rng.below(20) as i32);
                grid.add_tweights(n, s, t);
                b.add_tweights(n, s, t);
                for d in (0..conn.directions()).step_by(2) {
                    let (c, r) = (rng.below(15) as i32, rng.below(15) as i32);
                    if grid.set_grid_edge(n, d, c, r) {
                        let q = grid.topology().head(grid.topology().arc(n, d).unwrap());
                        b.add_edge(n, q, c, r);
                    }
                }
            }
            let mut csr = b.build();
            assert_eq!(grid.maxflow(), csr.maxflow());
        }
    }
}

/// A random `w × h` 4-connected grid network: terminal and edge capacities in small ranges
/// with many zeros (free nodes, blocked arcs).
fn random_grid<T: Cost>(
    rng: &mut Lcg,
    w: usize,
    h: usize,
) -> (GridMaxFlow<T>, MaxFlow<T, GridTopology>) {
    let mut g4 = GridMaxFlow::<T>::new(w, h);
    let mut bk = MaxFlow::<T, _>::grid(w, h, Connectivity::Four);
    let val = |rng: &mut Lcg, m: u64| T::from_f64(rng.below(m).saturating_sub(m / 3) as f64);
    for n in 0..(w * h) as u32 {
        let (s, t) = (val(rng, 24), val(rng, 24));
        g4.add_tweights(n, s, t);
        bk.add_tweights(n, s, t);
        for d in [0, 2] {
            let (c, r) = (val(rng, 15), val(rng, 15));
            assert_eq!(g4.set_grid_edge(n, d, c, r), bk.set_grid_edge(n, d, c, r));
        }
    }
    (g4, bk)
}

#[test]
fn grid4_matches_bk_and_keeps_its_invariants() {
    let mut rng = Lcg(17);
    for trial in 0..400 {
        let (w, h) = (1 + rng.below(13) as usize, 1 + rng.below(11) as usize);
        let (mut g4, mut bk) = random_grid::<i32>(&mut rng, w, h);
        let f = g4.maxflow();
        g4.check_invariants();
        assert_eq!(f, bk.maxflow(), "trial {trial} ({w}x{h})");
        // The sink side of BK's result is the set of nodes that reach the sink in the
        // residual graph, the same for every maximum flow.
        for n in 0..(w * h) as u32 {
            assert_eq!(g4.segment(n), bk.segment(n), "trial {trial} node {n}");
        }
        // Float capacities (integer-valued here, so exact).
        let (mut g4, mut bk) = random_grid::<f64>(&mut rng, w, h);
        let f = g4.maxflow();
        g4.check_invariants();
        assert_eq!(f, bk.maxflow(), "f64 trial {trial}");
    }
}

#[test]
fn grid4_resolves_after_capacity_changes() {
    let mut rng = Lcg(23);
    for trial in 0..200 {
        let (w, h) = (1 + rng.below(9) as usize, 1 + rng.below(9) as usize);
        let (mut g4, mut bk) = random_grid::<i64>(&mut rng, w, h);
        assert_eq!(g4.maxflow(), bk.maxflow());
        for _round in 0..3 {
            for _ in 0..1 + rng.below(4) {
                let i = rng.below((w * h) as u64) as u32;
                let (ds, dt) = (rng.below(9) as i64 - 4, rng.below(9) as i64 - 4);
                g4.add_tweights(i, ds, dt);
                bk.add_tweights(i, ds, dt);
            }
            let i = rng.below((w * h) as u64) as u32;
            let d = rng.below(4) as usize;
            if let Some(a) = bk.topology().arc(i, d) {
                assert!(g4.topology().arc(i, d).is_some());
                let delta = rng.below(5) as i64;
                g4.add_arc_capacity(i, d, delta);
                bk.add_arc_capacity(a, delta);
            }
            let f = g4.maxflow();
            g4.check_invariants();
            assert_eq!(f, bk.maxflow(), "trial {trial}");
        }
    }
}
