//! Labelling problems: sites on a pixel grid or a general graph, data costs, pairwise
//! (smoothness) costs, per-label feasibility and label costs, with an exact energy evaluation.
//!
//! The energy of a labelling `f` is
//! `E(f) = Σ_p D(p, f_p) + Σ_{(p,q)} w_pq · V(p, q, f_p, f_q) + Σ_{l used} h_l`
//! (data term, pairwise term over the graph's edges, Delong et al. CVPR 2010 label costs).
use crate::cost::Cost;
use crate::maxflow::{Connectivity, CsrTopology, GridTopology, Topology};

/// Expands `$body` once per (topology, data, pairwise) representation with `$topo`,
/// `$data` and `$pair` bound to concrete types, so hot loops are monomorphised.
macro_rules! with_terms {
    ($mrf:expr, |$topo:ident, $data:ident, $pair:ident| $body:expr) => {{
        let mrf = $mrf;
        match &mrf.graph {
            $crate::mrf::SiteGraph::Grid(g) => {
                with_terms!(@data mrf, g, |$topo, $data, $pair| $body)
            }
            $crate::mrf::SiteGraph::General(g) => {
                with_terms!(@data mrf, g, |$topo, $data, $pair| $body)
            }
        }
    }};
    (@data $mrf:ident, $g:ident, |$topo:ident, $data:ident, $pair:ident| $body:expr) => {
        match &$mrf.data {
            $crate::mrf::DataCost::Dense(d) => {
                let dd = $crate::mrf::DenseData { data: d, labels: $mrf.num_labels };
                with_terms!(@pair $mrf, $g, dd, |$topo, $data, $pair| $body)
            }
            $crate::mrf::DataCost::Fn(f) => {
                let dd = $crate::mrf::FnData(f.as_ref());
                with_terms!(@pair $mrf, $g, dd, |$topo, $data, $pair| $body)
            }
        }
    };
    (@pair $mrf:ident, $g:ident, $dd:ident, |$topo:ident, $data:ident, $pair:ident| $body:expr) => {
        match &$mrf.pair {
            $crate::mrf::Pairwise::Potts(l) => {
                let $pair = $crate::mrf::PottsPair { lambda: *l, w: $mrf.weights };
                let $topo = $g;
                let $data = &$dd;
                $body
            }
            $crate::mrf::Pairwise::Table(t) => {
                let $pair = $crate::mrf::TablePair {
                    table: t,
                    labels: $mrf.num_labels,
                    w: $mrf.weights,
                };
                let $topo = $g;
                let $data = &$dd;
                $body
            }
            $crate::mrf::Pairwise::Fn(f) => {
                let $pair = $crate::mrf::FnPair { f: f.as_ref(), w: $mrf.weights };
                let $topo = $g;
                let $data = &$dd;
                $body
            }
        }
    };
}
pub(crate) use with_terms;

/// Errors raised when a labelling problem or a labelling is malformed.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum MrfError {
    /// The dense data-cost array does not hold `sites × labels` values.
    #[error(
        "data costs hold {got} values, expected sites ({sites}) x labels ({labels}) = {expected}"
    )]
    DataSize {
        /// Values given.
        got: usize,
        /// Number of sites.
        sites: usize,
        /// Number of labels.
        labels: usize,
        /// `sites * labels`.
        expected: usize,
    },
    /// A pairwise table is not `labels × labels`.
    #[error("pairwise table holds {got} values, expected labels^2 = {expected}")]
    TableSize {
        /// Values given.
        got: usize,
        /// `labels * labels`.
        expected: usize,
    },
    /// The per-edge weight array has the wrong length.
    #[error("edge weights hold {got} values, expected {expected}")]
    WeightSize {
        /// Values given.
        got: usize,
        /// Size of the edge index space.
        expected: usize,
    },
    /// An edge names a site outside `0..sites`, or joins a site to itself.
    #[error("edge {edge} = ({p}, {q}) is invalid for {sites} sites")]
    BadEdge {
        /// Edge index.
        edge: usize,
        /// First endpoint.
        p: u32,
        /// Second endpoint.
        q: u32,
        /// Number of sites.
        sites: usize,
    },
    /// A label index is out of range.
    #[error("label {label} out of range (problem has {labels} labels)")]
    BadLabel {
        /// The label.
        label: u32,
        /// Number of labels.
        labels: usize,
    },
    /// A site index is out of range.
    #[error("site {site} out of range (problem has {sites} sites)")]
    BadSite {
        /// The site.
        site: u32,
        /// Number of sites.
        sites: usize,
    },
    /// A labelling has the wrong length.
    #[error("labelling has {got} entries, expected {expected}")]
    LabellingSize {
        /// Entries given.
        got: usize,
        /// Number of sites.
        expected: usize,
    },
    /// A labelling uses a label that is not feasible at a site.
    #[error("label {label} is not feasible at site {site}")]
    Infeasible {
        /// The site.
        site: usize,
        /// The label.
        label: u32,
    },
    /// A site admits no label at all.
    #[error("site {site} admits no feasible label")]
    NoFeasibleLabel {
        /// The site.
        site: usize,
    },
    /// The label-cost array does not hold one cost per label, or a cost is negative.
    #[error("label costs: expected {expected} non-negative values")]
    LabelCosts {
        /// Number of labels.
        expected: usize,
    },
    /// The problem has no labels.
    #[error("a labelling problem needs at least one label")]
    NoLabels,
    /// A solver option is out of range.
    #[error("invalid solver option: {0}")]
    BadOption(&'static str),
}

