//! Shared machinery of the move-making solvers: building the binary graph of one move
//! (Kolmogorov & Zabih 2004 construction, non-submodular pairs truncated after Rother et
//! al. 2005), solving it, and evaluating the true energy change of the proposed move.
//!
//! A move gives every *active* site `p` (current label `c_p`) a target label `t_p`; the
//! binary variable `x_p = 1` (sink side) means "switch to `t_p`". Inactive sites keep their
//! label. The move's graph is built over all sites (inactive ones are isolated nodes with no
//! capacity, never touched by the search), so the arc layout is the site graph's own.
use crate::cost::Cost;
use crate::maxflow::{GraphBuilder, GridMaxFlow, MaxFlow, Topology};
use crate::mrf::{DataFn, PairFn};

/// Statistics of one cycle (one sweep over all labels or label pairs, or over all sites).
#[derive(Clone, Debug, PartialEq)]
pub struct CycleStats<A> {
    /// Energy after the cycle.
    pub energy: A,
    /// Wall time of the cycle in seconds.
    pub seconds: f64,
    /// Moves whose graph was built and solved (moves known to fail are skipped).
    pub moves_tried: usize,
    /// Moves that lowered the energy and were kept.
    pub moves_accepted: usize,
    /// Sites whose label changed during the cycle (counted per move).
    pub sites_changed: usize,
}

/// A solver's result.
#[derive(Clone, Debug, PartialEq)]
pub struct Solution<A> {
    /// One label per site.
    pub labels: Vec<u32>,
    /// Energy of `labels` (equal to [`Mrf::energy`](crate::mrf::Mrf::energy)`.total`,
    /// exactly for integer costs).
    pub energy: A,
    /// Energy of the initial labelling.
    pub initial_energy: A,
    /// Per-cycle statistics.
    pub cycles: Vec<CycleStats<A>>,
    /// Whether the last cycle changed nothing (a local optimum w.r.t. the move family), as
    /// opposed to stopping at the cycle limit.
    pub converged: bool,
}

/// Receives the terms of one move's binary energy.
pub(crate) trait Emit<T> {
    /// Adds `delta` to the cost of `x_p = 1` relative to `x_p = 0`.
    fn unary(&mut self, p: usize, delta: T);
    /// Edge `p → q` (forward arc `arc`, reverse `sister`) with capacity `cap ≥ 0` paid when
    /// `x_p = 0, x_q = 1`; the reverse capacity is 0.
    fn pair(&mut self, arc: u32, sister: u32, p: usize, q: usize, cap: T);
    /// An edge that carries nothing in this move.
    fn empty(&mut self, arc: u32, sister: u32);
}

/// Writes straight into a [`MaxFlow`]'s arrays (after `rebuild` and zeroing `tr`).
pub(crate) struct FastEmit<'x, T> {
    pub cap: &'x mut [T],
    pub tr: &'x mut [T],
}
impl<T: Cost> Emit<T> for FastEmit<'_, T> {
    #[inline(always)]
    fn unary(&mut self, p: usize, delta: T) {
        self.tr[p] += delta;
    }
    #[inline(always)]
    fn pair(&mut self, arc: u32, sister: u32, _p: usize, _q: usize, cap: T) {
        self.cap[arc as usize] = cap;
        self.cap[sister as usize] = T::ZERO;
    }
    #[inline(always)]
    fn empty(&mut self, arc: u32, sister: u32) {
        self.cap[arc as usize] = T::ZERO;
        self.cap[sister as usize] = T::ZERO;
    }
}

/// Collects the terms into a [`GraphBuilder`] (general path, e.g. with label-cost nodes).
pub(crate) struct BuilderEmit<'x, T: Cost> {
    pub b: &'x mut GraphBuilder<T>,
}
impl<T: Cost> Emit<T> for BuilderEmit<'_, T> {
    fn unary(&mut self, p: usize, delta: T) {
        if delta != T::ZERO {
            self.b.add_tweights(p as u32, delta, T::ZERO);
        }
    }
    fn pair(&mut self, _arc: u32, _sister: u32, p: usize, q: usize, cap: T) {
        if cap.is_pos() {
            self.b.add_edge(p as u32, q as u32, cap, T::ZERO);
        }
    }
    fn empty(&mut self, _arc: u32, _sister: u32) {}
}

