//! The command line at its edges, one test per class of rough edge a new user met: output paths
//! checked before any work, a `.png` output, flag values that say what the flag takes, the
//! nearest name for a misspelt one, chunks larger than the image, and one vocabulary across
//! commands. `RAYSCHED_BIN` runs them against another build (how they were seen to fail on the
//! code before the fixes).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const SCENE: &str = crate::support::sphere_scene_8x8!();

/// The binary under test: `RAYSCHED_BIN`, else this build's.
pub(crate) fn bin() -> PathBuf {
    std::env::var_os("RAYSCHED_BIN").map_or_else(
        || PathBuf::from(env!("CARGO_BIN_EXE_raysched")),
        PathBuf::from,
    )
}

fn raysched(args: &[&str], cwd: &Path) -> Output {
    Command::new(bin())
        .args(args)
        .current_dir(cwd)
        .output()
        .unwrap()
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Exit code 2, one line on stderr containing every needle, no panic.
#[track_caller]
fn assert_bad_input(what: &str, out: &Output, needles: &[&str]) {
    let err = stderr(out);
    assert_eq!(out.status.code(), Some(2), "{what}: {err}");
    assert_eq!(
        err.trim_end().lines().count(),
        1,
        "{what}: not one line: {err}"
    );
    assert!(!err.contains("panicked"), "{what}: {err}");
    for n in needles {
        assert!(err.contains(n), "{what}: '{n}' not in: {err}");
    }
}

/// A folder with the 8×8 scene `s.toml` and a one-configuration experiment `e.toml`.
fn setup() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("s.toml"), SCENE).unwrap();
    std::fs::write(
        dir.path().join("e.toml"),
        "repetitions = 1\nwarmup = 0\nworkers = [1]\n[[scenes]]\npath = \"s.toml\"\n\
         [[schedulers]]\nkind = \"static\"\nchunk = 8\n",
    )
    .unwrap();
    std::fs::write(dir.path().join("afile"), "").unwrap();
    dir
}

#[test]
fn output_paths_are_checked_before_any_work() {
    let dir = setup();
    let d = dir.path();
    std::fs::create_dir(d.join("adir.exr")).unwrap();
    std::fs::create_dir(d.join("adir.png")).unwrap();
    let file_out = [
        "/proc/m7.exr",
        "afile/x.exr",
        "adir.exr",
        "/proc/self/x.exr",
    ];
    let folder_out = ["/proc/nope", "afile/sub", "/dev/full", "afile"];
    let mut cases: Vec<(Vec<String>, &str)> = Vec::new();
    let v = |a: &[&str]| a.iter().map(|s| s.to_string()).collect::<Vec<_>>();
    for exr in file_out {
        cases.push((
            v(&["render", "s.toml", "--threads", "1", "-o", exr]),
            "--output",
        ));
        let png = exr.replace(".exr", ".png");
        cases.push((v(&["profile", "s.toml", "-o", &png]), "--output"));
    }
    for p in folder_out {
        cases.push((v(&["run", "e.toml", "--quiet", "--out", p]), "--out"));
        cases.push((
            v(&[
                "converge",
                "s.toml",
                "--max-spp",
                "1",
                "--ref-spp",
                "1",
                "--threads",
                "1",
                "-o",
                p,
            ]),
            "--output",
        ));
        cases.push((
            v(&["stability", "--quick", "--threads", "1", "-o", p]),
            "--output",
        ));
    }
    for (args, flag) in &cases {
        let a: Vec<&str> = args.iter().map(String::as_str).collect();
        let out = raysched(&a, d);
        assert_bad_input(&format!("{a:?}"), &out, &[flag]);
        assert!(
            out.stdout.is_empty(),
            "{a:?}: worked first: {}",
            String::from_utf8_lossy(&out.stdout)
        );
    }
    assert!(!d.join("afile").is_dir());
    // A good path still works, its folders created.
    let out = raysched(
        &["render", "s.toml", "--threads", "1", "-o", "new/dir/o.exr"],
        d,
    );
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    assert!(d.join("new/dir/o.exr").is_file() && d.join("new/dir/o.png").is_file());
    let left: Vec<_> = std::fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(".raysched"))
        .collect();
    assert!(left.is_empty(), "left behind: {left:?}");
}

