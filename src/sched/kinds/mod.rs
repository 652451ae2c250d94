//! Every built-in scheduler, one file each: its parameters (a `scheduler_params!` struct, empty
//! when it has none) and its [`BuiltIn`] definition — what it does, its hand-out rule and the
//! few facts the rest of the tool derives from (its default order and item size, whether
//! `advise` weighs it, whether it picks its own tiles).
//!
//! The registry at the bottom of this file is the one list of them. Each line names the id, the
//! variant and the file; from it come [`SchedulerKind`] (ids, `from_id`, `ALL`), [`Policy`] (a
//! kind with its parameters), the CLI flags, TOML keys, CSV columns, `advise`'s defaults and
//! the reference pages. Adding a built-in scheduler is its file here plus one registry line
//! (`docs/extending.md`). A scheduler kept outside the crate implements
//! [`Scheduler`](super::rule::Scheduler) instead.

use super::param::{err, id_enum, one_of, Chunk, Order, ParamValue, Params, Slow, SpecError};
use super::rule::{HandOut, Scheduler};
use serde::{Deserialize, Serialize};

/// A policy's own layout: the tile side and order for a `width`×`height` image on `workers`
/// workers.
pub type Layout = fn(width: u32, height: u32, workers: usize) -> (Chunk, Order);

