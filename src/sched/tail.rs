//! The end of a run over sources of different speeds: how much work each source may hold so
//! that none finishes after the run could have ended without it.
//!
//! Equal buffers of equal items let a slow source take the tail: on the H200 machine 16 CPU
//! threads held four 32² tiles of 512 spp each (about 3 s of work per thread) when the GPU had
//! rendered everything else in 1.6 s, and threads + GPU took 2.79 s against 1.75 s for the GPU
//! alone (`results/published/gpu/2026-12-04-h200/`). The guard bounds what a source holds by
//! the projected end of the run, from measured rates: everything not yet returned over the sum
//! of the rates. A source may hold what it renders in half that time at the lowest rate it has
//! shown ([`COMMIT`]), so near the end a slow source gets nothing; the fastest source is not
//! bounded, and finishes the queue. An earlier form also let a source take an item
//! it would finish before any other source could (earliest finish time); with the GPU's results
//! coming back a 256-tile dispatch at a time, that let every thread take a 0.8 s tile until
//! the end (threads + GPU 0.34–0.35 of the sum of their rates, against 0.57–0.61 unguarded, in
//! three passes on the same machine). The guard may refuse every source while some hold work;
//! the master lifts it when none holds anything, so the run cannot stall.

/// One source as the guard sees it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Load {
    /// Work per second of its busy time (any unit all sources share; the master counts rays);
    /// `None` until it has returned a result.
    pub rate: Option<f64>,
    /// The lowest rate of one collection of its results (infinite before the first).
    pub floor_rate: f64,
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
/// measured yet, no other live source's is, or it is the fastest. `unissued_px` is the work
/// never handed out.
pub fn allowance(loads: &[Load], s: usize, unissued_px: f64) -> Option<f64> {
    let rate = loads.get(s)?.measured_rate()?;
    let rates: Vec<f64> = loads.iter().filter_map(Load::measured_rate).collect();
    if rates.len() < 2 || rates.iter().all(|&r| r <= rate) {
        return None;
    }
    // Its share of the sources' speed, of the pixels not yet returned; the projected end's
    // seconds cancel, so the unit of the rates does not matter.
    let held: f64 = loads.iter().filter(|l| l.alive).map(|l| l.held_px).sum();
    let share = rate.min(loads[s].floor_rate) / rates.iter().sum::<f64>();
    Some(COMMIT * share * (unissued_px + held))
}

/// The share of the time to the projected end a bounded source may commit, at the lowest rate
/// it has shown: a thread's first tiles of the Cornell box at 1024² and 512 spp (the ceiling
/// rows) took it 0.27 s, the later ones 0.8–0.9 s, so a rate measured early promised three
/// times what it rendered later.
pub const COMMIT: f64 = 0.5;

#[cfg(test)]
mod tests {
    use super::*;

    fn load(rate: f64, held_px: f64) -> Load {
        Load {
            rate: Some(rate),
            floor_rate: rate,
            held_px,
            alive: true,
        }
    }

    #[test]
    fn a_source_is_unbounded_until_it_and_another_are_measured() {
        let unmeasured = Load {
            rate: None,
            floor_rate: f64::INFINITY,
            held_px: 0.0,
            alive: true,
        };
        assert_eq!(allowance(&[unmeasured, load(1e3, 0.0)], 0, 1e6), None);
        assert_eq!(allowance(&[load(1e3, 0.0), unmeasured], 0, 1e6), None);
        let lost = Load {
            alive: false,
            ..load(1e3, 0.0)
        };
        assert_eq!(allowance(&[load(1e3, 0.0), lost], 0, 1e6), None);
        assert_eq!(allowance(&[load(1e3, 0.0)], 0, 1e6), None);
    }

    #[test]
    fn mid_run_a_source_holds_its_share_of_the_remaining_time() {
        // 14 500 px left, rates 1 000, 9 000 and 4 500 px/s: the run ends in 1 s; each slower
        // source may hold what it renders in half that second.
        let loads = [load(1e3, 0.0), load(9e3, 0.0), load(9e3 / 2.0, 0.0)];
        assert_eq!(allowance(&loads, 0, 1.45e4), Some(500.0));
        assert_eq!(allowance(&loads, 2, 1.45e4), Some(2250.0));
        // The fastest is not bounded.
        assert_eq!(allowance(&loads, 1, 1.45e4), None);
        // What is held counts as remaining work.
        let loads = [load(1e3, 500.0), load(9e3, 4500.0)];
        assert_eq!(allowance(&loads, 0, 5e3), Some(500.0));
    }

    #[test]
    fn a_source_commits_at_the_lowest_rate_it_has_shown() {
        // Its mean says 3 000 px/s, its dearest items ran at 1 000: in the 1 s left it may
        // hold half of what 1 000 px/s renders.
        let uneven = Load {
            floor_rate: 1e3,
            ..load(3e3, 0.0)
        };
        let loads = [uneven, load(9e3, 0.0)];
        assert_eq!(allowance(&loads, 0, 1.2e4), Some(500.0));
    }

    #[test]
    fn at_the_end_the_slow_source_gets_nothing_and_the_fastest_is_unbounded() {
        // 100 px left, 1 000 vs 99 000 px/s: the run ends in 1 ms; one 100 px item would take
        // the slow source 0.1 s and the fast one about 1 ms.
        let loads = [load(1e3, 0.0), load(9.9e4, 0.0)];
        let slow = allowance(&loads, 0, 100.0).unwrap();
        assert!(slow < 100.0, "slow source may hold {slow} px");
        assert_eq!(allowance(&loads, 1, 100.0), None);
    }
}