#[test]
fn a_png_output_is_written_with_its_exr_beside_it() {
    let dir = setup();
    let out = raysched(
        &["render", "s.toml", "--threads", "1", "-o", "c.png"],
        dir.path(),
    );
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let png = dir.path().join("c.png");
    assert!(png.is_file() && dir.path().join("c.exr").is_file());
    assert_eq!(&std::fs::read(&png).unwrap()[1..4], b"PNG");
    let help = raysched(&["render", "--help"], dir.path());
    let help = String::from_utf8_lossy(&help.stdout);
    assert!(
        help.contains(".png, with the linear .exr beside it"),
        "{help}"
    );
}

#[test]
fn flag_values_say_what_the_flag_takes() {
    let dir = setup();
    let d = dir.path();
    let cases: &[(&[&str], &[&str])] = &[
        (
            &["render", "s.toml", "--spp", "-4"],
            &["'--spp", "whole number from 1"],
        ),
        (
            &["render", "s.toml", "--spp", "-inf"],
            &["--spp", "--spp=-inf"],
        ),
        (
            &["render", "s.toml", "--threads", "x"],
            &["'--threads", "whole number"],
        ),
        (
            &["render", "s.toml", "--deadline-ms", "0"],
            &["--deadline-ms", "whole number from 1"],
        ),
        (
            &["profile", "s.toml", "--repeats", "-1"],
            &["--repeats", "whole number"],
        ),
        (
            &["run", "e.toml", "--max-runs", "-3"],
            &["--max-runs", "whole number"],
        ),
        (
            &["run", "e.toml", "--budget-s", "soon"],
            &["--budget-s", "a number"],
        ),
        (&["advise", "s.toml", "--sources", "gpu,x"], &["--sources"]),
        (&["render", "s.toml", "--spp", "1\n2"], &["--spp", "1\\n2"]),
        (&["render"], &["<SCENE>"]),
        (&["advise", "s.toml", "--buffer", ""], &["--buffer"]),
    ];
    for (args, needles) in cases {
        let out = raysched(args, d);
        assert_bad_input(&format!("{args:?}"), &out, needles);
    }
    assert!(!d.join("results").exists(), "a bad flag wrote output");
}

#[test]
fn misspelt_names_get_the_nearest_name() {
    let dir = setup();
    let d = dir.path();
    std::fs::write(d.join("typo.toml"), SCENE.replace("spp = 1", "sppp = 1")).unwrap();
    let cases: &[(&[&str], &str)] = &[
        (
            &["render", "s.toml", "--scheduler", "self_schedulng"],
            "did you mean self_scheduling?",
        ),
        (
            &["render", "s.toml", "--order", "hilbrt"],
            "did you mean hilbert?",
        ),
        (
            &["render", "s.toml", "--tracer", "bhv"],
            "did you mean bvh?",
        ),
        (
            &["render", "s.toml", "--thread", "2"],
            "did you mean --threads?",
        ),
        (&["rendr", "s.toml"], "did you mean render?"),
        (
            &["render", "s.toml", "--sources", "thread"],
            "did you mean threads?",
        ),
        (
            &["advise", "s.toml", "--scheduler", "gided"],
            "did you mean guided?",
        ),
        (
            &["converge", "s.toml", "--tracers", "bvh,brut"],
            "did you mean brute?",
        ),
        (&["render", "typo.toml"], "did you mean `spp`?"),
    ];
    for (args, needle) in cases {
        let out = raysched(args, d);
        assert_bad_input(&format!("{args:?}"), &out, &[needle]);
    }
    // An experiment key, too.
    std::fs::write(d.join("k.toml"), "repetitons = 1\n").unwrap();
    let out = raysched(&["run", "k.toml"], d);
    assert_bad_input("experiment key", &out, &["did you mean `repetitions`?"]);
}

