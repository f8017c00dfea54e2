//! Boykov–Kolmogorov max-flow specialised to 4-connected pixel grids.
//!
//! Same algorithm as [`MaxFlow`](super::MaxFlow) (two search trees, orphan adoption), laid
//! out so that the growth loop touches little memory and runs few, well-predicted
//! instructions, with a cheaper and stronger initialisation:
//!
//! * arc capacities are **direction-major** ([`Grid4Topology`]: arc `d * n + node`), so the
//!   initialisation works on four contiguous arrays, one row at a time, in loops the
//!   compiler vectorises;
//! * one **state byte** per node: parent direction (0–3, see
//!   [`GRID_DIRECTIONS`](super::GRID_DIRECTIONS)) or terminal / orphan / free, the tree bit
//!   and the in-queue bit (1 MB for a megapixel: it stays in L2);
//! * one **residual byte** per node: which of its four outgoing and which of its four
//!   incoming arcs have residual capacity. Growing the sink tree needs the residual of the
//!   arc *into* the node, stored with the neighbour; the byte answers without touching the
//!   neighbour's capacities. It is kept exact wherever a capacity changes (initialisation
//!   and augmentation only). Arcs leaving the grid have zero capacity both ways and zero
//!   bits, so the growth loop needs no boundary tests;
//! * time stamp and distance (8 bytes) are read only by orphan adoption: the growth loop
//!   does not apply BK's distance heuristic to same-tree neighbours (measured: no change in
//!   augmentations on the segmentation benchmark);
//! * the active queue is a ring buffer of node indices (each node is queued at most once);
//! * the initialisation saturates all length-two paths source → p → q → sink (vectorised
//!   direction by direction) and then the length-three paths source → p → z → q → sink
//!   through balanced nodes `z`, and activates only the *frontier*: nodes with a residual
//!   arc in their growth direction to a node outside their tree. On image grids most of the
//!   flow takes such short paths; on the 1024² segmentation benchmark what is left needs
//!   about 30 % of the generic BK's augmentations and 40 % of its growth steps.
//!
//! A second [`GridMaxFlow::maxflow`] after capacity changes is correct (the residual
//! network is solved again, the flow accumulates) but builds new search trees instead of
//! repairing the old ones; [`MaxFlow`](super::MaxFlow) keeps them (dynamic graph cuts).
use super::topology::Grid4Topology;
use super::Segment;
use crate::cost::Cost;

const TERMINAL: u8 = 4;
const ORPHAN: u8 = 5;
const FREE: u8 = 6;
const CODE: u8 = 7;
const SINK: u8 = 8;
const ACTIVE: u8 = 16;
const INF_DIST: u32 = u32::MAX;
const NONE: u32 = u32::MAX;

/// BK max-flow on a `width × height` 4-connected grid (see the module documentation).
///
/// Memory per node for capacity type `T`: `5 · size_of::<T>()` (four arc residuals and the
/// terminal residual) + 1 (state) + 1 (residual bits) + 8 (time stamp, distance) + 4
/// (queue) + 1 (the topology's boundary mask) = 35 bytes for `i32`, i.e. 19 bytes per node
/// plus 8 per undirected edge (two 4-byte residuals; the slots of arcs leaving the grid are
/// allocated but unused). Initialisation scratch: a few rows.
#[derive(Clone, Debug)]
pub struct GridMaxFlow<T: Cost> {
    topo: Grid4Topology,
    width: usize,
    height: usize,
    n: usize,
    off: [u32; 4],
    cap: Vec<T>,
    tr: Vec<T>,
    state: Vec<u8>,
    resid: Vec<u8>,
    /// (time stamp, distance to the terminal) per node.
    td: Vec<(u32, u32)>,
    queue: Vec<u32>,
    q_head: usize,
    q_len: usize,
    orphans: Vec<u32>,
    time: u32,
    flow: T::Acc,
    /// Whether the initialisation saturates length-three paths.
    sat3: bool,
    /// Row scratch of the initialisation.
    push: Vec<T>,
    sign: Vec<u8>,
}

