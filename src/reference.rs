//! The reference pages under `docs/reference/`, written from the definitions themselves: the
//! scheduler kinds and their parameters (`sched::spec`), the rule each plays (`sched::rule`),
//! the value enums, the kinds of compute source and their settings (`sched::sources`) and the
//! columns of `runs.csv` (`experiment::results`). A test compares the committed pages with
//! these functions, so the pages cannot drift from the code; `RAYSCHED_BLESS=1` rewrites them.

use crate::sched::kinds::over_sources;
use crate::sched::rule::{HandOut, Steal, WorkerRule};
use crate::sched::{
    param_columns, source_params, Order, Passes, Policy, SchedulerKind, Slow, SourceKind, Weights,
};
use crate::studies::experiment::results::RunRow;
use std::fmt::Write;

/// Every page: its path under the repository root and its text.
pub fn pages() -> Vec<(&'static str, String)> {
    vec![
        ("docs/reference/schedulers.md", schedulers()),
        ("docs/reference/sources.md", sources()),
        ("docs/reference/literature.md", literature()),
        ("docs/reference/columns.md", columns()),
    ]
}

const HEADER: &str = "<!-- Generated from the code by `raysched::reference`; do not edit. \
The test `reference_pages_match_the_code` fails when this page and the code disagree; \
`RAYSCHED_BLESS=1 cargo test --test it reference` rewrites it. -->\n\n";

/// A rustdoc line as plain Markdown: intra-doc links lose their targets.
fn plain(doc: &str) -> String {
    let mut out = String::new();
    let mut rest = doc;
    while let Some(at) = rest.find("](") {
        let (before, after) = rest.split_at(at);
        out.push_str(before);
        out.push(']');
        rest = after[2..].find(')').map_or("", |end| &after[2 + end + 1..]);
    }
    out.push_str(rest);
    out.replace("[`", "`").replace("`]", "`")
}

/// The rule a kind plays, in words.
fn rule_words(kind: SchedulerKind) -> &'static str {
    match Policy::defaults(kind).rule(1024, 4, Slow::NONE) {
        HandOut::ByMaster(_) => "master: ≤ B outstanding per source, FIFO re-queue",
        HandOut::ByWorkers(WorkerRule::Own(_)) => "owned: every item's worker fixed up front",
        HandOut::ByWorkers(WorkerRule::Pool(p)) if p.rule.as_grab().is_some() => {
            "pool: chunks sized from the items left alone"
        }
        HandOut::ByWorkers(WorkerRule::Pool(_)) => "pool: chunks sized by a stateful rule",
        HandOut::ByWorkers(WorkerRule::Steal(Steal::Split { .. })) => {
            "stealing: rayon's recursive split"
        }
        HandOut::ByWorkers(WorkerRule::Steal(Steal::Half)) => "stealing: half a victim's deque",
        HandOut::ByWorkers(WorkerRule::Dispense(_)) => "pool: a shape of its own",
    }
}

/// `docs/reference/schedulers.md`.
pub fn schedulers() -> String {
    let mut s = String::from(HEADER);
    s += "# Schedulers\n\nEvery scheduler by its id (`--scheduler`, an experiment's \
          `schedulers[].kind`, the `scheduler` column). *Sources* says whether it can hand \
          out to sources behind the source interface (a GPU, MPI ranks, a researcher's own): \
          every rule but stealing can. Every scheduler runs on local threads, in the \
          simulation and in the cost model.\n\n";
    s += "| id | rule | default chunk | default order | parameters | sources |\n";
    s += "|---|---|---|---|---|---|\n";
    for k in SchedulerKind::ALL {
        let params: Vec<String> = Policy::defaults(k)
            .info()
            .iter()
            .map(|p| format!("`{}`", p.name))
            .collect();
        let (chunk, order) = if k.picks_own_layout() {
            ("its own".to_string(), "its own".to_string())
        } else {
            (
                format!("`{}`", k.default_chunk()),
                format!("`{}`", k.default_order().id()),
            )
        };
        let _ = writeln!(
            s,
            "| `{}` | {} | {chunk} | {order} | {} | {} |",
            k.id(),
            rule_words(k),
            if params.is_empty() {
                "–".to_string()
            } else {
                params.join(", ")
            },
            if over_sources(k) { "yes" } else { "no" },
        );
    }
    for k in SchedulerKind::ALL {
        let _ = write!(s, "\n## `{}`\n\n{}\n", k.id(), plain(&k.doc()));
        let policy = Policy::defaults(k);
        if policy.info().is_empty() {
            continue;
        }
        s += "\n| parameter | flag | default | meaning |\n|---|---|---|---|\n";
        for p in policy.info() {
            let default = policy
                .params()
                .and_then(|d| d.get(p.name))
                .unwrap_or_default();
            let _ = writeln!(
                s,
                "| `{}` | `--{}` | `{default}` | {} |",
                p.name,
                p.flag(),
                plain(p.help).replace('|', "\\|")
            );
        }
    }
    s += "\n# Values\n";
    value_table(&mut s, "order", Order::ALL.map(|v| (v.id(), v.doc())));
    value_table(&mut s, "weights", Weights::ALL.map(|v| (v.id(), v.doc())));
    value_table(&mut s, "passes", Passes::ALL.map(|v| (v.id(), v.doc())));
    s
}

