//! Arc layouts for the max-flow solver: implicit pixel grids and general graphs in CSR form.
//!
//! Arcs are identified by `u32` indices into a flat capacity array. Every arc has a sister
//! (the reverse arc), and the arcs leaving one node are contiguous, so growing a search tree
//! walks memory linearly.

/// How the max-flow solver sees a graph: the arcs out of each node, their heads and sisters.
///
/// Implemented by [`GridTopology`] (implicit neighbour arcs, nothing stored per arc but the
/// capacity) and [`CsrTopology`] (general graphs, head and sister stored per arc).
pub trait Topology {
    /// Iterator over the arc indices leaving one node.
    type Arcs: Iterator<Item = u32>;
    /// Number of nodes.
    fn num_nodes(&self) -> usize;
    /// Size of the arc index space (capacity array length). For grids this includes the
    /// unused slots of boundary nodes.
    fn num_arcs(&self) -> usize;
    /// The arcs leaving `node`.
    fn arcs(&self, node: u32) -> Self::Arcs;
    /// The node an arc points to.
    fn head(&self, arc: u32) -> u32;
    /// The reverse arc of `arc`.
    fn sister(&self, arc: u32) -> u32;
    /// Whether `arc` is the canonical ("forward") one of its pair; each undirected edge has
    /// exactly one forward arc.
    fn is_forward(&self, arc: u32) -> bool;
    /// Index of the undirected edge an arc belongs to (into the per-edge weight array).
    fn edge_of(&self, arc: u32) -> usize;
    /// Size of the edge index space.
    fn num_edges(&self) -> usize;
    /// `Some((width, height))` if this is a 4-connected grid whose edge indices are
    /// [`GridTopology`]'s (`node * 2 + d / 2`), so that [`GridMaxFlow`](super::GridMaxFlow)
    /// can solve it.
    fn grid4_size(&self) -> Option<(usize, usize)> {
        None
    }
}

/// Neighbourhood of a pixel grid.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Connectivity {
    /// Right, left, down, up.
    Four,
    /// The four axis neighbours and the four diagonals.
    Eight,
}

impl Connectivity {
    /// Number of arc directions per node (4 or 8).
    pub fn directions(self) -> usize {
        match self {
            Connectivity::Four => 4,
            Connectivity::Eight => 8,
        }
    }
}

/// Direction offsets `(dx, dy)`; direction `d` and `d ^ 1` are opposite, even directions are
/// forward: 0 right, 1 left, 2 down, 3 up, 4 down-right, 5 up-left, 6 down-left, 7 up-right.
pub const GRID_DIRECTIONS: [(i32, i32); 8] = [
    (1, 0),
    (-1, 0),
    (0, 1),
    (0, -1),
    (1, 1),
    (-1, -1),
    (-1, 1),
    (1, -1),
];

/// A `width × height` pixel grid, nodes numbered row-major (`y * width + x`).
///
/// Arc `node * K + d` goes from `node` in direction `d` of [`GRID_DIRECTIONS`] (`K` = 4 or
/// 8); its sister is `head * K + (d ^ 1)`. Arcs that would leave the grid are never
/// enumerated (a per-node direction mask, one byte per node). Edge `node * K/2 + d/2` is the
/// undirected edge of the forward arc `node * K + d` (`d` even).
#[derive(Clone, Debug)]
pub struct GridTopology {
    width: u32,
    height: u32,
    shift: u32,
    offsets: [i64; 8],
    mask: Vec<u8>,
}

