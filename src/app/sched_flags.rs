//! The scheduler's flags, derived from the scheduler definition: `--scheduler`, `--chunk`,
//! `--order`, and one flag per parameter of any kind (`--buffer`, `--grab`, …) whose help
//! lists what it means for each kind that has it. A parameter left out takes the kind's
//! default (the same default an experiment file gets); one the kind does not have is an error.

use clap::{Arg, ArgMatches, Args, Command, FromArgMatches};
use raysched::sched::sources::SourceField;
use raysched::sched::spec::kinds_with;
use raysched::sched::{
    param_columns, source_params, Chunk, Order, Policy, SchedulerKind, SchedulerSpec, Slow,
    SourceSet, SourceSetup,
};

/// What the scheduler flags said, before the worker count is known.
#[derive(Clone, Debug)]
pub(crate) struct SchedulerFlags {
    kind: SchedulerKind,
    /// Was `--scheduler` given (not its default)?
    named: bool,
    /// `None`: the kind's own default item size.
    chunk: Option<Chunk>,
    /// `None`: the kind's own default order.
    order: Option<Order>,
    slow: Slow,
    /// (parameter name, text given), in column order.
    params: Vec<(&'static str, String)>,
}

impl SchedulerFlags {
    /// `kind` in place of the default when `--scheduler` was not given (a GPU or MPI source
    /// runs under the master: asking for one picks it).
    pub(crate) fn defaulting_to(&self, kind: SchedulerKind) -> Self {
        let mut f = self.clone();
        if !f.named {
            f.kind = kind;
        }
        f
    }

