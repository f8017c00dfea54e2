//! Coarse-to-fine α-expansion on 4-connected grids ([`Mrf::expansion_coarse_to_fine`]).
//!
//! A labelling of a large image is mostly wide regions of one label; only near the
//! boundaries between them does the full resolution matter. So:
//!
//! 1. **Coarse problem.** Each 2×2 block of sites becomes one site. Its data cost for label
//!    `l` is the sum of the block's costs (for integer costs capped at a quarter of the
//!    type's range, so that capacities cannot overflow at any level); a label is
//!    feasible there if it is feasible at any site of the block. The pairwise cost between
//!    two neighbouring blocks sums, over the fine rows (columns) crossing their border, the
//!    least fine pairwise cost at the border or one site to either side of it: a label
//!    change between two blocks may follow a cheap path through a block, as it could at
//!    the full resolution. (An edge-aware smoothness makes label changes cheap only along
//!    image edges. Charged at the block border alone, the coarse level merged regions whose
//!    outline runs inside blocks: on a real facade, the paving into the wall's plane.) With
//!    every block labelled uniformly the coarse energy is at most the fine energy, and
//!    equal for a pairwise cost that does not depend on the sites.
//! 2. **Recursion.** The coarse problem is solved the same way, `levels` times, and the
//!    coarsest one by plain α-expansion ([`Mrf::expansion`]).
//! 3. **Refinement in a band.** The coarse labelling is copied to the blocks' sites (a site
//!    where the copied label is infeasible takes its fine start label). Every site within
//!    `band` sites (Chebyshev distance) of a label change is then relabelled at full
//!    resolution by α-expansion over the labels the copied labelling uses, with the sites
//!    outside the band fixed: their pairwise costs to the band fold into the band's data
//!    costs, so the sub-problem's energy is the fine energy up to a constant.
//! 4. **Polish** (optional): one α-expansion cycle over every label on the whole level, so
//!    that whole regions may still change label (on a real 768×512 view, 60 000 pixels did,
//!    which the coarser level had given a neighbouring plane) and small regions the coarser
//!    level lost may come back.
//!
//! Without the polish, the result is a local optimum of the band's sub-problem, not of the
//! whole fine problem: a region narrower than a block that the coarse level never labelled
//! stays lost, and the energy may be higher than [`Mrf::expansion`]'s. The time falls with
//! the sites each move touches: a quarter per coarser level, and the band; the polish adds
//! one cycle at full size. The idea of solving a reduced problem and refining only where
//! labels change is that of Lombaert, Sun, Grady & Xu, "A multilevel banded graph cuts
//! method for fast image segmentation", ICCV 2005, here applied to α-expansion.

use crate::cost::Cost;
use crate::expansion::ExpansionConfig;
use crate::moves::Solution;
use crate::mrf::{DataCost, Mrf, MrfError, Pairwise, SiteGraph, Smoothness};

/// Options of [`Mrf::expansion_coarse_to_fine`].
#[derive(Clone, Debug, PartialEq)]
pub struct CoarseToFine {
    /// Number of 2× coarser levels below the given one (0 = plain α-expansion).
    pub levels: usize,
    /// Half-width of the refinement band around the coarse labelling's label changes, in
    /// sites of the finer level (Chebyshev distance), ≥ 1.
    pub band: usize,
    /// Smallest number of sites a coarser level may have; below it the recursion stops
    /// and that level is solved by plain α-expansion.
    pub min_sites: usize,
    /// After the band's refinement, one α-expansion cycle over every label on the whole
    /// level (at every level): whole regions may still change label and small regions
    /// the coarser level lost may come back, at the cost of one cycle at that resolution.
    pub polish: bool,
}

impl Default for CoarseToFine {
    fn default() -> Self {
        CoarseToFine {
            levels: 1,
            band: 2,
            min_sites: 1024,
            polish: true,
        }
    }
}

