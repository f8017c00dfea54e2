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

/// Boykov–Kolmogorov max-flow solver over the arc layout `Tp`, capacities of type `T`.
///
/// Build the network with [`MaxFlow::add_tweights`] and [`MaxFlow::set_arc`] (or the grid
/// helper [`MaxFlow::set_grid_edge`]), call [`MaxFlow::maxflow`], read the cut with
/// [`MaxFlow::segment`]. After a solve, [`MaxFlow::add_tweights`] and
/// [`MaxFlow::add_arc_capacity`] (increases only) may be called again and the next
/// [`MaxFlow::maxflow`] reuses the search trees and the flow already pushed.
///
/// Memory: per node `size_of::<T>() + 17` bytes (+ the topology's own), per arc
/// `size_of::<T>()` bytes.
#[derive(Clone, Debug)]
pub struct MaxFlow<T: Cost, Tp: Topology> {
    topo: Tp,
    cap: Vec<T>,
    tr: Vec<T>,
    parent: Vec<u32>,
    next: Vec<u32>,
    ts: Vec<u32>,
    dist: Vec<u32>,
    sink: Vec<bool>,
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
            parent: vec![NONE; n],
            next: vec![NONE; n],
            ts: vec![0; n],
            dist: vec![0; n],
            sink: vec![false; n],
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
        if self.parent[i] != NONE && self.sink[i] {
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
        self.parent[i] != NONE && self.sink[i]
    }

    /// Panics if a passive-tree invariant is broken (tests only).
    #[cfg(test)]
    pub(crate) fn check_invariants(&self) {
        for p in 0..self.tr.len() as u32 {
            let pu = p as usize;
            if self.parent[pu] == NONE {
                assert_eq!(self.tr[pu], T::ZERO, "free node {p} with terminal residue");
                continue;
            }
            assert!(self.parent[pu] != ORPHAN);
            let mut arcs = self.topo.arcs(p);
            while let Some(a) = arcs.next() {
                let q = self.topo.head(a) as usize;
                if !self.sink[pu] && self.cap[a as usize].is_pos() {
                    assert!(
                        self.parent[q] != NONE && !self.sink[q],
                        "source {p} -> {q} open"
                    );
                }
                if self.sink[pu] && self.cap[self.topo.sister(a) as usize].is_pos() {
                    assert!(
                        self.parent[q] != NONE && self.sink[q],
                        "{q} -> sink {p} open"
                    );
                }
            }
        }
    }

    #[inline(always)]
    fn activate(&mut self, i: u32) {
        if self.next[i as usize] == NONE {
            if self.q_last == NONE {
                self.q_first = i;
            } else {
                self.next[self.q_last as usize] = i;
            }
            self.next[i as usize] = i;
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
            let n = self.next[i as usize];
            if n == i {
                self.q_first = NONE;
                self.q_last = NONE;
            } else {
                self.q_first = n;
            }
            self.next[i as usize] = NONE;
            if self.parent[i as usize] != NONE {
                return Some(i);
            }
        }
    }

