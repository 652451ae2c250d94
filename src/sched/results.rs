//! A run's results, found by item id but left where they were produced.
//!
//! Workers of the shared schedulers append results to their own lists; gathering them into
//! one `Vec<Option<TileResult>>` meant writing 2¹⁸ empty slots and then moving 2¹⁸ 48-byte
//! results into them (~25 MB, 1.7–2.7 ms per run of one-pixel items, serial after the join).
//! [`Results`] keeps the lists and builds a 4-byte index per item instead.

use super::wire;
use crate::core::metrics::{MasterStats, Probe, RunStats, Span};
use crate::core::render::TileResult;
use crate::source::ComputeSource;

/// No result for this item (yet).
const NONE: u32 = u32::MAX;

/// Results by item id: the lists they were produced in, and where each item's result is.
#[derive(Debug)]
pub struct Results {
    lists: Vec<Vec<TileResult>>,
    /// Position of each list's first result in the lists laid end to end.
    starts: Vec<u32>,
    /// Per item: the position of its (first) result in the lists laid end to end, or NONE.
    index: Vec<u32>,
}

impl Results {
    /// Index `lists` for `n` items; `ids[k][j]` is the item of `lists[k][j]` (kept apart by the
    /// producer so that indexing reads 4 bytes per result, not the 48-byte results: reading
    /// them cost 2.6 ns of self-scheduling's ~14 ns per item on one worker). A second result of
    /// an item is a duplicate: the first in list order wins. Returns the duplicates' count.
    pub(crate) fn from_lists(
        n: usize,
        lists: Vec<Vec<TileResult>>,
        ids: &[Vec<u32>],
    ) -> (Self, u64) {
        let mut index = vec![NONE; n];
        let mut starts = Vec::with_capacity(lists.len());
        let (mut pos, mut duplicates) = (0u32, 0u64);
        for (list, ids) in lists.iter().zip(ids) {
            debug_assert!(
                list.len() == ids.len() && list.iter().zip(ids).all(|(r, &i)| r.item == i)
            );
            starts.push(pos);
            for &i in ids {
                let entry = &mut index[i as usize];
                if *entry == NONE {
                    *entry = pos;
                } else {
                    duplicates += 1;
                }
                pos += 1;
            }
        }
        let results = Self {
            lists,
            starts,
            index,
        };
        (results, duplicates)
    }

    /// The result of `item`, if there is one.
    pub fn get(&self, item: u32) -> Option<&TileResult> {
        let pos = *self.index.get(item as usize)?;
        if pos == NONE {
            return None;
        }
        let list = self.starts.partition_point(|&s| s <= pos) - 1;
        Some(&self.lists[list][(pos - self.starts[list]) as usize])
    }

    /// Whether `item` has a result.
    pub fn has(&self, item: u32) -> bool {
        self.index[item as usize] != NONE
    }

    /// Number of items (with or without a result).
    pub fn len(&self) -> usize {
        self.index.len()
    }

    /// Whether there are no items at all.
    pub fn is_empty(&self) -> bool {
        self.index.is_empty()
    }

    /// Each item's result in item order.
    pub fn iter(&self) -> impl Iterator<Item = Option<&TileResult>> + '_ {
        (0..self.index.len() as u32).map(|i| self.get(i))
    }
}

/// What collecting results counted, apart from the results themselves.
#[derive(Debug, Default)]
pub(crate) struct Tally {
    pub done: usize,
    pub duplicates: u64,
    pub bytes: u64,
    pub rays: u64,
    pub nonfinite: u64,
}

impl Tally {
    /// `r` as a first result of its item.
    #[inline]
    pub(crate) fn add(&mut self, r: &TileResult) {
        self.bytes += wire::result_bytes(r);
        self.rays += r.rays;
        self.nonfinite += r.nonfinite;
        self.done += 1;
    }

    /// Another worker's tally into this one.
    pub(crate) fn merge(&mut self, o: &Tally) {
        self.done += o.done;
        self.duplicates += o.duplicates;
        self.bytes += o.bytes;
        self.rays += o.rays;
        self.nonfinite += o.nonfinite;
    }

    /// `r`, to be stored at position `pos`, for its item's index `entry`: the first result
    /// wins, a later one is a duplicate (its bytes count as moved, its rays do not).
    fn count(&mut self, entry: &mut u32, pos: u32, r: &TileResult) -> bool {
        if *entry != NONE {
            self.bytes += wire::result_bytes(r);
            self.duplicates += 1;
            return false;
        }
        *entry = pos;
        self.add(r);
        true
    }