impl<T: Cost> GridMaxFlow<T> {
    /// An empty `width × height` network (all capacities zero).
    pub fn new(width: usize, height: usize) -> Self {
        let topo = Grid4Topology::new(width, height);
        let n = width * height;
        let w = width as u32;
        GridMaxFlow {
            topo,
            width,
            height,
            n,
            off: [1, u32::MAX, w, w.wrapping_neg()],
            cap: touched(4 * n, T::ZERO),
            tr: touched(n, T::ZERO),
            state: touched(n, FREE),
            resid: touched(n, 0),
            td: touched(n, (0, 0)),
            queue: touched(n.max(1), 0),
            q_head: 0,
            q_len: 0,
            orphans: Vec::new(),
            time: 0,
            flow: T::Acc::default(),
            sat3: true,
            push: vec![T::ZERO; width],
            sign: vec![0; 3 * (width + 2)],
        }
    }

    /// Whether the initialisation also saturates the length-three paths source → p → z → q
    /// → sink through balanced nodes (default on). It pays on image segmentation (1024²
    /// benchmark: 30 % of the augmentations, −8 % time) but not on α-expansion moves
    /// (there it costs about what it saves, +4 %), where it is switched off.
    pub fn set_length_three_paths(&mut self, on: bool) {
        self.sat3 = on;
    }

    /// The arc layout.
    pub fn topology(&self) -> &Grid4Topology {
        &self.topo
    }

    /// Number of nodes.
    pub fn num_nodes(&self) -> usize {
        self.n
    }

    /// Adds terminal capacities, as [`MaxFlow::add_tweights`](super::MaxFlow::add_tweights).
    pub fn add_tweights(&mut self, node: u32, source_cap: T, sink_cap: T) {
        let i = node as usize;
        let (mut s, mut t) = (source_cap, sink_cap);
        let r = self.tr[i];
        if r > T::ZERO {
            s += r;
        } else {
            t -= r;
        }
        self.flow += s.min_of(t).widen();
        self.tr[i] = s - t;
    }

    /// Sets the capacities of the edge from `node` in direction `dir` (0 right, 1 left,
    /// 2 down, 3 up): `cap` for `node → neighbour`, `rev_cap` for the reverse. Returns
    /// `false` (and does nothing) if the neighbour lies outside the grid.
    pub fn set_grid_edge(&mut self, node: u32, dir: usize, cap: T, rev_cap: T) -> bool {
        match self.topo.arc(node, dir) {
            Some(a) => {
                let j = node.wrapping_add(self.off[dir]);
                self.cap[a as usize] = cap;
                let s = self.ci(j, dir as u32 ^ 1);
                self.cap[s] = rev_cap;
                true
            }
            None => false,
        }
    }

    /// Increases the residual capacity of `node`'s arc in direction `dir` by `delta ≥ 0`.
    /// Panics if the arc leaves the grid.
    pub fn add_arc_capacity(&mut self, node: u32, dir: usize, delta: T) {
        let a = self.topo.arc(node, dir).expect("arc leaves the grid");
        debug_assert!(delta >= T::ZERO);
        self.cap[a as usize] += delta;
    }

    /// Starts rebuilding the whole network in place, as
    /// [`MaxFlow::rebuild`](super::MaxFlow::rebuild): forgets the flow, hands out the
    /// topology, the arc capacities (indexed by the topology's arcs) and the signed terminal
    /// capacities. The caller must overwrite every arc the topology enumerates and every
    /// `tr`; arcs leaving the grid are not enumerated and stay zero.
    pub fn rebuild(&mut self) -> (&Grid4Topology, &mut [T], &mut [T]) {
        self.flow = T::Acc::default();
        (&self.topo, &mut self.cap, &mut self.tr)
    }

    /// The value of the maximum flow found by the last solve, plus the constants folded in
    /// by [`GridMaxFlow::add_tweights`].
    pub fn flow(&self) -> T::Acc {
        self.flow
    }

    /// Whether `node` ends on the sink side (sink side = label 1 for the move solvers).
    #[inline]
    pub fn is_sink(&self, node: u32) -> bool {
        let s = self.state[node as usize];
        s & CODE != FREE && s & SINK != 0
    }

    /// Side of the minimum cut of `node` after a solve (free nodes go to the source).
    #[inline]
    pub fn segment(&self, node: u32) -> Segment {
        if self.is_sink(node) {
            Segment::Sink
        } else {
            Segment::Source
        }
    }