fn value_table<const N: usize>(s: &mut String, name: &str, rows: [(&str, String); N]) {
    let _ = write!(s, "\n## `{name}`\n\n| value | meaning |\n|---|---|\n");
    for (id, doc) in rows {
        let _ = writeln!(s, "| `{id}` | {} |", plain(&doc).replace('|', "\\|"));
    }
}

/// `docs/reference/literature.md`: every technique of LB4OMP and Auto4OMP, its paper and the
/// kinds that play it, from the registry's [`SchedulerKind::published`].
pub fn literature() -> String {
    use crate::sched::kinds::literature::TECHNIQUES;
    let mut s = String::from(HEADER);
    s += "# raysched against LB4OMP and Auto4OMP\n\nEvery loop-scheduling technique of LB4OMP \
          (`runtime/src/kmp_dispatch.cpp`) and every selection method of Auto4OMP, the paper \
          that defines it, and the raysched kinds that play it: *exact* where one plays it as \
          published (held to an independent reference by `tests/it/dls_conformance.rs` for \
          the chunk-sizing rules), *variant* where the kinds differ from the paper in a way \
          their reference entry states, *missing* with the reason.\n\n";
    s += "| technique | peer | paper | status | raysched kinds |\n|---|---|---|---|---|\n";
    for t in TECHNIQUES {
        let kinds: Vec<(SchedulerKind, bool)> = SchedulerKind::ALL
            .into_iter()
            .filter_map(|k| {
                k.published()
                    .filter(|(name, _)| *name == t.name)
                    .map(|(_, exact)| (k, exact))
            })
            .collect();
        let status = if kinds.iter().any(|k| k.1) {
            "exact".to_string()
        } else if !kinds.is_empty() {
            "variant".to_string()
        } else {
            format!("missing: {}", t.absent)
        };
        let ids: Vec<String> = kinds
            .iter()
            .map(|(k, exact)| {
                if *exact {
                    format!("`{}`", k.id())
                } else {
                    format!("`{}` (variant)", k.id())
                }
            })
            .collect();
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} |",
            t.name,
            t.peer,
            t.paper,
            status,
            if ids.is_empty() {
                "–".to_string()
            } else {
                ids.join(", ")
            }
        );
    }
    s
}

/// `docs/reference/sources.md`.
pub fn sources() -> String {
    let mut s = String::from(HEADER);
    s += "# Compute sources\n\nThe kinds of source a run renders with (`--sources`, an \
          experiment's `sources`, the `sources` column), built in the set's order by \
          `sched::factory::build_sources`. A researcher's own source implements \
          `source::ComputeSource` and joins a run through `sched::run` (see \
          [extending](../extending.md)).\n\n| id | cargo feature |\n|---|---|\n";
    for k in SourceKind::ALL {
        let _ = writeln!(
            s,
            "| `{}` | {} |",
            k.id(),
            k.feature().map_or("–".to_string(), |f| format!("`{f}`"))
        );
    }
    s += "\n## Per-kind settings under the master\n\n| key | flag | meaning |\n|---|---|---|\n";
    for p in source_params() {
        let help = p.help.split_whitespace().collect::<Vec<_>>().join(" ");
        let _ = writeln!(s, "| `{}` | `--{}` | {help} |", p.name, p.flag());
    }
    s
}

/// `docs/reference/columns.md`.
pub fn columns() -> String {
    let mut s = String::from(HEADER);
    s += "# Columns of `runs.csv`\n\nOne row per measured sample, in this order. The \
          scheduler parameters' columns are the union of every kind's parameters; a kind \
          without one leaves it empty.\n\n| column | scheduler parameter |\n|---|---|\n";
    let params: Vec<&str> = param_columns().iter().map(|p| p.name).collect();
    for c in RunRow::header() {
        let _ = writeln!(
            s,
            "| `{c}` | {} |",
            if params.contains(&c.as_str()) {
                "yes"
            } else {
                ""
            }
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::plain;

    #[test]
    fn intra_doc_links_lose_their_targets() {
        assert_eq!(
            plain("cut into [`BLOCK_PX`](super::decompose::BLOCK_PX)² blocks, [`Slow`] too"),
            "cut into `BLOCK_PX`² blocks, `Slow` too"
        );
    }
}
