//! Max-flow / min-cut for the binary subproblems of the move-making solvers.
//!
//! [`MaxFlow`] is a Boykov–Kolmogorov solver generic over the capacity type ([`Cost`]) and
//! the arc layout ([`Topology`]): [`GridTopology`] for 4- and 8-connected pixel grids with
//! implicit neighbour arcs, [`CsrTopology`] for general graphs (built by [`GraphBuilder`]).

/// Unchecked indexing for the solver's hot loops. Every index is a node or arc produced by
/// the topology (validated when the network was built) or a stored parent arc, so it is in
/// range by construction; debug builds still check.
macro_rules! at {
    ($v:expr, $i:expr) => {{
        let i = $i;
        debug_assert!(i < $v.len());
        // SAFETY: see the macro's doc: indices come from the topology and are in range.
        *unsafe { $v.get_unchecked(i) }
    }};
}
macro_rules! at_mut {
    ($v:expr, $i:expr) => {
        (*{
            let i = $i;
            debug_assert!(i < $v.len());
            // SAFETY: as for `at!`.
            unsafe { $v.get_unchecked_mut(i) }
        })
    };
}

mod bk;
mod grid4;
mod topology;

pub use bk::{MaxFlow, Segment};
pub use grid4::GridMaxFlow;
pub use topology::{
    Connectivity, CsrTopology, Grid4Arcs, Grid4Topology, GridArcs, GridTopology, Topology,
    GRID_DIRECTIONS,
};

use crate::cost::Cost;

impl<T: Cost> MaxFlow<T, GridTopology> {
    /// An empty `width × height` grid network.
    pub fn grid(width: usize, height: usize, connectivity: Connectivity) -> Self {
        MaxFlow::new(GridTopology::new(width, height, connectivity))
    }

    /// Sets the capacities of the edge from `node` in direction `dir` (see
    /// [`GRID_DIRECTIONS`]): `cap` for `node → neighbour`, `rev_cap` for the reverse.
    /// Returns `false` (and does nothing) if the neighbour lies outside the grid. Before the
    /// first solve only.
    pub fn set_grid_edge(&mut self, node: u32, dir: usize, cap: T, rev_cap: T) -> bool {
        match self.topology().arc(node, dir) {
            Some(a) => {
                let s = self.topology().sister(a);
                self.set_arc(a, cap);
                self.set_arc(s, rev_cap);
                true
            }
            None => false,
        }
    }
}

/// Collects nodes and edges of a general network, then lays it out in CSR form.
#[derive(Clone, Debug, Default)]
pub struct GraphBuilder<T: Cost> {
    num_nodes: usize,
    edges: Vec<[u32; 2]>,
    caps: Vec<[T; 2]>,
    tweights: Vec<(u32, T, T)>,
}

impl<T: Cost> GraphBuilder<T> {
    /// A builder with `num_nodes` nodes and no edges.
    pub fn new(num_nodes: usize) -> Self {
        GraphBuilder {
            num_nodes,
            ..Default::default()
        }
    }
    /// Adds one node; returns its index.
    pub fn add_node(&mut self) -> u32 {
        self.num_nodes += 1;
        (self.num_nodes - 1) as u32
    }
    /// Number of nodes so far.
    pub fn num_nodes(&self) -> usize {
        self.num_nodes
    }
    /// Adds an edge with capacity `cap` for `p → q` and `rev_cap` for `q → p`. Parallel
    /// edges are allowed. Panics on an out-of-range endpoint (a programming error).
    pub fn add_edge(&mut self, p: u32, q: u32, cap: T, rev_cap: T) {
        assert!((p as usize) < self.num_nodes && (q as usize) < self.num_nodes);
        self.edges.push([p, q]);
        self.caps.push([cap, rev_cap]);
    }
    /// Adds terminal capacities (see [`MaxFlow::add_tweights`]).
    pub fn add_tweights(&mut self, node: u32, source_cap: T, sink_cap: T) {
        self.tweights.push((node, source_cap, sink_cap));
    }
    /// Lays the network out in CSR form, ready for [`MaxFlow::maxflow`].
    pub fn build(&self) -> MaxFlow<T, CsrTopology> {
        let (topo, fwd) = CsrTopology::from_edges(self.num_nodes, &self.edges);
        let mut mf = MaxFlow::new(topo);
        for (e, &a) in fwd.iter().enumerate() {
            let s = mf.topology().sister(a);
            mf.set_arc(a, self.caps[e][0]);
            mf.set_arc(s, self.caps[e][1]);
        }
        for &(n, s, t) in &self.tweights {
            mf.add_tweights(n, s, t);
        }
        mf
    }
}

#[cfg(test)]
mod tests;
