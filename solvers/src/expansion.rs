//! α-expansion (Boykov, Veksler & Zabih, PAMI 2001) with label costs (Delong et al. 2010).
//!
//! Each move lets every site where α is feasible either keep its label or switch to α; the
//! best such move is one minimum cut when the pairwise cost is a metric. For non-metric
//! costs the offending pair terms are truncated to submodular ones (Rother et al. 2005) and
//! the move is kept only if the *true* energy drops, so the energy never increases.
//!
//! Speed: the move's graph reuses the site graph's arc layout (implicit neighbour arcs on
//! grids, 32-bit indices; on 4-connected grids the grid-specialised
//! [`GridMaxFlow`](crate::maxflow::GridMaxFlow), filled by a row-wise builder), is written
//! in one pass without reallocation, and moves that are
//! known to fail are skipped: a label whose last expansion failed is not retried until some
//! other move has changed the labelling, and (for exact integer costs, when no truncation
//! was needed) a label whose expansion just succeeded is known to be optimal w.r.t. its own
//! move. Before the first cycle a few warm-start sweeps move sites to a neighbour's label
//! when that lowers the energy ([`Mrf::with_warm_start`]), so the first cycle (the costly
//! one from a noisy start) pushes much less flow; dense data costs with rows longer than a
//! cache line are read from a label-major copy so that a move streams `D(·, α)`.
use std::time::Instant;

use crate::cost::Cost;
use crate::maxflow::{GraphBuilder, Topology};
use crate::moves::{
    build_move, label_cost_delta, move_delta, BuilderEmit, CycleStats, MoveFlow, Solution, SplitMix,
};
use crate::mrf::{
    energy_of, feasible, with_terms, DataCost, DataFn, LabelMajorData, Mrf, MrfError, PairFn,
    SiteGraph,
};

/// Order in which the labels are expanded within a cycle.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum LabelOrder {
    /// `0, 1, …, L−1` every cycle.
    #[default]
    Fixed,
    /// After the first cycle, labels whose last expansion changed the most sites first
    /// (ties by index).
    Adaptive,
    /// A fresh pseudo-random permutation each cycle from this seed (deterministic).
    Shuffled(u64),
}

/// Options of [`Mrf::expansion`] and [`Mrf::swap`].
#[derive(Clone, Debug, PartialEq)]
pub struct ExpansionConfig {
    /// Maximum number of cycles (sweeps over all labels). Default 100.
    pub max_cycles: usize,
    /// Label order. Default [`LabelOrder::Fixed`].
    pub order: LabelOrder,
}

impl Default for ExpansionConfig {
    fn default() -> Self {
        ExpansionConfig {
            max_cycles: 100,
            order: LabelOrder::Fixed,
        }
    }
}

impl<T: Cost> Mrf<'_, T> {
    /// Minimises the energy by α-expansion from `initial` (or from the per-site data
    /// argmin over feasible labels). Deterministic: the same problem gives bit-identical
    /// labels.
    pub fn expansion(
        &self,
        config: &ExpansionConfig,
        initial: Option<&[u32]>,
    ) -> Result<Solution<T::Acc>, MrfError> {
        let labels = match initial {
            Some(l) => {
                self.check_labelling(l)?;
                l.to_vec()
            }
            None => self.data_argmin()?,
        };
        let mrf = self;
        // A site's cost row spans more than one cache line beyond 64 bytes (16 `i32`s);
        // below that a move reads D(p, α) and D(p, f_p) from the same line anyway.
        let row_bytes = mrf.num_labels * std::mem::size_of::<T>();
        if let (DataCost::Dense(d), true) = (&mrf.data, row_bytes > 64) {
            // Label-major copy of the data costs (memory: one more sites × labels array):
            // each move then streams D(·, α) instead of touching every site's cost row.
            let mut buf = Vec::new();
            let dd = LabelMajorData::transpose(d, mrf.num_labels, &mut buf);
            return Ok(match &mrf.graph {
                SiteGraph::Grid(g) => with_terms!(@pair mrf, g, dd, |topo, data, pair| expand(
                    mrf, topo, data, &pair, config, labels
                )),
                SiteGraph::General(g) => {
                    with_terms!(@pair mrf, g, dd, |topo, data, pair| expand(
                        mrf, topo, data, &pair, config, labels
                    ))
                }
            });
        }
        Ok(with_terms!(mrf, |topo, data, pair| expand(
            mrf, topo, data, &pair, config, labels
        )))
    }
}