/// Default number of warm-start sweeps of α-expansion (see [`Mrf::with_warm_start`]).
pub const DEFAULT_WARM_SWEEPS: usize = 2;

/// Data costs `D(p, l)`: the cost of giving label `l` to site `p`.
pub enum DataCost<'a, T> {
    /// Dense `sites × labels` array, site-major: `D(p, l) = data[p * labels + l]`.
    Dense(&'a [T]),
    /// A closure `D(p, l)`; called O(sites) times per move, so keep it cheap.
    Fn(Box<dyn Fn(usize, u32) -> T + Sync + 'a>),
}

/// Pairwise costs `V(p, q, a, b)` between neighbouring sites `p`, `q` with labels `a`, `b`.
///
/// `V` must be symmetric (`V(p,q,a,b) = V(q,p,b,a)`), non-negative and 0 when `a == b`. It
/// need not be a metric: α-expansion truncates non-submodular pair terms (Rother et al.
/// 2005) and keeps a move only if the true energy drops. The solvers always call `V` with
/// `p < q`.
pub enum Smoothness<'a, T> {
    /// `V = λ · [a ≠ b]`.
    Potts(T),
    /// `V = min(scale · |a − b|, truncation)`.
    TruncatedLinear {
        /// Cost per unit of label distance.
        scale: T,
        /// Upper bound of the cost.
        truncation: T,
    },
    /// `V = min(scale · (a − b)², truncation)`.
    TruncatedQuadratic {
        /// Cost per squared unit of label distance.
        scale: T,
        /// Upper bound of the cost.
        truncation: T,
    },
    /// A dense `labels × labels` table: `V = table[a * labels + b]`.
    Table(&'a [T]),
    /// A closure `V(p, q, a, b)` depending on the site pair (e.g. the 3D gap between two
    /// planes along the ray through the pair's midpoint).
    Fn(Box<dyn Fn(usize, usize, u32, u32) -> T + Sync + 'a>),
}

/// The graph of sites.
#[derive(Clone, Debug)]
pub(crate) enum SiteGraph {
    Grid(GridTopology),
    General(CsrTopology),
}

pub(crate) enum Pairwise<'a, T> {
    Potts(T),
    Table(Vec<T>),
    Fn(Box<dyn Fn(usize, usize, u32, u32) -> T + Sync + 'a>),
}

/// A labelling problem (a pairwise Markov random field with label costs).
///
/// Sites are numbered `0..num_sites()`; on a grid, site `y * width + x`. Edge weights, if
/// given, multiply the pairwise cost; their index space is [`Mrf::num_edge_slots`]: for a
/// general graph the edge index, for a grid `p * K/2 + d/2` for the edge from pixel `p` in
/// the forward direction `d` (`K` = 4 or 8; see [`Mrf::grid_edge_slot`]).
pub struct Mrf<'a, T: Cost> {
    pub(crate) graph: SiteGraph,
    pub(crate) num_labels: usize,
    pub(crate) data: DataCost<'a, T>,
    pub(crate) pair: Pairwise<'a, T>,
    pub(crate) weights: Option<&'a [T]>,
    pub(crate) feasible: Vec<Option<Vec<u64>>>,
    pub(crate) label_costs: Option<Vec<T>>,
    pub(crate) warm_sweeps: usize,
}

impl<'a, T: Cost> Mrf<'a, T> {
    /// A problem on a `width × height` pixel grid with `num_labels` labels and Potts
    /// smoothness of weight 1 until [`Mrf::with_smoothness`] says otherwise.
    pub fn grid(
        width: usize,
        height: usize,
        connectivity: Connectivity,
        num_labels: usize,
        data: DataCost<'a, T>,
    ) -> Result<Self, MrfError> {
        let topo = GridTopology::new(width, height, connectivity);
        Self::from_graph(SiteGraph::Grid(topo), num_labels, data)
    }

    /// A problem on a general graph of `num_sites` sites and undirected `edges`.
    pub fn general(
        num_sites: usize,
        edges: &[[u32; 2]],
        num_labels: usize,
        data: DataCost<'a, T>,
    ) -> Result<Self, MrfError> {
        for (e, &[p, q]) in edges.iter().enumerate() {
            if p as usize >= num_sites || q as usize >= num_sites || p == q {
                return Err(MrfError::BadEdge {
                    edge: e,
                    p,
                    q,
                    sites: num_sites,
                });
            }
        }
        let (topo, _) = CsrTopology::from_edges(num_sites, edges);
        Self::from_graph(SiteGraph::General(topo), num_labels, data)
    }

    fn from_graph(
        graph: SiteGraph,
        num_labels: usize,
        data: DataCost<'a, T>,
    ) -> Result<Self, MrfError> {
        if num_labels == 0 {
            return Err(MrfError::NoLabels);
        }
        let sites = match &graph {
            SiteGraph::Grid(g) => g.num_nodes(),
            SiteGraph::General(g) => g.num_nodes(),
        };
        if let DataCost::Dense(d) = &data {
            if d.len() != sites * num_labels {
                return Err(MrfError::DataSize {
                    got: d.len(),
                    sites,
                    labels: num_labels,
                    expected: sites * num_labels,
                });
            }
        }
        Ok(Mrf {
            graph,
            num_labels,
            data,
            pair: Pairwise::Potts(T::from_f64(1.0)),
            weights: None,
            feasible: vec![None; num_labels],
            label_costs: None,
            warm_sweeps: DEFAULT_WARM_SWEEPS,
        })
    }

    /// Sets the pairwise cost.
    pub fn with_smoothness(mut self, smoothness: Smoothness<'a, T>) -> Result<Self, MrfError> {
        let l = self.num_labels;
        self.pair = match smoothness {
            Smoothness::Potts(lambda) => Pairwise::Potts(lambda),
            Smoothness::TruncatedLinear { scale, truncation } => Pairwise::Table(
                (0..l * l)
                    .map(|i| {
                        let d = (i / l).abs_diff(i % l) as f64;
                        (scale * T::from_f64(d)).min_of(truncation)
                    })
                    .collect(),
            ),
            Smoothness::TruncatedQuadratic { scale, truncation } => Pairwise::Table(
                (0..l * l)
                    .map(|i| {
                        let d = (i / l).abs_diff(i % l) as f64;
                        (scale * T::from_f64(d * d)).min_of(truncation)
                    })
                    .collect(),
            ),
            Smoothness::Table(t) => {
                if t.len() != l * l {
                    return Err(MrfError::TableSize {
                        got: t.len(),
                        expected: l * l,
                    });
                }
                // A Potts-shaped table (zero diagonal, one off-diagonal value) takes the
                // Potts path: same costs, no table lookups in the move loops.
                let lambda = if l > 1 { t[1] } else { T::ZERO };
                let potts =
                    (0..l * l).all(|i| t[i] == if i / l == i % l { T::ZERO } else { lambda });
                if potts {
                    Pairwise::Potts(lambda)
                } else {
                    Pairwise::Table(t.to_vec())
                }
            }
            Smoothness::Fn(f) => Pairwise::Fn(f),
        };
        Ok(self)
    }

    /// Sets per-edge weights multiplying the pairwise cost (see the type's docs for the
    /// index space).
    pub fn with_edge_weights(mut self, weights: &'a [T]) -> Result<Self, MrfError> {
        if weights.len() != self.num_edge_slots() {
            return Err(MrfError::WeightSize {
                got: weights.len(),
                expected: self.num_edge_slots(),
            });
        }
        self.weights = Some(weights);
        Ok(self)
    }

    /// Restricts `label` to the given sites (sparse feasibility: a plane hypothesis that
    /// only some pixels may take). Other labels stay feasible everywhere.
    pub fn with_feasible_sites(mut self, label: u32, sites: &[u32]) -> Result<Self, MrfError> {
        if label as usize >= self.num_labels {
            return Err(MrfError::BadLabel {
                label,
                labels: self.num_labels,
            });
        }
        let n = self.num_sites();
        let mut bits = vec![0u64; n.div_ceil(64)];
        for &s in sites {
            if s as usize >= n {
                return Err(MrfError::BadSite { site: s, sites: n });
            }
            bits[s as usize >> 6] |= 1 << (s & 63);
        }
        self.feasible[label as usize] = Some(bits);
        Ok(self)
    }

    /// Sets a cost per label, paid once if any site uses the label (Delong et al. 2010).
    pub fn with_label_costs(mut self, costs: &[T]) -> Result<Self, MrfError> {
        if costs.len() != self.num_labels || costs.iter().any(|&c| c < T::ZERO) {
            return Err(MrfError::LabelCosts {
                expected: self.num_labels,
            });
        }
        self.label_costs = if costs.iter().all(|&c| c == T::ZERO) {
            None
        } else {
            Some(costs.to_vec())
        };
        Ok(self)
    }

    /// Sets how many warm-start sweeps α-expansion runs before its first cycle (default
    /// [`DEFAULT_WARM_SWEEPS`]; 0 disables). A sweep lets each site take a neighbour's label
    /// when that strictly lowers the energy (a restricted ICM); it never raises the energy
    /// and makes the first cycle's max-flows much cheaper on noisy starts. Skipped when
    /// label costs are set.
    pub fn with_warm_start(mut self, sweeps: usize) -> Self {
        self.warm_sweeps = sweeps;
        self
    }

    /// Number of sites.
    pub fn num_sites(&self) -> usize {
        match &self.graph {
            SiteGraph::Grid(g) => g.num_nodes(),
            SiteGraph::General(g) => g.num_nodes(),
        }
    }

    /// Number of labels.
    pub fn num_labels(&self) -> usize {
        self.num_labels
    }

    /// Size of the edge index space of [`Mrf::with_edge_weights`].
    pub fn num_edge_slots(&self) -> usize {
        match &self.graph {
            SiteGraph::Grid(g) => g.num_edges(),
            SiteGraph::General(g) => g.num_edges(),
        }
    }

    /// Edge-weight slot of the grid edge from pixel `(x, y)` in forward direction `dir`
    /// (0 right, 2 down, 4 down-right, 6 down-left; see
    /// [`GRID_DIRECTIONS`](crate::maxflow::GRID_DIRECTIONS)). `None` for general graphs,
    /// odd directions, or edges leaving the grid.
    pub fn grid_edge_slot(&self, x: usize, y: usize, dir: usize) -> Option<usize> {
        match &self.graph {
            SiteGraph::Grid(g) if dir % 2 == 0 && x < g.width() && y < g.height() => {
                let a = g.arc((y * g.width() + x) as u32, dir)?;
                Some(g.edge_of(a))
            }
            _ => None,
        }
    }

    /// Whether `label` is feasible at `site`.
    #[inline(always)]
    pub fn is_feasible(&self, site: usize, label: u32) -> bool {
        feasible(&self.feasible, site, label)
    }

    /// Checks that `labels` is a complete, feasible labelling.
    pub fn check_labelling(&self, labels: &[u32]) -> Result<(), MrfError> {
        if labels.len() != self.num_sites() {
            return Err(MrfError::LabellingSize {
                got: labels.len(),
                expected: self.num_sites(),
            });
        }
        for (p, &l) in labels.iter().enumerate() {
            if l as usize >= self.num_labels {
                return Err(MrfError::BadLabel {
                    label: l,
                    labels: self.num_labels,
                });
            }
            if !self.is_feasible(p, l) {
                return Err(MrfError::Infeasible { site: p, label: l });
            }
        }
        Ok(())
    }

    /// The labelling that minimises the data term alone over the feasible labels (ties to
    /// the smallest label): the default start of every solver.
    pub fn data_argmin(&self) -> Result<Vec<u32>, MrfError> {
        with_terms!(self, |_topo, data, _pair| {
            (0..self.num_sites())
                .map(|p| {
                    let mut best: Option<(T, u32)> = None;
                    for l in 0..self.num_labels as u32 {
                        if self.is_feasible(p, l) {
                            let c = data.d(p, l);
                            if best.is_none_or(|(b, _)| c < b) {
                                best = Some((c, l));
                            }
                        }
                    }
                    best.map(|b| b.1)
                        .ok_or(MrfError::NoFeasibleLabel { site: p })
                })
                .collect()
        })
    }

    /// The energy of a labelling, evaluated independently of any solver (a plain sum over
    /// sites, edges and used labels, in [`Cost::Acc`]).
    pub fn energy(&self, labels: &[u32]) -> Result<Energy<T::Acc>, MrfError> {
        self.check_labelling(labels)?;
        Ok(with_terms!(self, |topo, data, pair| energy_of(
            topo,
            data,
            &pair,
            self.label_costs.as_deref(),
            labels
        )))
    }
}

/// An energy split into its terms.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Energy<A> {
    /// `Σ_p D(p, f_p)`.
    pub data: A,
    /// `Σ_(p,q) w_pq V(p, q, f_p, f_q)`.
    pub smoothness: A,
    /// `Σ_{l used} h_l`.
    pub label: A,
    /// The sum of the three.
    pub total: A,
}