    /// Panics if a residual byte disagrees with the capacities, an arc leaving the grid has
    /// capacity, or a passive-tree invariant is broken (tests only).
    #[cfg(test)]
    pub(crate) fn check_invariants(&self) {
        use super::topology::Topology;
        for p in 0..self.n as u32 {
            let pu = p as usize;
            for d in 0..4u32 {
                let a = self.ci(p, d);
                let Some(arc) = self.topo.arc(p, d as usize) else {
                    assert!(!self.cap[a].is_pos(), "boundary arc {p}/{d} has capacity");
                    assert_eq!(self.resid[pu] >> d & 1, 0);
                    assert_eq!(self.resid[pu] >> (4 + d) & 1, 0);
                    continue;
                };
                assert_eq!(arc as usize, a);
                let q = self.nb(p, d);
                assert_eq!(q, self.topo.head(arc));
                assert_eq!(self.resid[pu] >> d & 1, self.cap[a].is_pos() as u8);
                let back = self.cap[self.ci(q, d ^ 1)].is_pos() as u8;
                assert_eq!(self.resid[pu] >> (4 + d) & 1, back);
                let (sp, sq) = (self.state[pu], self.state[q as usize]);
                let (fp, fq) = (sp & CODE == FREE, sq & CODE == FREE);
                assert!(sp & CODE != ORPHAN);
                if !fp && sp & SINK == 0 && self.cap[a].is_pos() {
                    assert!(!fq && sq & SINK == 0, "source {p} -> {q} open");
                }
                if !fp && sp & SINK != 0 && back != 0 {
                    assert!(!fq && sq & SINK != 0, "{q} -> sink {p} open");
                }
            }
            if self.state[pu] & CODE == FREE {
                assert!(
                    self.tr[pu] == T::ZERO,
                    "free node {p} with terminal residue"
                );
            }
        }
    }

    /// Capacity index of the arc leaving `i` in direction `d`.
    #[inline(always)]
    fn ci(&self, i: u32, d: u32) -> usize {
        d as usize * self.n + i as usize
    }

    /// The neighbour of `i` in direction `d` (wrapping arithmetic: only called for arcs
    /// inside the grid).
    #[inline(always)]
    fn nb(&self, i: u32, d: u32) -> u32 {
        i.wrapping_add(at!(self.off, d as usize))
    }

    /// Residual bits after pushing flow along arc `(tail, d)` to `head`: the reverse arc
    /// is open now (out-bit `d ^ 1` of `head`, in-bit `d` of `tail`); if `saturated`, the
    /// arc itself is closed (out-bit `d` of `tail`, in-bit `d ^ 1` of `head`).
    #[inline(always)]
    fn pushed_bits(&mut self, tail: u32, d: u32, head: u32, saturated: bool) {
        let s = saturated as u8;
        let r = &mut at_mut!(self.resid, tail as usize);
        *r = (*r | (1 << (4 + d))) & !(s << d);
        let r = &mut at_mut!(self.resid, head as usize);
        *r = (*r | (1 << (d ^ 1))) & !(s << (4 + (d ^ 1)));
    }

    #[inline(always)]
    fn set_code(&mut self, i: u32, code: u8) {
        let s = &mut at_mut!(self.state, i as usize);
        *s = (*s & !CODE) | code;
    }

    #[inline(always)]
    fn activate(&mut self, i: u32) {
        let s = &mut at_mut!(self.state, i as usize);
        if *s & ACTIVE == 0 {
            *s |= ACTIVE;
            let mut k = self.q_head + self.q_len;
            if k >= self.queue.len() {
                k -= self.queue.len();
            }
            at_mut!(self.queue, k) = i;
            self.q_len += 1;
        }
    }

    #[inline(always)]
    fn pop_active(&mut self) -> Option<u32> {
        while self.q_len > 0 {
            let i = at!(self.queue, self.q_head);
            self.q_head += 1;
            if self.q_head == self.queue.len() {
                self.q_head = 0;
            }
            self.q_len -= 1;
            let s = &mut at_mut!(self.state, i as usize);
            *s &= !ACTIVE;
            if *s & CODE != FREE {
                return Some(i);
            }
        }
        None
    }