/// Emits the binary energy of the move `target` from `labels`. Returns whether any pair
/// term had to be truncated to make it submodular (then the move is only approximately
/// optimal).
#[inline(always)]
pub(crate) fn build_move<T, Tp, D, P, E, Tg>(
    topo: &Tp,
    data: &D,
    pair: &P,
    labels: &[u32],
    target: &Tg,
    em: &mut E,
) -> bool
where
    T: Cost,
    Tp: Topology,
    D: DataFn<T>,
    P: PairFn<T>,
    E: Emit<T>,
    Tg: Fn(usize, u32) -> Option<u32>,
{
    let mut truncated = false;
    for p in 0..labels.len() {
        let cp = labels[p];
        let tp = target(p, cp);
        if let Some(t) = tp {
            em.unary(p, data.d(p, t) - data.d(p, cp));
        }
        for a in topo.arcs(p as u32) {
            if !topo.is_forward(a) {
                continue;
            }
            let q = topo.head(a) as usize;
            let s = topo.sister(a);
            let cq = labels[q];
            match (tp, target(q, cq)) {
                (Some(t), Some(u)) => {
                    let e = topo.edge_of(a);
                    let ea = pair.v(p, q, e, cp, cq);
                    let eb = pair.v(p, q, e, cp, u);
                    let ec = pair.v(p, q, e, t, cq);
                    let ed = pair.v(p, q, e, t, u);
                    // Submodular iff A + D <= B + C; otherwise lower A (Rother et al. 2005).
                    let ea = if ea + ed > eb + ec {
                        truncated = true;
                        eb + ec - ed
                    } else {
                        ea
                    };
                    em.pair(a, s, p, q, eb + ec - ea - ed);
                    em.unary(p, ec - ea);
                    em.unary(q, ed - ec);
                }
                (Some(t), None) => {
                    let e = topo.edge_of(a);
                    em.unary(p, pair.v(p, q, e, t, cq) - pair.v(p, q, e, cp, cq));
                    em.empty(a, s);
                }
                (None, Some(u)) => {
                    let e = topo.edge_of(a);
                    em.unary(q, pair.v(p, q, e, cp, u) - pair.v(p, q, e, cp, cq));
                    em.empty(a, s);
                }
                (None, None) => em.empty(a, s),
            }
        }
    }
    truncated
}

/// The true change of the data and pairwise energy if every site with `switch(p)` takes
/// `target(p)`. Fills `changed` with `(site, new label)`.
#[inline(always)]
pub(crate) fn move_delta<T, Tp, D, P, Tg, S>(
    topo: &Tp,
    data: &D,
    pair: &P,
    labels: &[u32],
    target: &Tg,
    switch: &S,
    changed: &mut Vec<(u32, u32)>,
) -> T::Acc
where
    T: Cost,
    Tp: Topology,
    D: DataFn<T>,
    P: PairFn<T>,
    Tg: Fn(usize, u32) -> Option<u32>,
    S: Fn(usize) -> bool,
{
    changed.clear();
    let mut d = T::Acc::default();
    for p in 0..labels.len() {
        if !switch(p) {
            continue;
        }
        let cp = labels[p];
        let Some(t) = target(p, cp) else { continue };
        changed.push((p as u32, t));
        d += data.d(p, t).widen();
        d -= data.d(p, cp).widen();
        for a in topo.arcs(p as u32) {
            let q = topo.head(a) as usize;
            let qs = switch(q) && target(q, labels[q]).is_some();
            if qs && q < p {
                continue;
            }
            let cq = labels[q];
            let nq = if qs { target(q, cq).unwrap_or(cq) } else { cq };
            let e = topo.edge_of(a);
            if topo.is_forward(a) {
                d += pair.v(p, q, e, t, nq).widen();
                d -= pair.v(p, q, e, cp, cq).widen();
            } else {
                d += pair.v(q, p, e, nq, t).widen();
                d -= pair.v(q, p, e, cq, cp).widen();
            }
        }
    }
    d
}

