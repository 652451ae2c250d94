//! `meta.toml`: the machine and build a run was measured on, and the experiment file's hash.
//! What it records about the rows is written once, when runs.csv is started; each later start
//! appends a [`Start`] to its `history` (and the scenes a grown experiment adds), and a start
//! on another machine or build is refused ([`resume_conflict`]).

use super::plan::{ExperimentPlan, GpuMeta};
use serde::{Deserialize, Serialize};

/// The contents of `meta.toml`.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Meta {
    /// The experiment's name (its results folder).
    pub experiment: String,
    /// The experiment file's path as given on the command line.
    pub experiment_file: String,
    /// FNV-1a of the experiment file's bytes, as of the latest start (each start's own is in
    /// its [`Start`]).
    pub experiment_hash: String,
    /// UTC, when runs.csv was started.
    pub started: String,
    /// UTC, the latest resume (absent if never resumed).
    pub resumed: Option<String>,
    /// The crate version (`CARGO_PKG_VERSION`) of the binary that measured.
    pub raysched_version: String,
    /// The commit the binary was built from, `-dirty+<diff hash>` if its sources had local
    /// changes (fixed at build time; older files: read from the working directory at run time).
    pub git_commit: String,
    /// `rustc -V` of the compiler that built the binary.
    pub rustc: String,
    /// Cargo features compiled in (`embree`, `mpi`).
    pub features: Vec<String>,
    /// The machine measured on.
    pub machine: Machine,
    /// Plan stage, never timed with a run.
    pub scenes: Vec<SceneMeta>,
    /// The measuring binary's provenance (absent in files written before it was recorded).
    #[serde(default)]
    pub build: Option<crate::util::provenance::Build>,
    /// Every start of `raysched run` on this folder, the first one included, oldest first.
    #[serde(default)]
    pub history: Vec<Start>,
    /// The GPU the rows with a GPU source rendered on (absent without one, and in files
    /// written before it was recorded).
    #[serde(default)]
    pub gpu: Option<GpuMeta>,
    /// The configuration ids the experiment file named at the latest start. Rows of others
    /// (a grid value since removed or changed) stay in runs.csv but are left out of summary,
    /// plots, report and `compare` ([`current_rows`]). Empty in files written before it was
    /// recorded: every row counts.
    #[serde(default)]
    pub configs: Vec<String>,
}

/// `rows` less those of configurations the latest start's experiment file no longer names
/// ([`Meta::configs`]), and how many rows were left out.
pub fn current_rows(
    meta: Option<&Meta>,
    rows: Vec<super::results::RunRow>,
) -> (Vec<super::results::RunRow>, usize) {
    let Some(ids) = meta.filter(|m| !m.configs.is_empty()).map(|m| {
        m.configs
            .iter()
            .map(String::as_str)
            .collect::<std::collections::HashSet<&str>>()
    }) else {
        return (rows, 0);
    };
    let before = rows.len();
    let kept: Vec<_> = rows
        .into_iter()
        .filter(|r| ids.contains(r.config.as_str()))
        .collect();
    let left = before - kept.len();
    (kept, left)
}

/// [`current_rows`] for the results folder `dir`, reading its `meta.toml`.
pub fn current_rows_in(
    dir: &std::path::Path,
    rows: Vec<super::results::RunRow>,
) -> (Vec<super::results::RunRow>, usize) {
    let meta: Option<Meta> = std::fs::read_to_string(dir.join("meta.toml"))
        .ok()
        .and_then(|t| toml::from_str(&t).ok());
    current_rows(meta.as_ref(), rows)
}

/// One start of `raysched run` on a results folder: when, where, with what, under what load.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Start {
    /// UTC.
    pub time: String,
    /// The host name.
    pub host: String,
    /// The CPU model.
    pub cpu_model: String,
    /// Logical CPUs available.
    pub cores: usize,
    /// The binary's commit label ([`crate::util::provenance::Build::commit_label`]).
    pub commit: String,
    /// The binary's rustc.
    pub rustc: String,
    /// The binary's profile.
    pub profile: String,
    /// 1-minute load average when the start began (`-1` if unknown).
    pub load1: f64,
    /// Rows already in runs.csv at this start.
    pub rows_before: usize,
    /// The statistics settings this start measured with.
    pub stats: crate::studies::experiment::plan::StatsSettings,
    /// FNV-1a of the experiment file this start ran (absent in files written before it was
    /// recorded): a grown grid resumes, so the file may differ between starts.
    #[serde(default)]
    pub experiment_hash: Option<String>,
}

impl Start {
    /// This process starting now on `rows_before` existing rows.
    pub fn now(rows_before: usize, stats: crate::studies::experiment::plan::StatsSettings) -> Self {
        let b = crate::util::provenance::Build::current();
        let m = machine();
        Self {
            time: now_utc(),
            host: crate::util::host::hostname(),
            cpu_model: m.cpu_model,
            cores: m.cores,
            commit: b.commit_label(),
            rustc: b.rustc,
            profile: b.profile,
            load1: crate::util::host::load_average().map_or(-1.0, |l| l[0]),
            rows_before,
            stats,
            experiment_hash: None,
        }
    }
}