#[inline(always)]
pub(crate) fn feasible(f: &[Option<Vec<u64>>], site: usize, label: u32) -> bool {
    match &f[label as usize] {
        None => true,
        Some(b) => (b[site >> 6] >> (site & 63)) & 1 == 1,
    }
}

/// Data-cost access, monomorphised per representation.
pub(crate) trait DataFn<T>: Sync {
    fn d(&self, p: usize, l: u32) -> T;
}
pub(crate) struct DenseData<'a, T> {
    pub(crate) data: &'a [T],
    pub(crate) labels: usize,
}
impl<T: Cost> DataFn<T> for DenseData<'_, T> {
    #[inline(always)]
    fn d(&self, p: usize, l: u32) -> T {
        self.data[p * self.labels + l as usize]
    }
}
/// Dense data costs stored label-major (`D(p, l) = data[l * sites + p]`): an expansion
/// move reads `D(·, α)` as one contiguous stream instead of one cache line per site.
pub(crate) struct LabelMajorData<'a, T> {
    pub(crate) data: &'a [T],
    pub(crate) sites: usize,
}
impl<T: Cost> DataFn<T> for LabelMajorData<'_, T> {
    #[inline(always)]
    fn d(&self, p: usize, l: u32) -> T {
        self.data[l as usize * self.sites + p]
    }
}
impl<'a, T: Cost> LabelMajorData<'a, T> {
    /// Transposes site-major `data` (`sites × labels`) into `buf`.
    pub(crate) fn transpose(data: &[T], labels: usize, buf: &'a mut Vec<T>) -> Self {
        let sites = data.len() / labels;
        buf.clear();
        buf.resize(data.len(), T::ZERO);
        const B: usize = 256;
        for p0 in (0..sites).step_by(B) {
            let p1 = (p0 + B).min(sites);
            for l in 0..labels {
                let dst = &mut buf[l * sites + p0..l * sites + p1];
                for (i, x) in dst.iter_mut().enumerate() {
                    *x = data[(p0 + i) * labels + l];
                }
            }
        }
        LabelMajorData { data: buf, sites }
    }
}
pub(crate) struct FnData<'a, 'b, T>(pub(crate) &'b (dyn Fn(usize, u32) -> T + Sync + 'a));
impl<T: Cost> DataFn<T> for FnData<'_, '_, T> {
    #[inline(always)]
    fn d(&self, p: usize, l: u32) -> T {
        (self.0)(p, l)
    }
}

