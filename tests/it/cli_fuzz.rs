//! A fuzzer of the command line: every command × every argument × hostile values (empty,
//! negative, zero, huge, NaN, unicode, control characters, 100 k characters, not UTF-8, paths
//! into /proc and /dev/full, a file where a folder is expected), run on the real binary.
//!
//! The commands and their arguments come from clap's own definition (`raysched cli-spec`,
//! hidden), so a new flag is fuzzed without a change here. Each invocation changes one argument
//! of a base invocation that is cheap and, where the inputs exist, succeeds (once every case
//! was tried, pairs of changed flags of one command follow, at random); it must:
//! - end in time (no hang) and by an exit, not a signal;
//! - not panic (no "panicked", no "internal error" on stderr);
//! - exit 0 or 2 (bad input), never 1: the value given is the only thing changed;
//! - on exit 2, say so in one `error:` line that names the flag (for a positional, its name or
//!   value), unless the base invocation fails the same way on its own (a feature not built).
//!
//! `RAYSCHED_CLI_FUZZ_S` sets the budget in seconds (default 30, what CI runs),
//! `RAYSCHED_CLI_FUZZ_SEED` the order the cases are tried in, `RAYSCHED_CLI_FUZZ_TIMEOUT_S`
//! the limit of one invocation (default 60). Run long with
//! `RAYSCHED_CLI_FUZZ_S=600 cargo test --test it cli_fuzz -- --nocapture`.

use std::ffi::OsString;
use std::os::unix::ffi::OsStringExt;
use std::os::unix::process::{CommandExt, ExitStatusExt};
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

#[derive(Clone, Debug)]
struct ArgSpec {
    id: String,
    long: Option<String>,
    positional: bool,
    takes_value: bool,
    values: Vec<String>,
}

#[derive(Clone, Debug)]
struct CmdSpec {
    name: String,
    args: Vec<ArgSpec>,
}

