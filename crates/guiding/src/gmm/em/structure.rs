//! Split, merge and prune: the structure changes of the middle EM iteration.

use super::estep::SplitCandidate;
use super::stats::SuffStats;
use super::{map_gaussian, FitParams, FitReport, MIN_BIRTH_SHARE, MIN_SPLIT_POINTS};
use crate::gmm::gaussian::Gaussian3;
use crate::gmm::sym3::Sym3;

/// A component during the structure step.
pub(super) struct Entry {
    pub(super) component: Gaussian3,
    /// This update's statistics.
    pub(super) fresh: SuffStats,
    /// The decayed statistics of earlier updates.
    pub(super) previous: SuffStats,
    pub(super) split: Option<SplitCandidate>,
    pub(super) touched: bool,
}

impl Entry {
    pub(super) fn blended(&self) -> SuffStats {
        self.previous.combine(&self.fresh)
    }
}

/// Splits an entry by birth from its best cell (see the module notes), if the parts are valid.
fn birth_split(
    e: &Entry,
    birth: &SuffStats,
) -> Option<((SuffStats, SuffStats), (SuffStats, SuffStats))> {
    let fresh_rest = e.fresh.subtract(birth)?;
    let share = e.previous.weight / e.fresh.weight;
    let history = (share > 0.0 && share.is_finite())
        .then(|| {
            let part = birth.scaled(share);
            e.previous.subtract(&part).map(|rest| (part, rest))
        })
        .flatten()
        .unwrap_or((
            SuffStats {
                weight: 0.0,
                mean: birth.mean,
                scatter: Sym3::ZERO,
            },
            e.previous,
        ));
    Some(((*birth, fresh_rest), history))
}

/// Merges, prunes and splits (see the module notes).
pub(super) fn restructure(entries: &mut Vec<Entry>, params: &FitParams, report: &mut FitReport) {
    let total_of = |entries: &[Entry]| entries.iter().map(|e| e.blended().weight).sum::<f64>();
    // Merges.
    while entries.len() > params.k_min.max(1) {
        let mut best = (f64::INFINITY, 0, 0);
        for i in 0..entries.len() {
            if entries[i].touched {
                continue;
            }
            for j in i + 1..entries.len() {
                if entries[j].touched {
                    continue;
                }
                let d = entries[i].component.bhattacharyya(&entries[j].component);
                if d < best.0 {
                    best = (d, i, j);
                }
            }
        }
        let (d, i, j) = best;
        if !(d < params.merge_threshold) {
            break;
        }
        let other = entries.remove(j);
        let nu = params.prior_strength * total_of(entries);
        let e = &mut entries[i];
        e.fresh = e.fresh.combine(&other.fresh);
        e.previous = e.previous.combine(&other.previous);
        e.component = map_gaussian(&e.blended(), nu, params, &e.component);
        e.split = None;
        e.touched = true;
        report.merges += 1;
    }
    // Prunes.
    let total = total_of(entries);
    while entries.len() > params.k_min.max(1) {
        let (i, w) = entries
            .iter()
            .enumerate()
            .map(|(i, e)| (i, e.blended().weight))
            .fold((0, f64::INFINITY), |b, c| if c.1 < b.1 { c } else { b });
        if !(w < params.prune_share * total) {
            break;
        }
        entries.remove(i);
        report.prunes += 1;
    }
    // Splits, best first.
    let total = total_of(entries);
    if !(total > 0.0) {
        return;
    }
    let mut candidates: Vec<(f64, usize)> = entries
        .iter()
        .enumerate()
        .filter(|(_, e)| !e.touched)
        .filter_map(|(i, e)| {
            let s = e.split?;
            let score = e.blended().weight / total * s.divergence;
            (s.effective_points >= MIN_SPLIT_POINTS
                && s.birth_share >= MIN_BIRTH_SHARE
                && score > params.split_threshold)
                .then_some((score, i))
        })
        .collect();
    candidates.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    let nu = params.prior_strength * total;
    for (_, i) in candidates {
        if entries.len() >= params.k_max {
            break;
        }
        let Some(split) = entries[i].split else {
            continue;
        };
        let Some(((fresh_child, fresh_rest), (prev_child, prev_rest))) =
            birth_split(&entries[i], &split.birth)
        else {
            continue;
        };
        let parent = entries[i].component;
        let make = |fresh: SuffStats, previous: SuffStats| {
            let blended = previous.combine(&fresh);
            Entry {
                component: map_gaussian(&blended, nu, params, &parent),
                fresh,
                previous,
                split: None,
                touched: true,
            }
        };
        entries[i] = make(fresh_rest, prev_rest);
        entries.push(make(fresh_child, prev_child));
        report.splits += 1;
    }
}