    /// The scheduler spec for `workers` workers; errors name the flag.
    pub(crate) fn spec(&self, workers: usize, timeline: bool) -> Result<SchedulerSpec, String> {
        let mut spec = SchedulerSpec {
            timeline,
            slow: self.slow,
            ..SchedulerSpec::new(
                self.kind,
                self.chunk.unwrap_or(self.kind.default_chunk()),
                workers,
            )
        };
        if let Some(order) = self.order {
            spec.order = order;
        }
        for (name, text) in &self.params {
            spec.set(name, text)
                .map_err(|e| format!("--{}: {}", name.replace('_', "-"), e.msg))?;
        }
        spec.validate().map_err(|e| {
            let flag = match e.field.as_str() {
                "workers" => "threads".to_string(),
                f => f.replace('_', "-"),
            };
            format!("--{flag}: {}", e.msg)
        })?;
        Ok(spec)
    }
}

/// `kind: meaning [default: v]` for every kind that has parameter `name`.
fn param_help(name: &str) -> String {
    kinds_with(name)
        .iter()
        .map(|(k, p)| {
            let default = Policy::defaults(*k)
                .params()
                .and_then(|d| d.get(name))
                .unwrap_or_default();
            format!("{}: {} [default: {default}]", k.id(), p.help)
        })
        .collect::<Vec<_>>()
        .join("; ")
}

fn ids(all: &[&'static str]) -> String {
    all.join(", ")
}

impl Args for SchedulerFlags {
    fn augment_args(cmd: Command) -> Command {
        let kinds: Vec<&str> = SchedulerKind::ALL.iter().map(|k| k.id()).collect();
        let orders: Vec<&str> = Order::ALL.iter().map(|o| o.id()).collect();
        let mut cmd = cmd
            .arg(
                Arg::new("scheduler")
                    .long("scheduler")
                    .value_name("SCHEDULER")
                    .default_value(SchedulerKind::WorkStealing.id())
                    // One default in the help, both cases in it: clap would add a second.
                    .hide_default_value(true)
                    .value_parser(|s: &str| SchedulerKind::from_id(s).map_err(|e| e.msg))
                    .help(format!(
                        "Scheduler: {} [default: {}; master with gpu or mpi among --sources]",
                        ids(&kinds),
                        SchedulerKind::WorkStealing.id()
                    )),
            )
            .arg(
                Arg::new("chunk")
                    .long("chunk")
                    .value_name("CHUNK")
                    .value_parser(super::parse_chunk)
                    .help(format!(
                        "Work item size: N (N×N tile; 1 = per ray), WxH, rows:N, frame (alias \
                         frames: one whole frame per item; an animation is cut frame by frame \
                         for every size) [default: {} for guided and the factoring family, \
                         which size their own hand-outs; {} otherwise]",
                        SchedulerKind::Guided.default_chunk(),
                        SchedulerKind::SelfScheduling.default_chunk(),
                    )),
            )
            .arg(
                Arg::new("order")
                    .long("order")
                    .value_name("ORDER")
                    .value_parser(|s: &str| Order::from_id(s).map_err(|e| e.msg))
                    .help(format!(
                        "Hand-out order of the items: {} [default: {} for guided and the \
                         factoring family, whose first chunks are a share of all items; {} \
                         otherwise]",
                        ids(&orders),
                        SchedulerKind::Guided.default_order().id(),
                        SchedulerKind::SelfScheduling.default_order().id(),
                    )),
            )
            .arg(
                Arg::new("slow")
                    .long("slow")
                    .value_name("K:F")
                    .default_value("none")
                    .value_parser(|s: &str| Slow::parse(s).map_err(|e| e.msg))
                    .help(
                        "Heterogeneous run: the first K workers take F× as long per item \
                         (they render it, then spin), e.g. 1:4; none for equal workers",
                    ),
            );
        for p in param_columns() {
            cmd = cmd.arg(
                Arg::new(p.name)
                    .long(p.flag())
                    .value_name(p.name.to_uppercase())
                    .help(param_help(p.name)),
            );
        }
        cmd
    }

    fn augment_args_for_update(cmd: Command) -> Command {
        Self::augment_args(cmd)
    }
}

impl FromArgMatches for SchedulerFlags {
    fn from_arg_matches(m: &ArgMatches) -> Result<Self, clap::Error> {
        let get = |id: &str| m.get_one::<String>(id).cloned();
        Ok(Self {
            kind: *m.get_one("scheduler").expect("has a default"),
            named: m.value_source("scheduler") != Some(clap::parser::ValueSource::DefaultValue),
            chunk: m.get_one("chunk").copied(),
            order: m.get_one("order").copied(),
            slow: *m.get_one("slow").expect("has a default"),
            params: param_columns()
                .iter()
                .filter_map(|p| Some((p.name, get(p.name)?)))
                .collect(),
        })
    }

    fn update_from_arg_matches(&mut self, m: &ArgMatches) -> Result<(), clap::Error> {
        *self = Self::from_arg_matches(m)?;
        Ok(())
    }
}

/// The per-source flags, derived from the compute-source definition
/// (`raysched::sched::source_params`): `--gpu-chunk`, `--gpu-buffer`, `--balance`.
#[derive(Clone, Debug, Default)]
pub(crate) struct SourceFlags {
    /// (setting name, text given), in definition order.
    given: Vec<(String, String)>,
}

impl SourceFlags {
    /// The setup of `set` with the flags applied; errors name the flag.
    pub(crate) fn setup(&self, set: &SourceSet) -> Result<SourceSetup, String> {
        let flag = |name: &str| format!("--{}", name.replace('_', "-"));
        let mut setup = SourceSetup::of(set.clone());
        for (name, text) in &self.given {
            setup
                .set_param(name, text)
                .map_err(|e| format!("{}: {}", flag(name), e.msg))?;
        }
        setup
            .validate()
            .map_err(|e| format!("{}: {}", flag(&e.field), e.msg))?;
        Ok(setup)
    }
}

impl Args for SourceFlags {
    fn augment_args(mut cmd: Command) -> Command {
        for p in source_params() {
            let mut arg = Arg::new(p.name.clone()).long(p.flag()).help(p.help.clone());
            arg = if p.field == SourceField::Balance {
                // `--balance` alone means on; `--balance false` turns the default off. A
                // value is taken when one follows, so a bad one is an error naming the flag.
                arg.num_args(0..=1)
                    .default_missing_value("true")
                    .value_name("BOOL")
            } else {
                arg.value_name(p.name.to_uppercase())
            };
            cmd = cmd.arg(arg);
        }
        cmd
    }

    fn augment_args_for_update(cmd: Command) -> Command {
        Self::augment_args(cmd)
    }
}

impl FromArgMatches for SourceFlags {
    fn from_arg_matches(m: &ArgMatches) -> Result<Self, clap::Error> {
        Ok(Self {
            given: source_params()
                .iter()
                .filter_map(|p| {
                    let text = m.get_one::<String>(&p.name)?.clone();
                    Some((p.name.clone(), text))
                })
                .collect(),
        })
    }

    fn update_from_arg_matches(&mut self, m: &ArgMatches) -> Result<(), clap::Error> {
        *self = Self::from_arg_matches(m)?;
        Ok(())
    }
}