/// The command line as clap defines it, from the binary itself.
fn spec(bin: &Path) -> Vec<CmdSpec> {
    let out = Command::new(bin).arg("cli-spec").output().unwrap();
    assert!(
        out.status.success(),
        "cli-spec: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let s = |v: &serde_json::Value| v.as_str().map(str::to_string);
    v.as_array()
        .unwrap()
        .iter()
        .map(|c| CmdSpec {
            name: s(&c["name"]).unwrap(),
            args: c["args"]
                .as_array()
                .unwrap()
                .iter()
                .map(|a| ArgSpec {
                    id: s(&a["id"]).unwrap(),
                    long: s(&a["long"]),
                    positional: a["positional"].as_bool().unwrap(),
                    takes_value: a["takes_value"].as_bool().unwrap(),
                    values: a["values"]
                        .as_array()
                        .unwrap()
                        .iter()
                        .filter_map(s)
                        .collect(),
                })
                .collect(),
        })
        .collect()
}

const SCENE: &str = crate::support::sphere_scene_8x8!();

/// The files the base invocations read, in `dir`.
fn setup(dir: &Path, bin: &Path) {
    std::fs::write(dir.join("s.toml"), SCENE).unwrap();
    std::fs::write(
        dir.join("e.toml"),
        "name = \"fz\"\nrepetitions = 1\nwarmup = 0\nworkers = [1]\n[[scenes]]\npath = \"s.toml\"\n\
         [[schedulers]]\nkind = \"static\"\nchunk = 8\n",
    )
    .unwrap();
    std::fs::write(dir.join("afile"), "").unwrap();
    // A results folder for `plot` and `compare`.
    let out = Command::new(bin)
        .args(["run", "e.toml", "--quiet", "--out", "res"])
        .current_dir(dir)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "setup run: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// The positional value of a base invocation, by the argument's id.
fn positional(cmd: &str, id: &str) -> String {
    match (cmd, id) {
        // The 8×8 scene converges to its reference at once: no error left to plot.
        ("converge", "scene") => crate::support::scene_path("cornell_box.toml")
            .to_string_lossy()
            .into_owned(),
        (_, "scene") => "s.toml".into(),
        ("simulate", _) => "e.toml".into(),
        (_, "experiment") => "e.toml".into(),
        (_, "dir" | "a" | "b") => "res/fz".into(),
        (_, "job") => "{}".into(),
        _ => "x".into(),
    }
}

/// Commands left out: `simgrid-child` is the process SimGrid's C++ runs in because it aborts
/// on a malformed platform file; `simulate` reports such a child's end.
const NOT_FUZZED: &[&str] = &["simgrid-child"];

/// Flags that keep a base invocation quick (one thread, few samples, outputs in the folder).
fn cheap(cmd: &str) -> &'static [&'static str] {
    match cmd {
        "render" => &["--threads", "1", "-o", "o.exr"],
        "profile" => &["--repeats", "1", "--chunks", "4", "-o", "h.png"],
        "converge" => &[
            "--max-spp",
            "2",
            "--ref-spp",
            "4",
            "--threads",
            "1",
            "-o",
            "cv",
            "--force",
        ],
        "stability" => &[
            "--quick",
            "--threads",
            "1",
            "--size",
            "4",
            "--spp",
            "2",
            "-o",
            "st",
            "--force",
        ],
        "advise" => &[
            "--workers",
            "1",
            "--scheduler",
            "static",
            "--chunks",
            "4",
            "--spp",
            "1",
        ],
        "run" => &[
            "--quiet",
            "--out",
            "res2",
            "--max-runs",
            "1",
            "--isolation",
            "none",
        ],
        "simulate" => &["--quiet", "--out", "res3"],
        _ => &[],
    }
}

/// The hostile values every argument gets.
fn hostile() -> Vec<OsString> {
    let mut v: Vec<OsString> = [
        "",
        " ",
        "0",
        "-0",
        "-1",
        "-4",
        "1",
        "2",
        "-inf",
        "inf",
        "NaN",
        "nan",
        "-nan",
        "1e308",
        "-1e308",
        "1e-320",
        "4294967296",
        "18446744073709551616",
        "99999999999999999999999999",
        "0x10",
        "1.5",
        "1,2,,3",
        ",",
        "-",
        "--",
        "=",
        "a\nb",
        "\t",
        "\u{1b}[31m",
        "ünïcødé ✓",
        "🦀",
        "\u{202e}exr.txt",
        "/proc/x.exr",
        "/proc/nope/x",
        "/proc/self/status",
        "/proc",
        "/dev/full",
        "/dev/full/x.exr",
        "afile/x.exr",
        "afile",
        "/nonexistent/x.toml",
        "frame",
        "rows:0",
        "0x0",
        "1:0",
        "master",
        "workers",
        "threads,gpu",
        "mpi",
    ]
    .iter()
    .map(OsString::from)
    .collect();
    v.push("x".repeat(100_000).into());
    v.push("9".repeat(100_000).into());
    v.push(format!("{}.exr", "n".repeat(300)).into());
    v.push(OsString::from_vec(vec![0xff, 0xfe, b'x']));
    v
}

/// One invocation to try: the argument changed and the argv after the binary.
#[derive(Clone, Debug)]
struct Case {
    cmd: String,
    /// How the changed argument is named in an error: `--spp`, or a positional's id and value.
    names: Vec<String>,
    argv: Vec<OsString>,
    /// The changed flag's own arguments at the end of `argv` (empty for a positional).
    tail: usize,
}

/// Two flag cases of one command at once: `a` with `b`'s flag and value appended; an error
/// may name either.
fn pair(a: &Case, b: &Case) -> Option<Case> {
    if a.cmd != b.cmd || a.tail == 0 || b.tail == 0 || a.names == b.names {
        return None;
    }
    let mut argv = a.argv.clone();
    argv.extend_from_slice(&b.argv[b.argv.len() - b.tail..]);
    Some(Case {
        cmd: a.cmd.clone(),
        names: [a.names.clone(), b.names.clone()].concat(),
        argv,
        tail: 0,
    })
}

fn base(cmd: &CmdSpec, skip: Option<&str>) -> Vec<OsString> {
    let mut argv: Vec<OsString> = vec![cmd.name.clone().into()];
    for a in cmd.args.iter().filter(|a| a.positional) {
        if Some(a.id.as_str()) != skip {
            argv.push(positional(&cmd.name, &a.id).into());
        }
    }
    argv
}

/// `cheap` without the pair (or switch) of `flag`.
fn cheap_without(cmd: &str, flag: &str, short: Option<&str>) -> Vec<OsString> {
    let c = cheap(cmd);
    let mut out = Vec::new();
    let mut i = 0;
    while i < c.len() {
        let takes = i + 1 < c.len() && !c[i + 1].starts_with('-');
        let hit = c[i] == flag || Some(c[i]) == short;
        if !hit {
            out.push(OsString::from(c[i]));
            if takes {
                out.push(OsString::from(c[i + 1]));
            }
        }
        i += if takes { 2 } else { 1 };
    }
    out
}

fn cases(spec: &[CmdSpec]) -> Vec<Case> {
    let values = hostile();
    let mut out = Vec::new();
    for cmd in spec
        .iter()
        .filter(|c| !NOT_FUZZED.contains(&c.name.as_str()))
    {
        for arg in &cmd.args {
            let mut vals = values.clone();
            // Near misses of the values it lists.
            for v in &arg.values {
                vals.push(format!("{v}x").into());
                vals.push(v.to_uppercase().into());
            }
            if arg.positional {
                // `--` ends the flags: not a value.
                for v in vals.iter().filter(|v| *v != "--") {
                    let mut argv = base(cmd, Some(&arg.id));
                    // Positionals in order: put the value where the skipped one was.
                    let at = 1 + cmd
                        .args
                        .iter()
                        .filter(|a| a.positional)
                        .position(|a| a.id == arg.id)
                        .unwrap();
                    argv.insert(at, v.clone());
                    argv.extend(cheap_without(&cmd.name, "", None));
                    out.push(Case {
                        cmd: cmd.name.clone(),
                        names: vec![arg.id.clone(), v.to_string_lossy().into_owned()],
                        argv,
                        tail: 0,
                    });
                }
                continue;
            }
            let Some(long) = &arg.long else { continue };
            let flag = format!("--{long}");
            let short = match long.as_str() {
                "output" => Some("-o"),
                _ => None,
            };
            let mut with = |tail: Vec<OsString>| {
                let mut argv = base(cmd, None);
                argv.extend(cheap_without(&cmd.name, &flag, short));
                let n = tail.len();
                argv.extend(tail);
                out.push(Case {
                    cmd: cmd.name.clone(),
                    names: vec![flag.clone()],
                    argv,
                    tail: n,
                });
            };
            if arg.takes_value {
                for v in &vals {
                    with(vec![flag.clone().into(), v.clone()]);
                    let mut eq = OsString::from(format!("{flag}="));
                    eq.push(v);
                    with(vec![eq]);
                }
                with(vec![flag.clone().into()]);
                with(vec![
                    flag.clone().into(),
                    "1".into(),
                    flag.clone().into(),
                    "2".into(),
                ]);
            } else {
                with(vec![flag.clone().into()]);
                with(vec![flag.clone().into(), flag.clone().into()]);
                with(vec![format!("{flag}=1").into()]);
            }
        }
    }
    out
}

/// What one invocation did.
struct Outcome {
    code: Option<i32>,
    signal: Option<i32>,
    timed_out: bool,
    stderr: String,
    secs: f64,
}

fn invoke(bin: &Path, dir: &Path, argv: &[OsString], limit: Duration) -> Outcome {
    let err_path = dir.join(".fuzz-stderr");
    let err_file = std::fs::File::create(&err_path).unwrap();
    let t0 = Instant::now();
    let mut child = Command::new(bin)
        .args(argv)
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(err_file)
        .process_group(0)
        .spawn()
        .unwrap();
    let mut timed_out = false;
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if t0.elapsed() > limit {
            timed_out = true;
            // The whole group: `run` starts a process per round.
            unsafe { libc::kill(-(child.id() as i32), libc::SIGKILL) };
            break child.wait().unwrap();
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    let stderr =
        String::from_utf8_lossy(&std::fs::read(&err_path).unwrap_or_default()).into_owned();
    Outcome {
        code: status.code(),
        signal: status.signal(),
        timed_out,
        stderr,
        secs: t0.elapsed().as_secs_f64(),
    }
}

/// The `error:` lines of a stderr.
fn error_lines(stderr: &str) -> Vec<&str> {
    stderr.lines().filter(|l| l.starts_with("error:")).collect()
}

/// Why `o` is a failure of `case`, if it is; `base_err` is the base invocation's error line.
fn judge(case: &Case, o: &Outcome, base_err: Option<&str>) -> Option<String> {
    if o.timed_out {
        return Some(format!("no exit within the limit ({:.0} s)", o.secs));
    }
    if let Some(s) = o.signal {
        return Some(format!("killed by signal {s}"));
    }
    if o.stderr.contains("panicked") || o.stderr.contains("internal error") {
        return Some("panic".into());
    }
    match o.code {
        Some(0) => None,
        Some(2) => {
            let errs = error_lines(&o.stderr);
            if errs.len() != 1 {
                return Some(format!("{} error lines", errs.len()));
            }
            let line = errs[0];
            if base_err == Some(line) {
                return None;
            }
            let named = case.names.iter().any(|n| {
                let n: String = n.chars().take(40).collect();
                let escaped: String = n.chars().flat_map(char::escape_default).collect();
                if n.trim().is_empty() {
                    // A blank value (" ", "\t") is named escaped or quoted, never bare.
                    return (!escaped.trim().is_empty() && line.contains(&escaped))
                        || [format!("'{n}'"), format!("`{n}`"), format!("\"{n}\"")]
                            .iter()
                            .any(|q| line.contains(q.as_str()));
                }
                line.contains(&n)
                    || line.contains(&escaped)
                    || line.to_lowercase().contains(&n.to_lowercase())
            });
            (!named).then(|| "the error does not name the argument".into())
        }
        Some(c) => Some(format!("exit {c}")),
        None => Some("no exit code".into()),
    }
}

/// A small deterministic generator for the case order.
fn shuffle<T>(v: &mut [T], mut seed: u64) {
    for i in (1..v.len()).rev() {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        v.swap(i, (seed % (i as u64 + 1)) as usize);
    }
}

fn shown(argv: &[OsString]) -> String {
    argv.iter()
        .map(|a| {
            let s = a.to_string_lossy();
            if s.len() > 60 {
                format!("{}…({} bytes)", &s[..s.floor_char_boundary(40)], s.len())
            } else {
                format!("{s:?}")
            }
        })
        .collect::<Vec<_>>()
        .join(" ")
}

#[test]
fn cli_fuzz() {
    let env = |k: &str, d: u64| {
        std::env::var(k)
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(d)
    };
    let budget = Duration::from_secs(env("RAYSCHED_CLI_FUZZ_S", 30));
    let limit = Duration::from_secs(env("RAYSCHED_CLI_FUZZ_TIMEOUT_S", 60));
    let seed = env("RAYSCHED_CLI_FUZZ_SEED", 0x5eed_cafe).max(1);
    let bin = super::cli_edges::bin();
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    setup(d, &bin);
    let spec = spec(&bin);
    assert!(spec
        .iter()
        .any(|c| c.name == "render" && c.args.iter().any(|a| a.id == "spp")));
    // Each base once: its error line, if it fails on its own (a feature this build lacks).
    let mut base_err = std::collections::HashMap::new();
    for c in &spec {
        let mut argv = base(c, None);
        argv.extend(cheap_without(&c.name, "", None));
        let o = invoke(&bin, d, &argv, limit);
        if o.code != Some(0) {
            base_err.insert(
                c.name.clone(),
                error_lines(&o.stderr).first().map(|l| l.to_string()),
            );
        }
    }
    let mut all = cases(&spec);
    shuffle(&mut all, seed);
    let t0 = Instant::now();
    let (mut n, mut failures) = (0usize, Vec::new());
    let mut per_cmd = std::collections::BTreeMap::<String, usize>::new();
    // One line per (command, argument, kind of failure), with its first example.
    let mut groups = std::collections::BTreeMap::<(String, String, String), (usize, String)>::new();
    // Every case once, then pairs of flags of one command at random until the budget ends.
    let mut rng = seed;
    let mut next = |k: usize| {
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        (rng % k as u64) as usize
    };
    let mut i = 0;
    while t0.elapsed() < budget {
        let paired;
        let case = if i < all.len() {
            &all[i]
        } else {
            match pair(&all[next(all.len())], &all[next(all.len())]) {
                Some(p) => {
                    paired = p;
                    &paired
                }
                None => continue,
            }
        };
        i += 1;
        let o = invoke(&bin, d, &case.argv, limit);
        n += 1;
        *per_cmd.entry(case.cmd.clone()).or_default() += 1;
        let base = base_err.get(&case.cmd).and_then(|e| e.as_deref());
        if let Some(why) = judge(case, &o, base) {
            let first = o
                .stderr
                .lines()
                .find(|l| l.starts_with("error:"))
                .unwrap_or("");
            let first: String = first.chars().take(300).collect();
            let example = format!("{why}: raysched {} → {first}", shown(&case.argv));
            let key = (case.cmd.clone(), case.names[0].clone(), why);
            groups.entry(key).or_insert((0, example.clone())).0 += 1;
            failures.push(example);
        }
    }
    eprintln!(
        "cli_fuzz: {n} invocations ({} single-flag cases, then pairs) in {:.0} s (seed {seed}), {} failures; per command {per_cmd:?}",
        all.len(),
        t0.elapsed().as_secs_f64(),
        failures.len()
    );
    for (n, example) in groups.values() {
        eprintln!("  ×{n} {example}");
    }
    assert!(
        failures.is_empty(),
        "{} failures, first: {}",
        failures.len(),
        failures[0]
    );
}
