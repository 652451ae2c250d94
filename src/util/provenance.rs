//! What this binary is, fixed when it was built (`build/provenance.rs` reads git, rustc and
//! cargo's environment): shown by `raysched --version` and recorded in every `meta.toml`.

use serde::{Deserialize, Serialize};

/// The build's provenance.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq, Eq)]
pub struct Build {
    /// The crate version.
    pub version: String,
    /// `git rev-parse HEAD` of the source tree at build time (`unknown` outside git).
    pub commit: String,
    /// The sources the binary is built from (src/, Cargo files, assets/) differed from the
    /// commit.
    pub dirty: bool,
    /// FNV-1a of those differences (empty when clean): two dirty builds of one commit differ
    /// here when their code does.
    #[serde(default)]
    pub diff: String,
    /// `rustc -V` of the compiler that built the binary.
    pub rustc: String,
    /// The target triple.
    pub target: String,
    /// The target CPU features compiled for (`CARGO_CFG_TARGET_FEATURE`).
    pub cpu_features: String,
    /// Cargo features compiled in, e.g. `embree,mpi`.
    pub features: Vec<String>,
    /// Cargo's profile name (`release`, or `debug` for dev and test builds) and opt-level.
    pub profile: String,
}

impl Build {
    /// This binary's provenance.
    pub fn current() -> Self {
        let features = env!("RAYSCHED_BUILD_FEATURES");
        Self {
            version: env!("CARGO_PKG_VERSION").into(),
            commit: env!("RAYSCHED_BUILD_COMMIT").into(),
            dirty: env!("RAYSCHED_BUILD_DIRTY") == "true",
            diff: env!("RAYSCHED_BUILD_DIFF").into(),
            rustc: env!("RAYSCHED_BUILD_RUSTC").into(),
            target: env!("RAYSCHED_BUILD_TARGET").into(),
            cpu_features: env!("RAYSCHED_BUILD_CPU_FEATURES").into(),
            features: features
                .split(',')
                .filter(|f| !f.is_empty())
                .map(str::to_string)
                .collect(),
            profile: format!(
                "{} (opt-level {})",
                env!("RAYSCHED_BUILD_PROFILE"),
                env!("RAYSCHED_BUILD_OPT_LEVEL")
            ),
        }
    }

    /// The commit with `-dirty+<diff>` when the sources had local changes.
    pub fn commit_label(&self) -> String {
        if self.dirty {
            format!("{}-dirty+{}", self.commit, self.diff)
        } else {
            self.commit.clone()
        }
    }

    /// What `raysched --version` prints, one fact a line.
    pub fn long_version(&self) -> String {
        format!(
            "{}\ncommit:       {}\nrustc:        {}\nprofile:      {}\ntarget:       {}\nfeatures:     [{}]\ncpu features: {}",
            self.version,
            self.commit_label(),
            self.rustc,
            self.profile,
            self.target,
            self.features.join(", "),
            self.cpu_features
        )
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_build_knows_its_compiler_and_profile() {
        let b = super::Build::current();
        assert!(b.rustc.starts_with("rustc "), "{}", b.rustc);
        assert!(b.profile.contains("opt-level"), "{}", b.profile);
        assert_eq!(b.dirty, !b.diff.is_empty());
        assert_eq!(
            b.features.contains(&"mpi".to_string()),
            cfg!(feature = "mpi")
        );
    }
}