/// What a built-in scheduler's file defines beside its parameter struct.
pub trait BuiltIn: Params + Copy {
    /// What it does, in one paragraph: the reference page's text.
    const DOC: &'static str;
    /// Does `advise` weigh it unless told otherwise?
    const ADVISED_BY_DEFAULT: bool = true;
    /// Does it size each hand-out as a share of what is left (guided, the factoring family)?
    /// Its default order, item size and scanline runs of hand-outs follow from that
    /// ([`SchedulerKind::default_order`]).
    const SIZES_OWN_HAND_OUTS: bool = false;
    /// The tile side and order it picks itself for a `width`×`height` image on `workers`
    /// workers (the production renderers' policies); `None`: the run's chunk and order.
    const OWN_LAYOUT: Option<Layout> = None;
    /// The published technique it plays ([`literature::TECHNIQUES`]' name) and whether as
    /// published (`true`) or as a variant (`false`); `None`: none of the catalogue's.
    const PUBLISHED: Option<(&'static str, bool)> = None;
    /// Its rule over `n` items on `workers` workers, worker i slowed as `slow` says.
    fn hand_out(&self, n: usize, workers: usize, slow: Slow) -> HandOut;
}

/// Generates [`SchedulerKind`] and [`Policy`] from the registry's lines.
macro_rules! builtin_schedulers {
    ($( $variant:ident = $id:literal in $module:ident :: $ty:ident, )*) => {
        $( pub mod $module; )*
        $( pub use $module::$ty; )*

        /// Who decides who renders what: the id of a built-in scheduler.
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
        #[serde(rename_all = "snake_case")]
        pub enum SchedulerKind {
            $(
                #[doc = concat!("`", $id, "`: see [`", stringify!($module), "`].")]
                $variant,
            )*
        }

        id_enum!(impl SchedulerKind ("scheduler", "scheduler") { $( $variant = $id, )* });

        impl SchedulerKind {
            /// What it does, one paragraph (the reference pages' text).
            pub fn doc(self) -> String {
                match self {
                    $( Self::$variant => <$ty as BuiltIn>::DOC.to_string(), )*
                }
            }

            /// Does `advise` weigh this kind unless told otherwise?
            pub fn advised_by_default(self) -> bool {
                match self {
                    $( Self::$variant => <$ty as BuiltIn>::ADVISED_BY_DEFAULT, )*
                }
            }

            /// Is this guided or one of the factoring family: a rule that sizes each hand-out
            /// from what is left, its first chunks a share of all items? Its default order,
            /// item size and scanline runs of hand-outs all follow from that.
            pub fn sizes_own_hand_outs(self) -> bool {
                match self {
                    $( Self::$variant => <$ty as BuiltIn>::SIZES_OWN_HAND_OUTS, )*
                }
            }

            /// The published technique this kind plays and whether exactly (see
            /// [`literature`]).
            pub fn published(self) -> Option<(&'static str, bool)> {
                match self {
                    $( Self::$variant => <$ty as BuiltIn>::PUBLISHED, )*
                }
            }

            /// Does this scheduler choose its own tile size and order from the image and the
            /// thread count (the production renderers' policies)? Its `chunk` and `order` are
            /// then ignored.
            pub fn picks_own_layout(self) -> bool {
                match self {
                    $( Self::$variant => <$ty as BuiltIn>::OWN_LAYOUT.is_some(), )*
                }
            }
        }

        /// A scheduler kind with its parameters.
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
        pub enum Policy {
            $(
                #[doc = concat!("`", $id, "` with its parameters.")]
                $variant($ty),
            )*
        }

        $(
            impl From<$ty> for Policy {
                fn from(p: $ty) -> Self {
                    Self::$variant(p)
                }
            }
        )*

        impl Policy {
            /// `kind` with every parameter at its default.
            pub const fn defaults(kind: SchedulerKind) -> Self {
                match kind {
                    $( SchedulerKind::$variant => Self::$variant(<$ty>::DEFAULT), )*
                }
            }

            /// The kind, without its parameters.
            pub fn kind(&self) -> SchedulerKind {
                match self {
                    $( Self::$variant(_) => SchedulerKind::$variant, )*
                }
            }

            /// The parameters by name (`None`: the kind has none).
            pub fn params(&self) -> Option<&dyn Params> {
                let p: &dyn Params = match self {
                    $( Self::$variant(p) => p, )*
                };
                (!p.info().is_empty()).then_some(p)
            }

            /// The parameters by name, to set (`None`: the kind has none).
            pub(crate) fn params_mut(&mut self) -> Option<&mut dyn Params> {
                let p: &mut dyn Params = match self {
                    $( Self::$variant(p) => p, )*
                };
                (!p.info().is_empty()).then_some(p)
            }

            /// The rule over `n` items on `workers` workers, slowed as `slow` says.
            pub fn rule(&self, n: usize, workers: usize, slow: Slow) -> HandOut {
                match self {
                    $( Self::$variant(p) => p.hand_out(n, workers, slow), )*
                }
            }

            /// The tile side and order this kind picks itself for a `width`×`height` image on
            /// `workers` workers; `None`: it takes the run's.
            pub fn own_layout(&self, width: u32, height: u32, workers: usize) -> Option<(Chunk, Order)> {
                let layout = match self {
                    $( Self::$variant(_) => <$ty as BuiltIn>::OWN_LAYOUT, )*
                };
                layout.map(|f| f(width, height, workers))
            }
        }
    };
}

// The registry: one line per built-in scheduler, in the order help texts, CSV columns and
// plot styles list them (append new ones at the end so existing styles keep their colours).
builtin_schedulers! {
    Static = "static" in static_bands::StaticParams,
    StaticCyclic = "static_cyclic" in static_cyclic::StaticCyclicParams,
    Master = "master" in master::MasterParams,
    WorkStealing = "work_stealing" in work_stealing::WorkStealingParams,
    WorkStealingDeque = "work_stealing_deque" in work_stealing_deque::WorkStealingDequeParams,
    SelfScheduling = "self_scheduling" in self_scheduling::SelfSchedulingParams,
    Guided = "guided" in guided::GuidedParams,
    Factoring = "factoring" in factoring::FactoringParams,
    WeightedFactoring = "weighted_factoring" in weighted_factoring::WeightedFactoringParams,
    Trapezoid = "trapezoid" in trapezoid::TrapezoidParams,
    FixedSize = "fixed_size" in fixed_size::FixedSizeParams,
    AdaptiveFactoring = "adaptive_factoring" in adaptive_factoring::AdaptiveFactoringParams,
    Awf = "awf" in awf::AwfParams,
    Pbrt = "pbrt" in pbrt::PbrtParams,
    Mitsuba = "mitsuba" in mitsuba::MitsubaParams,
    TrapezoidFactoring = "trapezoid_factoring" in trapezoid_factoring::TrapezoidFactoringParams,
    Tss = "tss" in tss::TssParams,
    Tfss = "tfss" in tfss::TfssParams,
    Fsc = "fsc" in fsc::FscParams,
    Fac = "fac" in fac::FacParams,
    AwfB = "awf_b" in awf_b::AwfBParams,
    AwfC = "awf_c" in awf_c::AwfCParams,
    AwfD = "awf_d" in awf_d::AwfDParams,
    AwfE = "awf_e" in awf_e::AwfEParams,
    Mfsc = "mfsc" in mfsc::MfscParams,
    Fiss = "fiss" in fiss::FissParams,
    Viss = "viss" in viss::VissParams,
    Pls = "pls" in pls::PlsParams,
    Rnd = "rnd" in rnd::RndParams,
    Maf = "maf" in maf::MafParams,
    RandomSel = "random_sel" in random_sel::RandomSelParams,
    ExhaustiveSel = "exhaustive_sel" in exhaustive_sel::ExhaustiveSelParams,
    BinarySel = "binary_sel" in binary_sel::BinarySelParams,
    Auto = "auto" in auto::AutoParams,
    Tap = "tap" in tap::TapParams,
}

impl SchedulerKind {
    /// The kind a run over several kinds of source takes unless told otherwise: the one whose
    /// rule gives each kind of source its own buffer and grain ([`super::rule::Needs`]).
    pub const FOR_MIXED_SOURCES: Self = Self::Master;
}

pub mod literature;
pub mod select;

impl Scheduler for Policy {
    fn id(&self) -> String {
        self.kind().id().to_string()
    }