fn expand<T: Cost, Tp: Topology + Clone, D: DataFn<T>, P: PairFn<T>>(
    mrf: &Mrf<'_, T>,
    topo: &Tp,
    data: &D,
    pair: &P,
    config: &ExpansionConfig,
    mut labels: Vec<u32>,
) -> Solution<T::Acc> {
    let num_labels = mrf.num_labels;
    let h = mrf.label_costs.as_deref();
    let mut mf = h.is_none().then(|| MoveFlow::<T, Tp>::new(topo));
    let mut energy = energy_of(topo, data, pair, h, &labels).total;
    let initial_energy = energy;
    if h.is_none() {
        for _ in 0..mrf.warm_sweeps {
            let (d, n) = neighbour_sweep(mrf, topo, data, pair, &mut labels);
            energy += d;
            if n == 0 {
                break;
            }
        }
        debug_check_energy(topo, data, pair, h, &labels, energy);
    }
    let mut counts = vec![0u32; num_labels];
    for &l in &labels {
        counts[l as usize] += 1;
    }
    let mut version = 0u64;
    let mut known_fail = vec![u64::MAX; num_labels];
    let mut last_changed = vec![0usize; num_labels];
    let mut changed = Vec::new();
    let mut scratch = Vec::new();
    let mut order: Vec<u32> = (0..num_labels as u32).collect();
    let mut rng = match config.order {
        LabelOrder::Shuffled(seed) => SplitMix(seed),
        _ => SplitMix(0),
    };
    let mut cycles = Vec::new();
    let mut converged = false;
    for cycle in 0..config.max_cycles {
        let start = Instant::now();
        match config.order {
            LabelOrder::Fixed => {}
            LabelOrder::Adaptive => {
                if cycle > 0 {
                    order.sort_by_key(|&l| (std::cmp::Reverse(last_changed[l as usize]), l));
                }
            }
            LabelOrder::Shuffled(_) => rng.shuffle(&mut order),
        }
        let mut stats = CycleStats {
            energy,
            seconds: 0.0,
            moves_tried: 0,
            moves_accepted: 0,
            sites_changed: 0,
        };
        for &alpha in &order {
            let ai = alpha as usize;
            if known_fail[ai] == version {
                continue;
            }
            stats.moves_tried += 1;
            // α's feasibility set, looked up once per move.
            let fa = mrf.feasible[ai].as_deref();
            let target = |p: usize, c: u32| {
                (c != alpha && fa.is_none_or(|b| (b[p >> 6] >> (p & 63)) & 1 == 1)).then_some(alpha)
            };
            let (mut delta, truncated) = match (&mut mf, h) {
                (Some(mf), _) => mf.solve_move(topo, data, pair, &labels, &target, &mut changed),
                (None, Some(h)) => solve_move_label_costs(
                    topo,
                    data,
                    pair,
                    h,
                    &counts,
                    &labels,
                    alpha,
                    &target,
                    &mut changed,
                ),
                (None, None) => unreachable!("a max-flow graph exists without label costs"),
            };
            if let Some(h) = h {
                delta += label_cost_delta(h, &counts, &labels, &changed, &mut scratch);
            }
            if !changed.is_empty() && delta < T::Acc::default() {
                for &(p, t) in &changed {
                    counts[labels[p as usize] as usize] -= 1;
                    counts[t as usize] += 1;
                    labels[p as usize] = t;
                }
                energy += delta;
                version += 1;
                stats.moves_accepted += 1;
                stats.sites_changed += changed.len();
                last_changed[ai] = changed.len();
                // An exact, untruncated move is optimal over its move space, which contains
                // the next α-move's space: retrying α now cannot help.
                if T::EXACT && !truncated {
                    known_fail[ai] = version;
                }
                debug_check_energy(topo, data, pair, h, &labels, energy);
            } else {
                known_fail[ai] = version;
                last_changed[ai] = 0;
            }
        }
        stats.energy = energy;
        stats.seconds = start.elapsed().as_secs_f64();
        let done = stats.moves_accepted == 0;
        cycles.push(stats);
        if done {
            converged = true;
            break;
        }
    }
    // Report the independently evaluated energy (identical for integer costs; removes the
    // drift of accumulated deltas for floats).
    let energy = energy_of(topo, data, pair, h, &labels).total;
    Solution {
        labels,
        energy,
        initial_energy,
        cycles,
        converged,
    }
}