/// Change of the label-cost term when `changed` is applied (`counts` = sites per label).
pub(crate) fn label_cost_delta<T: Cost>(
    h: &[T],
    counts: &[u32],
    labels: &[u32],
    changed: &[(u32, u32)],
    scratch: &mut Vec<i64>,
) -> T::Acc {
    scratch.clear();
    scratch.resize(counts.len(), 0);
    for &(p, t) in changed {
        scratch[labels[p as usize] as usize] -= 1;
        scratch[t as usize] += 1;
    }
    let mut d = T::Acc::default();
    for l in 0..counts.len() {
        let before = counts[l] > 0;
        let after = counts[l] as i64 + scratch[l] > 0;
        if before && !after {
            d -= h[l].widen();
        } else if after && !before {
            d += h[l].widen();
        }
    }
    d
}

/// A max-flow solver the fast move path can rebuild in place: it hands out its topology,
/// arc capacities and signed terminal capacities, solves, and reports each node's side.
pub(crate) trait FastFlow<T: Cost> {
    /// The solver's arc layout (its edge indices must be the site graph's).
    type Topo: Topology;
    /// See [`MaxFlow::rebuild`].
    fn rebuild(&mut self) -> (&Self::Topo, &mut [T], &mut [T]);
    /// Solves; returns the flow.
    fn maxflow(&mut self) -> T::Acc;
    /// Whether `node` is on the sink side (label switches).
    fn is_sink(&self, node: u32) -> bool;
    /// Writes the move's graph over the whole network (see [`build_move`]); returns
    /// whether a pair term was truncated.
    fn build_move<D, P, Tg>(&mut self, data: &D, pair: &P, labels: &[u32], target: &Tg) -> bool
    where
        D: DataFn<T>,
        P: PairFn<T>,
        Tg: Fn(usize, u32) -> Option<u32>,
    {
        let (mtopo, cap, tr) = self.rebuild();
        tr.fill(T::ZERO);
        let mut em = FastEmit { cap, tr };
        build_move(mtopo, data, pair, labels, target, &mut em)
    }
}

impl<T: Cost, Tp: Topology> FastFlow<T> for MaxFlow<T, Tp> {
    type Topo = Tp;
    fn rebuild(&mut self) -> (&Tp, &mut [T], &mut [T]) {
        MaxFlow::rebuild(self)
    }
    fn maxflow(&mut self) -> T::Acc {
        MaxFlow::maxflow(self)
    }
    #[inline(always)]
    fn is_sink(&self, node: u32) -> bool {
        MaxFlow::is_sink(self, node)
    }
}

impl<T: Cost> FastFlow<T> for GridMaxFlow<T> {
    type Topo = crate::maxflow::Grid4Topology;
    fn rebuild(&mut self) -> (&Self::Topo, &mut [T], &mut [T]) {
        GridMaxFlow::rebuild(self)
    }
    fn maxflow(&mut self) -> T::Acc {
        GridMaxFlow::maxflow(self)
    }
    #[inline(always)]
    fn is_sink(&self, node: u32) -> bool {
        GridMaxFlow::is_sink(self, node)
    }
    fn build_move<D, P, Tg>(&mut self, data: &D, pair: &P, labels: &[u32], target: &Tg) -> bool
    where
        D: DataFn<T>,
        P: PairFn<T>,
        Tg: Fn(usize, u32) -> Option<u32>,
    {
        let (topo, cap, tr) = GridMaxFlow::rebuild(self);
        build_move_grid4(
            topo.width(),
            topo.height(),
            data,
            pair,
            labels,
            target,
            cap,
            tr,
        )
    }
}

