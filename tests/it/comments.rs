//! A lint on the comments of `src/`: a comment keeps the why in a few lines and cites the
//! measurement behind a decision by its ledger id (`docs/measurements.md`, `M-012`); it holds
//! no dates, and no block of more than [`LONG_BLOCK`] lines carries measured figures.
//!
//! Files listed in `.ci/comment-lint-allow` are reported but tolerated; the list is to be
//! emptied, and an entry whose files are clean fails the test so that it is removed.

use std::path::{Path, PathBuf};

/// A comment block longer than this may carry no measured figure.
const LONG_BLOCK: usize = 6;

/// Words that say a figure was measured rather than chosen or derived.
const MEASURING: [&str; 16] = [
    "took",
    "measured",
    "Measured",
    "alternated",
    "pairs",
    "perf",
    "callgrind",
    "VM",
    "guest",
    "Xeon",
    "EPYC",
    "H200",
    "median",
    "runs of",
    "rounds",
    "ran ",
];

/// Does `s` hold a date (`2026-12-05`) or a UTC time (`21:36 UTC`)?
fn has_date(s: &str) -> bool {
    let b = s.as_bytes();
    let digit = |i: usize| b.get(i).is_some_and(u8::is_ascii_digit);
    let word_edge = |i: Option<usize>| match i {
        None => true,
        Some(i) => b.get(i).is_none_or(|c| !c.is_ascii_alphanumeric()),
    };
    for i in 0..b.len() {
        // YYYY-MM-DD with a 20xx year.
        if b[i] == b'2'
            && b.get(i + 1) == Some(&b'0')
            && digit(i + 2)
            && digit(i + 3)
            && b.get(i + 4) == Some(&b'-')
            && digit(i + 5)
            && digit(i + 6)
            && b.get(i + 7) == Some(&b'-')
            && digit(i + 8)
            && digit(i + 9)
            && word_edge(i.checked_sub(1))
            && word_edge(Some(i + 10))
        {
            return true;
        }
        // H:MM or HH:MM, optional :SS, then " UTC".
        if b[i] == b':' && i >= 1 && digit(i - 1) && digit(i + 1) && digit(i + 2) {
            let mut j = i + 3;
            if b.get(j) == Some(&b':') && digit(j + 1) && digit(j + 2) {
                j += 3;
            }
            if s[j..].trim_start().starts_with("UTC") {
                return true;
            }
        }
    }
    false
}

/// Does `s` hold a measured-looking figure: a time (`18 ns`, `2.5 µs`, `0.42 s`), a
/// percentage with decimals or a range (`4.6 %`, `8–17 %`), a ratio with decimals (`1.05×`)
/// or a ray rate?
fn has_figure(s: &str) -> bool {
    if s.contains("Mrays/s") {
        return true;
    }
    let chars: Vec<char> = s.chars().collect();
    let mut i = 0;
    while i < chars.len() {
        if !chars[i].is_ascii_digit() || (i > 0 && chars[i - 1].is_alphanumeric()) {
            i += 1;
            continue;
        }
        let mut j = i;
        while j < chars.len() && chars[j].is_ascii_digit() {
            j += 1;
        }
        let mut decimal = false;
        if j + 1 < chars.len() && chars[j] == '.' && chars[j + 1].is_ascii_digit() {
            decimal = true;
            j += 1;
            while j < chars.len() && chars[j].is_ascii_digit() {
                j += 1;
            }
        }
        // A range: 8–17 or 0.61-0.65; the unit then follows the second number.
        let mut ranged = false;
        if j + 1 < chars.len()
            && (chars[j] == '–' || chars[j] == '-')
            && chars[j + 1].is_ascii_digit()
        {
            ranged = true;
            j += 1;
            while j < chars.len() && (chars[j].is_ascii_digit() || chars[j] == '.') {
                j += 1;
            }
        }
        let mut k = j;
        if k < chars.len() && chars[k] == ' ' {
            k += 1;
        }
        let rest: String = chars[k..].iter().take(3).collect();
        let edge = |n: usize| chars.get(k + n).is_none_or(|c| !c.is_alphanumeric());
        let unit = (rest.starts_with("ns") && edge(2))
            || (rest.starts_with("µs") && edge(2))
            || (rest.starts_with("us") && edge(2))
            || (rest.starts_with("ms") && edge(2))
            || ((decimal || ranged) && rest.starts_with('s') && edge(1))
            || ((decimal || ranged) && rest.starts_with('%'))
            || ((decimal || ranged) && rest.starts_with('×'));
        if unit {
            return true;
        }
        i = j.max(i + 1);
    }
    false
}