    /// Builds the initial search trees in one pipelined pass over the rows. Step `y`:
    /// saturates the length-two paths source → p → q → sink within row `y` and between rows
    /// `y - 1` and `y` ([`GridMaxFlow::sat2_rows`]); then the length-three paths through the
    /// balanced nodes of row `y - 1` ([`GridMaxFlow::sat3_row`]); then row `y - 3`, whose
    /// capacities and neighbours' terminal residuals are final by then, gets its residual
    /// bytes, tree membership and activation ([`GridMaxFlow::finalize_row`]).
    fn init_trees(&mut self) {
        let h = self.height;
        self.q_head = 0;
        self.q_len = 0;
        self.orphans.clear();
        // Time stamps persist across solves; a new solve starts a new period so that no
        // stale stamp counts as current.
        if self.time > u32::MAX / 2 {
            self.td.fill((0, 0));
            self.time = 0;
        }
        self.time += 1;
        if self.n == 0 {
            return;
        }
        for y in 0..h + 3 {
            if y < h {
                self.sat2_rows(y);
            }
            if self.sat3 && (1..=h).contains(&y) {
                self.sat3_row(y - 1);
            }
            if y >= 3 {
                self.finalize_row(y - 3);
            }
        }
    }

    /// One direction's length-two pushes: `from[x] → to[x]` with residual `c[x]`; every
    /// node is either a sender (`tr > 0`) or a receiver (`tr < 0`), never both, so the
    /// pushes of one pass are independent. Returns the flow pushed; `push` receives the
    /// amounts.
    #[inline(always)]
    fn push_pass(from: &[T], to: &[T], c: &[T], push: &mut [T]) -> T::Acc {
        let mut f = T::Acc::default();
        for (((b, &s), &t), &c) in push.iter_mut().zip(from).zip(to).zip(c) {
            let v = s.min_of(-t).min_of(c);
            *b = if v.is_pos() { v } else { T::ZERO };
            f += b.widen();
        }
        f
    }

    /// Length-two paths within row `y` (rightwards, then leftwards) and between rows
    /// `y - 1` and `y` (downwards, then upwards).
    fn sat2_rows(&mut self, y: usize) {
        let (w, n) = (self.width, self.n);
        let r = y * w;
        let mut push = std::mem::take(&mut self.push);
        if w > 1 {
            let m = w - 1;
            // Rightwards: r + x → r + x + 1 (arc slot 0, sister slot 1), then leftwards:
            // r + x + 1 → r + x (arc slot 1, sister slot 0).
            for (fwd, from, to) in [(0, r, r + 1), (1, r + 1, r)] {
                let back = 1 - fwd;
                let pushed = &mut push[..m];
                self.flow += Self::push_pass(
                    &self.tr[from..from + m],
                    &self.tr[to..to + m],
                    &self.cap[fwd * n + from..fwd * n + from + m],
                    pushed,
                );
                sub_assign(&mut self.tr[from..from + m], pushed);
                add_assign(&mut self.tr[to..to + m], pushed);
                sub_assign(&mut self.cap[fwd * n + from..fwd * n + from + m], pushed);
                add_assign(&mut self.cap[back * n + to..back * n + to + m], pushed);
            }
        }
        if y > 0 {
            let u = r - w;
            // Downwards: u + x → r + x (slot 2, sister 3), then upwards: r + x → u + x
            // (slot 3, sister 2).
            for (fwd, from, to) in [(2, u, r), (3, r, u)] {
                let back = fwd ^ 1;
                let pushed = &mut push[..w];
                self.flow += Self::push_pass(
                    &self.tr[from..from + w],
                    &self.tr[to..to + w],
                    &self.cap[fwd * n + from..fwd * n + from + w],
                    pushed,
                );
                sub_assign(&mut self.tr[from..from + w], pushed);
                add_assign(&mut self.tr[to..to + w], pushed);
                sub_assign(&mut self.cap[fwd * n + from..fwd * n + from + w], pushed);
                add_assign(&mut self.cap[back * n + to..back * n + to + w], pushed);
            }
        }
        self.push = push;
    }