/// The pair term of the move on edge `e = (p, q)`, `p < q` (current labels `cp`, `cq`,
/// targets `tp`, `tq`): the capacity of `p → q` (paid for `x_p = 0, x_q = 1`) and the unary
/// shares of `p` and `q`, as in [`build_move`].
#[inline(always)]
fn grid_edge<T, P>(
    pair: &P,
    truncated: &mut bool,
    (p, q, e): (usize, usize, usize),
    (cp, tp): (u32, Option<u32>),
    (cq, tq): (u32, Option<u32>),
) -> (T, T, T)
where
    T: Cost,
    P: PairFn<T>,
{
    match (tp, tq) {
        (Some(t), Some(u)) => {
            let [ea, eb, ec, ed] = pair.quad(p, q, e, cp, cq, t, u);
            // Submodular iff A + D <= B + C; otherwise lower A (Rother et al. 2005).
            let ea = if ea + ed > eb + ec {
                *truncated = true;
                eb + ec - ed
            } else {
                ea
            };
            (eb + ec - ea - ed, ec - ea, ed - ec)
        }
        (Some(t), None) => (
            T::ZERO,
            pair.v(p, q, e, t, cq) - pair.v(p, q, e, cp, cq),
            T::ZERO,
        ),
        (None, Some(u)) => (
            T::ZERO,
            T::ZERO,
            pair.v(p, q, e, cp, u) - pair.v(p, q, e, cp, cq),
        ),
        (None, None) => (T::ZERO, T::ZERO, T::ZERO),
    }
}

/// [`build_move`] for a 4-connected grid in [`Grid4Topology`](crate::maxflow::Grid4Topology)
/// layout (`cap[d * n + p]`), row by row: each site's terminal capacity is summed in a
/// register from its data term, its right and down edges and the shares its left and upper
/// neighbours passed on (a carry and a row buffer), and written once.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn build_move_grid4<T, D, P, Tg>(
    w: usize,
    h: usize,
    data: &D,
    pair: &P,
    labels: &[u32],
    target: &Tg,
    cap: &mut [T],
    tr: &mut [T],
) -> bool
where
    T: Cost,
    D: DataFn<T>,
    P: PairFn<T>,
    Tg: Fn(usize, u32) -> Option<u32>,
{
    let n = w * h;
    assert!(labels.len() == n && tr.len() == n && cap.len() == 4 * n);
    let mut truncated = false;
    let (c0, rest) = cap.split_at_mut(n);
    let (c1, rest) = rest.split_at_mut(n);
    let (c2, c3) = rest.split_at_mut(n);
    let mut from_above = vec![T::ZERO; w];
    // Targets of rows y and y + 1 (each site's target is evaluated once).
    let mut t_cur: Vec<Option<u32>> = (0..w).map(|x| target(x, labels[x])).collect();
    let mut t_next: Vec<Option<u32>> = vec![None; w];
    for y in 0..h {
        let r = y * w;
        let down = y + 1 < h;
        // Row slices (bounds checks hoisted): this row's labels, right, left and down arcs
        // and terminal capacities; the next row's labels and up arcs (this row's again on
        // the last row, unused there).
        let nr = if down { r + w } else { r };
        let (lab, lab_dn) = (&labels[r..r + w], &labels[nr..nr + w]);
        if down {
            for (x, t) in t_next.iter_mut().enumerate() {
                *t = target(nr + x, lab_dn[x]);
            }
        }
        let (right, left, dn) = (&mut c0[r..r + w], &mut c1[r..r + w], &mut c2[r..r + w]);
        let up_dn = &mut c3[nr..nr + w];
        let trr = &mut tr[r..r + w];
        let (tc, tn, fa) = (&t_cur[..w], &t_next[..w], &mut from_above[..w]);
        let mut from_left = T::ZERO;
        for x in 0..w {
            let p = r + x;
            let cp = lab[x];
            let tp = tc[x];
            let mut acc = from_left + fa[x];
            if let Some(t) = tp {
                acc += data.d(p, t) - data.d(p, cp);
            }
            from_left = T::ZERO;
            if x + 1 < w {
                let (c, up, uq) = grid_edge(
                    pair,
                    &mut truncated,
                    (p, p + 1, 2 * p),
                    (cp, tp),
                    (lab[x + 1], tc[x + 1]),
                );
                right[x] = c;
                left[x + 1] = T::ZERO;
                acc += up;
                from_left = uq;
            }
            if down {
                let (c, up, uq) = grid_edge(
                    pair,
                    &mut truncated,
                    (p, p + w, 2 * p + 1),
                    (cp, tp),
                    (lab_dn[x], tn[x]),
                );
                dn[x] = c;
                up_dn[x] = T::ZERO;
                acc += up;
                fa[x] = uq;
            }
            trr[x] = acc;
        }
        std::mem::swap(&mut t_cur, &mut t_next);
    }
    truncated
}

