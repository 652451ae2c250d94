//! The one definition of every scheduler: its id, what it does, and its parameters with their
//! defaults. The CLI flags, experiment keys, CSV columns, config keys and run labels are all
//! derived from here ([`param_columns`], [`SchedulerSpec::set`], [`SchedulerSpec::get`]).
//!
//! Adding a parameter: one line in the kind's `scheduler_params!` struct below, then its use
//! in the scheduler's own file. Adding a scheduler: a [`SchedulerKind`] id, a [`Policy`]
//! variant (with a parameter struct if it has any) and the scheduler's own file.

use super::param::{
    err, id_enum, one_of, scheduler_params, Chunk, Order, ParamInfo, ParamValue, Params, Passes,
    Requeue, Returns, Slow, SpecError, Wait, Weights,
};
use serde::{Deserialize, Serialize};
use std::sync::OnceLock;

id_enum! {
    /// Who decides who renders what.
    pub enum SchedulerKind("scheduler", "scheduler") {
        /// Contiguous bands of items, one per worker; no master.
        Static = "static",
        /// Item i to worker i mod n; no master.
        StaticCyclic = "static_cyclic",
        /// The founding design: a master thread (renders nothing) keeps ≤ B items outstanding
        /// per compute source, re-queueing handed-out items at the back of a FIFO.
        Master = "master",
        /// rayon over items, split no finer than `grab` items per task.
        WorkStealing = "work_stealing",
        /// One crossbeam-deque per worker, stealing from the others when empty.
        WorkStealingDeque = "work_stealing_deque",
        /// One shared atomic counter over items; each grab takes `grab` items.
        SelfScheduling = "self_scheduling",
        /// Grabs of max(grab, remaining / (k·workers)) items from a shared counter.
        Guided = "guided",
        /// Factoring (FAC2): batches of P chunks of ⌈R/(2P)⌉ items, R left at the batch start.
        Factoring = "factoring",
        /// Weighted factoring: FAC2 batches, each worker's chunk scaled by its relative speed.
        WeightedFactoring = "weighted_factoring",
        /// Trapezoid self-scheduling (TSS): chunks shrinking linearly from ⌈N/(2P)⌉ to 1.
        Trapezoid = "trapezoid",
        /// Fixed-size chunking (FSC): one chunk size K from the measured hand-out cost and the
        /// spread of item times (Kruskal–Weiss).
        FixedSize = "fixed_size",
        /// Adaptive factoring (AF): each chunk from the worker's running mean and spread of
        /// item times.
        AdaptiveFactoring = "adaptive_factoring",
        /// Adaptive weighted factoring, variant C (AWF-C): FAC2 batches, weights updated from
        /// measured speed after every chunk.
        Awf = "awf",
        /// pbrt-v4's parallel loop: tiles of clamp(⌊√(W·H/(8·threads))⌋, 1, 32), row order,
        /// one tile per grab under a lock.
        Pbrt = "pbrt",
        /// Mitsuba 3 (scalar): 32² blocks halved until blocks ≥ threads, spiral order, grabs
        /// of max(blocks/(4·threads), 1) blocks.
        Mitsuba = "mitsuba",
    }
}

impl SchedulerKind {
    /// Does `advise` weigh this kind unless told otherwise? All but three: the model plays
    /// `work_stealing_deque` as `work_stealing` and `weighted_factoring` over equal workers as
    /// `factoring`, and `static_cyclic` is a fixed assignment like `static`.
    pub fn advised_by_default(self) -> bool {
        !matches!(
            self,
            Self::StaticCyclic | Self::WorkStealingDeque | Self::WeightedFactoring
        )
    }

    /// Does this scheduler choose its own tile size and order from the image and the thread
    /// count (the production renderers' policies)? Its `chunk` and `order` are then ignored.
    pub fn picks_own_layout(self) -> bool {
        matches!(self, Self::Pbrt | Self::Mitsuba)
    }

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

    /// Is this guided or one of the factoring family: a rule that sizes each hand-out from
    /// what is left, its first chunks a share of all items? Their default order, item size
    /// and scanline runs of hand-outs all follow from that.
    pub fn sizes_own_hand_outs(self) -> bool {
        self.is_dls() || self == Self::Guided
    }

    /// Is this one of the dynamic-loop-scheduling rules of `sched::dls` (a chunk size per
    /// grab from a shared dispenser)?
    pub fn is_dls(self) -> bool {
        matches!(
            self,
            Self::Factoring
                | Self::WeightedFactoring
                | Self::Trapezoid
                | Self::FixedSize
                | Self::AdaptiveFactoring
                | Self::Awf
        )
    }
}