    fn init_trees(&mut self) {
        self.q_first = NONE;
        self.q_last = NONE;
        self.time = 0;
        self.orphans.clear();
        for i in 0..self.tr.len() {
            self.next[i] = NONE;
            self.ts[i] = 0;
            let r = self.tr[i];
            if r > T::ZERO {
                self.parent[i] = TERMINAL;
                self.sink[i] = false;
                self.dist[i] = 1;
                self.activate(i as u32);
            } else if r < T::ZERO {
                self.parent[i] = TERMINAL;
                self.sink[i] = true;
                self.dist[i] = 1;
                self.activate(i as u32);
            } else {
                self.parent[i] = NONE;
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
            let r = self.tr[iu];
            let in_tree = self.parent[iu] != NONE;
            let was_sink = self.sink[iu];
            if r != T::ZERO {
                let want_sink = r < T::ZERO;
                if in_tree && want_sink != was_sink {
                    // i changes tree: its children lose their path to the old terminal.
                    self.orphan_children(i, was_sink);
                }
                self.parent[iu] = TERMINAL;
                self.sink[iu] = want_sink;
                self.dist[iu] = 1;
                self.ts[iu] = self.time;
                self.activate(i);
            } else if in_tree && self.parent[iu] == TERMINAL {
                self.parent[iu] = ORPHAN;
                self.orphans.push(i);
            } else if in_tree {
                // An arc capacity changed: let i look for new paths.
                self.activate(i);
            }
            if !in_tree || self.parent[iu] == NONE {
                // A free node next to a raised arc: wake its tree neighbours.
                let mut arcs = self.topo.arcs(i);
                while let Some(a) = arcs.next() {
                    let j = self.topo.head(a);
                    if self.parent[j as usize] != NONE {
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
        let mut arcs = self.topo.arcs(i);
        while let Some(a) = arcs.next() {
            let j = self.topo.head(a) as usize;
            let pj = self.parent[j];
            if self.sink[j] == tree_sink
                && pj != NONE
                && pj != TERMINAL
                && pj != ORPHAN
                && self.topo.head(pj) == i
            {
                self.parent[j] = ORPHAN;
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
            let i = if current != NONE && self.parent[current as usize] != NONE {
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
        let (ti, di) = (self.ts[iu], self.dist[iu]);
        let mut arcs = self.topo.arcs(i);
        if !self.sink[iu] {
            while let Some(a) = arcs.next() {
                if self.cap[a as usize].is_pos() {
                    let j = self.topo.head(a);
                    let ju = j as usize;
                    if self.parent[ju] == NONE {
                        self.sink[ju] = false;
                        self.parent[ju] = self.topo.sister(a);
                        self.ts[ju] = ti;
                        self.dist[ju] = di + 1;
                        self.activate(j);
                    } else if self.sink[ju] {
                        return a;
                    } else if self.ts[ju] <= ti && self.dist[ju] > di {
                        self.parent[ju] = self.topo.sister(a);
                        self.ts[ju] = ti;
                        self.dist[ju] = di + 1;
                    }
                }
            }
        } else {
            while let Some(a) = arcs.next() {
                let s = self.topo.sister(a);
                if self.cap[s as usize].is_pos() {
                    let j = self.topo.head(a);
                    let ju = j as usize;
                    if self.parent[ju] == NONE {
                        self.sink[ju] = true;
                        self.parent[ju] = s;
                        self.ts[ju] = ti;
                        self.dist[ju] = di + 1;
                        self.activate(j);
                    } else if !self.sink[ju] {
                        return s;
                    } else if self.ts[ju] <= ti && self.dist[ju] > di {
                        self.parent[ju] = s;
                        self.ts[ju] = ti;
                        self.dist[ju] = di + 1;
                    }
                }
            }
        }
        NONE
    }

    /// Pushes the bottleneck flow along source-root → `mid` → sink-root.
    fn augment(&mut self, mid: u32) {
        let mut b = self.cap[mid as usize];
        // Source side: arcs point from child to parent; flow runs along their sisters.
        let mut i = self.topo.head(self.topo.sister(mid));
        loop {
            let pa = self.parent[i as usize];
            if pa == TERMINAL {
                break;
            }
            b = b.min_of(self.cap[self.topo.sister(pa) as usize]);
            i = self.topo.head(pa);
        }
        b = b.min_of(self.tr[i as usize]);
        let mut i = self.topo.head(mid);
        loop {
            let pa = self.parent[i as usize];
            if pa == TERMINAL {
                break;
            }
            b = b.min_of(self.cap[pa as usize]);
            i = self.topo.head(pa);
        }
        b = b.min_of(-self.tr[i as usize]);

        let ms = self.topo.sister(mid);
        self.cap[ms as usize] += b;
        self.cap[mid as usize] -= b;
        let mut i = self.topo.head(ms);
        loop {
            let pa = self.parent[i as usize];
            if pa == TERMINAL {
                break;
            }
            let up = self.topo.sister(pa);
            self.cap[pa as usize] += b;
            self.cap[up as usize] -= b;
            if !self.cap[up as usize].is_pos() {
                self.parent[i as usize] = ORPHAN;
                self.orphans.push(i);
            }
            i = self.topo.head(pa);
        }
        self.tr[i as usize] -= b;
        if !self.tr[i as usize].is_pos() {
            self.parent[i as usize] = ORPHAN;
            self.orphans.push(i);
        }
        let mut i = self.topo.head(mid);
        loop {
            let pa = self.parent[i as usize];
            if pa == TERMINAL {
                break;
            }
            let down = self.topo.sister(pa);
            self.cap[down as usize] += b;
            self.cap[pa as usize] -= b;
            if !self.cap[pa as usize].is_pos() {
                self.parent[i as usize] = ORPHAN;
                self.orphans.push(i);
            }
            i = self.topo.head(pa);
        }
        self.tr[i as usize] += b;
        if !(-self.tr[i as usize]).is_pos() {
            self.parent[i as usize] = ORPHAN;
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
            if self.ts[ku] == self.time {
                d += self.dist[ku];
                break;
            }
            let pa = self.parent[ku];
            d += 1;
            if pa == TERMINAL {
                self.ts[ku] = self.time;
                self.dist[ku] = 1;
                break;
            }
            if pa == ORPHAN {
                return INF_DIST;
            }
            k = self.topo.head(pa);
        }
        let mut k = j;
        let mut dd = d;
        while self.ts[k as usize] != self.time {
            self.ts[k as usize] = self.time;
            self.dist[k as usize] = dd;
            dd -= 1;
            k = self.topo.head(self.parent[k as usize]);
        }
        d
    }

    fn adopt(&mut self) {
        let mut idx = 0;
        while idx < self.orphans.len() {
            let i = self.orphans[idx];
            idx += 1;
            let iu = i as usize;
            if self.parent[iu] != ORPHAN {
                continue;
            }
            let is_sink = self.sink[iu];
            let mut best = NONE;
            let mut dmin = INF_DIST;
            let mut arcs = self.topo.arcs(i);
            while let Some(a) = arcs.next() {
                let residual = if is_sink {
                    self.cap[a as usize]
                } else {
                    self.cap[self.topo.sister(a) as usize]
                };
                if residual.is_pos() {
                    let j = self.topo.head(a);
                    let ju = j as usize;
                    if self.sink[ju] == is_sink && self.parent[ju] != NONE {
                        let d = self.origin_distance(j);
                        if d < dmin {
                            best = a;
                            dmin = d;
                        }
                    }
                }
            }
            if best != NONE {
                self.parent[iu] = best;
                self.ts[iu] = self.time;
                self.dist[iu] = dmin + 1;
            } else {
                self.parent[iu] = NONE;
                let mut arcs = self.topo.arcs(i);
                while let Some(a) = arcs.next() {
                    let j = self.topo.head(a);
                    let ju = j as usize;
                    let pj = self.parent[ju];
                    if pj != NONE {
                        // Any tree neighbour that could grow into i must look again (after
                        // tree reuse the other tree may border i through an open arc).
                        let residual = if self.sink[ju] {
                            self.cap[a as usize]
                        } else {
                            self.cap[self.topo.sister(a) as usize]
                        };
                        if residual.is_pos() {
                            self.activate(j);
                        }
                        if self.sink[ju] == is_sink
                            && pj != TERMINAL
                            && pj != ORPHAN
                            && self.topo.head(pj) == i
                        {
                            self.parent[ju] = ORPHAN;
                            self.orphans.push(j);
                        }
                    }
                }
            }
        }
        self.orphans.clear();
    }
}
