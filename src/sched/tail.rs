//! The end of a run over sources of different speeds: how much work each source may hold so
//! that none finishes after the run could have ended without it.
//!
//! Equal buffers of equal items let a slow source take the tail: on the H200 machine 16 CPU
//! threads held four 32² tiles of 512 spp each (about 3 s of work per thread) when the GPU had
//! rendered everything else in 1.6 s, and threads + GPU took 2.79 s against 1.75 s for the GPU
//! alone (`results/published/gpu/2026-12-04-h200/`). The guard bounds what a source holds by
//! the later of two horizons, both from measured rates:
//! - the projected end of the run: everything not yet returned, over the sum of the rates;
//! - the earliest another source would finish one more item (earliest finish time, the rule of
//!   list scheduling on related machines), so the source that would finish an item first may
//!   always take it and the run cannot stall.

/// One source as the guard sees it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Load {
    /// Pixels per second of its busy time; `None` until it has returned a result.
    pub rate: Option<f64>,
    /// Pixels it holds: handed out, result not yet taken.
    pub held_px: f64,
    /// False once it is lost.
    pub alive: bool,
}

impl Load {
    fn measured_rate(&self) -> Option<f64> {
        self.rate
            .filter(|r| self.alive && *r > 0.0 && r.is_finite())
    }
}

/// Most pixels source `s` may hold once topped up, or `None` for no bound: its rate is not
/// measured yet, or no other live source's is. `unissued_px` is the work never handed out,
/// `item_px` the pixels of the next item.
pub fn allowance(loads: &[Load], s: usize, unissued_px: f64, item_px: f64) -> Option<f64> {
    let rate = loads.get(s)?.measured_rate()?;
    let others = loads
        .iter()
        .enumerate()
        .filter(|&(r, _)| r != s)
        .filter_map(|(_, l)| l.measured_rate().map(|rate| (rate, l.held_px)));
    // The earliest another source would finish one more item.
    let earliest = others
        .map(|(rate, held)| (held + item_px) / rate)
        .min_by(f64::total_cmp)?;
    let measured = loads.iter().filter(|l| l.measured_rate().is_some());
    let total_rate: f64 = measured.clone().filter_map(|l| l.measured_rate()).sum();
    let held: f64 = loads.iter().filter(|l| l.alive).map(|l| l.held_px).sum();
    let end = (unissued_px + held) / total_rate;
    Some(end.max(earliest) * rate)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn load(rate: f64, held_px: f64) -> Load {
        Load {
            rate: Some(rate),
            held_px,
            alive: true,
        }
    }

    #[test]
    fn a_source_is_unbounded_until_it_and_another_are_measured() {
        let unmeasured = Load {
            rate: None,
            held_px: 0.0,
            alive: true,
        };
        assert_eq!(allowance(&[unmeasured, load(1e3, 0.0)], 0, 1e6, 10.0), None);
        assert_eq!(allowance(&[load(1e3, 0.0), unmeasured], 0, 1e6, 10.0), None);
        let lost = Load {
            alive: false,
            ..load(1e3, 0.0)
        };
        assert_eq!(allowance(&[load(1e3, 0.0), lost], 0, 1e6, 10.0), None);
        assert_eq!(allowance(&[load(1e3, 0.0)], 0, 1e6, 10.0), None);
    }

    #[test]
    fn mid_run_a_source_holds_its_share_of_the_remaining_time() {
        // 10 000 px left, rates 1 000 and 9 000 px/s: the run ends in 1 s; the slow source
        // may hold what it renders in that second, the fast one nine times as much.
        let loads = [load(1e3, 0.0), load(9e3, 0.0)];
        assert_eq!(allowance(&loads, 0, 1e4, 10.0), Some(1e3));
        assert_eq!(allowance(&loads, 1, 1e4, 10.0), Some(9e3));
        // What is held counts as remaining work.
        let loads = [load(1e3, 500.0), load(9e3, 4500.0)];
        assert_eq!(allowance(&loads, 0, 5e3, 10.0), Some(1e3));
    }

    #[test]
    fn at_the_end_the_slow_source_gets_nothing_the_fast_one_would_finish_first() {
        // 100 px left, 1 000 vs 99 000 px/s: the run ends in 1 ms; one 100 px item would take
        // the slow source 0.1 s and the fast one about 1 ms.
        let loads = [load(1e3, 0.0), load(9.9e4, 0.0)];
        let slow = allowance(&loads, 0, 100.0, 100.0).unwrap();
        assert!(slow < 100.0, "slow source may hold {slow} px");
        let fast = allowance(&loads, 1, 100.0, 100.0).unwrap();
        assert!(fast >= 100.0, "fast source may hold {fast} px");
    }

    #[test]
    fn the_source_that_would_finish_an_item_first_may_always_take_it() {
        // The last item, equal sources, nothing held: the projected end (half an item's
        // time) is too soon for either, but each would finish it no later than the other.
        let loads = [load(1e3, 0.0), load(1e3, 0.0)];
        for s in 0..2 {
            assert!(allowance(&loads, s, 100.0, 100.0).unwrap() >= 100.0);
        }
        // A fast source busy with a long queue: the idle slow one finishes the item first.
        let loads = [load(1e3, 0.0), load(1e4, 5e4)];
        assert!(allowance(&loads, 0, 100.0, 100.0).unwrap() >= 100.0);
    }
}