impl GridTopology {
    /// A grid of `width × height` nodes. Panics if `width * height * 8` overflows `u32`.
    pub fn new(width: usize, height: usize, connectivity: Connectivity) -> Self {
        let k = connectivity.directions();
        assert!(
            (width as u64) * (height as u64) * (k as u64) < u32::MAX as u64,
            "grid too large for 32-bit arc indices"
        );
        let mut offsets = [0i64; 8];
        for (d, (dx, dy)) in GRID_DIRECTIONS.iter().enumerate().take(k) {
            offsets[d] = *dy as i64 * width as i64 + *dx as i64;
        }
        let mut mask = vec![0u8; width * height];
        for y in 0..height {
            for x in 0..width {
                let mut m = 0u8;
                for (d, (dx, dy)) in GRID_DIRECTIONS.iter().enumerate().take(k) {
                    let (nx, ny) = (x as i64 + *dx as i64, y as i64 + *dy as i64);
                    if nx >= 0 && ny >= 0 && nx < width as i64 && ny < height as i64 {
                        m |= 1 << d;
                    }
                }
                mask[y * width + x] = m;
            }
        }
        GridTopology {
            width: width as u32,
            height: height as u32,
            shift: k.trailing_zeros(),
            offsets,
            mask,
        }
    }
    /// Grid width in nodes.
    pub fn width(&self) -> usize {
        self.width as usize
    }
    /// Grid height in nodes.
    pub fn height(&self) -> usize {
        self.height as usize
    }
    /// Directions per node (4 or 8).
    pub fn directions(&self) -> usize {
        1 << self.shift
    }
    /// The arc leaving `node` in direction `d`, if it stays inside the grid.
    pub fn arc(&self, node: u32, d: usize) -> Option<u32> {
        if d < self.directions() && self.mask[node as usize] & (1 << d) != 0 {
            Some((node << self.shift) | d as u32)
        } else {
            None
        }
    }
}

/// Iterator over the set bits of a grid node's direction mask.
pub struct GridArcs {
    base: u32,
    mask: u32,
}

impl Iterator for GridArcs {
    type Item = u32;
    #[inline(always)]
    fn next(&mut self) -> Option<u32> {
        if self.mask == 0 {
            None
        } else {
            let d = self.mask.trailing_zeros();
            self.mask &= self.mask - 1;
            Some(self.base | d)
        }
    }
}

impl Topology for GridTopology {
    type Arcs = GridArcs;
    #[inline(always)]
    fn num_nodes(&self) -> usize {
        self.mask.len()
    }
    #[inline(always)]
    fn num_arcs(&self) -> usize {
        self.mask.len() << self.shift
    }
    #[inline(always)]
    fn arcs(&self, node: u32) -> GridArcs {
        GridArcs {
            base: node << self.shift,
            mask: self.mask[node as usize] as u32,
        }
    }
    #[inline(always)]
    fn head(&self, arc: u32) -> u32 {
        let d = (arc & ((1 << self.shift) - 1)) as usize;
        ((arc >> self.shift) as i64 + self.offsets[d]) as u32
    }
    #[inline(always)]
    fn sister(&self, arc: u32) -> u32 {
        let d = arc & ((1 << self.shift) - 1);
        (self.head(arc) << self.shift) | (d ^ 1)
    }
    #[inline(always)]
    fn is_forward(&self, arc: u32) -> bool {
        arc & 1 == 0
    }
    #[inline(always)]
    fn edge_of(&self, arc: u32) -> usize {
        let fwd = if arc & 1 == 0 { arc } else { self.sister(arc) };
        (fwd >> 1) as usize
    }
    fn num_edges(&self) -> usize {
        self.mask.len() << (self.shift - 1)
    }
    fn grid4_size(&self) -> Option<(usize, usize)> {
        (self.shift == 2).then_some((self.width as usize, self.height as usize))
    }
}

/// A 4-connected `width × height` grid with direction-major arcs: arc `d * n + node` leaves
/// `node` in direction `d` of [`GRID_DIRECTIONS`] (`n` nodes), so each direction's
/// capacities form one contiguous array (the layout of
/// [`GridMaxFlow`](super::GridMaxFlow), whose initialisation runs vectorised row passes
/// over them). Edge indices are [`GridTopology`]'s: `node * 2 + d / 2` for the forward arc
/// (`d` even).
#[derive(Clone, Debug)]
pub struct Grid4Topology {
    grid: GridTopology,
    n: u32,
}

impl Grid4Topology {
    /// A 4-connected grid of `width × height` nodes. Panics if `4 * width * height`
    /// overflows `u32`.
    pub fn new(width: usize, height: usize) -> Self {
        let grid = GridTopology::new(width, height, Connectivity::Four);
        Grid4Topology {
            n: (width * height) as u32,
            grid,
        }
    }
    /// Grid width in nodes.
    pub fn width(&self) -> usize {
        self.grid.width()
    }
    /// Grid height in nodes.
    pub fn height(&self) -> usize {
        self.grid.height()
    }
    /// The arc leaving `node` in direction `d` (0..4), if it stays inside the grid.
    pub fn arc(&self, node: u32, d: usize) -> Option<u32> {
        self.grid.arc(node, d).map(|_| d as u32 * self.n + node)
    }
    /// Direction and tail of an arc.
    #[inline(always)]
    fn split(&self, arc: u32) -> (u32, u32) {
        let n = self.n;
        let d = (arc >= n) as u32 + (arc >= 2 * n) as u32 + (arc >= 3 * n) as u32;
        (d, arc - d * n)
    }
}