/// Why rows measured under `old` cannot be resumed by `now` (another machine, commit, rustc or
/// profile), as "what: old → new" parts; empty when they match. Files written before the
/// history was recorded are compared on their machine, commit and rustc fields.
pub fn resume_conflict(old: &Meta, now: &Start) -> Vec<String> {
    let mut diffs = Vec::new();
    let mut check = |what: &str, a: &str, b: &str| {
        if a != b {
            diffs.push(format!("{what} {a} → {b}"));
        }
    };
    match old.history.first() {
        Some(first) => {
            check("host", &first.host, &now.host);
            check("CPU", &first.cpu_model, &now.cpu_model);
            check("cores", &first.cores.to_string(), &now.cores.to_string());
            check("commit", &first.commit, &now.commit);
            check("rustc", &first.rustc, &now.rustc);
            check("profile", &first.profile, &now.profile);
        }
        None => {
            check("CPU", &old.machine.cpu_model, &now.cpu_model);
            check(
                "cores",
                &old.machine.cores.to_string(),
                &now.cores.to_string(),
            );
            check("commit", &old.git_commit, &now.commit);
            check("rustc", &old.rustc, &now.rustc);
        }
    }
    diffs
}

/// The host a run was measured on.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Machine {
    /// The CPU's model name from /proc/cpuinfo (`unknown` if absent).
    pub cpu_model: String,
    /// Logical CPUs this process may use (std::thread::available_parallelism).
    pub cores: usize,
    /// Total memory in GiB, rounded to 0.1 (0 if unknown).
    pub memory_gib: f64,
    /// The distribution's pretty name, else the OS family.
    pub os: String,
    /// The kernel release (`uname -r`; empty if unknown).
    pub kernel: String,
    /// The CPU architecture the binary was built for (`x86_64`, `aarch64`, …).
    pub arch: String,
}

/// One planned scene as loaded, with the build time of each tracer on it.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct SceneMeta {
    /// The path as written in the experiment file.
    pub file: String,
    /// The scene's name.
    pub name: String,
    /// The scene's hash (canonical text after overrides and its mesh files), 16 hex digits.
    pub hash: String,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Samples per pixel.
    pub spp: u32,
    /// Number of geometry primitives.
    pub primitives: usize,
    /// Seconds taken to load the scene.
    pub load_s: f64,
    /// (tracer, build seconds)
    pub tracers: Vec<(String, f64)>,
    /// Seconds taken to upload the scene to the GPU (absent without one).
    #[serde(default)]
    pub gpu_upload_s: Option<f64>,
}

/// Describe this host.
pub fn machine() -> Machine {
    use crate::util::host;
    Machine {
        cpu_model: host::cpu_model(),
        cores: host::available_threads(),
        memory_gib: host::memory_gib(),
        os: host::os_name(),
        kernel: host::kernel(),
        arch: std::env::consts::ARCH.to_string(),
    }
}

/// UTC date and time, `YYYY-MM-DDTHH:MM:SSZ` (no date crate needed for one timestamp).
pub fn now_utc() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs() as i64);
    let (days, rem) = (secs.div_euclid(86_400), secs.rem_euclid(86_400));
    // Howard Hinnant's civil_from_days.
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}Z",
        rem / 3600,
        rem / 60 % 60,
        rem % 60
    )
}

/// The meta of a run of `plan` starting now (`started` is now, `resumed` unset, no history
/// yet); the build facts come from [`crate::util::provenance::Build::current`].
pub fn collect(plan: &ExperimentPlan) -> Meta {
    let build = crate::util::provenance::Build::current();
    let scenes = plan
        .scenes
        .iter()
        .enumerate()
        .map(|(i, s)| SceneMeta {
            file: s.file.clone(),
            name: s.scene.name.clone(),
            hash: crate::util::hash::hex(s.scene.hash),
            width: s.scene.width(),
            height: s.scene.height(),
            spp: s.scene.settings.spp,
            primitives: s.scene.geometry.len(),
            load_s: s.load_s,
            tracers: plan
                .baselines
                .iter()
                .filter(|b| b.scene == i)
                .map(|b| (b.tracer_id.clone(), b.build_s))
                .collect(),
            gpu_upload_s: plan.gpu.as_ref().and_then(|g| g.upload_s.get(i).copied()),
        })
        .collect();
    Meta {
        experiment: plan.name.clone(),
        experiment_file: plan.file.display().to_string(),
        experiment_hash: plan.file_hash.clone(),
        started: now_utc(),
        resumed: None,
        raysched_version: env!("CARGO_PKG_VERSION").to_string(),
        git_commit: build.commit_label(),
        rustc: build.rustc.clone(),
        features: build.features.clone(),
        machine: machine(),
        scenes,
        build: Some(build),
        history: vec![],
        gpu: plan.gpu.as_ref().map(|g| g.info.clone()),
        configs: plan.configs.iter().map(|c| c.id.clone()).collect(),
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn utc_timestamp_is_well_formed() {
        let t = super::now_utc();
        assert_eq!(t.len(), 20, "{t}");
        assert!(
            t.starts_with("20") && t.ends_with('Z') && &t[10..11] == "T",
            "{t}"
        );
    }
}