#[test]
fn chunks_larger_than_the_image_warn_and_dry_runs_estimate_them_serial() {
    let dir = setup();
    let d = dir.path();
    let cornell = crate::support::scene_path("cornell_box.toml");
    let out = raysched(
        &[
            "render",
            cornell.to_str().unwrap(),
            "--chunk",
            "512",
            "--spp",
            "1",
            "--threads",
            "2",
            "-o",
            "c.exr",
        ],
        d,
    );
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(0), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.starts_with("warning: --chunk 512") && err.contains("1 item"),
        "{err}"
    );
    // A chunk that gives every thread an item says nothing.
    let out = raysched(
        &[
            "render",
            "s.toml",
            "--chunk",
            "2",
            "--threads",
            "2",
            "-o",
            "c.exr",
        ],
        d,
    );
    assert!(
        out.status.success() && out.stderr.is_empty(),
        "{}",
        stderr(&out)
    );

    // The dry run: chunk 512 is one item, estimated as the serial render; chunk 1 as parallel.
    std::fs::write(
        d.join("big.toml"),
        format!(
            "repetitions = 1\nwarmup = 0\nworkers = [2]\n[[scenes]]\npath = {:?}\n\
             [[schedulers]]\nkind = \"self_scheduling\"\nchunk = [1, 512]\n",
            cornell.to_str().unwrap()
        ),
    )
    .unwrap();
    let out = raysched(&["run", "big.toml", "--dry-run"], d);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{}", stderr(&out));
    let est = |needle: &str| -> f64 {
        let line = text
            .lines()
            .find(|l| l.contains(needle))
            .unwrap_or_else(|| panic!("no '{needle}' in {text}"));
        let ms = line.split_whitespace().nth(1).unwrap();
        ms.trim_end_matches("ms").parse().unwrap()
    };
    let serial = est("· serial");
    let one_item = est("chunk=512");
    assert!(
        serial > 0.0 && (one_item - serial).abs() <= 0.01 * serial,
        "chunk 512 estimated {one_item} ms, serial {serial} ms: {text}"
    );
    if raysched::util::host::available_threads() >= 2 {
        let per_pixel = est("chunk=1 ");
        assert!(per_pixel < 0.75 * serial, "{text}");
    }
}

#[test]
fn one_vocabulary_across_commands() {
    let dir = setup();
    let d = dir.path();
    // render's overrides, validated like the scene's fields but naming the flag.
    let out = raysched(
        &[
            "render",
            "s.toml",
            "--width",
            "4",
            "--height",
            "6",
            "--max-depth",
            "2",
            "--threads",
            "1",
            "-o",
            "o.exr",
        ],
        d,
    );
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(text.contains("(4×6, 1 spp, max_depth 2)"), "{text}");
    // "wall" once.
    assert_eq!(text.matches("wall").count(), 1, "{text}");
    for (flag, value) in [
        ("--width", "0"),
        ("--height", "70000"),
        ("--max-depth", "0"),
        ("--max-depth", "-2"),
    ] {
        let out = raysched(&["render", "s.toml", flag, value, "-o", "o2.exr"], d);
        assert_bad_input(&format!("{flag} {value}"), &out, &[flag]);
    }
    let out = raysched(
        &[
            "render", "s.toml", "--width", "60000", "--height", "60000", "-o", "o2.exr",
        ],
        d,
    );
    assert_bad_input("width × height", &out, &["--width"]);
    assert!(!d.join("o2.exr").exists());
    // profile's count is --repeats; --passes (who runs the master's passes elsewhere) says so.
    let out = raysched(&["profile", "s.toml", "--repeats", "1", "-o", "h.png"], d);
    assert!(out.status.success(), "{}", stderr(&out));
    let out = raysched(&["profile", "s.toml", "--passes", "1", "-o", "h.png"], d);
    assert_bad_input("profile --passes", &out, &["--passes", "--repeats"]);
    // threads is the one word for local threads; local is refused with the hint.
    for cmd in ["render", "advise"] {
        let out = raysched(&[cmd, "s.toml", "--sources", "local"], d);
        assert_bad_input(
            &format!("{cmd} --sources local"),
            &out,
            &["--sources", "did you mean threads?"],
        );
    }
    let out = raysched(
        &[
            "advise",
            "s.toml",
            "--sources",
            "threads",
            "--workers",
            "1",
            "--scheduler",
            "static",
            "--chunks",
            "4",
        ],
        d,
    );
    assert!(out.status.success(), "{}", stderr(&out));
}