/// One warm-start sweep (before the first expansion cycle): every site in order takes the
/// label of one of its neighbours if that strictly lowers the energy with the neighbours'
/// current labels (ties: the smaller label). A restricted ICM: it removes most of the
/// isolated noise of a data-argmin start, so the first expansion cycle's max-flows carry
/// far less flow. Returns the energy change (≤ 0) and the number of sites changed.
fn neighbour_sweep<T: Cost, Tp: Topology, D: DataFn<T>, P: PairFn<T>>(
    mrf: &Mrf<'_, T>,
    topo: &Tp,
    data: &D,
    pair: &P,
    labels: &mut [u32],
) -> (T::Acc, usize) {
    let mut total = T::Acc::default();
    let mut changed = 0;
    for p in 0..labels.len() {
        let cur = labels[p];
        let local = |l: u32, labels: &[u32]| crate::icm::local_cost(topo, data, pair, p, l, labels);
        let mut best: Option<(T::Acc, u32)> = None;
        let mut base = None;
        for a in topo.arcs(p as u32) {
            let l = labels[topo.head(a) as usize];
            if l == cur || !feasible(&mrf.feasible, p, l) {
                continue;
            }
            if let Some((_, bl)) = best {
                if bl == l {
                    continue;
                }
            }
            let b = *base.get_or_insert_with(|| local(cur, labels));
            let d = local(l, labels) - b;
            let better = match best {
                None => d < T::Acc::default(),
                Some((bd, bl)) => d < bd || (d == bd && l < bl),
            };
            if better {
                best = Some((d, l));
            }
        }
        if let Some((d, l)) = best {
            labels[p] = l;
            total += d;
            changed += 1;
        }
    }
    (total, changed)
}

/// Debug builds: the tracked energy equals an independent evaluation and never rose.
#[inline]
pub(crate) fn debug_check_energy<T: Cost, Tp: Topology, D: DataFn<T>, P: PairFn<T>>(
    topo: &Tp,
    data: &D,
    pair: &P,
    h: Option<&[T]>,
    labels: &[u32],
    tracked: T::Acc,
) {
    if cfg!(debug_assertions) {
        let e = energy_of(topo, data, pair, h, labels).total;
        let (a, b) = (T::acc_to_f64(e), T::acc_to_f64(tracked));
        if T::EXACT {
            assert_eq!(a, b, "tracked energy drifted from the true energy");
        } else {
            assert!(
                (a - b).abs() <= 1e-6 * (1.0 + a.abs()),
                "energy drift {a} vs {b}"
            );
        }
    }
}