/// What a coarse-to-fine solve did, beside its [`Solution`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PyramidStats {
    /// Per level, finest first: sites of the level, sites relabelled in its band (all of
    /// them at the coarsest level), labels offered there.
    pub levels: Vec<(usize, usize, usize)>,
}

impl<T: Cost> Mrf<'_, T> {
    /// Minimises the energy coarse-to-fine (see the [module docs](crate::pyramid)): a 2×
    /// coarser problem is solved first (recursively, `pyramid.levels` times), and its
    /// labelling is refined at full resolution in a band around its label changes.
    /// The coarser levels start from their own data argmin; `initial` (or this level's
    /// data argmin) is used only where a copied coarse label is infeasible. `config` applies to every level's α-expansion;
    /// the returned cycles are the finest level's, with energies of the whole problem.
    ///
    /// Only 4-connected grids with dense data costs, no edge weights and no label costs
    /// have a coarse level; any other problem (or `pyramid.levels == 0`, or a grid whose
    /// coarse level would have fewer than `pyramid.min_sites` sites) is solved by
    /// [`Mrf::expansion`]. Deterministic.
    pub fn expansion_coarse_to_fine(
        &self,
        config: &ExpansionConfig,
        pyramid: &CoarseToFine,
        initial: Option<&[u32]>,
    ) -> Result<(Solution<T::Acc>, PyramidStats), MrfError> {
        let mut stats = PyramidStats::default();
        let solution = self.coarse_to_fine(config, pyramid, initial, &mut stats)?;
        Ok((solution, stats))
    }

    fn coarse_to_fine(
        &self,
        config: &ExpansionConfig,
        pyramid: &CoarseToFine,
        initial: Option<&[u32]>,
        stats: &mut PyramidStats,
    ) -> Result<Solution<T::Acc>, MrfError> {
        let n = self.num_sites();
        let flat = |stats: &mut PyramidStats| {
            stats.levels.push((n, n, self.num_labels));
            self.expansion(config, initial)
        };
        let (w, h) = match &self.graph {
            SiteGraph::Grid(g) if g.directions() == 4 => (g.width(), g.height()),
            _ => return flat(stats),
        };
        let DataCost::Dense(data) = &self.data else {
            return flat(stats);
        };
        let (cw, ch) = (w.div_ceil(2), h.div_ceil(2));
        if pyramid.levels == 0
            || self.weights.is_some()
            || self.label_costs.is_some()
            || cw * ch < pyramid.min_sites.max(1)
        {
            return flat(stats);
        }
        if pyramid.band == 0 {
            return Err(MrfError::BadOption(
                "coarse-to-fine band must be at least 1",
            ));
        }
        let num_labels = self.num_labels;
        let start = match initial {
            Some(l) => {
                self.check_labelling(l)?;
                l.to_vec()
            }
            None => self.data_argmin()?,
        };

        // 1. The coarse problem.
        // A block's cost is the sum of its four, capped for integer types at a quarter of
        // the type's range (floats saturate to infinity: no cap), so that a caller's
        // "infeasible" costs near the limit cannot overflow the coarse capacities.
        let cap = T::from_f64(T::to_f64(T::from_f64(f64::MAX)) / 4.0);
        let block = |c: usize| {
            let (cx, cy) = (c % cw, c / cw);
            let (x0, y0) = (2 * cx, 2 * cy);
            (y0..(y0 + 2).min(h)).flat_map(move |y| (x0..(x0 + 2).min(w)).map(move |x| y * w + x))
        };
        let mut coarse_data = vec![T::ZERO; cw * ch * num_labels];
        for c in 0..cw * ch {
            for l in 0..num_labels {
                let mut sum = T::ZERO.widen();
                for p in block(c) {
                    sum += data[p * num_labels + l].widen();
                }
                let v = T::from_f64(T::acc_to_f64(sum));
                coarse_data[c * num_labels + l] = v.min_of(cap);
            }
        }
        let coarse_pair = move |c1: usize, c2: usize, a: u32, b: u32| -> T {
            if a == b {
                return T::ZERO;
            }
            let (cx, cy) = (c1 % cw, c1 / cw);
            let mut sum = T::ZERO;
            if c2 == c1 + 1 {
                let x1 = 2 * cx + 1;
                for y in (2 * cy)..(2 * cy + 2).min(h) {
                    let at = |x: usize| self.pair_at(y * w + x, y * w + x + 1, a, b);
                    let mut v = at(x1).min_of(at(x1 - 1));
                    if x1 + 2 < w {
                        v = v.min_of(at(x1 + 1));
                    }
                    sum += v;
                }
            } else {
                let y1 = 2 * cy + 1;
                for x in (2 * cx)..(2 * cx + 2).min(w) {
                    let at = |y: usize| self.pair_at(y * w + x, (y + 1) * w + x, a, b);
                    let mut v = at(y1).min_of(at(y1 - 1));
                    if y1 + 2 < h {
                        v = v.min_of(at(y1 + 1));
                    }
                    sum += v;
                }
            }
            sum
        };
        let mut coarse = Mrf::grid(
            cw,
            ch,
            crate::Connectivity::Four,
            num_labels,
            DataCost::Dense(&coarse_data),
        )?
        .with_smoothness(Smoothness::Fn(Box::new(coarse_pair)))?
        .with_warm_start(self.warm_sweeps);
        for l in 0..num_labels {
            if self.feasible[l].is_some() {
                let sites: Vec<u32> = (0..cw * ch)
                    .filter(|&c| block(c).any(|p| self.is_feasible(p, l as u32)))
                    .map(|c| c as u32)
                    .collect();
                coarse = coarse.with_feasible_sites(l as u32, &sites)?;
            }
        }
        let deeper = CoarseToFine {
            levels: pyramid.levels - 1,
            ..pyramid.clone()
        };
        let mut coarse_stats = PyramidStats::default();
        let coarse_solution = coarse.coarse_to_fine(config, &deeper, None, &mut coarse_stats)?;

        // 2. Copy it to the fine sites.
        let mut labels: Vec<u32> = (0..n)
            .map(|p| coarse_solution.labels[(p / w / 2) * cw + (p % w) / 2])
            .collect();
        let mut in_band = vec![false; n];
        for p in 0..n {
            if !self.is_feasible(p, labels[p]) {
                labels[p] = start[p];
                in_band[p] = true;
            }
        }
        // 3. The band: label changes dilated by `band` (separable Chebyshev dilation).
        let mut edge = vec![false; n];
        for y in 0..h {
            for x in 0..w {
                let p = y * w + x;
                if x + 1 < w && labels[p] != labels[p + 1] {
                    edge[p] = true;
                    edge[p + 1] = true;
                }
                if y + 1 < h && labels[p] != labels[p + w] {
                    edge[p] = true;
                    edge[p + w] = true;
                }
            }
        }
        let r = pyramid.band - 1;
        let mut rows = vec![false; n];
        for y in 0..h {
            dilate_line(&edge, &mut rows, y * w, 1, w, r);
        }
        for x in 0..w {
            dilate_line(&rows, &mut in_band, x, w, h, r);
        }
        let band: Vec<u32> = (0..n as u32).filter(|&p| in_band[p as usize]).collect();
        let mut used = vec![false; num_labels];
        for &l in &labels {
            used[l as usize] = true;
        }
        let used: Vec<u32> = (0..num_labels as u32)
            .filter(|&l| used[l as usize])
            .collect();
        stats.levels.push((n, band.len(), used.len()));
        stats.levels.extend(coarse_stats.levels);
        let initial_energy = self.energy(&start)?.total;
        if band.is_empty() || used.len() < 2 {
            let copied = Solution {
                energy: self.energy(&labels)?.total,
                labels,
                initial_energy,
                cycles: Vec::new(),
                converged: true,
            };
            return self.polish(config, pyramid, copied);
        }

        // 4. The band's sub-problem: the outside is fixed and folds into the data costs.
        let mut local = vec![u32::MAX; n];
        for (i, &p) in band.iter().enumerate() {
            local[p as usize] = i as u32;
        }
        let mut local_label = vec![u32::MAX; num_labels];
        for (k, &l) in used.iter().enumerate() {
            local_label[l as usize] = k as u32;
        }
        let k = used.len();
        let mut edges = Vec::new();
        let mut sub_data = vec![T::ZERO; band.len() * k];
        for (i, &p) in band.iter().enumerate() {
            let p = p as usize;
            let (x, y) = (p % w, p / w);
            let neighbours = [
                (x + 1 < w).then(|| p + 1),
                (y + 1 < h).then(|| p + w),
                (x > 0).then(|| p - 1),
                (y > 0).then(|| p - w),
            ];
            for (j, &l) in used.iter().enumerate() {
                let mut c = data[p * num_labels + l as usize];
                for q in neighbours.into_iter().flatten() {
                    if local[q] == u32::MAX {
                        c += if p < q {
                            self.pair_at(p, q, l, labels[q])
                        } else {
                            self.pair_at(q, p, labels[q], l)
                        };
                    }
                }
                sub_data[i * k + j] = c;
            }
            for q in neighbours[..2].iter().flatten() {
                if local[*q] != u32::MAX {
                    edges.push([i as u32, local[*q]]);
                }
            }
        }
        let sub_pair = |i: usize, j: usize, a: u32, b: u32| -> T {
            self.pair_at(
                band[i] as usize,
                band[j] as usize,
                used[a as usize],
                used[b as usize],
            )
        };
        let mut sub = Mrf::general(band.len(), &edges, k, DataCost::Dense(&sub_data))?
            .with_smoothness(Smoothness::Fn(Box::new(sub_pair)))?
            .with_warm_start(self.warm_sweeps);
        for (j, &l) in used.iter().enumerate() {
            if self.feasible[l as usize].is_some() {
                let sites: Vec<u32> = band
                    .iter()
                    .enumerate()
                    .filter(|&(_, &p)| self.is_feasible(p as usize, l))
                    .map(|(i, _)| i as u32)
                    .collect();
                sub = sub.with_feasible_sites(j as u32, &sites)?;
            }
        }
        let sub_start: Vec<u32> = band
            .iter()
            .map(|&p| local_label[labels[p as usize] as usize])
            .collect();
        let solved = sub.expansion(config, Some(&sub_start))?;
        for (i, &p) in band.iter().enumerate() {
            labels[p as usize] = used[solved.labels[i] as usize];
        }
        // The sub-problem's energy differs from the whole one's by the fixed part.
        let energy = self.energy(&labels)?.total;
        let offset = energy - solved.energy;
        let mut cycles = solved.cycles;
        for c in &mut cycles {
            c.energy += offset;
        }
        let refined = Solution {
            labels,
            energy,
            initial_energy,
            cycles,
            converged: solved.converged,
        };
        self.polish(config, pyramid, refined)
    }

    /// Step 4 of the module docs, if `pyramid.polish`: one α-expansion cycle over every
    /// label on the whole level, from `refined`.
    fn polish(
        &self,
        config: &ExpansionConfig,
        pyramid: &CoarseToFine,
        refined: Solution<T::Acc>,
    ) -> Result<Solution<T::Acc>, MrfError> {
        if !pyramid.polish {
            return Ok(refined);
        }
        let one = ExpansionConfig {
            max_cycles: 1,
            ..config.clone()
        };
        let polished = self.expansion(&one, Some(&refined.labels))?;
        let mut cycles = refined.cycles;
        cycles.extend(polished.cycles);
        Ok(Solution {
            labels: polished.labels,
            energy: polished.energy,
            initial_energy: refined.initial_energy,
            cycles,
            converged: polished.converged,
        })
    }

    /// `V(p, q, a, b)` of a problem without edge weights (`p < q`).
    #[inline]
    fn pair_at(&self, p: usize, q: usize, a: u32, b: u32) -> T {
        if a == b {
            return T::ZERO;
        }
        match &self.pair {
            Pairwise::Potts(l) => *l,
            Pairwise::Table(t) => t[a as usize * self.num_labels + b as usize],
            Pairwise::Fn(f) => f(p, q, a, b),
        }
    }
}