#[test]
fn output_checks_leave_nothing_when_the_input_is_bad() {
    // The write check of an output folder creates and removes a file: with a bad scene
    // nothing is left, not even the folder.
    let dir = setup();
    let out = raysched(&["render", "missing.toml", "-o", "out/o.exr"], dir.path());
    assert_bad_input("missing scene", &out, &["missing.toml"]);
    assert!(!dir.path().join("out").exists());
    let names: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names.len(), 3, "{names:?}");
}

/// A newcomer's frictions (issue 58, item 7): a misspelt experiment file names the one meant;
/// `plot` on the folder above an experiment's names the experiment's folder; more threads
/// than cores warn once; `render --help` gives `--scheduler` one default and its per-source
/// flags' help no runs of blanks.
#[test]
fn newcomer_frictions_get_a_pointer_not_a_bare_error() {
    let dir = setup();
    let out = raysched(&["run", "e2.toml", "--quiet", "--out", "res"], dir.path());
    assert_bad_input(
        "a misspelt experiment",
        &out,
        &["e2.toml", "did you mean e.toml?"],
    );
    std::fs::create_dir_all(dir.path().join("sub")).unwrap();
    let out = raysched(&["run", "sub/quik.toml"], dir.path());
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(
        !stderr(&out).contains("did you mean"),
        "nothing near: {}",
        stderr(&out)
    );

    let out = raysched(&["run", "e.toml", "--quiet", "--out", "res/a"], dir.path());
    assert!(out.status.success(), "{}", stderr(&out));
    let out = raysched(&["plot", "res/a"], dir.path());
    assert_bad_input(
        "plot one level up",
        &out,
        &["res/a", "res/a/e", "raysched plot"],
    );

    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let many = (cores + 1).to_string();
    let out = raysched(
        &["render", "s.toml", "-o", "o.exr", "--threads", &many],
        dir.path(),
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let err = stderr(&out);
    assert_eq!(
        err.lines().filter(|l| l.contains("cores")).count(),
        1,
        "{err}"
    );
    assert!(
        err.contains(&format!("{many} threads on {cores} cores")),
        "{err}"
    );
    let out = raysched(
        &["render", "s.toml", "-o", "o.exr", "--threads", "1"],
        dir.path(),
    );
    assert!(!stderr(&out).contains("cores"), "{}", stderr(&out));

    let help =
        String::from_utf8_lossy(&raysched(&["render", "--help"], dir.path()).stdout).into_owned();
    // A flag's entry: its line and the help lines under it, up to the next flag.
    let entry = |flag: &str| -> Vec<String> {
        let lines: Vec<&str> = help.lines().collect();
        let at = lines
            .iter()
            .position(|l| l.trim_start().starts_with(flag))
            .unwrap_or_else(|| panic!("{flag} in render --help: {help}"));
        std::iter::once(lines[at])
            .chain(
                lines[at + 1..]
                    .iter()
                    .copied()
                    .take_while(|l| !l.trim_start().starts_with('-')),
            )
            .map(str::to_owned)
            .collect()
    };
    let sched = entry("--scheduler").join("\n");
    assert_eq!(sched.matches("[default:").count(), 1, "{sched}");
    for flag in ["--gpu-chunk", "--gpu-buffer", "--balance"] {
        // clap wraps long help over indented lines; within a line, words are one blank apart.
        for (i, line) in entry(flag).iter().enumerate() {
            let line = line.trim();
            // The flag's own line may set its help two blanks after the flag.
            let text = match (i, line.split_once("  ")) {
                (0, Some((_, help))) => help.trim_start(),
                _ => line,
            };
            assert!(!text.contains("  "), "{flag}: stray blanks in {line:?}");
        }
    }
}