    /// Which of the four directions stay inside the grid at `(x, y)`.
    #[inline(always)]
    fn inside(&self, x: usize, y: usize) -> u8 {
        ((x + 1 < self.width) as u8)
            | ((x > 0) as u8) << 1
            | ((y + 1 < self.height) as u8) << 2
            | ((y > 0) as u8) << 3
    }

    /// Length-three paths source → p → z → q → sink through the balanced (free) nodes `z`
    /// of row `y`.
    fn sat3_row(&mut self, y: usize) {
        let w = self.width;
        for x in 0..w {
            let z = (y * w + x) as u32;
            if at!(self.tr, z as usize) != T::ZERO {
                continue;
            }
            let inside = self.inside(x, y);
            // Sink-linked neighbours q with an open arc z → q.
            let mut outs = 0u8;
            for e in 0..4u32 {
                if inside >> e & 1 != 0 {
                    let q = self.nb(z, e) as usize;
                    if at!(self.tr, q) < T::ZERO && at!(self.cap, self.ci(z, e)).is_pos() {
                        outs |= 1 << e;
                    }
                }
            }
            if outs == 0 {
                continue;
            }
            for d in 0..4u32 {
                if inside >> d & 1 == 0 {
                    continue;
                }
                let p = self.nb(z, d);
                let pa = self.ci(p, d ^ 1);
                let mut rp = at!(self.tr, p as usize);
                let mut cin = at!(self.cap, pa);
                if !rp.is_pos() || !cin.is_pos() {
                    continue;
                }
                let mut m = outs;
                while m != 0 {
                    let e = m.trailing_zeros();
                    m &= m - 1;
                    let q = self.nb(z, e);
                    let za = self.ci(z, e);
                    let cz = at!(self.cap, za);
                    let rq = -at!(self.tr, q as usize);
                    let b = rp.min_of(cin).min_of(cz).min_of(rq);
                    if !b.is_pos() {
                        continue;
                    }
                    rp -= b;
                    cin -= b;
                    at_mut!(self.tr, q as usize) += b;
                    at_mut!(self.cap, za) = cz - b;
                    let qa = self.ci(q, e ^ 1);
                    at_mut!(self.cap, qa) += b;
                    let zb = self.ci(z, d);
                    at_mut!(self.cap, zb) += b;
                    self.flow += b.widen();
                    if at!(self.tr, q as usize) >= T::ZERO {
                        outs &= !(1 << e);
                    }
                    if !rp.is_pos() || !cin.is_pos() {
                        break;
                    }
                }
                at_mut!(self.tr, p as usize) = rp;
                at_mut!(self.cap, pa) = cin;
                if outs == 0 {
                    break;
                }
            }
        }
    }

