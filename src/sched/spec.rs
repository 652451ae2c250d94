//! One scheduler run, fully specified ([`SchedulerSpec`]), and what is derived from the
//! schedulers' one definition (their files under [`super::kinds`]): the CLI flags, experiment
//! keys, CSV columns, config keys and run labels ([`param_columns`], [`SchedulerSpec::set`],
//! [`SchedulerSpec::get`]).
//!
//! Adding a parameter: one line in the kind's `scheduler_params!` struct in its file, then its
//! use in that file's rule. Adding a scheduler: its file under `kinds/` and one registry line.

pub use super::kinds::{
    AdaptiveFactoringParams, AwfParams, FactoringParams, FixedSizeParams, GuidedParams,
    MasterParams, MitsubaParams, PbrtParams, Policy, SchedulerKind, SelfSchedulingParams,
    StaticCyclicParams, StaticParams, TrapezoidParams, WeightedFactoringParams,
    WorkStealingDequeParams, WorkStealingParams,
};
use super::param::{err, one_of, Chunk, Order, ParamInfo, ParamValue, Slow, SpecError};
use super::rule::Needs;
use serde::{Deserialize, Serialize};
use std::sync::OnceLock;

impl SchedulerKind {
    /// The order this kind takes its items in unless told otherwise: stratified
    /// ([`Order::Scatter`]) for the rules whose first chunks are a share of all items (the
    /// factoring family and guided), scanline for the rest. Factoring's chunk sizes assume
    /// items whose costs do not depend on their place in the order (Hummel, Schonberg & Flynn
    /// 1992); in scanline order a hot spot lies in one early chunk instead (M-121). These
    /// kinds run each hand-out in scanline order ([`Self::runs_hand_outs_in_scanline`]).
    pub fn default_order(self) -> Order {
        if self.sizes_own_hand_outs() {
            Order::Scatter
        } else {
            Order::Scanline
        }
    }

    /// The item size this kind takes unless told otherwise (the command line's `--chunk`; an
    /// experiment names its chunks). 2×2 tiles for guided and the factoring family, whose
    /// chunk rules size the hand-outs themselves: one-pixel items pay each pixel's own cost,
    /// larger tiles leave a hot spot's tile as the tail (M-120). 16×16 tiles for the rest.
    pub fn default_chunk(self) -> Chunk {
        if self.sizes_own_hand_outs() {
            Chunk::Tile { w: 2, h: 2 }
        } else {
            Chunk::Tile { w: 16, h: 16 }
        }
    }

    /// Does a worker of this kind run the items of each hand-out in scanline order rather than
    /// as handed out (`sched::scanline`)? The kinds whose hand-outs are shares of items in
    /// [`Self::default_order`]'s `scatter`: over one-pixel items on one worker factoring then
    /// took 1.003× its scanline time instead of 1.04×.
    pub fn runs_hand_outs_in_scanline(self) -> bool {
        self.sizes_own_hand_outs()
    }
}

impl Policy {
    /// What this kind's rule shape needs from an executor ([`Needs`]): the one question the
    /// studies ask instead of naming a kind.
    pub fn needs(&self) -> Needs {
        self.rule(1, 1, Slow::NONE).needs()
    }

    /// The parameters this kind has, in column order.
    pub fn info(&self) -> &'static [ParamInfo] {
        self.params().map_or(&[], |p| p.info())
    }
}

/// Every parameter any kind has, first appearance in [`SchedulerKind::ALL`] order: the CSV
/// columns (and CLI flags) after `order`. A name shared by several kinds is one column.
pub fn param_columns() -> &'static [ParamInfo] {
    static COLUMNS: OnceLock<Vec<ParamInfo>> = OnceLock::new();
    COLUMNS.get_or_init(|| {
        let mut out: Vec<ParamInfo> = Vec::new();
        for k in SchedulerKind::ALL {
            for p in Policy::defaults(k).info() {
                if !out.iter().any(|q| q.name == p.name) {
                    out.push(*p);
                }
            }
        }
        out
    })
}

/// The kinds that have parameter `name`, with its meaning for each.
pub fn kinds_with(name: &str) -> Vec<(SchedulerKind, &'static ParamInfo)> {
    SchedulerKind::ALL
        .into_iter()
        .filter_map(|k| {
            let p = Policy::defaults(k).info().iter().find(|p| p.name == name)?;
            Some((k, p))
        })
        .collect()
}