    fn hand_out(&self, n: usize, workers: usize, slow: Slow) -> HandOut {
        self.rule(n, workers, slow)
    }
}

/// Can `kind` hand items to sources behind the source interface (MPI ranks, a GPU, a
/// researcher's own)? Every rule but stealing, which needs workers that share memory.
pub fn over_sources(kind: crate::sched::SchedulerKind) -> bool {
    !Policy::defaults(kind).needs().shared_memory
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sched::rule::{chunk_sequence, Dispense, Grab, WorkerRule};

    #[test]
    fn every_built_in_kind_has_a_rule_that_hands_out_every_item() {
        for kind in SchedulerKind::ALL {
            let policy = Policy::defaults(kind);
            match policy.rule(1000, 4, Slow::NONE) {
                HandOut::ByMaster(m) => assert_eq!(kind, SchedulerKind::Master, "{m:?}"),
                HandOut::ByWorkers(WorkerRule::Pool(mut pool)) => {
                    let seq = chunk_sequence(pool.rule.as_mut(), 1000, 4);
                    assert_eq!(seq.iter().sum::<usize>(), 1000, "{kind:?}");
                    assert_eq!(pool.locked, kind == SchedulerKind::Pbrt);
                    assert_eq!(pool.scanline, kind.runs_hand_outs_in_scanline(), "{kind:?}");
                }
                HandOut::ByWorkers(WorkerRule::Own(o)) => {
                    let total: usize = (0..4).map(|k| o.items(k, 1000, 4).count()).sum();
                    assert_eq!(total, 1000, "{kind:?}");
                }
                HandOut::ByWorkers(WorkerRule::Steal(s)) => assert!(s.grab() >= 1),
                HandOut::ByWorkers(WorkerRule::Dispense(_)) => {
                    panic!("{kind:?}: no built-in shape")
                }
            }
        }
    }

    /// The dispenser every executor drives hands out the chunk sequence of the rule alone:
    /// the same hand-out counts as before the pool protocol was written once.
    #[test]
    fn the_dispenser_hands_out_each_pool_rules_own_chunk_sequence() {
        for kind in SchedulerKind::ALL {
            let rule = || Policy::defaults(kind).rule(1000, 4, Slow::NONE);
            let (
                HandOut::ByWorkers(WorkerRule::Pool(mut a)),
                HandOut::ByWorkers(WorkerRule::Pool(b)),
            ) = (rule(), rule())
            else {
                continue;
            };
            let want = chunk_sequence(a.rule.as_mut(), 1000, 4);
            let mut d = b.dispenser(1000);
            let mut got = Vec::new();
            let mut next = 0;
            while let Some(r) = d.grant(got.len() % 4, None) {
                assert_eq!(r.start, next, "{kind:?}: consecutive from the front");
                next = r.end;
                got.push(r.len());
            }
            assert_eq!(got, want, "{kind:?}");
        }
    }

    #[test]
    fn guided_and_mitsuba_chunks_follow_their_formulas() {
        // Guided, k = 2, P = 4, grab 1: ⌈1000/8⌉ = 125, ⌈875/8⌉ = 110, ⌈765/8⌉ = 96.
        let HandOut::ByWorkers(WorkerRule::Pool(mut g)) =
            Policy::defaults(SchedulerKind::Guided).rule(1000, 4, Slow::NONE)
        else {
            panic!("guided is a pool")
        };
        assert_eq!(
            &chunk_sequence(g.rule.as_mut(), 1000, 4)[..3],
            [125, 110, 96]
        );
        // Mitsuba's grain: max(blocks / (4·threads), 1) = 64 / 8 = 8.
        let HandOut::ByWorkers(WorkerRule::Pool(mut m)) =
            Policy::defaults(SchedulerKind::Mitsuba).rule(64, 2, Slow::NONE)
        else {
            panic!("mitsuba is a pool")
        };
        assert_eq!(chunk_sequence(m.rule.as_mut(), 64, 2), [8; 8]);
        assert_eq!(m.rule.as_grab(), Some(Grab::fixed(8)));
    }
}
