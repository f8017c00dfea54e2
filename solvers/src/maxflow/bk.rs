//! Boykov–Kolmogorov max-flow (PAMI 2004) over a [`Topology`], with search-tree reuse
//! after terminal-capacity changes (Kohli & Torr 2005, "dynamic graph cuts").
//!
//! Storage is flat: per node a signed residual terminal capacity `tr` (positive: residual
//! source→node capacity, negative: residual node→sink capacity), the parent arc (`u32`), the
//! active-queue link, a time stamp and a distance estimate, and the tree bit; per arc only
//! the residual capacity (the topology supplies heads and sisters).
use super::topology::Topology;
use crate::cost::Cost;

const NONE: u32 = u32::MAX;
const TERMINAL: u32 = u32::MAX - 1;
const ORPHAN: u32 = u32::MAX - 2;
const INF_DIST: u32 = u32::MAX;

/// Which side of the minimum cut a node lies on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Segment {
    /// Reachable from the source in the residual graph (or free: ties go to the source).
    Source,
    /// Can reach the sink in the residual graph.
    Sink,
}

/// Search-tree state of one node, 16 bytes (four per cache line).
#[derive(Clone, Copy, Debug)]
struct Node {
    /// Arc to the parent in the search tree, or `NONE` / `TERMINAL` / `ORPHAN`.
    parent: u32,
    /// Next node in the active queue (`NONE`: not queued; itself: last).
    next: u32,
    /// Time stamp of the last distance update.
    ts: u32,
    /// Distance to the terminal (bits 0..31) and tree bit (bit 31: sink tree).
    dist_sink: u32,
}

const SINK_BIT: u32 = 1 << 31;

impl Default for Node {
    fn default() -> Self {
        Node {
            parent: NONE,
            next: NONE,
            ts: 0,
            dist_sink: 0,
        }
    }
}

impl Node {
    #[inline(always)]
    fn sink(&self) -> bool {
        self.dist_sink & SINK_BIT != 0
    }
    #[inline(always)]
    fn set_sink(&mut self, s: bool) {
        self.dist_sink = (self.dist_sink & !SINK_BIT) | if s { SINK_BIT } else { 0 };
    }
    #[inline(always)]
    fn dist(&self) -> u32 {
        self.dist_sink & !SINK_BIT
    }
    #[inline(always)]
    fn set_dist(&mut self, d: u32) {
        self.dist_sink = (self.dist_sink & SINK_BIT) | d;
    }
}

/// Boykov–Kolmogorov max-flow solver over the arc layout `Tp`, capacities of type `T`.
///
/// Build the network with [`MaxFlow::add_tweights`] and [`MaxFlow::set_arc`] (or the grid
/// helper [`MaxFlow::set_grid_edge`]), call [`MaxFlow::maxflow`], read the cut with
/// [`MaxFlow::segment`]. After a solve, [`MaxFlow::add_tweights`] and
/// [`MaxFlow::add_arc_capacity`] (increases only) may be called again and the next
/// [`MaxFlow::maxflow`] reuses the search trees and the flow already pushed.
///
/// Memory: per node `size_of::<T>() + 16` bytes (+ 1 byte bookkeeping for tree reuse) (+ the topology's own), per arc
/// `size_of::<T>()` bytes.
#[derive(Clone, Debug)]
pub struct MaxFlow<T: Cost, Tp: Topology> {
    topo: Tp,
    cap: Vec<T>,
    tr: Vec<T>,
    nodes: Vec<Node>,
    q_first: u32,
    q_last: u32,
    orphans: Vec<u32>,
    changed: Vec<u32>,
    is_changed: Vec<bool>,
    time: u32,
    flow: T::Acc,
    solved: bool,
}

impl<T: Cost, Tp: Topology> MaxFlow<T, Tp> {
    /// An empty network (all capacities zero) over `topo`.
    pub fn new(topo: Tp) -> Self {
        let n = topo.num_nodes();
        let m = topo.num_arcs();
        MaxFlow {
            cap: vec![T::ZERO; m],
            tr: vec![T::ZERO; n],
            nodes: vec![Node::default(); n],
            q_first: NONE,
            q_last: NONE,
            orphans: Vec::new(),
            changed: Vec::new(),
            is_changed: vec![false; n],
            time: 0,
            flow: T::Acc::default(),
            solved: false,
            topo,
        }
    }

    /// The arc layout.
    pub fn topology(&self) -> &Tp {
        &self.topo
    }

    /// Number of nodes.
    pub fn num_nodes(&self) -> usize {
        self.tr.len()
    }