/// Pairwise-cost access including the edge weight, monomorphised per representation.
pub(crate) trait PairFn<T>: Sync {
    /// `w_e · V(p, q, a, b)` for the edge `e` between sites `p < q`.
    fn v(&self, p: usize, q: usize, e: usize, a: u32, b: u32) -> T;
    /// The four terms of a binary move on edge `e`: `v(a, b)`, `v(a, u)`, `v(t, b)`,
    /// `v(t, u)` (current labels `a`, `b`; targets `t`, `u`). Representations override it
    /// to read the edge weight once.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn quad(&self, p: usize, q: usize, e: usize, a: u32, b: u32, t: u32, u: u32) -> [T; 4] {
        [
            self.v(p, q, e, a, b),
            self.v(p, q, e, a, u),
            self.v(p, q, e, t, b),
            self.v(p, q, e, t, u),
        ]
    }
}
pub(crate) struct PottsPair<'w, T> {
    pub(crate) lambda: T,
    pub(crate) w: Option<&'w [T]>,
}
impl<T: Cost> PairFn<T> for PottsPair<'_, T> {
    #[inline(always)]
    fn v(&self, _p: usize, _q: usize, e: usize, a: u32, b: u32) -> T {
        // Computed before the label test so that the test becomes a select, not a branch.
        let c = match self.w {
            Some(w) => w[e] * self.lambda,
            None => self.lambda,
        };
        if a == b {
            T::ZERO
        } else {
            c
        }
    }
    #[inline(always)]
    fn quad(&self, _p: usize, _q: usize, e: usize, a: u32, b: u32, t: u32, u: u32) -> [T; 4] {
        let c = match self.w {
            Some(w) => w[e] * self.lambda,
            None => self.lambda,
        };
        let sel = |x: u32, y: u32| if x == y { T::ZERO } else { c };
        [sel(a, b), sel(a, u), sel(t, b), sel(t, u)]
    }
}
pub(crate) struct TablePair<'w, T> {
    pub(crate) table: &'w [T],
    pub(crate) labels: usize,
    pub(crate) w: Option<&'w [T]>,
}
impl<T: Cost> PairFn<T> for TablePair<'_, T> {
    #[inline(always)]
    fn v(&self, _p: usize, _q: usize, e: usize, a: u32, b: u32) -> T {
        let c = self.table[a as usize * self.labels + b as usize];
        match self.w {
            Some(w) => w[e] * c,
            None => c,
        }
    }
    #[inline(always)]
    fn quad(&self, _p: usize, _q: usize, e: usize, a: u32, b: u32, t: u32, u: u32) -> [T; 4] {
        let l = self.labels;
        let (a, b, t, u) = (a as usize, b as usize, t as usize, u as usize);
        let v = [
            self.table[a * l + b],
            self.table[a * l + u],
            self.table[t * l + b],
            self.table[t * l + u],
        ];
        match self.w {
            Some(w) => {
                let we = w[e];
                v.map(|c| we * c)
            }
            None => v,
        }
    }
}
pub(crate) struct FnPair<'a, 'b, T> {
    pub(crate) f: &'b (dyn Fn(usize, usize, u32, u32) -> T + Sync + 'a),
    pub(crate) w: Option<&'b [T]>,
}
impl<T: Cost> PairFn<T> for FnPair<'_, '_, T> {
    #[inline(always)]
    fn v(&self, p: usize, q: usize, e: usize, a: u32, b: u32) -> T {
        let c = (self.f)(p, q, a, b);
        match self.w {
            Some(w) => w[e] * c,
            None => c,
        }
    }
}

/// Energy of `labels` (assumed valid) from monomorphised terms.
pub(crate) fn energy_of<T: Cost, Tp: Topology, D: DataFn<T>, P: PairFn<T>>(
    topo: &Tp,
    data: &D,
    pair: &P,
    label_costs: Option<&[T]>,
    labels: &[u32],
) -> Energy<T::Acc> {
    let mut e = Energy::<T::Acc>::default();
    for (p, &l) in labels.iter().enumerate() {
        e.data += data.d(p, l).widen();
    }
    for p in 0..topo.num_nodes() as u32 {
        for a in topo.arcs(p) {
            if topo.is_forward(a) {
                let q = topo.head(a) as usize;
                e.smoothness += pair
                    .v(
                        p as usize,
                        q,
                        topo.edge_of(a),
                        labels[p as usize],
                        labels[q],
                    )
                    .widen();
            }
        }
    }
    if let Some(h) = label_costs {
        let mut used = vec![false; h.len()];
        for &l in labels {
            used[l as usize] = true;
        }
        for (l, &u) in used.iter().enumerate() {
            if u {
                e.label += h[l].widen();
            }
        }
    }
    e.total = e.data + e.smoothness + e.label;
    e
}
