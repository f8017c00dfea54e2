//! Iterated conditional modes (Besag 1986), a comparison baseline: sweep the sites in
//! order, give each the feasible label minimising its local energy (data + pairwise to the
//! current neighbours + label-cost change), until a sweep changes nothing.
use std::time::Instant;

use crate::cost::Cost;
use crate::maxflow::Topology;
use crate::moves::{CycleStats, Solution};
use crate::mrf::{energy_of, feasible, with_terms, DataFn, Mrf, MrfError, PairFn};

impl<T: Cost> Mrf<'_, T> {
    /// Minimises the energy by ICM sweeps (at most `max_cycles`).
    pub fn icm(
        &self,
        max_cycles: usize,
        initial: Option<&[u32]>,
    ) -> Result<Solution<T::Acc>, MrfError> {
        let labels = match initial {
            Some(l) => {
                self.check_labelling(l)?;
                l.to_vec()
            }
            None => self.data_argmin()?,
        };
        Ok(with_terms!(self, |topo, data, pair| icm(
            self, topo, data, &pair, max_cycles, labels
        )))
    }
}

fn icm<T: Cost, Tp: Topology, D: DataFn<T>, P: PairFn<T>>(
    mrf: &Mrf<'_, T>,
    topo: &Tp,
    data: &D,
    pair: &P,
    max_cycles: usize,
    mut labels: Vec<u32>,
) -> Solution<T::Acc> {
    let nl = mrf.num_labels as u32;
    let h = mrf.label_costs.as_deref();
    let mut counts = vec![0u32; nl as usize];
    for &l in &labels {
        counts[l as usize] += 1;
    }
    let initial_energy = energy_of(topo, data, pair, h, &labels).total;
    let mut energy = initial_energy;
    let mut cycles = Vec::new();
    let mut converged = false;
    for _ in 0..max_cycles {
        let start = Instant::now();
        let mut changed = 0;
        for p in 0..labels.len() {
            let local = |l: u32, labels: &[u32]| local_cost(topo, data, pair, p, l, labels);
            let cur = labels[p];
            let base = local(cur, &labels);
            let mut best = (T::Acc::default(), cur);
            for l in 0..nl {
                if l == cur || !feasible(&mrf.feasible, p, l) {
                    continue;
                }
                let mut d = local(l, &labels) - base;
                if let Some(h) = h {
                    if counts[l as usize] == 0 {
                        d += h[l as usize].widen();
                    }
                    if counts[cur as usize] == 1 {
                        d -= h[cur as usize].widen();
                    }
                }
                if d < best.0 {
                    best = (d, l);
                }
            }
            if best.1 != cur {
                counts[cur as usize] -= 1;
                counts[best.1 as usize] += 1;
                labels[p] = best.1;
                energy += best.0;
                changed += 1;
            }
        }
        let stats = CycleStats {
            energy,
            seconds: start.elapsed().as_secs_f64(),
            moves_tried: labels.len(),
            moves_accepted: changed,
            sites_changed: changed,
        };
        cycles.push(stats);
        if changed == 0 {
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

/// Local energy of label `l` at site `p`: its data cost plus the pairwise costs to the
/// neighbours' current `labels` (label costs excluded). Shared by ICM and the expansion's
/// warm-start sweeps.
pub(crate) fn local_cost<T: Cost, Tp: Topology, D: DataFn<T>, P: PairFn<T>>(
    topo: &Tp,
    data: &D,
    pair: &P,
    p: usize,
    l: u32,
    labels: &[u32],
) -> T::Acc {
    let mut c = data.d(p, l).widen();
    for a in topo.arcs(p as u32) {
        let q = topo.head(a) as usize;
        let e = topo.edge_of(a);
        c += if topo.is_forward(a) {
            pair.v(p, q, e, l, labels[q])
        } else {
            pair.v(q, p, e, labels[q], l)
        }
        .widen();
    }
    c
}