/// General path with label costs: the move's graph gets one auxiliary node per label-cost
/// term (Delong et al. 2010, Sec. 3): for a label `l ≠ α` whose sites may all switch, a node
/// `y` with `E = h_l (1 − y) + Σ_{p: f_p = l} h_l y (1 − x_p)`; for an unused α, a node `z`
/// with `E = h_α z + Σ_p h_α (1 − z) x_p`.
#[allow(clippy::too_many_arguments)]
fn solve_move_label_costs<T, Tp, D, P, Tg>(
    topo: &Tp,
    data: &D,
    pair: &P,
    h: &[T],
    counts: &[u32],
    labels: &[u32],
    alpha: u32,
    target: &Tg,
    changed: &mut Vec<(u32, u32)>,
) -> (T::Acc, bool)
where
    T: Cost,
    Tp: Topology,
    D: DataFn<T>,
    P: PairFn<T>,
    Tg: Fn(usize, u32) -> Option<u32>,
{
    let n = labels.len();
    let mut b = GraphBuilder::<T>::new(n);
    let truncated = build_move(
        topo,
        data,
        pair,
        labels,
        target,
        &mut BuilderEmit { b: &mut b },
    );
    // Which labels can vanish: every site holding them must be able to switch to α.
    let mut pinned = vec![false; h.len()];
    for (p, &l) in labels.iter().enumerate() {
        if target(p, l).is_none() {
            pinned[l as usize] = true;
        }
    }
    let mut aux = vec![u32::MAX; h.len()];
    for l in 0..h.len() {
        if l != alpha as usize && counts[l] > 0 && !pinned[l] && h[l].is_pos() {
            let y = b.add_node();
            b.add_tweights(y, T::ZERO, h[l]);
            aux[l] = y;
        }
    }
    let a = alpha as usize;
    let z = (counts[a] == 0 && h[a].is_pos()).then(|| {
        let z = b.add_node();
        b.add_tweights(z, h[a], T::ZERO);
        z
    });
    for (p, &l) in labels.iter().enumerate() {
        if aux[l as usize] != u32::MAX {
            b.add_edge(p as u32, aux[l as usize], h[l as usize], T::ZERO);
        }
        if let (Some(z), Some(_)) = (z, target(p, l)) {
            b.add_edge(z, p as u32, h[a], T::ZERO);
        }
    }
    let mut mf = b.build();
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::maxflow::Connectivity;
    use crate::mrf::{DataCost, Smoothness};

    struct Rng(u64);
    impl Rng {
        fn below(&mut self, n: u64) -> u64 {
            self.0 = self
                .0
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (self.0 >> 33) % n
        }
    }

    /// Minimum energy by enumerating all feasible labellings.
    fn brute_force(mrf: &Mrf<'_, i32>) -> i64 {
        let (n, l) = (mrf.num_sites(), mrf.num_labels() as u64);
        let mut best = i64::MAX;
        let mut labels = vec![0u32; n];
        for code in 0..l.pow(n as u32) {
            let mut c = code;
            for x in labels.iter_mut() {
                *x = (c % l) as u32;
                c /= l;
            }
            if let Ok(e) = mrf.energy(&labels) {
                best = best.min(e.total);
            }
        }
        best
    }

    /// No single expansion move lowers the energy of `labels`: for each α, enumerate all
    /// subsets of the sites that may switch (tiny problems only).
    fn assert_expansion_local_optimum(mrf: &Mrf<'_, i32>, labels: &[u32]) {
        let e0 = mrf.energy(labels).unwrap().total;
        for alpha in 0..mrf.num_labels() as u32 {
            let movable: Vec<usize> = (0..labels.len())
                .filter(|&p| labels[p] != alpha && mrf.is_feasible(p, alpha))
                .collect();
            for mask in 1u32..(1 << movable.len()) {
                let mut m = labels.to_vec();
                for (i, &p) in movable.iter().enumerate() {
                    if mask >> i & 1 == 1 {
                        m[p] = alpha;
                    }
                }
                let e = mrf.energy(&m).unwrap().total;
                assert!(e >= e0, "α = {alpha} move lowers {e0} to {e}");
            }
        }
    }

    fn random_data(rng: &mut Rng, n: usize, l: usize) -> Vec<i32> {
        (0..n * l).map(|_| rng.below(20) as i32).collect()
    }

    #[test]
    fn metric_expansion_is_a_local_optimum_within_twice_the_optimum() {
        let mut rng = Rng(5);
        for trial in 0..60 {
            let (w, h, l) = (2 + trial % 3, 2 + (trial / 3) % 2, 3);
            let data = random_data(&mut rng, w * h, l);
            let lambda = rng.below(12) as i32;
            let smooth = if trial % 2 == 0 {
                Smoothness::Potts(lambda)
            } else {
                Smoothness::TruncatedLinear {
                    scale: lambda,
                    truncation: 2 * lambda,
                }
            };
            let mrf = Mrf::grid(w, h, Connectivity::Four, l, DataCost::Dense(&data))
                .unwrap()
                .with_smoothness(smooth)
                .unwrap();
            let sol = mrf.expansion(&ExpansionConfig::default(), None).unwrap();
            assert!(sol.converged);
            assert_eq!(sol.energy, mrf.energy(&sol.labels).unwrap().total);
            let opt = brute_force(&mrf);
            assert!(sol.energy >= opt);
            // Boykov et al.: within 2·max/min of V of the optimum for metrics (2 for Potts).
            assert!(
                sol.energy <= 2 * opt.max(0) + 1 || trial % 2 == 1,
                "trial {trial}"
            );
            assert_expansion_local_optimum(&mrf, &sol.labels);
            let energies: Vec<i64> = std::iter::once(sol.initial_energy)
                .chain(sol.cycles.iter().map(|c| c.energy))
                .collect();
            assert!(energies.windows(2).all(|w| w[1] <= w[0]), "{energies:?}");
        }
    }

    #[test]
    fn warm_start_sweep_lowers_the_energy_exactly_as_reported() {
        let mut rng = Rng(71);
        for trial in 0..40 {
            let (w, h, l) = (4, 3, 4);
            let data = random_data(&mut rng, w * h, l);
            let mrf = Mrf::grid(w, h, Connectivity::Four, l, DataCost::Dense(&data))
                .unwrap()
                .with_smoothness(Smoothness::TruncatedLinear {
                    scale: 4,
                    truncation: 10,
                })
                .unwrap()
                .with_feasible_sites(3, &[0, 5, 6, 7])
                .unwrap();
            let mut labels: Vec<u32> = (0..w * h)
                .map(|p| {
                    let x = rng.below(l as u64) as u32;
                    if x == 3 && !mrf.is_feasible(p, 3) {
                        0
                    } else {
                        x
                    }
                })
                .collect();
            let mut e = mrf.energy(&labels).unwrap().total;
            let mut sweeps = 0;
            loop {
                let (d, n) = with_terms!(&mrf, |topo, data, pair| neighbour_sweep(
                    &mrf,
                    topo,
                    data,
                    &pair,
                    &mut labels
                ));
                let e2 = mrf.energy(&labels).unwrap().total;
                assert_eq!(e2, e + d, "trial {trial}");
                assert!(d <= 0 && (n == 0) == (d == 0), "trial {trial}: {d} {n}");
                e = e2;
                sweeps += 1;
                if n == 0 {
                    break;
                }
                assert!(sweeps < 100);
            }
            // At the fixed point no site gains by taking a neighbour's label.
            for p in 0..w * h {
                let x = p % w;
                for q in [p.wrapping_sub(1), p + 1, p.wrapping_sub(w), p + w] {
                    let nb = q < w * h && (q / w == p / w || q % w == x);
                    if nb && mrf.is_feasible(p, labels[q]) {
                        let mut m = labels.clone();
                        m[p] = labels[q];
                        assert!(mrf.energy(&m).unwrap().total >= e);
                    }
                }
            }
            // With or without the warm start, expansion ends at a local optimum.
            for k in [0, 1, 3] {
                let m = Mrf::grid(w, h, Connectivity::Four, l, DataCost::Dense(&data))
                    .unwrap()
                    .with_smoothness(Smoothness::Potts(5))
                    .unwrap()
                    .with_warm_start(k);
                let sol = m.expansion(&ExpansionConfig::default(), None).unwrap();
                assert!(sol.energy <= sol.initial_energy);
                assert_eq!(sol.energy, m.energy(&sol.labels).unwrap().total);
                assert_expansion_local_optimum(&m, &sol.labels);
            }
        }
    }

    #[test]
    fn binary_potts_expansion_is_optimal() {
        // With two labels and a submodular pair term one expansion is an exact min cut.
        let mut rng = Rng(9);
        for _ in 0..40 {
            let (w, h) = (3, 3);
            let data = random_data(&mut rng, w * h, 2);
            let lambda = rng.below(15) as i32;
            let mrf = Mrf::grid(w, h, Connectivity::Eight, 2, DataCost::Dense(&data))
                .unwrap()
                .with_smoothness(Smoothness::Potts(lambda))
                .unwrap();
            let sol = mrf.expansion(&ExpansionConfig::default(), None).unwrap();
            assert_eq!(sol.energy, brute_force(&mrf));
        }
    }

    #[test]
    fn non_metric_closure_never_raises_the_energy() {
        let mut rng = Rng(13);
        for trial in 0..60 {
            let (n, l) = (7, 4);
            let mut edges = Vec::new();
            for p in 0..n as u32 {
                for q in p + 1..n as u32 {
                    if rng.below(3) == 0 {
                        edges.push([p, q]);
                    }
                }
            }
            let data = random_data(&mut rng, n, l);
            // A "gap between planes" style cost: non-metric, pair dependent, truncated.
            let table: Vec<i32> = (0..l * l)
                .map(|i| {
                    if i / l == i % l {
                        0
                    } else {
                        1 + rng.below(25) as i32
                    }
                })
                .collect();
            let sym = move |a: u32, b: u32| table[(a.min(b) * l as u32 + a.max(b)) as usize];
            let v = move |p: usize, q: usize, a: u32, b: u32| -> i32 {
                assert!(p < q);
                (sym(a, b) * (1 + ((p + q) % 3) as i32)).min(40)
            };
            let mrf = Mrf::general(n, &edges, l, DataCost::Dense(&data))
                .unwrap()
                .with_smoothness(Smoothness::Fn(Box::new(v)))
                .unwrap();
            let init: Vec<u32> = (0..n).map(|_| rng.below(l as u64) as u32).collect();
            let e0 = mrf.energy(&init).unwrap().total;
            for order in [
                LabelOrder::Fixed,
                LabelOrder::Adaptive,
                LabelOrder::Shuffled(trial as u64),
            ] {
                let cfg = ExpansionConfig {
                    max_cycles: 50,
                    order,
                };
                let sol = mrf.expansion(&cfg, Some(&init)).unwrap();
                assert_eq!(sol.initial_energy, e0);
                assert!(sol.energy <= e0);
                assert_eq!(sol.energy, mrf.energy(&sol.labels).unwrap().total);
                assert!(sol.energy >= brute_force(&mrf));
                let mut prev = e0;
                for c in &sol.cycles {
                    assert!(c.energy <= prev);
                    prev = c.energy;
                }
            }
        }
    }

    #[test]
    fn feasibility_and_label_costs_are_respected() {
        let mut rng = Rng(21);
        for trial in 0..40 {
            let (w, h, l) = (3, 2, 3);
            let n = w * h;
            let data = random_data(&mut rng, n, l);
            let only: Vec<u32> = (0..n as u32).filter(|_| rng.below(2) == 0).collect();
            let costs: Vec<i32> = (0..l).map(|_| rng.below(30) as i32).collect();
            let mrf = Mrf::grid(w, h, Connectivity::Four, l, DataCost::Dense(&data))
                .unwrap()
                .with_smoothness(Smoothness::Potts(3))
                .unwrap()
                .with_feasible_sites(2, &only)
                .unwrap()
                .with_label_costs(&costs)
                .unwrap();
            let sol = mrf.expansion(&ExpansionConfig::default(), None).unwrap();
            mrf.check_labelling(&sol.labels).unwrap();
            let e = mrf.energy(&sol.labels).unwrap();
            assert_eq!(sol.energy, e.total);
            assert!(sol.energy >= brute_force(&mrf), "trial {trial}");
            assert_expansion_local_optimum(&mrf, &sol.labels);
            // Label costs must matter: with huge costs only one label survives.
            let huge = vec![10_000; l];
            let mrf1 = Mrf::grid(w, h, Connectivity::Four, l, DataCost::Dense(&data))
                .unwrap()
                .with_label_costs(&huge)
                .unwrap();
            let sol1 = mrf1.expansion(&ExpansionConfig::default(), None).unwrap();
            let mut used: Vec<u32> = sol1.labels.clone();
            used.sort();
            used.dedup();
            assert_eq!(used.len(), 1, "trial {trial}: {:?}", sol1.labels);
            assert_eq!(sol1.energy, brute_force(&mrf1));
        }
    }

    /// The 4-connected grid path (grid-specialised max-flow and move builder) gives the
    /// general path's labels on many random instances: Potts-shaped tables, truncated
    /// linear, a non-metric closure (truncated moves), per-edge weights, feasibility.
    #[test]
    fn grid4_path_matches_general_path_on_random_instances() {
        let mut rng = Rng(91);
        for trial in 0..60 {
            let (w, h) = (1 + rng.below(7) as usize, 1 + rng.below(6) as usize);
            let l = 2 + rng.below(4) as usize;
            let n = w * h;
            let data = random_data(&mut rng, n, l);
            let lambda = 1 + rng.below(6) as i32;
            let potts: Vec<i32> = (0..l * l)
                .map(|i| if i / l == i % l { 0 } else { lambda })
                .collect();
            let kind = trial % 3;
            fn smooth(kind: u64, potts: &[i32]) -> Smoothness<'_, i32> {
                match kind {
                    0 => Smoothness::Table(potts),
                    1 => Smoothness::TruncatedLinear {
                        scale: 2,
                        truncation: 5,
                    },
                    _ => Smoothness::Fn(Box::new(|p, q, a, b| {
                        if a == b {
                            0
                        } else {
                            ((a * 7 + b * 7 + (p + q) as u32) % 9) as i32
                        }
                    })),
                }
            }
            let grid = Mrf::grid(w, h, Connectivity::Four, l, DataCost::Dense(&data)).unwrap();
            let weights: Vec<i32> = (0..grid.num_edge_slots())
                .map(|_| rng.below(4) as i32)
                .collect();
            let sites: Vec<u32> = (0..n as u32).filter(|_| rng.below(3) > 0).collect();
            let mut edges = Vec::new();
            let mut gw = Vec::new();
            for y in 0..h {
                for x in 0..w {
                    let p = (y * w + x) as u32;
                    for (dir, dx, dy) in [(0, 1, 0), (2, 0, 1)] {
                        if x + dx < w && y + dy < h {
                            edges.push([p, p + (dy * w + dx) as u32]);
                            gw.push(weights[grid.grid_edge_slot(x, y, dir).unwrap()]);
                        }
                    }
                }
            }
            let grid = grid
                .with_smoothness(smooth(kind, &potts))
                .unwrap()
                .with_edge_weights(&weights)
                .unwrap()
                .with_feasible_sites(1, &sites)
                .unwrap();
            let general = Mrf::general(n, &edges, l, DataCost::Dense(&data))
                .unwrap()
                .with_smoothness(smooth(kind, &potts))
                .unwrap()
                .with_edge_weights(&gw)
                .unwrap()
                .with_feasible_sites(1, &sites)
                .unwrap();
            let init: Vec<u32> = (0..n)
                .map(|p| if sites.contains(&(p as u32)) { 1 } else { 0 })
                .collect();
            let a = grid
                .expansion(&ExpansionConfig::default(), Some(&init))
                .unwrap();
            let b = general
                .expansion(&ExpansionConfig::default(), Some(&init))
                .unwrap();
            assert_eq!(a.labels, b.labels, "trial {trial} ({w}x{h}, {l} labels)");
            assert_eq!(a.energy, b.energy);
            assert_eq!(a.energy, general.energy(&a.labels).unwrap().total);
        }
    }

    #[test]
    fn grid_and_general_paths_agree_and_weights_apply() {
        let mut rng = Rng(33);
        let (w, h, l) = (6, 5, 4);
        let n = w * h;
        let data = random_data(&mut rng, n, l);
        let grid = Mrf::grid(w, h, Connectivity::Four, l, DataCost::Dense(&data)).unwrap();
        let weights: Vec<i32> = (0..grid.num_edge_slots())
            .map(|_| rng.below(4) as i32)
            .collect();
        let grid = grid
            .with_smoothness(Smoothness::TruncatedQuadratic {
                scale: 2,
                truncation: 9,
            })
            .unwrap()
            .with_edge_weights(&weights)
            .unwrap();
        let mut edges = Vec::new();
        let mut gw = Vec::new();
        for y in 0..h {
            for x in 0..w {
                let p = (y * w + x) as u32;
                for (dir, dx, dy) in [(0, 1, 0), (2, 0, 1)] {
                    if x + dx < w && y + dy < h {
                        edges.push([p, p + (dy * w + dx) as u32]);
                        gw.push(weights[grid.grid_edge_slot(x, y, dir).unwrap()]);
                    }
                }
            }
        }
        let general = Mrf::general(n, &edges, l, DataCost::Dense(&data))
            .unwrap()
            .with_smoothness(Smoothness::TruncatedQuadratic {
                scale: 2,
                truncation: 9,
            })
            .unwrap()
            .with_edge_weights(&gw)
            .unwrap();
        let a = grid.expansion(&ExpansionConfig::default(), None).unwrap();
        let b = general
            .expansion(&ExpansionConfig::default(), None)
            .unwrap();
        assert_eq!(a.energy, general.energy(&a.labels).unwrap().total);
        assert_eq!(b.energy, grid.energy(&b.labels).unwrap().total);
        assert_eq!(a.labels, b.labels);
        // Float costs give the same labelling on this integer-valued instance.
        let fdata: Vec<f64> = data.iter().map(|&d| d as f64).collect();
        let fw: Vec<f64> = weights.iter().map(|&d| d as f64).collect();
        let fgrid = Mrf::grid(w, h, Connectivity::Four, l, DataCost::Dense(&fdata))
            .unwrap()
            .with_smoothness(Smoothness::TruncatedQuadratic {
                scale: 2.0,
                truncation: 9.0,
            })
            .unwrap()
            .with_edge_weights(&fw)
            .unwrap();
        let c = fgrid.expansion(&ExpansionConfig::default(), None).unwrap();
        assert_eq!(c.energy, a.energy as f64);
    }

    #[test]
    fn swap_and_icm_baselines_never_raise_the_energy() {
        let mut rng = Rng(44);
        for _ in 0..30 {
            let (w, h, l) = (3, 3, 3);
            let data = random_data(&mut rng, w * h, l);
            let mrf = Mrf::grid(w, h, Connectivity::Four, l, DataCost::Dense(&data))
                .unwrap()
                .with_smoothness(Smoothness::Potts(rng.below(10) as i32))
                .unwrap();
            let init: Vec<u32> = (0..w * h).map(|_| rng.below(l as u64) as u32).collect();
            let e0 = mrf.energy(&init).unwrap().total;
            let s = mrf.swap(&ExpansionConfig::default(), Some(&init)).unwrap();
            let i = mrf.icm(100, Some(&init)).unwrap();
            let opt = brute_force(&mrf);
            for sol in [&s, &i] {
                assert!(sol.converged);
                assert!(sol.energy <= e0 && sol.energy >= opt);
                assert_eq!(sol.energy, mrf.energy(&sol.labels).unwrap().total);
            }
            // ICM result: no single-site change helps.
            for p in 0..w * h {
                for lab in 0..l as u32 {
                    let mut m = i.labels.clone();
                    m[p] = lab;
                    assert!(mrf.energy(&m).unwrap().total >= i.energy);
                }
            }
        }
    }

    #[test]
    fn bad_input_is_an_error_not_a_panic() {
        let data = vec![0i32; 5];
        assert!(matches!(
            Mrf::grid(2, 2, Connectivity::Four, 2, DataCost::Dense(&data)),
            Err(MrfError::DataSize { expected: 8, .. })
        ));
        let data = vec![0i32; 8];
        let mrf = Mrf::grid(2, 2, Connectivity::Four, 2, DataCost::Dense(&data)).unwrap();
        assert!(matches!(
            mrf.expansion(&ExpansionConfig::default(), Some(&[0, 1, 2, 0])),
            Err(MrfError::BadLabel { label: 2, .. })
        ));
        let mrf = mrf.with_feasible_sites(1, &[3]).unwrap();
        assert_eq!(
            mrf.expansion(&ExpansionConfig::default(), Some(&[0, 1, 0, 0])),
            Err(MrfError::Infeasible { site: 1, label: 1 })
        );
        assert!(matches!(
            Mrf::general(3, &[[0, 3]], 2, DataCost::Dense(&[0i32; 6])),
            Err(MrfError::BadEdge { edge: 0, .. })
        ));
    }
}
