//! α-β swap (Boykov, Veksler & Zabih 2001), a comparison baseline: each move lets the sites
//! labelled α or β exchange those two labels. Label costs, if any, enter only the acceptance
//! test (a move is kept only if the true energy drops).
use std::time::Instant;

use crate::cost::Cost;
use crate::expansion::{debug_check_energy, ExpansionConfig, LabelOrder};
use crate::maxflow::{MaxFlow, Topology};
use crate::moves::{label_cost_delta, solve_move_fast, CycleStats, Solution, SplitMix};
use crate::mrf::{energy_of, feasible, with_terms, DataFn, Mrf, MrfError, PairFn};

impl<T: Cost> Mrf<'_, T> {
    /// Minimises the energy by α-β swap moves over all label pairs per cycle.
    /// [`LabelOrder::Adaptive`] behaves like [`LabelOrder::Fixed`] here.
    pub fn swap(
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
        Ok(with_terms!(self, |topo, data, pair| swap(
            self, topo, data, &pair, config, labels
        )))
    }
}

fn swap<T: Cost, Tp: Topology + Clone, D: DataFn<T>, P: PairFn<T>>(
    mrf: &Mrf<'_, T>,
    topo: &Tp,
    data: &D,
    pair: &P,
    config: &ExpansionConfig,
    mut labels: Vec<u32>,
) -> Solution<T::Acc> {
    let nl = mrf.num_labels;
    let h = mrf.label_costs.as_deref();
    let mut mf = MaxFlow::<T, Tp>::new(topo.clone());
    let mut energy = energy_of(topo, data, pair, h, &labels).total;
    let initial_energy = energy;
    let mut counts = vec![0u32; nl];
    for &l in &labels {
        counts[l as usize] += 1;
    }
    let mut pairs: Vec<(u32, u32)> = (0..nl as u32)
        .flat_map(|a| (a + 1..nl as u32).map(move |b| (a, b)))
        .collect();
    let mut known_fail = vec![u64::MAX; pairs.len()];
    let mut version = 0u64;
    let mut rng = match config.order {
        LabelOrder::Shuffled(seed) => SplitMix(seed),
        _ => SplitMix(0),
    };
    let mut changed = Vec::new();
    let mut scratch = Vec::new();
    let mut cycles = Vec::new();
    let mut converged = false;
    for _ in 0..config.max_cycles {
        let start = Instant::now();
        if let LabelOrder::Shuffled(_) = config.order {
            rng.shuffle(&mut pairs);
        }
        let mut stats = CycleStats {
            energy,
            seconds: 0.0,
            moves_tried: 0,
            moves_accepted: 0,
            sites_changed: 0,
        };
        for &(a, b) in &pairs {
            let key = a as usize * nl - (a as usize * (a as usize + 1)) / 2 + (b - a - 1) as usize;
            if known_fail[key] == version || counts[a as usize] + counts[b as usize] == 0 {
                continue;
            }
            stats.moves_tried += 1;
            let target = |p: usize, c: u32| {
                if c == a && feasible(&mrf.feasible, p, b) {
                    Some(b)
                } else if c == b && feasible(&mrf.feasible, p, a) {
                    Some(a)
                } else {
                    None
                }
            };
            let (mut delta, _) =
                solve_move_fast(&mut mf, topo, data, pair, &labels, &target, &mut changed);
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
                debug_check_energy(topo, data, pair, h, &labels, energy);
            } else {
                known_fail[key] = version;
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
    let energy = energy_of(topo, data, pair, h, &labels).total;
    Solution {
        labels,
        energy,
        initial_energy,
        cycles,
        converged,
    }
}