/// Iterator over the arcs of one node of a [`Grid4Topology`].
pub struct Grid4Arcs {
    node: u32,
    n: u32,
    mask: u32,
}

impl Iterator for Grid4Arcs {
    type Item = u32;
    #[inline(always)]
    fn next(&mut self) -> Option<u32> {
        if self.mask == 0 {
            None
        } else {
            let d = self.mask.trailing_zeros();
            self.mask &= self.mask - 1;
            Some(d * self.n + self.node)
        }
    }
}

impl Topology for Grid4Topology {
    type Arcs = Grid4Arcs;
    #[inline(always)]
    fn num_nodes(&self) -> usize {
        self.n as usize
    }
    #[inline(always)]
    fn num_arcs(&self) -> usize {
        4 * self.n as usize
    }
    #[inline(always)]
    fn arcs(&self, node: u32) -> Grid4Arcs {
        Grid4Arcs {
            node,
            n: self.n,
            mask: self.grid.mask[node as usize] as u32,
        }
    }
    #[inline(always)]
    fn head(&self, arc: u32) -> u32 {
        let (d, i) = self.split(arc);
        (i as i64 + self.grid.offsets[d as usize]) as u32
    }
    #[inline(always)]
    fn sister(&self, arc: u32) -> u32 {
        let (d, _) = self.split(arc);
        (d ^ 1) * self.n + self.head(arc)
    }
    #[inline(always)]
    fn is_forward(&self, arc: u32) -> bool {
        self.split(arc).0 & 1 == 0
    }
    #[inline(always)]
    fn edge_of(&self, arc: u32) -> usize {
        let (d, i) = self.split(arc);
        if d & 1 == 0 {
            (i * 2 + d / 2) as usize
        } else {
            (self.head(arc) * 2 + d / 2) as usize
        }
    }
    fn num_edges(&self) -> usize {
        2 * self.n as usize
    }
    fn grid4_size(&self) -> Option<(usize, usize)> {
        Some((self.width(), self.height()))
    }
}

/// A general graph in compressed sparse row form: the arcs of node `i` are
/// `first[i]..first[i + 1]`, with `head` and `sister` stored per arc (8 bytes per arc).
#[derive(Clone, Debug, Default)]
pub struct CsrTopology {
    first: Vec<u32>,
    head: Vec<u32>,
    sister: Vec<u32>,
    edge: Vec<u32>,
}

impl CsrTopology {
    /// Builds the topology of `num_nodes` nodes and the undirected `edges` (each becomes a
    /// forward arc `p → q` and its sister `q → p`; edge `e` keeps index `e`). Returns the
    /// topology and the forward arc of each edge. Panics if an endpoint is out of range or
    /// the sizes overflow `u32`.
    pub fn from_edges(num_nodes: usize, edges: &[[u32; 2]]) -> (Self, Vec<u32>) {
        assert!(num_nodes < u32::MAX as usize && edges.len() * 2 < u32::MAX as usize);
        let mut first = vec![0u32; num_nodes + 1];
        for &[p, q] in edges {
            assert!(
                (p as usize) < num_nodes && (q as usize) < num_nodes,
                "edge endpoint out of range"
            );
            first[p as usize + 1] += 1;
            first[q as usize + 1] += 1;
        }
        for i in 0..num_nodes {
            first[i + 1] += first[i];
        }
        let m = edges.len() * 2;
        let mut fill = first.clone();
        let mut head = vec![0u32; m];
        let mut sister = vec![0u32; m];
        let mut edge = vec![0u32; m];
        let mut fwd = vec![0u32; edges.len()];
        for (e, &[p, q]) in edges.iter().enumerate() {
            let a = fill[p as usize];
            fill[p as usize] += 1;
            let b = fill[q as usize];
            fill[q as usize] += 1;
            head[a as usize] = q;
            head[b as usize] = p;
            sister[a as usize] = b;
            sister[b as usize] = a;
            edge[a as usize] = e as u32;
            edge[b as usize] = e as u32;
            fwd[e] = a;
        }
        (
            CsrTopology {
                first,
                head,
                sister,
                edge,
            },
            fwd,
        )
    }
    /// Bytes of topology storage per node and per undirected edge.
    pub fn bytes_per_node_and_edge() -> (usize, usize) {
        (4, 2 * 12)
    }
}