    /// Zeroes every capacity and forgets the flow and the search trees, keeping the
    /// allocation (for building the next network over the same layout).
    pub fn reset(&mut self) {
        self.cap.fill(T::ZERO);
        self.tr.fill(T::ZERO);
        self.flow = T::Acc::default();
        self.solved = false;
        for &i in &self.changed {
            self.is_changed[i as usize] = false;
        }
        self.changed.clear();
    }

    /// Starts rebuilding the whole network in place: forgets the flow and the trees and
    /// hands out the topology, the arc capacities and the signed terminal capacities
    /// (`tr[i] > 0`: source→i capacity, `tr[i] < 0`: i→sink capacity `-tr[i]`). The caller
    /// must overwrite **every** arc capacity that the topology enumerates and every `tr`
    /// (this avoids a separate zeroing pass). Used by the move solvers.
    pub fn rebuild(&mut self) -> (&Tp, &mut [T], &mut [T]) {
        self.flow = T::Acc::default();
        self.solved = false;
        for &i in &self.changed {
            self.is_changed[i as usize] = false;
        }
        self.changed.clear();
        (&self.topo, &mut self.cap, &mut self.tr)
    }

    /// Sets the residual capacity of one arc (before the first solve).
    pub fn set_arc(&mut self, arc: u32, cap: T) {
        debug_assert!(!self.solved, "use add_arc_capacity after a solve");
        self.cap[arc as usize] = cap;
    }