    /// Duplicates, result bytes, rays and non-finite samples into the run's statistics.
    pub(crate) fn record(&self, stats: &mut RunStats) {
        stats.duplicates = self.duplicates;
        stats.bytes += self.bytes;
        stats.rays = self.rays;
        stats.nonfinite = self.nonfinite;
    }
}

/// Results arriving one at a time (a master's loop): one list, duplicates dropped at once.
pub(crate) struct Collector {
    pub results: Results,
    pub tally: Tally,
}

impl Collector {
    pub(crate) fn new(n: usize) -> Self {
        Self {
            results: Results {
                lists: vec![Vec::new()],
                starts: vec![0],
                index: vec![NONE; n],
            },
            tally: Tally::default(),
        }
    }

    pub(crate) fn is_done(&self, item: u32) -> bool {
        self.results.has(item)
    }

    /// Keep `r` unless its item already has a result (then it is counted and dropped).
    pub(crate) fn accept(&mut self, r: TileResult) {
        let res = &mut self.results;
        let list = &mut res.lists[0];
        let pos = list.len() as u32;
        if self.tally.count(&mut res.index[r.item as usize], pos, &r) {
            list.push(r);
        }
    }
}

/// Stop every source (its results' handles already dropped) and add its report to `stats`
/// and `spans`; its idle time is `wall_s` minus its busy time. Returns, per source, whether it
/// was lost by the time it stopped.
pub(crate) fn finish_sources(
    sources: Vec<Box<dyn ComputeSource>>,
    wall_s: f64,
    stats: &mut RunStats,
    spans: &mut Vec<Span>,
) -> Vec<bool> {
    let mut lost = Vec::with_capacity(sources.len());
    for src in sources {
        let mut rep = src.finish();
        rep.stats.idle_s = (wall_s - rep.stats.busy_s).max(0.0);
        stats.workers.push(rep.stats);
        spans.extend(rep.spans);
        lost.push(rep.lost);
    }
    lost
}

/// A finished run's last numbers: its timeline (sorted, when recorded), wall time, the
/// results' tallies and the master's own statistics.
pub(crate) fn seal_stats(
    stats: &mut RunStats,
    mut spans: Vec<Span>,
    probe: &Probe,
    wall_s: f64,
    collector: &Collector,
    master: MasterStats,
) {
    if probe.timeline {
        spans.sort_by_key(|s| (s.start_ns, s.worker));
        stats.timeline = Some(spans);
    }
    stats.wall_s = wall_s;
    collector.tally.record(stats);
    stats.master = Some(master);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn result(item: u32, rays: u64) -> TileResult {
        TileResult {
            item,
            pixels: smallvec::smallvec![[item as f32; 3]],
            rays,
            nonfinite: 0,
        }
    }

    #[test]
    fn results_are_found_by_item_across_lists_and_the_first_of_a_duplicate_wins() {
        let lists = vec![
            vec![result(3, 1), result(0, 1)],
            vec![],
            vec![result(1, 1), result(3, 7)],
        ];
        let ids: Vec<Vec<u32>> = lists
            .iter()
            .map(|l| l.iter().map(|r| r.item).collect())
            .collect();
        let (r, duplicates) = Results::from_lists(5, lists, &ids);
        assert_eq!(r.len(), 5);
        let found: Vec<Option<u32>> = r.iter().map(|x| x.map(|x| x.item)).collect();
        assert_eq!(found, [Some(0), Some(1), None, Some(3), None]);
        assert_eq!(r.get(3).unwrap().rays, 1, "the first result of item 3 wins");
        assert!(r.get(9).is_none());
        assert_eq!(duplicates, 1);
    }

    #[test]
    fn a_collector_drops_a_duplicate_and_keeps_the_first() {
        let mut c = Collector::new(3);
        c.accept(result(2, 5));
        c.accept(result(2, 9));
        c.accept(result(0, 1));
        assert!(c.is_done(2) && c.is_done(0) && !c.is_done(1));
        assert_eq!(c.results.get(2).unwrap().rays, 5);
        assert_eq!(c.results.lists[0].len(), 2, "the duplicate is not kept");
        assert_eq!((c.tally.done, c.tally.duplicates, c.tally.rays), (2, 1, 6));
    }
}