    /// Residual bytes, tree membership and activation of row `y`'s nodes. Row `y + 1`'s
    /// capacities and terminal residuals are final here, so its out-bits and tree
    /// membership are written first (row 0's at the start).
    fn finalize_row(&mut self, y: usize) {
        let (w, h) = (self.width, self.height);
        if y == 0 {
            self.classify_row(0);
        }
        if y + 1 < h {
            self.classify_row(y + 1);
        }
        let r = y * w;
        // Row y's residual and state bytes padded by one on each side; the rows above and
        // below (zero where there is none: their bits are masked off by the zero boundary
        // bits of row y).
        let mut pad = std::mem::take(&mut self.sign);
        let (pr, rest) = pad.split_at_mut(w + 2);
        let (ps, zero) = rest.split_at_mut(w + 2);
        let zero = &zero[..w];
        pr[1..=w].copy_from_slice(&self.resid[r..r + w]);
        ps[1..=w].copy_from_slice(&self.state[r..r + w]);
        let (res_above, res_rest) = self.resid.split_at_mut(r);
        let (res_out, res_below) = res_rest.split_at_mut(w);
        let (st_above, st_rest) = self.state.split_at_mut(r);
        let (st_out, st_below) = st_rest.split_at_mut(w);
        let (ra, sa): (&[u8], &[u8]) = if y > 0 {
            (&res_above[r - w..], &st_above[r - w..])
        } else {
            (zero, zero)
        };
        let (rb, sb): (&[u8], &[u8]) = if y + 1 < h {
            (&res_below[..w], &st_below[..w])
        } else {
            (zero, zero)
        };
        let (rl, rm, rr) = (&pr[..w], &pr[1..w + 1], &pr[2..w + 2]);
        let (sl, sm, sr) = (&ps[..w], &ps[1..w + 1], &ps[2..w + 2]);
        // Bit 0 of `not_src`: not in the source tree; bit 0 of `not_snk`: not in the sink
        // tree (state bytes here are TERMINAL, TERMINAL | SINK or FREE).
        let not_src = |s: u8| ((s & CODE == FREE) | (s & SINK != 0)) as u8;
        let not_snk = |s: u8| ((s & CODE == FREE) | (s & SINK == 0)) as u8;
        for x in 0..w {
            let out = rm[x] & 15;
            // In-bit d of p = out-bit d ^ 1 of its neighbour in direction d.
            let inn =
                (rr[x] >> 1 & 1) | (rl[x] & 1) << 1 | (rb[x] >> 3 & 1) << 2 | (ra[x] >> 2 & 1) << 3;
            res_out[x] = out | inn << 4;
            let nsrc =
                not_src(sr[x]) | not_src(sl[x]) << 1 | not_src(sb[x]) << 2 | not_src(sa[x]) << 3;
            let nsnk =
                not_snk(sr[x]) | not_snk(sl[x]) << 1 | not_snk(sb[x]) << 2 | not_snk(sa[x]) << 3;
            let s = sm[x];
            let free = s & CODE == FREE;
            let snk = s & SINK != 0;
            let grow = if snk { inn & nsnk } else { out & nsrc };
            st_out[x] = s | (((!free & (grow != 0)) as u8) * ACTIVE);
        }
        self.sign = pad;
        // Queue the active nodes in index order (branch-free append).
        let mut k = self.q_head + self.q_len;
        for x in 0..w {
            self.queue[k] = (r + x) as u32;
            k += (self.state[r + x] & ACTIVE != 0) as usize;
        }
        self.q_len = k - self.q_head;
    }

    /// Out-bits (low nibble of the residual byte) and tree membership (terminal-linked
    /// nodes start the trees, the others are free) of row `y`, from its final capacities
    /// and terminal residuals.
    fn classify_row(&mut self, y: usize) {
        let (w, n) = (self.width, self.n);
        let r = y * w;
        let (c0, c1, c2, c3) = (
            &self.cap[r..r + w],
            &self.cap[n + r..n + r + w],
            &self.cap[2 * n + r..2 * n + r + w],
            &self.cap[3 * n + r..3 * n + r + w],
        );
        for (x, o) in self.resid[r..r + w].iter_mut().enumerate() {
            *o = (c0[x].is_pos() as u8)
                | (c1[x].is_pos() as u8) << 1
                | (c2[x].is_pos() as u8) << 2
                | (c3[x].is_pos() as u8) << 3;
        }
        for (s, &t) in self.state[r..r + w].iter_mut().zip(&self.tr[r..r + w]) {
            let (src, snk) = (t.is_pos(), t < T::ZERO);
            let code = if src | snk { TERMINAL } else { FREE };
            *s = code | ((snk as u8) * SINK);
        }
    }

    /// Computes the maximum flow; returns [`GridMaxFlow::flow`]. Every call builds the
    /// search trees afresh over the current residual network.
    pub fn maxflow(&mut self) -> T::Acc {
        self.init_trees();
        let mut current = NONE;
        loop {
            let i = if current != NONE && at!(self.state, current as usize) & CODE != FREE {
                current
            } else {
                match self.pop_active() {
                    Some(i) => i,
                    None => break,
                }
            };
            current = NONE;
            let found = self.grow(i);
            if found != NONE {
                self.activate(i);
                current = i;
                self.time += 1;
                self.augment(found);
                self.adopt();
            }
        }
        self.flow
    }