    /// Adds terminal capacities `source_cap` (paid if the node ends on the sink side) and
    /// `sink_cap` (paid if it ends on the source side). Negative values are allowed: they
    /// are folded into a constant, so [`MaxFlow::flow`] is then the minimum cut value plus
    /// that constant. May be called after a solve; the next solve reuses the trees.
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
        if self.solved {
            self.mark(node);
        }
    }

    /// Increases the residual capacity of `arc` by `delta ≥ 0`; usable after a solve (the
    /// next solve reuses the trees).
    pub fn add_arc_capacity(&mut self, arc: u32, delta: T) {
        debug_assert!(delta >= T::ZERO);
        self.cap[arc as usize] += delta;
        if self.solved {
            let tail = self.topo.head(self.topo.sister(arc));
            let head = self.topo.head(arc);
            self.mark(tail);
            self.mark(head);
        }
    }

    fn mark(&mut self, node: u32) {
        if !self.is_changed[node as usize] {
            self.is_changed[node as usize] = true;
            self.changed.push(node);
        }
    }

    /// The value of the maximum flow (= minimum cut) found by the last solve, plus the
    /// constants folded in by [`MaxFlow::add_tweights`].
    pub fn flow(&self) -> T::Acc {
        self.flow
    }

    /// Side of the minimum cut of `node` after a solve.
    #[inline]
    pub fn segment(&self, node: u32) -> Segment {
        let i = node as usize;
        if self.nodes[i].parent != NONE && self.nodes[i].sink() {
            Segment::Sink
        } else {
            Segment::Source
        }
    }

    /// Whether `node` ends on the sink side (the convention used by the move solvers:
    /// sink side = label 1).
    #[inline]
    pub fn is_sink(&self, node: u32) -> bool {
        let i = node as usize;
        self.nodes[i].parent != NONE && self.nodes[i].sink()
    }

    /// Panics if a passive-tree invariant is broken (tests only).
    #[cfg(test)]
    pub(crate) fn check_invariants(&self) {
        for p in 0..self.tr.len() as u32 {
            let pu = p as usize;
            if self.nodes[pu].parent == NONE {
                assert_eq!(self.tr[pu], T::ZERO, "free node {p} with terminal residue");
                continue;
            }
            assert!(self.nodes[pu].parent != ORPHAN);
            let arcs = self.topo.arcs(p);
            for a in arcs {
                let q = self.topo.head(a) as usize;
                if !self.nodes[pu].sink() && self.cap[a as usize].is_pos() {
                    assert!(
                        self.nodes[q].parent != NONE && !self.nodes[q].sink(),
                        "source {p} -> {q} open"
                    );
                }
                if self.nodes[pu].sink() && self.cap[self.topo.sister(a) as usize].is_pos() {
                    assert!(
                        self.nodes[q].parent != NONE && self.nodes[q].sink(),
                        "{q} -> sink {p} open"
                    );
                }
            }
        }
    }

    #[inline(always)]
    fn activate(&mut self, i: u32) {
        if at!(self.nodes, i as usize).next == NONE {
            if self.q_last == NONE {
                self.q_first = i;
            } else {
                at_mut!(self.nodes, self.q_last as usize).next = i;
            }
            at_mut!(self.nodes, i as usize).next = i;
            self.q_last = i;
        }
    }

    #[inline(always)]
    fn pop_active(&mut self) -> Option<u32> {
        loop {
            let i = self.q_first;
            if i == NONE {
                return None;
            }
            let n = at!(self.nodes, i as usize).next;
            if n == i {
                self.q_first = NONE;
                self.q_last = NONE;
            } else {
                self.q_first = n;
            }
            at_mut!(self.nodes, i as usize).next = NONE;
            if at!(self.nodes, i as usize).parent != NONE {
                return Some(i);
            }
        }
    }

    /// Saturates the length-two paths source → p → q → sink and builds the initial trees
    /// in one linear pass: on image grids most of the flow takes such paths, and pushing it
    /// here is far cheaper than discovering each path by tree growth. Node `p` is pushed
    /// from, then classified; a node `q < p` already classified as sink-linked whose
    /// residual a later push exhausts becomes free again (it stays in the queue; popping
    /// skips free nodes).
    fn init_trees(&mut self) {
        self.q_first = NONE;
        self.q_last = NONE;
        self.time = 0;
        self.orphans.clear();
        for p in 0..self.tr.len() as u32 {
            let pu = p as usize;
            let mut rp = at!(self.tr, pu);
            if rp.is_pos() {
                let arcs = self.topo.arcs(p);
                for a in arcs {
                    let c = at!(self.cap, a as usize);
                    if !c.is_pos() {
                        continue;
                    }
                    let q = self.topo.head(a) as usize;
                    let rq = -at!(self.tr, q);
                    if !rq.is_pos() {
                        continue;
                    }
                    let b = rp.min_of(rq).min_of(c);
                    rp -= b;
                    at_mut!(self.tr, q) += b;
                    at_mut!(self.cap, a as usize) = c - b;
                    at_mut!(self.cap, self.topo.sister(a) as usize) += b;
                    self.flow += b.widen();
                    if q < pu && at!(self.tr, q) == T::ZERO {
                        at_mut!(self.nodes, q).parent = NONE;
                    }
                    if !rp.is_pos() {
                        break;
                    }
                }
                at_mut!(self.tr, pu) = rp;
            }
            at_mut!(self.nodes, pu).next = NONE;
            at_mut!(self.nodes, pu).ts = 0;
            if rp > T::ZERO {
                at_mut!(self.nodes, pu).parent = TERMINAL;
                at_mut!(self.nodes, pu).set_sink(false);
                at_mut!(self.nodes, pu).set_dist(1);
                self.activate(p);
            } else if rp < T::ZERO {
                at_mut!(self.nodes, pu).parent = TERMINAL;
                at_mut!(self.nodes, pu).set_sink(true);
                at_mut!(self.nodes, pu).set_dist(1);
                self.activate(p);
            } else {
                at_mut!(self.nodes, pu).parent = NONE;
            }
        }
        for &i in &self.changed {
            self.is_changed[i as usize] = false;
        }
        self.changed.clear();
    }

    /// Repairs the trees around nodes whose capacities changed since the last solve.
    fn reuse_trees(&mut self) {
        self.time += 1;
        let changed = std::mem::take(&mut self.changed);
        for &i in &changed {
            self.is_changed[i as usize] = false;
            let iu = i as usize;
            let r = at!(self.tr, iu);
            let in_tree = at!(self.nodes, iu).parent != NONE;
            let was_sink = at!(self.nodes, iu).sink();
            if r != T::ZERO {
                let want_sink = r < T::ZERO;
                if in_tree && want_sink != was_sink {
                    // i changes tree: its children lose their path to the old terminal.
                    self.orphan_children(i, was_sink);
                }
                at_mut!(self.nodes, iu).parent = TERMINAL;
                at_mut!(self.nodes, iu).set_sink(want_sink);
                at_mut!(self.nodes, iu).set_dist(1);
                at_mut!(self.nodes, iu).ts = self.time;
                self.activate(i);
            } else if in_tree && at!(self.nodes, iu).parent == TERMINAL {
                at_mut!(self.nodes, iu).parent = ORPHAN;
                self.orphans.push(i);
            } else if in_tree {
                // An arc capacity changed: let i look for new paths.
                self.activate(i);
            }
            if !in_tree || at!(self.nodes, iu).parent == NONE {
                // A free node next to a raised arc: wake its tree neighbours.
                let arcs = self.topo.arcs(i);
                for a in arcs {
                    let j = self.topo.head(a);
                    if at!(self.nodes, j as usize).parent != NONE {
                        self.activate(j);
                    }
                }
            }
        }
        self.changed = changed;
        self.changed.clear();
        self.adopt();
    }

    fn orphan_children(&mut self, i: u32, tree_sink: bool) {
        let arcs = self.topo.arcs(i);
        for a in arcs {
            let j = self.topo.head(a) as usize;
            let pj = at!(self.nodes, j).parent;
            if at!(self.nodes, j).sink() == tree_sink
                && pj != NONE
                && pj != TERMINAL
                && pj != ORPHAN
                && self.topo.head(pj) == i
            {
                at_mut!(self.nodes, j).parent = ORPHAN;
                self.orphans.push(j as u32);
            }
        }
    }

    /// Computes the maximum flow; returns [`MaxFlow::flow`]. A second call after capacity
    /// changes reuses the search trees (dynamic graph cuts).
    pub fn maxflow(&mut self) -> T::Acc {
        if self.solved {
            self.reuse_trees();
        } else {
            self.init_trees();
        }
        self.solved = true;
        let mut current = NONE;
        loop {
            let i = if current != NONE && at!(self.nodes, current as usize).parent != NONE {
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
                // Keep i active while it may still have residual arcs to the other tree.
                self.activate(i);
                current = i;
                self.time += 1;
                self.augment(found);
                self.adopt();
            }
        }
        self.flow
    }

    /// Grows the tree of `i` by one layer; returns an arc from the source tree to the sink
    /// tree if the trees touch, else `NONE`.
    #[inline(always)]
    fn grow(&mut self, i: u32) -> u32 {
        let iu = i as usize;
        let (ti, di) = (at!(self.nodes, iu).ts, at!(self.nodes, iu).dist());
        let arcs = self.topo.arcs(i);
        if !at!(self.nodes, iu).sink() {
            for a in arcs {
                if at!(self.cap, a as usize).is_pos() {
                    let j = self.topo.head(a);
                    let ju = j as usize;
                    if at!(self.nodes, ju).parent == NONE {
                        at_mut!(self.nodes, ju).set_sink(false);
                        at_mut!(self.nodes, ju).parent = self.topo.sister(a);
                        at_mut!(self.nodes, ju).ts = ti;
                        at_mut!(self.nodes, ju).set_dist(di + 1);
                        self.activate(j);
                    } else if at!(self.nodes, ju).sink() {
                        return a;
                    } else if at!(self.nodes, ju).ts <= ti && at!(self.nodes, ju).dist() > di {
                        at_mut!(self.nodes, ju).parent = self.topo.sister(a);
                        at_mut!(self.nodes, ju).ts = ti;
                        at_mut!(self.nodes, ju).set_dist(di + 1);
                    }
                }
            }
        } else {
            for a in arcs {
                let s = self.topo.sister(a);
                if at!(self.cap, s as usize).is_pos() {
                    let j = self.topo.head(a);
                    let ju = j as usize;
                    if at!(self.nodes, ju).parent == NONE {
                        at_mut!(self.nodes, ju).set_sink(true);
                        at_mut!(self.nodes, ju).parent = s;
                        at_mut!(self.nodes, ju).ts = ti;
                        at_mut!(self.nodes, ju).set_dist(di + 1);
                        self.activate(j);
                    } else if !at!(self.nodes, ju).sink() {
                        return s;
                    } else if at!(self.nodes, ju).ts <= ti && at!(self.nodes, ju).dist() > di {
                        at_mut!(self.nodes, ju).parent = s;
                        at_mut!(self.nodes, ju).ts = ti;
                        at_mut!(self.nodes, ju).set_dist(di + 1);
                    }
                }
            }
        }
        NONE
    }

    /// Pushes the bottleneck flow along source-root → `mid` → sink-root.
    fn augment(&mut self, mid: u32) {
        let mut b = at!(self.cap, mid as usize);
        // Source side: arcs point from child to parent; flow runs along their sisters.
        let mut i = self.topo.head(self.topo.sister(mid));
        loop {
            let pa = at!(self.nodes, i as usize).parent;
            if pa == TERMINAL {
                break;
            }
            b = b.min_of(at!(self.cap, self.topo.sister(pa) as usize));
            i = self.topo.head(pa);
        }
        b = b.min_of(at!(self.tr, i as usize));
        let mut i = self.topo.head(mid);
        loop {
            let pa = at!(self.nodes, i as usize).parent;
            if pa == TERMINAL {
                break;
            }
            b = b.min_of(at!(self.cap, pa as usize));
            i = self.topo.head(pa);
        }
        b = b.min_of(-at!(self.tr, i as usize));

        let ms = self.topo.sister(mid);
        at_mut!(self.cap, ms as usize) += b;
        at_mut!(self.cap, mid as usize) -= b;
        let mut i = self.topo.head(ms);
        loop {
            let pa = at!(self.nodes, i as usize).parent;
            if pa == TERMINAL {
                break;
            }
            let up = self.topo.sister(pa);
            at_mut!(self.cap, pa as usize) += b;
            at_mut!(self.cap, up as usize) -= b;
            if !at!(self.cap, up as usize).is_pos() {
                at_mut!(self.nodes, i as usize).parent = ORPHAN;
                self.orphans.push(i);
            }
            i = self.topo.head(pa);
        }
        at_mut!(self.tr, i as usize) -= b;
        if !at!(self.tr, i as usize).is_pos() {
            at_mut!(self.nodes, i as usize).parent = ORPHAN;
            self.orphans.push(i);
        }
        let mut i = self.topo.head(mid);
        loop {
            let pa = at!(self.nodes, i as usize).parent;
            if pa == TERMINAL {
                break;
            }
            let down = self.topo.sister(pa);
            at_mut!(self.cap, down as usize) += b;
            at_mut!(self.cap, pa as usize) -= b;
            if !at!(self.cap, pa as usize).is_pos() {
                at_mut!(self.nodes, i as usize).parent = ORPHAN;
                self.orphans.push(i);
            }
            i = self.topo.head(pa);
        }
        at_mut!(self.tr, i as usize) += b;
        if !(-at!(self.tr, i as usize)).is_pos() {
            at_mut!(self.nodes, i as usize).parent = ORPHAN;
            self.orphans.push(i);
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
            let ku = k as usize;
            if at!(self.nodes, ku).ts == self.time {
                d += at!(self.nodes, ku).dist();
                break;
            }
            let pa = at!(self.nodes, ku).parent;
            d += 1;
            if pa == TERMINAL {
                at_mut!(self.nodes, ku).ts = self.time;
                at_mut!(self.nodes, ku).set_dist(1);
                break;
            }
            if pa == ORPHAN {
                return INF_DIST;
            }
            k = self.topo.head(pa);
        }
        let mut k = j;
        let mut dd = d;
        while at!(self.nodes, k as usize).ts != self.time {
            at_mut!(self.nodes, k as usize).ts = self.time;
            at_mut!(self.nodes, k as usize).set_dist(dd);
            dd -= 1;
            k = self.topo.head(at!(self.nodes, k as usize).parent);
        }
        d
    }

    fn adopt(&mut self) {
        let mut idx = 0;
        while idx < self.orphans.len() {
            let i = self.orphans[idx];
            idx += 1;
            let iu = i as usize;
            if at!(self.nodes, iu).parent != ORPHAN {
                continue;
            }
            let is_sink = at!(self.nodes, iu).sink();
            let mut best = NONE;
            let mut dmin = INF_DIST;
            let arcs = self.topo.arcs(i);
            for a in arcs {
                let residual = if is_sink {
                    at!(self.cap, a as usize)
                } else {
                    at!(self.cap, self.topo.sister(a) as usize)
                };
                if residual.is_pos() {
                    let j = self.topo.head(a);
                    let ju = j as usize;
                    if at!(self.nodes, ju).sink() == is_sink && at!(self.nodes, ju).parent != NONE {
                        let d = self.origin_distance(j);
                        if d < dmin {
                            best = a;
                            dmin = d;
                        }
                    }
                }
            }
            if best != NONE {
                at_mut!(self.nodes, iu).parent = best;
                at_mut!(self.nodes, iu).ts = self.time;
                at_mut!(self.nodes, iu).set_dist(dmin + 1);
            } else {
                at_mut!(self.nodes, iu).parent = NONE;
                let arcs = self.topo.arcs(i);
                for a in arcs {
                    let j = self.topo.head(a);
                    let ju = j as usize;
                    let pj = at!(self.nodes, ju).parent;
                    if pj != NONE {
                        // Any tree neighbour that could grow into i must look again (after
                        // tree reuse the other tree may border i through an open arc).
                        let residual = if at!(self.nodes, ju).sink() {
                            at!(self.cap, a as usize)
                        } else {
                            at!(self.cap, self.topo.sister(a) as usize)
                        };
                        if residual.is_pos() {
                            self.activate(j);
                        }
                        if at!(self.nodes, ju).sink() == is_sink
                            && pj != TERMINAL
                            && pj != ORPHAN
                            && self.topo.head(pj) == i
                        {
                            at_mut!(self.nodes, ju).parent = ORPHAN;
                            self.orphans.push(j);
                        }
                    }
                }
            }
        }
        self.orphans.clear();
    }
}