/// One scheduler run, fully specified.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SchedulerSpec {
    /// The kind and its parameters.
    pub policy: Policy,
    /// How many pixels make one work item.
    pub chunk: Chunk,
    /// The order items are generated in.
    pub order: Order,
    /// Compute sources / worker threads (the master is extra and counted separately).
    pub workers: usize,
    /// Record a (worker, item, start, end) timeline for Gantt plots.
    pub timeline: bool,
    /// Workers slowed by a known factor (a heterogeneous run); [`Slow::NONE`] by default.
    #[serde(default)]
    pub slow: Slow,
}

impl SchedulerSpec {
    /// `kind` at its defaults, in its default order ([`SchedulerKind::default_order`]), no
    /// timeline.
    pub fn new(kind: SchedulerKind, chunk: Chunk, workers: usize) -> Self {
        Self {
            policy: Policy::defaults(kind),
            chunk,
            order: kind.default_order(),
            workers,
            timeline: false,
            slow: Slow::NONE,
        }
    }

    /// The tile size and order this run cuts a `width`×`height` image into: `chunk` and
    /// `order`, except for the policies that choose their own ([`SchedulerKind::picks_own_layout`]).
    pub fn layout(&self, width: u32, height: u32) -> (Chunk, Order) {
        self.policy
            .own_layout(width, height, self.workers)
            .unwrap_or((self.chunk, self.order))
    }

    /// The kind, without its parameters.
    pub fn kind(&self) -> SchedulerKind {
        self.policy.kind()
    }

    /// Is `name` a parameter of this kind? The error says which kinds have it.
    pub fn check_name(&self, name: &str) -> Result<(), SpecError> {
        if self.policy.info().iter().any(|p| p.name == name) {
            return Ok(());
        }
        let with: Vec<&str> = kinds_with(name).iter().map(|(k, _)| k.id()).collect();
        Err(match with.len() {
            0 => err(name, "unknown scheduler parameter"),
            n => err(
                name,
                format!(
                    "'{}' has no {name} (only {} {})",
                    self.kind().id(),
                    one_of(&with),
                    if n == 1 { "takes it" } else { "take it" }
                ),
            ),
        })
    }

    /// Set parameter `name` from its text form; a name this kind lacks is an error
    /// ([`Self::check_name`]).
    pub fn set(&mut self, name: &str, text: &str) -> Result<(), SpecError> {
        self.check_name(name)?;
        if let Some(p) = self.policy.params_mut() {
            p.set(name, text)?;
        }
        Ok(())
    }

    /// The text form of parameter `name`, `None` when this kind has no such parameter.
    pub fn get(&self, name: &str) -> Option<String> {
        self.policy.params()?.get(name)
    }

    /// Check what a struct literal could get wrong: no workers, an empty chunk, a parameter
    /// whose value its text form would refuse (a buffer of 0).
    pub fn validate(&self) -> Result<(), SpecError> {
        if self.workers == 0 {
            return Err(err("workers", "must be ≥ 1 (got 0)"));
        }
        if self.slow.workers as usize > self.workers {
            return Err(err(
                "slow",
                format!(
                    "{} slowed workers of only {}",
                    self.slow.workers, self.workers
                ),
            ));
        }
        if let Chunk::Tile { w: 0, .. } | Chunk::Tile { h: 0, .. } | Chunk::Rows(0) = self.chunk {
            return Err(err("chunk", "sizes must be ≥ 1 (chunk 0 has no pixels)"));
        }
        for p in self.policy.info() {
            let text = self.get(p.name).unwrap_or_default();
            let mut copy = self.policy;
            if let Some(params) = copy.params_mut() {
                params.set(p.name, &text)?;
            }
        }
        Ok(())
    }

    /// A short label for plots and logs, e.g.
    /// `master chunk=16 B=2 requeue=never wait=block returns=item passes=thread`.
    pub fn label(&self) -> String {
        let mut s = if self.kind().picks_own_layout() {
            format!("{} chunk=auto", self.kind().id())
        } else {
            format!("{} chunk={}", self.kind().id(), self.chunk)
        };
        if !self.kind().picks_own_layout() && self.order != self.kind().default_order() {
            s += &format!(" order={}", self.order.id());
        }
        if !self.slow.is_none() {
            s += &format!(" slow={}", self.slow);
        }
        for p in self.policy.info() {
            if let (Some(short), Some(v)) = (p.label, self.get(p.name)) {
                s += &format!(" {short}={v}");
            }
        }
        s
    }
}