/// Marks in `dst` every site of the line `start + i · stride` (`i < len`) within `r` sites
/// of a site marked in `src`: one pass each way, remembering the last mark.
fn dilate_line(src: &[bool], dst: &mut [bool], start: usize, stride: usize, len: usize, r: usize) {
    let at = |i: usize| start + i * stride;
    let mut last: Option<usize> = None;
    for i in 0..len {
        if src[at(i)] {
            last = Some(i);
        }
        if last.is_some_and(|l| i - l <= r) {
            dst[at(i)] = true;
        }
    }
    last = None;
    for i in (0..len).rev() {
        if src[at(i)] {
            last = Some(i);
        }
        if last.is_some_and(|l| l - i <= r) {
            dst[at(i)] = true;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Connectivity;

    /// A noisy piecewise-constant image of `labels` vertical stripes with a truncated-linear
    /// smoothness: deterministic pseudo-random data costs.
    fn stripes(w: usize, h: usize, labels: usize, noise: i32) -> Vec<i32> {
        let mut state = 0x2545F4914F6CDD1Du64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state % 1000) as i32
        };
        let mut d = vec![0i32; w * h * labels];
        for y in 0..h {
            for x in 0..w {
                // Stripe boundaries not on block boundaries, and a slanted one.
                let truth = ((x * labels + y / 3) / (w + 1)).min(labels - 1);
                for l in 0..labels {
                    let base = if l == truth { 0 } else { 100 };
                    d[(y * w + x) * labels + l] = base + next() * noise / 1000;
                }
            }
        }
        d
    }

    fn truth_of(w: usize, h: usize, labels: usize) -> Vec<u32> {
        (0..w * h)
            .map(|p| (((p % w) * labels + (p / w) / 3) / (w + 1)).min(labels - 1) as u32)
            .collect()
    }

    #[test]
    fn coarse_to_fine_recovers_stripes_with_an_energy_near_the_flat_solve() {
        let (w, h, l) = (61, 47, 4);
        let data = stripes(w, h, l, 150);
        let pairs = || {
            [
                Smoothness::Potts(60),
                Smoothness::TruncatedLinear {
                    scale: 30,
                    truncation: 70,
                },
            ]
        };
        for (pair, polish) in pairs()
            .into_iter()
            .map(|p| (p, false))
            .chain(pairs().into_iter().map(|p| (p, true)))
        {
            let mrf = Mrf::grid(w, h, Connectivity::Four, l, DataCost::Dense(&data))
                .unwrap()
                .with_smoothness(pair)
                .unwrap();
            let cfg = ExpansionConfig::default();
            let flat = mrf.expansion(&cfg, None).unwrap();
            let pyr = CoarseToFine {
                levels: 2,
                band: 2,
                min_sites: 16,
                polish,
            };
            let (fast, stats) = mrf.expansion_coarse_to_fine(&cfg, &pyr, None).unwrap();
            assert_eq!(stats.levels.len(), 3, "{stats:?}");
            assert!(stats.levels[0].1 < w * h / 2, "band {:?}", stats.levels[0]);
            // Exact energy of what it returns, never above its start.
            assert_eq!(fast.energy, mrf.energy(&fast.labels).unwrap().total);
            assert!(
                fast.energy <= fast.initial_energy,
                "{} > {} (flat {})",
                fast.energy,
                fast.initial_energy,
                flat.energy
            );
            // Within 1 % of the flat solve's energy, and the same stripes.
            assert!(
                (fast.energy as f64) <= flat.energy as f64 * 1.01,
                "{} vs {}",
                fast.energy,
                flat.energy
            );
            let truth = truth_of(w, h, l);
            let wrong = fast
                .labels
                .iter()
                .zip(&truth)
                .filter(|(a, b)| a != b)
                .count();
            let wrong_flat = flat
                .labels
                .iter()
                .zip(&truth)
                .filter(|(a, b)| a != b)
                .count();
            assert!(wrong <= wrong_flat + w * h / 200, "{wrong} vs {wrong_flat}");
            // Cycle energies are the whole problem's and never rise.
            let mut prev = fast.initial_energy;
            for c in &fast.cycles {
                assert!(c.energy <= prev);
                prev = c.energy;
            }
            assert_eq!(prev, fast.energy);
        }
    }

    #[test]
    fn a_cheap_boundary_inside_the_blocks_is_found_without_the_polish() {
        // Two labels; the data prefers 0 left of x = 20.5 and 1 right of it, by 1 unit a
        // pixel; a label change costs 50 except across that line, which runs through
        // the coarse blocks (x = 20 and 21 share one), where it costs 1.
        let (w, h) = (40, 30);
        let data: Vec<i32> = (0..w * h)
            .flat_map(|p| if p % w <= 20 { [0, 1] } else { [1, 0] })
            .collect();
        let smooth = move |p: usize, q: usize, a: u32, b: u32| -> i32 {
            match (a == b, q == p + 1 && p % w == 20) {
                (true, _) => 0,
                (false, true) => 1,
                (false, false) => 50,
            }
        };
        let mrf = Mrf::grid(w, h, Connectivity::Four, 2, DataCost::Dense(&data))
            .unwrap()
            .with_smoothness(Smoothness::Fn(Box::new(smooth)))
            .unwrap();
        let pyr = CoarseToFine {
            levels: 1,
            band: 1,
            min_sites: 16,
            polish: false,
        };
        let (sol, _) = mrf
            .expansion_coarse_to_fine(&ExpansionConfig::default(), &pyr, None)
            .unwrap();
        for y in 0..h {
            assert_eq!(sol.labels[y * w + 20], 0, "row {y}");
            assert_eq!(sol.labels[y * w + 21], 1, "row {y}");
        }
        assert_eq!(sol.energy, h as i64);
    }

    #[test]
    fn feasibility_holds_at_every_level() {
        let (w, h, l) = (40, 30, 3);
        let data = stripes(w, h, l, 100);
        // Label 2 only on the left third.
        let left: Vec<u32> = (0..(w * h) as u32)
            .filter(|p| (*p as usize % w) < w / 3)
            .collect();
        let mrf = Mrf::grid(w, h, Connectivity::Four, l, DataCost::Dense(&data))
            .unwrap()
            .with_smoothness(Smoothness::Potts(50))
            .unwrap()
            .with_feasible_sites(2, &left)
            .unwrap();
        let pyr = CoarseToFine {
            levels: 1,
            band: 1,
            min_sites: 16,
            polish: true,
        };
        let (sol, _) = mrf
            .expansion_coarse_to_fine(&ExpansionConfig::default(), &pyr, None)
            .unwrap();
        mrf.check_labelling(&sol.labels).unwrap();
    }

    #[test]
    fn small_or_unsupported_problems_fall_back_to_the_flat_solve() {
        let (w, h, l) = (10, 8, 3);
        let data = stripes(w, h, l, 100);
        let mrf = Mrf::grid(w, h, Connectivity::Four, l, DataCost::Dense(&data))
            .unwrap()
            .with_smoothness(Smoothness::Potts(40))
            .unwrap();
        let cfg = ExpansionConfig::default();
        let flat = mrf.expansion(&cfg, None).unwrap();
        let (sol, stats) = mrf
            .expansion_coarse_to_fine(&cfg, &CoarseToFine::default(), None)
            .unwrap();
        assert_eq!(sol.labels, flat.labels);
        assert_eq!(stats.levels, vec![(w * h, w * h, l)]);
        let bad = CoarseToFine {
            band: 0,
            min_sites: 1,
            ..CoarseToFine::default()
        };
        assert!(mrf.expansion_coarse_to_fine(&cfg, &bad, None).is_err());
    }
}