impl Topology for CsrTopology {
    type Arcs = std::ops::Range<u32>;
    #[inline(always)]
    fn num_nodes(&self) -> usize {
        self.first.len() - 1
    }
    #[inline(always)]
    fn num_arcs(&self) -> usize {
        self.head.len()
    }
    #[inline(always)]
    fn arcs(&self, node: u32) -> std::ops::Range<u32> {
        self.first[node as usize]..self.first[node as usize + 1]
    }
    #[inline(always)]
    fn head(&self, arc: u32) -> u32 {
        self.head[arc as usize]
    }
    #[inline(always)]
    fn sister(&self, arc: u32) -> u32 {
        self.sister[arc as usize]
    }
    #[inline(always)]
    fn is_forward(&self, arc: u32) -> bool {
        arc < self.sister[arc as usize]
    }
    #[inline(always)]
    fn edge_of(&self, arc: u32) -> usize {
        self.edge[arc as usize] as usize
    }
    fn num_edges(&self) -> usize {
        self.head.len() / 2
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_arcs_sisters_and_edges() {
        for conn in [Connectivity::Four, Connectivity::Eight] {
            let g = GridTopology::new(5, 3, conn);
            let mut edges = std::collections::HashSet::new();
            let mut arcs = 0;
            for n in 0..15u32 {
                for a in g.arcs(n) {
                    arcs += 1;
                    let h = g.head(a);
                    assert!(h < 15);
                    assert_eq!(g.sister(g.sister(a)), a);
                    assert_eq!(g.head(g.sister(a)), n);
                    assert_eq!(g.edge_of(a), g.edge_of(g.sister(a)));
                    assert_ne!(g.is_forward(a), g.is_forward(g.sister(a)));
                    edges.insert(g.edge_of(a));
                    let (x, y) = ((n % 5) as i32, (n / 5) as i32);
                    let (hx, hy) = ((h % 5) as i32, (h / 5) as i32);
                    assert!((hx - x).abs() <= 1 && (hy - y).abs() <= 1);
                }
            }
            if conn == Connectivity::Four {
                // The direction-major layout has the same heads, sisters and edges.
                let g4 = Grid4Topology::new(5, 3);
                for n in 0..15u32 {
                    let a: Vec<u32> = g.arcs(n).collect();
                    let b: Vec<u32> = g4.arcs(n).collect();
                    assert_eq!(a.len(), b.len());
                    for (&a, &b) in a.iter().zip(&b) {
                        assert_eq!(g.head(a), g4.head(b));
                        assert_eq!(g.edge_of(a), g4.edge_of(b));
                        assert_eq!(g.is_forward(a), g4.is_forward(b));
                        assert_eq!(g4.head(g4.sister(b)), n);
                        assert_eq!(g4.sister(g4.sister(b)), b);
                    }
                }
            }
            // 4-conn: 4*3 + 5*2 = 22 edges; 8-conn adds 2 * 4 * 2 = 16 diagonals.
            let expect = if conn == Connectivity::Four { 22 } else { 38 };
            assert_eq!(edges.len(), expect);
            assert_eq!(arcs, 2 * expect);
        }
    }

    #[test]
    fn csr_from_edges() {
        let (t, fwd) = CsrTopology::from_edges(4, &[[0, 1], [1, 2], [0, 2], [3, 0]]);
        assert_eq!(t.num_nodes(), 4);
        assert_eq!(t.num_arcs(), 8);
        assert_eq!(t.arcs(0).len(), 3);
        for (e, &a) in fwd.iter().enumerate() {
            assert_ne!(t.is_forward(a), t.is_forward(t.sister(a)));
            assert_eq!(t.edge_of(a), e);
            assert_eq!(t.sister(t.sister(a)), a);
        }
        assert_eq!(t.head(fwd[3]), 0);
    }
}