#[test]
fn the_lint_tells_figures_and_dates() {
    assert!(has_date("(2-core AMD EPYC guest, 2026-12-05)."));
    assert!(has_date("VM, 2026-12-04 21:36 UTC, three runs"));
    assert!(has_date("at 9:05 UTC"));
    assert!(!has_date("/// UTC, when runs.csv was started."));
    assert!(!has_date("`YYYY-MM-DDTHH:MM:SSZ`"));
    assert!(!has_date("x = 12026-12-051"));
    assert!(has_figure("took 2.16–2.22 ms against"));
    assert!(has_figure("8–17 % slower"));
    assert!(has_figure("1.009× its time"));
    assert!(has_figure("~18 ns per read"));
    assert!(has_figure("3.33 / 5.59 Mrays/s"));
    assert!(!has_figure(
        "2×2 tiles, 16² tiles, a 1 % bias, 8 spp, M-012"
    ));
    assert!(!has_figure("vec3 and f32x8 lanes, 64 KiB"));
}

/// One violation: where, and what.
struct Finding {
    file: PathBuf,
    line: usize,
    what: String,
}

/// Every comment block of a Rust file (lines starting `//`, `///` or `//!`), as (first line
/// number, lines).
fn comment_blocks(text: &str) -> Vec<(usize, Vec<&str>)> {
    let mut blocks = Vec::new();
    let mut cur: Vec<&str> = Vec::new();
    let mut start = 0;
    for (n, line) in text.lines().enumerate() {
        let t = line.trim_start();
        if t.starts_with("//") {
            if cur.is_empty() {
                start = n + 1;
            }
            cur.push(t);
        } else if !cur.is_empty() {
            blocks.push((start, std::mem::take(&mut cur)));
        }
    }
    if !cur.is_empty() {
        blocks.push((start, cur));
    }
    blocks
}

fn lint_file(path: &Path, out: &mut Vec<Finding>) {
    let text = std::fs::read_to_string(path).unwrap();
    for (start, lines) in comment_blocks(&text) {
        for (k, l) in lines.iter().enumerate() {
            if has_date(l) {
                out.push(Finding {
                    file: path.to_path_buf(),
                    line: start + k,
                    what: "a date or UTC time in a comment".into(),
                });
            }
        }
        if lines.len() > LONG_BLOCK {
            let measuring = lines
                .iter()
                .any(|l| MEASURING.iter().any(|w| l.contains(w)));
            let figures: Vec<usize> = lines
                .iter()
                .enumerate()
                .filter(|(_, l)| has_figure(l))
                .map(|(k, _)| start + k)
                .collect();
            if measuring && !figures.is_empty() {
                out.push(Finding {
                    file: path.to_path_buf(),
                    line: figures[0],
                    what: format!(
                        "a {}-line comment block (from line {start}) carries measured figures \
                         on {} line(s): move them to docs/measurements.md and cite the id",
                        lines.len(),
                        figures.len()
                    ),
                });
            }
        }
    }
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let p = e.path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|e| e == "rs") {
            out.push(p);
        }
    }
}

#[test]
fn comments_carry_no_dates_and_no_long_measurement_histories() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let allow_text = std::fs::read_to_string(root.join(".ci/comment-lint-allow")).unwrap();
    let allowed: Vec<&str> = allow_text
        .lines()
        .map(|l| l.split('#').next().unwrap().trim())
        .filter(|l| !l.is_empty())
        .collect();
    let mut files = Vec::new();
    rust_files(&root.join("src"), &mut files);
    files.sort();
    let mut findings = Vec::new();
    for f in &files {
        lint_file(f, &mut findings);
    }
    let rel = |p: &Path| p.strip_prefix(root).unwrap().display().to_string();
    let is_allowed = |f: &Finding| allowed.iter().any(|a| rel(&f.file).starts_with(a));
    let (tolerated, failing): (Vec<_>, Vec<_>) = findings.iter().partition(|f| is_allowed(f));
    for f in &tolerated {
        eprintln!(
            "comment lint (tolerated by .ci/comment-lint-allow): {}:{}: {}",
            rel(&f.file),
            f.line,
            f.what
        );
    }
    let show = |v: &[&Finding]| {
        v.iter()
            .map(|f| format!("{}:{}: {}", rel(&f.file), f.line, f.what))
            .collect::<Vec<_>>()
            .join("\n")
    };
    assert!(failing.is_empty(), "comment lint:\n{}", show(&failing));
    let stale: Vec<&&str> = allowed
        .iter()
        .filter(|a| !findings.iter().any(|f| rel(&f.file).starts_with(**a)))
        .collect();
    assert!(
        stale.is_empty(),
        "clean now, remove from .ci/comment-lint-allow: {stale:?}"
    );
}