    /// Grows `i`'s tree into its free neighbours; returns the source-tree → sink-tree arc
    /// as `tail * 4 + d` if the trees touch, else `NONE`.
    #[inline(always)]
    fn grow(&mut self, i: u32) -> u32 {
        let iu = i as usize;
        let si = at!(self.state, iu);
        let sink = si & SINK;
        // Source tree: arcs out of i; sink tree: arcs into i.
        let mut m = if sink == 0 {
            at!(self.resid, iu) & 15
        } else {
            at!(self.resid, iu) >> 4
        };
        if m == 0 {
            return NONE;
        }
        let (ti, di) = at!(self.td, iu);
        while m != 0 {
            let d = m.trailing_zeros();
            m &= m - 1;
            let j = self.nb(i, d);
            let ju = j as usize;
            let sj = at!(self.state, ju);
            if sj & CODE == FREE {
                // The arc from j to its parent i points back: direction d ^ 1.
                at_mut!(self.state, ju) = (sj & ACTIVE) | sink | (d ^ 1) as u8;
                at_mut!(self.td, ju) = (ti, di + 1);
                self.activate(j);
            } else if (sj ^ si) & SINK != 0 {
                return if sink == 0 {
                    i * 4 + d
                } else {
                    j * 4 + (d ^ 1)
                };
            }
        }
        NONE
    }

    /// Pushes the bottleneck flow along source-root → `mid` → sink-root (`mid` =
    /// `tail * 4 + d`, tail in the source tree).
    fn augment(&mut self, mid: u32) {
        let (a_tail, a_dir) = (mid >> 2, mid & 3);
        let a_head = self.nb(a_tail, a_dir);
        let mut b = at!(self.cap, self.ci(a_tail, a_dir));
        // Source side: the tree arc of x is parent → x, i.e. arc (parent, code ^ 1).
        let mut x = a_tail;
        loop {
            let c = (at!(self.state, x as usize) & CODE) as u32;
            if c == TERMINAL as u32 {
                break;
            }
            let p = self.nb(x, c);
            b = b.min_of(at!(self.cap, self.ci(p, c ^ 1)));
            x = p;
        }
        b = b.min_of(at!(self.tr, x as usize));
        // Sink side: the tree arc of x is x → parent, i.e. arc (x, code).
        let mut x = a_head;
        loop {
            let c = (at!(self.state, x as usize) & CODE) as u32;
            if c == TERMINAL as u32 {
                break;
            }
            b = b.min_of(at!(self.cap, self.ci(x, c)));
            x = self.nb(x, c);
        }
        b = b.min_of(-at!(self.tr, x as usize));

        let (fa, fs) = (self.ci(a_tail, a_dir), self.ci(a_head, a_dir ^ 1));
        at_mut!(self.cap, fa) -= b;
        at_mut!(self.cap, fs) += b;
        let sat = !at!(self.cap, fa).is_pos();
        self.pushed_bits(a_tail, a_dir, a_head, sat);
        let mut x = a_tail;
        loop {
            let c = (at!(self.state, x as usize) & CODE) as u32;
            if c == TERMINAL as u32 {
                break;
            }
            let p = self.nb(x, c);
            let (down, up) = (self.ci(p, c ^ 1), self.ci(x, c));
            at_mut!(self.cap, down) -= b;
            at_mut!(self.cap, up) += b;
            let sat = !at!(self.cap, down).is_pos();
            self.pushed_bits(p, c ^ 1, x, sat);
            if sat {
                self.set_code(x, ORPHAN);
                self.orphans.push(x);
            }
            x = p;
        }
        at_mut!(self.tr, x as usize) -= b;
        if !at!(self.tr, x as usize).is_pos() {
            self.set_code(x, ORPHAN);
            self.orphans.push(x);
        }
        let mut x = a_head;
        loop {
            let c = (at!(self.state, x as usize) & CODE) as u32;
            if c == TERMINAL as u32 {
                break;
            }
            let p = self.nb(x, c);
            let (up, down) = (self.ci(x, c), self.ci(p, c ^ 1));
            at_mut!(self.cap, up) -= b;
            at_mut!(self.cap, down) += b;
            let sat = !at!(self.cap, up).is_pos();
            self.pushed_bits(x, c, p, sat);
            if sat {
                self.set_code(x, ORPHAN);
                self.orphans.push(x);
            }
            x = p;
        }
        at_mut!(self.tr, x as usize) += b;
        if !(-at!(self.tr, x as usize)).is_pos() {
            self.set_code(x, ORPHAN);
            self.orphans.push(x);
        }
        self.flow += b.widen();
    }