/// A parameter's value read back typed (for code that holds only its text form, e.g. a CSV).
pub fn parse_param<T: ParamValue>(text: &str) -> Option<T> {
    T::parse_value(text).ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_round_trip_and_unknown_ids_are_errors() {
        for k in SchedulerKind::ALL {
            assert_eq!(SchedulerKind::from_id(k.id()).unwrap(), k);
            assert_eq!(Policy::defaults(k).kind(), k);
        }
        assert!(SchedulerKind::from_id("fastest")
            .unwrap_err()
            .msg
            .contains("unknown scheduler"));
    }

    #[test]
    fn columns_are_the_union_of_every_kinds_parameters_in_order() {
        let names: Vec<&str> = param_columns().iter().map(|p| p.name).collect();
        assert_eq!(
            names,
            [
                "buffer",
                "requeue",
                "wait",
                "returns",
                "passes",
                "grab",
                "guided_k",
                "weights",
                "fsc_warm",
                "fac_cv",
                "pls_swr",
                "sel_phases",
                "tap_cv",
                "tap_alpha"
            ]
        );
        // Kinds appended to the registry may take `grab` too: the first ones stay in order.
        let grab: Vec<SchedulerKind> = kinds_with("grab").iter().map(|(k, _)| *k).collect();
        assert_eq!(
            grab[..8],
            [
                SchedulerKind::WorkStealing,
                SchedulerKind::SelfScheduling,
                SchedulerKind::Guided,
                SchedulerKind::Factoring,
                SchedulerKind::WeightedFactoring,
                SchedulerKind::Trapezoid,
                SchedulerKind::AdaptiveFactoring,
                SchedulerKind::Awf,
            ]
        );
    }

    #[test]
    fn parameters_are_set_by_name_and_refused_where_the_kind_has_none() {
        let mut m = SchedulerSpec::new(SchedulerKind::Master, Chunk::Frame, 2);
        m.set("buffer", "8").unwrap();
        m.set("requeue", "timeout:50").unwrap();
        assert_eq!(m.get("buffer").as_deref(), Some("8"));
        assert_eq!(
            m.label(),
            "master chunk=frame B=8 requeue=timeout:50 wait=block returns=item passes=thread"
        );
        assert_eq!(m.get("grab"), None);
        let e = m.set("grab", "2").unwrap_err();
        assert_eq!(e.field, "grab");
        assert!(e.msg.contains("'master' has no grab"), "{e}");
        assert_eq!(m.set("buffer", "0").unwrap_err().field, "buffer");
        assert!(m.set("colour", "red").unwrap_err().msg.contains("unknown"));
        let mut s = SchedulerSpec::new(SchedulerKind::Static, Chunk::Frame, 2);
        assert_eq!(
            s.set("buffer", "2").unwrap_err().msg,
            "'static' has no buffer (only master takes it)"
        );
        assert_eq!(s.label(), "static chunk=frame");
    }

    #[test]
    fn zero_sizes_are_rejected() {
        let base = SchedulerSpec::new(SchedulerKind::Master, Chunk::Frame, 2);
        assert!(base.validate().is_ok());
        let no_workers = SchedulerSpec {
            workers: 0,
            ..base.clone()
        };
        assert_eq!(no_workers.validate().unwrap_err().field, "workers");
        let no_buffer = SchedulerSpec {
            policy: Policy::Master(MasterParams {
                buffer: 0,
                ..MasterParams::DEFAULT
            }),
            ..base.clone()
        };
        assert_eq!(no_buffer.validate().unwrap_err().field, "buffer");
        let no_grab = SchedulerSpec {
            policy: Policy::SelfScheduling(SelfSchedulingParams { grab: 0 }),
            ..base
        };
        assert_eq!(no_grab.validate().unwrap_err().field, "grab");
    }

    /// More slowed workers than workers is refused (the CLI's `--slow`, an experiment's
    /// `slow` at each worker count), as many is not.
    #[test]
    fn more_slowed_workers_than_workers_is_rejected() {
        let spec = |k: &str, workers| SchedulerSpec {
            slow: Slow::parse(k).unwrap(),
            ..SchedulerSpec::new(SchedulerKind::SelfScheduling, Chunk::Frame, workers)
        };
        assert!(spec("2:3", 2).validate().is_ok());
        let e = spec("3:2", 2).validate().unwrap_err();
        assert_eq!(
            (e.field.as_str(), e.msg.as_str()),
            ("slow", "3 slowed workers of only 2")
        );
    }
}