/// The fast path's solver: the grid-specialised [`GridMaxFlow`] on 4-connected grids,
/// BK on the site graph's own layout otherwise.
pub(crate) enum MoveFlow<T: Cost, Tp: Topology> {
    /// BK over the site graph's layout.
    General(MaxFlow<T, Tp>),
    /// 4-connected grid (boxed: the variants differ in size).
    Grid4(Box<GridMaxFlow<T>>),
}

impl<T: Cost, Tp: Topology + Clone> MoveFlow<T, Tp> {
    /// The fastest solver for `topo`.
    pub fn new(topo: &Tp) -> Self {
        match topo.grid4_size() {
            Some((w, h)) => {
                let mut g = GridMaxFlow::new(w, h);
                g.set_length_three_paths(false);
                MoveFlow::Grid4(Box::new(g))
            }
            None => MoveFlow::General(MaxFlow::new(topo.clone())),
        }
    }

    /// [`solve_move_fast`] with whichever solver this is.
    pub fn solve_move<D, P, Tg>(
        &mut self,
        topo: &Tp,
        data: &D,
        pair: &P,
        labels: &[u32],
        target: &Tg,
        changed: &mut Vec<(u32, u32)>,
    ) -> (T::Acc, bool)
    where
        D: DataFn<T>,
        P: PairFn<T>,
        Tg: Fn(usize, u32) -> Option<u32>,
    {
        match self {
            MoveFlow::General(mf) => solve_move_fast(mf, topo, data, pair, labels, target, changed),
            MoveFlow::Grid4(mf) => {
                solve_move_fast(&mut **mf, topo, data, pair, labels, target, changed)
            }
        }
    }
}

/// Solves one move on the fast path (the solver's layout, written in place) and returns
/// the true energy change (data + pairwise; the caller adds label costs), whether the
/// move's graph needed truncation, and the proposed changes in `changed`.
#[allow(clippy::too_many_arguments)]
pub(crate) fn solve_move_fast<T, Tp, F, D, P, Tg>(
    mf: &mut F,
    topo: &Tp,
    data: &D,
    pair: &P,
    labels: &[u32],
    target: &Tg,
    changed: &mut Vec<(u32, u32)>,
) -> (T::Acc, bool)
where
    T: Cost,
    Tp: Topology,
    F: FastFlow<T>,
    D: DataFn<T>,
    P: PairFn<T>,
    Tg: Fn(usize, u32) -> Option<u32>,
{
    let truncated = mf.build_move(data, pair, labels, target);
    mf.maxflow();
    let d = move_delta(
        topo,
        data,
        pair,
        labels,
        target,
        &|p| mf.is_sink(p as u32),
        changed,
    );
    (d, truncated)
}

/// Minimal deterministic generator for shuffled label orders.
pub(crate) struct SplitMix(pub u64);
impl SplitMix {
    pub fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E3779B97F4A7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58476D1CE4E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D049BB133111EB);
        z ^ (z >> 31)
    }
    pub fn shuffle<X>(&mut self, v: &mut [X]) {
        for i in (1..v.len()).rev() {
            let j = (self.next() % (i as u64 + 1)) as usize;
            v.swap(i, j);
        }
    }
}
