//! The one definition of the kinds of compute source: ids (CLI `--sources`, experiment
//! `sources = [...]`, the CSV's `sources` column), the cargo feature each needs, and the set a
//! run renders with. A run's sources are a set of kinds: `threads`, `gpu`, `threads+gpu`,
//! `mpi`.

use super::param::{err, id_enum, one_of, ParamValue, SpecError};
use serde::{Deserialize, Serialize};

id_enum! {
    /// A kind of compute source.
    pub enum SourceKind("sources", "compute source") {
        /// Worker threads of this process (`local` is accepted as an alias).
        Threads = "threads",
        /// One GPU through wgpu/Vulkan (feature `gpu`): one dispatch per hand-out.
        Gpu = "gpu",
        /// MPI ranks 1…K−1 under `mpirun -n K` (feature `mpi`).
        Mpi = "mpi",
    }
}

impl SourceKind {
    /// The cargo feature this kind needs, if any.
    pub fn feature(self) -> Option<&'static str> {
        match self {
            Self::Threads => None,
            Self::Gpu => Some("gpu"),
            Self::Mpi => Some("mpi"),
        }
    }

    /// Was this build compiled with what the kind needs?
    pub fn compiled(self) -> bool {
        match self {
            Self::Threads => true,
            Self::Gpu => cfg!(feature = "gpu"),
            Self::Mpi => cfg!(feature = "mpi"),
        }
    }
}

/// The kinds of source one run renders with, in [`SourceKind::ALL`] order, no repeats.
#[derive(Clone, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct SourceSet(Vec<SourceKind>);

impl SourceSet {
    /// Local threads only: every run that names no sources.
    pub fn threads() -> Self {
        Self(vec![SourceKind::Threads])
    }

    /// `kinds` as a set; errors on an empty list, a repeat, `mpi` with another kind (MPI
    /// runs add local threads with `--local-threads`), or a kind this build lacks.
    pub fn new(kinds: &[SourceKind]) -> Result<Self, SpecError> {
        let mut v: Vec<SourceKind> = Vec::new();
        for &k in kinds {
            if v.contains(&k) {
                return Err(err("sources", format!("'{}' given twice", k.id())));
            }
            v.push(k);
        }
        if v.is_empty() {
            return Err(err("sources", "no compute source given".to_string()));
        }
        if v.contains(&SourceKind::Mpi) && v.len() > 1 {
            return Err(err(
                "sources",
                "mpi runs alone (add threads on rank 0 with --local-threads)".to_string(),
            ));
        }
        if let Some(k) = v.iter().find(|k| !k.compiled()) {
            let f = k.feature().unwrap_or_default();
            return Err(err(
                "sources",
                format!("'{}' needs cargo feature `{f}`, which this build was compiled without (cargo build --features {f})", k.id()),
            ));
        }
        v.sort_by_key(|k| SourceKind::ALL.iter().position(|a| a == k));
        Ok(Self(v))
    }

    /// Parse `threads`, `gpu`, `threads,gpu` (or `+`), `mpi`; `local` means `threads`.
    pub fn parse(text: &str) -> Result<Self, SpecError> {
        let kinds = text
            .split([',', '+'])
            .map(|s| match s.trim() {
                "local" => Ok(SourceKind::Threads),
                t => SourceKind::from_id(t),
            })
            .collect::<Result<Vec<_>, _>>()?;
        Self::new(&kinds)
    }

    /// The kinds, in order.
    pub fn kinds(&self) -> &[SourceKind] {
        &self.0
    }

    /// Does the set hold `k`?
    pub fn has(&self, k: SourceKind) -> bool {
        self.0.contains(&k)
    }

    /// The id as written to the CSV: kinds joined by `+` (`threads+gpu`).
    pub fn id(&self) -> String {
        self.0.iter().map(|k| k.id()).collect::<Vec<_>>().join("+")
    }
}

impl Default for SourceSet {
    fn default() -> Self {
        Self::threads()
    }
}

impl ParamValue for SourceSet {
    fn parse_value(text: &str) -> Result<Self, String> {
        Self::parse(text).map_err(|e| e.msg)
    }
    fn show(&self) -> String {
        self.id()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sets_parse_sort_and_refuse_what_cannot_run() {
        assert_eq!(SourceSet::parse("local").unwrap(), SourceSet::threads());
        assert_eq!(SourceSet::parse("threads").unwrap().id(), "threads");
        let e = SourceSet::parse("threads,threads").unwrap_err();
        assert!(e.msg.contains("twice"), "{}", e.msg);
        let e = SourceSet::parse("cuda").unwrap_err();
        assert!(e.msg.contains("unknown compute source 'cuda'"), "{}", e.msg);
        if cfg!(feature = "gpu") {
            assert_eq!(SourceSet::parse("gpu,threads").unwrap().id(), "threads+gpu");
        } else {
            let e = SourceSet::parse("threads,gpu").unwrap_err();
            assert!(e.msg.contains("--features gpu"), "{}", e.msg);
        }
        if cfg!(feature = "mpi") {
            assert!(SourceSet::parse("mpi,threads").is_err());
        }
    }
}