scheduler_params! {
    /// The master's parameters.
    pub struct MasterParams {
        /// Items outstanding per compute source (B).
        buffer: usize = 2, label Some("B");
        /// When a handed-out, unfinished item is handed out again: seed (when it comes round
        /// in the queue), never or timeout:<ms>.
        requeue: Requeue = Requeue::Never, label Some("requeue");
        /// How the master waits for results: spin, yield or block.
        wait: Wait = Wait::Block, label Some("wait");
        /// How local threads hand results back: item (each as soon as it is rendered) or
        /// hand_out (a hand-out's together, when its last item is done; the master then hands
        /// out at most ⌈B/2⌉ items at a time, so a source has the next one queued).
        returns: Returns = Returns::Item, label Some("returns");
        /// Who runs the master's passes: thread (a thread of its own that renders nothing; any
        /// source) or workers (each local thread for itself under one lock when it reports,
        /// the queue and re-queue rules unchanged; local threads only, no fault injection).
        passes: Passes = Passes::Thread, label Some("passes");
    }
}

scheduler_params! {
    /// Work stealing's parameters.
    pub struct WorkStealingParams {
        /// The fewest items one task holds (rayon's minimum split).
        grab: usize = 1, label None;
    }
}

scheduler_params! {
    /// Self-scheduling's parameters.
    pub struct SelfSchedulingParams {
        /// Items a worker takes from the shared counter at once.
        grab: usize = 1, label None;
    }
}

scheduler_params! {
    /// Guided self-scheduling's parameters.
    pub struct GuidedParams {
        /// The fewest items one grab takes.
        grab: usize = 1, label None;
        /// k in grab = max(grab, remaining / (k·workers)).
        guided_k: usize = 2, label None;
    }
}

scheduler_params! {
    /// Factoring's parameters.
    pub struct FactoringParams {
        /// The fewest items one grab takes.
        grab: usize = 1, label None;
    }
}

scheduler_params! {
    /// Weighted factoring's parameters.
    pub struct WeightedFactoringParams {
        /// The fewest items one grab takes.
        grab: usize = 1, label None;
        /// Where the per-worker weights come from: known (the run's slow setting) or measured
        /// (each worker's first chunk).
        weights: Weights = Weights::Known, label Some("weights");
    }
}

scheduler_params! {
    /// Trapezoid self-scheduling's parameters.
    pub struct TrapezoidParams {
        /// The last (smallest) chunk, l in TSS.
        grab: usize = 1, label None;
    }
}

scheduler_params! {
    /// Fixed-size chunking's parameters.
    pub struct FixedSizeParams {
        /// Items handed out one at a time first, to measure the hand-out cost h and the spread
        /// σ of item times online.
        fsc_warm: usize = 32, label Some("warm");
    }
}

scheduler_params! {
    /// Adaptive factoring's parameters.
    pub struct AdaptiveFactoringParams {
        /// The fewest items one grab takes.
        grab: usize = 1, label None;
    }
}

scheduler_params! {
    /// Adaptive weighted factoring's parameters.
    pub struct AwfParams {
        /// The fewest items one grab takes.
        grab: usize = 1, label None;
    }
}

/// A scheduler kind with its parameters.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Policy {
    /// See [`SchedulerKind::Static`].
    Static,
    /// See [`SchedulerKind::StaticCyclic`].
    StaticCyclic,
    /// See [`SchedulerKind::Master`].
    Master(MasterParams),
    /// See [`SchedulerKind::WorkStealing`].
    WorkStealing(WorkStealingParams),
    /// See [`SchedulerKind::WorkStealingDeque`].
    WorkStealingDeque,
    /// See [`SchedulerKind::SelfScheduling`].
    SelfScheduling(SelfSchedulingParams),
    /// See [`SchedulerKind::Guided`].
    Guided(GuidedParams),
    /// See [`SchedulerKind::Factoring`].
    Factoring(FactoringParams),
    /// See [`SchedulerKind::WeightedFactoring`].
    WeightedFactoring(WeightedFactoringParams),
    /// See [`SchedulerKind::Trapezoid`].
    Trapezoid(TrapezoidParams),
    /// See [`SchedulerKind::FixedSize`].
    FixedSize(FixedSizeParams),
    /// See [`SchedulerKind::AdaptiveFactoring`].
    AdaptiveFactoring(AdaptiveFactoringParams),
    /// See [`SchedulerKind::Awf`].
    Awf(AwfParams),
    /// See [`SchedulerKind::Pbrt`].
    Pbrt,
    /// See [`SchedulerKind::Mitsuba`].
    Mitsuba,
}

impl Policy {
    /// Is this the master with its results handed back per hand-out ([`Returns::HandOut`])?
    pub fn returns_per_hand_out(&self) -> bool {
        matches!(self, Self::Master(m) if m.returns == Returns::HandOut)
    }

    /// Is this the master with its passes run by the workers ([`Passes::Workers`]), which
    /// drives local threads only?
    pub fn passes_by_workers(&self) -> bool {
        matches!(self, Self::Master(m) if m.passes == Passes::Workers)
    }