    /// Distance from `j` to its tree's terminal, or `INF_DIST` if the path meets an orphan;
    /// stamps the path with the current time.
    #[inline(always)]
    fn origin_distance(&mut self, j: u32) -> u32 {
        let mut d = 0u32;
        let mut k = j;
        loop {
            let (ts, dist) = at!(self.td, k as usize);
            if ts == self.time {
                d += dist;
                break;
            }
            let c = (at!(self.state, k as usize) & CODE) as u32;
            d += 1;
            if c == TERMINAL as u32 {
                at_mut!(self.td, k as usize) = (self.time, 1);
                break;
            }
            if c == ORPHAN as u32 {
                return INF_DIST;
            }
            k = self.nb(k, c);
        }
        let mut k = j;
        let mut dd = d;
        while at!(self.td, k as usize).0 != self.time {
            at_mut!(self.td, k as usize) = (self.time, dd);
            dd -= 1;
            let c = (at!(self.state, k as usize) & CODE) as u32;
            k = self.nb(k, c);
        }
        d
    }

    fn adopt(&mut self) {
        let mut idx = 0;
        while idx < self.orphans.len() {
            let i = at!(self.orphans, idx);
            idx += 1;
            let iu = i as usize;
            let si = at!(self.state, iu);
            if si & CODE != ORPHAN {
                continue;
            }
            let sink = si & SINK;
            let r = at!(self.resid, iu);
            // Candidate parents: source tree, arcs into i; sink tree, arcs out of i.
            let mut m = if sink == 0 { r >> 4 } else { r & 15 };
            let mut best = NONE;
            let mut dmin = INF_DIST;
            while m != 0 {
                let d = m.trailing_zeros();
                m &= m - 1;
                let j = self.nb(i, d);
                let sj = at!(self.state, j as usize);
                if sj & SINK == sink && sj & CODE != FREE {
                    let dj = self.origin_distance(j);
                    if dj < dmin {
                        best = d;
                        dmin = dj;
                    }
                }
            }
            if best != NONE {
                self.set_code(i, best as u8);
                at_mut!(self.td, iu) = (self.time, dmin + 1);
            } else {
                self.set_code(i, FREE);
                // Non-orphan children keep an open tree arc, so every neighbour that
                // matters has some residual bit.
                let mut m = (r | r >> 4) & 15;
                while m != 0 {
                    let d = m.trailing_zeros();
                    m &= m - 1;
                    let j = self.nb(i, d);
                    let sj = at!(self.state, j as usize);
                    let cj = sj & CODE;
                    if cj == FREE {
                        continue;
                    }
                    // A source neighbour grows into i along j → i (in-bit d of i), a sink
                    // neighbour along i → j (out-bit d of i).
                    let open = if sj & SINK == 0 {
                        r >> (4 + d) & 1
                    } else {
                        r >> d & 1
                    };
                    if open != 0 {
                        self.activate(j);
                    }
                    if sj & SINK == sink && cj == (d ^ 1) as u8 {
                        self.set_code(j, ORPHAN);
                        self.orphans.push(j);
                    }
                }
            }
        }
        self.orphans.clear();
    }
}

#[inline(always)]
fn sub_assign<T: Cost>(a: &mut [T], b: &[T]) {
    for (x, &y) in a.iter_mut().zip(b) {
        *x -= y;
    }
}

#[inline(always)]
fn add_assign<T: Cost>(a: &mut [T], b: &[T]) {
    for (x, &y) in a.iter_mut().zip(b) {
        *x += y;
    }
}

/// `vec![v; n]`, but written element by element so that every page is mapped now rather
/// than on first use (`vec![0; n]` maps lazily zeroed pages): the solver's arrays are paid
/// for when the network is built, not inside [`GridMaxFlow::maxflow`] (on the benchmark
/// machine a first-touch page fault costs about 3 µs, i.e. ≈ 10 ms for a megapixel grid).
fn touched<X: Clone>(n: usize, v: X) -> Vec<X> {
    let mut a = Vec::with_capacity(n);
    a.resize(n, v);
    a
}