    /// `kind` with every parameter at its default.
    pub const fn defaults(kind: SchedulerKind) -> Self {
        match kind {
            SchedulerKind::Static => Self::Static,
            SchedulerKind::StaticCyclic => Self::StaticCyclic,
            SchedulerKind::Master => Self::Master(MasterParams::DEFAULT),
            SchedulerKind::WorkStealing => Self::WorkStealing(WorkStealingParams::DEFAULT),
            SchedulerKind::WorkStealingDeque => Self::WorkStealingDeque,
            SchedulerKind::SelfScheduling => Self::SelfScheduling(SelfSchedulingParams::DEFAULT),
            SchedulerKind::Guided => Self::Guided(GuidedParams::DEFAULT),
            SchedulerKind::Factoring => Self::Factoring(FactoringParams::DEFAULT),
            SchedulerKind::WeightedFactoring => {
                Self::WeightedFactoring(WeightedFactoringParams::DEFAULT)
            }
            SchedulerKind::Trapezoid => Self::Trapezoid(TrapezoidParams::DEFAULT),
            SchedulerKind::FixedSize => Self::FixedSize(FixedSizeParams::DEFAULT),
            SchedulerKind::AdaptiveFactoring => {
                Self::AdaptiveFactoring(AdaptiveFactoringParams::DEFAULT)
            }
            SchedulerKind::Awf => Self::Awf(AwfParams::DEFAULT),
            SchedulerKind::Pbrt => Self::Pbrt,
            SchedulerKind::Mitsuba => Self::Mitsuba,
        }
    }

    /// The kind, without its parameters.
    pub fn kind(&self) -> SchedulerKind {
        match self {
            Self::Static => SchedulerKind::Static,
            Self::StaticCyclic => SchedulerKind::StaticCyclic,
            Self::Master(_) => SchedulerKind::Master,
            Self::WorkStealing(_) => SchedulerKind::WorkStealing,
            Self::WorkStealingDeque => SchedulerKind::WorkStealingDeque,
            Self::SelfScheduling(_) => SchedulerKind::SelfScheduling,
            Self::Guided(_) => SchedulerKind::Guided,
            Self::Factoring(_) => SchedulerKind::Factoring,
            Self::WeightedFactoring(_) => SchedulerKind::WeightedFactoring,
            Self::Trapezoid(_) => SchedulerKind::Trapezoid,
            Self::FixedSize(_) => SchedulerKind::FixedSize,
            Self::AdaptiveFactoring(_) => SchedulerKind::AdaptiveFactoring,
            Self::Awf(_) => SchedulerKind::Awf,
            Self::Pbrt => SchedulerKind::Pbrt,
            Self::Mitsuba => SchedulerKind::Mitsuba,
        }
    }

    /// The parameters by name (`None`: the kind has none).
    pub fn params(&self) -> Option<&dyn Params> {
        match self {
            Self::Master(p) => Some(p),
            Self::WorkStealing(p) => Some(p),
            Self::SelfScheduling(p) => Some(p),
            Self::Guided(p) => Some(p),
            Self::Factoring(p) => Some(p),
            Self::WeightedFactoring(p) => Some(p),
            Self::Trapezoid(p) => Some(p),
            Self::FixedSize(p) => Some(p),
            Self::AdaptiveFactoring(p) => Some(p),
            Self::Awf(p) => Some(p),
            Self::Static
            | Self::StaticCyclic
            | Self::WorkStealingDeque
            | Self::Pbrt
            | Self::Mitsuba => None,
        }
    }

    fn params_mut(&mut self) -> Option<&mut dyn Params> {
        match self {
            Self::Master(p) => Some(p),
            Self::WorkStealing(p) => Some(p),
            Self::SelfScheduling(p) => Some(p),
            Self::Guided(p) => Some(p),
            Self::Factoring(p) => Some(p),
            Self::WeightedFactoring(p) => Some(p),
            Self::Trapezoid(p) => Some(p),
            Self::FixedSize(p) => Some(p),
            Self::AdaptiveFactoring(p) => Some(p),
            Self::Awf(p) => Some(p),
            Self::Static
            | Self::StaticCyclic
            | Self::WorkStealingDeque
            | Self::Pbrt
            | Self::Mitsuba => None,
        }
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
        use super::renderers::{mitsuba_block, pbrt_tile};
        match self.policy {
            Policy::Pbrt => {
                let t = pbrt_tile(width, height, self.workers);
                (Chunk::Tile { w: t, h: t }, Order::Scanline)
            }
            Policy::Mitsuba => {
                let b = mitsuba_block(width, height, self.workers);
                (Chunk::Tile { w: b, h: b }, Order::Spiral)
            }
            Policy::Static
            | Policy::StaticCyclic
            | Policy::Master(_)
            | Policy::WorkStealing(_)
            | Policy::WorkStealingDeque
            | Policy::SelfScheduling(_)
            | Policy::Guided(_)
            | Policy::Factoring(_)
            | Policy::WeightedFactoring(_)
            | Policy::Trapezoid(_)
            | Policy::FixedSize(_)
            | Policy::AdaptiveFactoring(_)
            | Policy::Awf(_) => (self.chunk, self.order),
        }
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
            p.set(name, text).map_err(|m| err(name, m))?;
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
                params.set(p.name, &text).map_err(|m| err(p.name, m))?;
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
                "buffer", "requeue", "wait", "returns", "passes", "grab", "guided_k", "weights",
                "fsc_warm"
            ]
        );
        let grab: Vec<SchedulerKind> = kinds_with("grab").iter().map(|(k, _)| *k).collect();
        assert_eq!(
            grab,
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
