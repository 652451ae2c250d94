//! What the readings say: every number `report.md` and `report.html` state is a column of
//! `summary.csv`, the overhead bars add up to workers × wall, and a damaged runs.csv is a
//! one-line error. On a real (small) experiment of every thread-scheduler shape: a shared
//! pool (self_scheduling), owned slices (static), stealing (work_stealing), the master on its
//! own thread and the master whose passes the workers run. The last shape, a GPU lane beside
//! threads, runs in the deterministic simulation and is checked beside it
//! (`studies::simulate::hetero`'s tests: the same `RunStats` → runs.csv columns → `Lanes`).

use crate::support::assert_ok;
use raysched::experiment::results::read_runs;
use raysched::experiment::summary::summarize;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_raysched");

/// The experiment: every shape at 1 and 2 workers, 3 repetitions, a timeline each.
fn write_shapes(dir: &Path) -> PathBuf {
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/simple.toml");
    let text = format!(
        r#"name = "shapes"
repetitions = 3
ci_target = 0
min_sample_s = 0
warmup = 0
workers = [1, 2]
[[scenes]]
path = "{scene}"
width = 32
height = 16
spp = 2
[[schedulers]]
kind = "master"
chunk = ["1", "16"]
passes = ["thread", "workers"]
[[schedulers]]
kind = "static"
chunk = "rows:1"
[[schedulers]]
kind = "self_scheduling"
chunk = ["4", "frame"]
[[schedulers]]
kind = "work_stealing"
chunk = ["4", "frame"]
"#,
        scene = scene.display()
    );
    let p = dir.join("shapes.toml");
    std::fs::write(&p, text).unwrap();
    p
}

/// The experiment run into `res/` of a fresh folder.
fn run_shapes() -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let exp = write_shapes(dir.path());
    let out = Command::new(BIN)
        .args(["run", exp.to_str().unwrap(), "--quiet", "--out", "res"])
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert_ok(&out);
    let res = results_dir(&dir.path().join("res"));
    (dir, res)
}

/// The folder under `root` holding runs.csv (`run --out res` writes `res/<name>/`).
fn results_dir(root: &Path) -> PathBuf {
    if root.join("runs.csv").exists() {
        return root.to_path_buf();
    }
    std::fs::read_dir(root)
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .find(|p| p.join("runs.csv").exists())
        .unwrap_or_else(|| panic!("no runs.csv under {}", root.display()))
}

/// summary.csv as (label, workers) → column → text.
fn summary_table(dir: &Path) -> HashMap<(String, String), HashMap<String, String>> {
    let mut rdr = csv::Reader::from_path(dir.join("summary.csv")).unwrap();
    let head = rdr.headers().unwrap().clone();
    rdr.records()
        .map(|r| {
            let r = r.unwrap();
            let row: HashMap<String, String> = head
                .iter()
                .zip(r.iter())
                .map(|(h, v)| (h.to_string(), v.to_string()))
                .collect();
            ((row["label"].clone(), row["workers"].clone()), row)
        })
        .collect()
}

fn num(row: &HashMap<String, String>, col: &str) -> f64 {
    row[col]
        .parse()
        .unwrap_or_else(|_| panic!("{col} = '{}'", row[col]))
}

/// The cells of every row of the Markdown table under `heading` (to the next `## `).
fn table_rows<'a>(md: &'a str, heading: &str) -> Vec<Vec<&'a str>> {
    let start = md
        .find(heading)
        .unwrap_or_else(|| panic!("no {heading}:\n{md}"));
    let body = &md[start + heading.len()..];
    let end = body.find("\n## ").unwrap_or(body.len());
    body[..end]
        .lines()
        .filter(|l| l.starts_with("| ") && !l.starts_with("|---"))
        .map(|l| {
            l.trim_matches('|')
                .split('|')
                .map(str::trim)
                .collect::<Vec<_>>()
        })
        .filter(|c| c[0] != "scheduler" && c[0] != "configuration")
        .collect()
}

/// The speedup and efficiency cells a summary row must read as.
fn speedup_cells(row: &HashMap<String, String>) -> (String, String) {
    let (v, lo, hi) = (
        num(row, "speedup"),
        num(row, "speedup_ci_lo"),
        num(row, "speedup_ci_hi"),
    );
    let speed = if lo < hi {
        format!("{v:.2}× (95 % CI {lo:.2}–{hi:.2})")
    } else {
        format!("{v:.2}×")
    };
    (speed, format!("{:.0} %", num(row, "efficiency") * 100.0))
}

/// Every decimal number with exactly `places` decimals in `text`.
fn decimals(text: &str, places: usize) -> Vec<String> {
    let b = text.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        if b[i].is_ascii_digit() && (i == 0 || !(b[i - 1].is_ascii_digit() || b[i - 1] == b'.')) {
            let s = i;
            while i < b.len() && b[i].is_ascii_digit() {
                i += 1;
            }
            if i < b.len() && b[i] == b'.' {
                let d = i + 1;
                let mut e = d;
                while e < b.len() && b[e].is_ascii_digit() {
                    e += 1;
                }
                if e - d == places {
                    out.push(text[s..e].to_string());
                }
                i = e;
            }
        } else {
            i += 1;
        }
    }
    out
}

/// `text` with every span from `open` to `close` taken out.
fn without(text: &str, open: &str, close: &str) -> String {
    let mut out = String::new();
    let mut rest = text;
    while let Some(i) = rest.find(open) {
        out += &rest[..i];
        rest = rest[i..]
            .find(close)
            .map_or("", |j| &rest[i + j + close.len()..]);
    }
    out + rest
}

/// The page's text without its tags, SVGs and script (what a reader sees).
fn page_text(html: &str) -> String {
    let bare = without(&without(html, "<svg", "</svg>"), "<script>", "</script>");
    let mut text = String::new();
    let mut in_tag = false;
    for c in bare.chars() {
        match c {
            '<' => in_tag = true,
            '>' if in_tag => {
                in_tag = false;
                text.push(' ');
            }
            c if !in_tag => text.push(c),
            _ => {}
        }
    }
    text.replace("&amp;", "&")
        .replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&quot;", "\"")
}

/// The checks of [`every_number_the_report_states_is_the_tables`] on one report's text:
/// the two tables cell by cell against summary.csv, "best" the least median wall of its
/// scheduler, and every 4-decimal figure (the seconds) one of the table's medians or bounds.
fn check_report(md: &str, table: &HashMap<(String, String), HashMap<String, String>>) {
    let every = table_rows(md, "## Every configuration");
    assert!(every.len() >= 10, "{every:?}");
    for c in &every {
        let label = c[0].trim_matches('`');
        let row = table
            .get(&(label.to_string(), c[3].to_string()))
            .unwrap_or_else(|| panic!("`{label}` ×{} not in summary.csv", c[3]));
        assert_eq!(c[1], row["scheduler"]);
        assert_eq!(c[4], format!("{:.4}", num(row, "wall_median_s")), "{label}");
        let ci = format!(
            "{:.4} – {:.4}",
            num(row, "wall_median_ci_lo_s"),
            num(row, "wall_median_ci_hi_s")
        );
        assert_eq!(c[5], ci, "{label}");
        let (speed, eff) = speedup_cells(row);
        assert_eq!((c[6], c[7]), (speed.as_str(), eff.as_str()), "{label}");
        assert_eq!(c[8], row["n"], "{label}");
    }
    let best = table_rows(md, "## Best configuration per scheduler");
    assert!(best.len() >= 5, "{best:?}");
    for c in &best {
        let label = c[1].trim_matches('`');
        let row = &table[&(label.to_string(), c[2].to_string())];
        assert_eq!(c[3], format!("{:.4}", num(row, "wall_median_s")), "{label}");
        let (speed, eff) = speedup_cells(row);
        assert_eq!((c[5], c[6]), (speed.as_str(), eff.as_str()), "{label}");
        // The best of its scheduler is the least median wall time the table holds for it.
        let least = table
            .values()
            .filter(|r| r["scheduler"] == c[0])
            .map(|r| num(r, "wall_median_s"))
            .fold(f64::INFINITY, f64::min);
        assert_eq!(num(row, "wall_median_s"), least, "best {}: {label}", c[0]);
    }
    let seconds: Vec<String> = table
        .values()
        .flat_map(|r| {
            [
                "wall_median_s",
                "wall_median_ci_lo_s",
                "wall_median_ci_hi_s",
            ]
            .map(|k| format!("{:.4}", num(r, k)))
        })
        .collect();
    for d in decimals(md, 4) {
        assert!(
            seconds.contains(&d),
            "{d} is stated but is no median or bound of summary.csv"
        );
    }
}

#[test]
fn every_number_the_report_states_is_the_tables() {
    let (_dir, res) = run_shapes();
    let table = summary_table(&res);
    let md = std::fs::read_to_string(res.join("report.md")).unwrap();
    check_report(&md, &table);
    let html = std::fs::read_to_string(res.join("report.html")).unwrap();
    let text = page_text(&html);
    // The page holds every section of the Markdown, and its tables say the same.
    for h in md.lines().filter(|l| l.starts_with("## ")) {
        let h = h.trim_start_matches("## ");
        assert!(
            html.contains(&format!("<h2>{h}</h2>")),
            "report.html lacks {h}"
        );
    }
    let as_md = text
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .collect::<Vec<_>>()
        .join("\n");
    for d in decimals(&as_md, 4) {
        assert!(
            md.contains(&d),
            "report.html states {d}, report.md does not"
        );
    }
    assert_eq!(decimals(&as_md, 4).len(), decimals(&md, 4).len());
    // The check fails on a report that states another figure.
    let (k, row) = table.iter().next().unwrap();
    let wall = format!("{:.4}", num(row, "wall_median_s"));
    let forged = md.replacen(
        &format!("| {} | {wall} |", k.1),
        &format!("| {} | 9.8765 |", k.1),
        1,
    );
    assert_ne!(forged, md, "the row of {k:?} is in the report");
    let caught = std::panic::catch_unwind(|| check_report(&forged, &table));
    assert!(caught.is_err(), "a forged median went unnoticed");
}

#[test]
fn the_overhead_breakdown_adds_up_to_workers_times_wall_for_every_shape() {
    let (_dir, res) = run_shapes();
    let (rows, _) = read_runs(&res.join("runs.csv")).unwrap();
    let sums = summarize(&rows);
    let mut shapes: Vec<String> = Vec::new();
    for s in sums.iter().filter(|s| !s.row.is_serial()) {
        let lanes = s.row.workers as f64 * s.wall_median;
        let parts = s.lanes.parts();
        assert!(
            parts.iter().all(|p| *p >= 0.0),
            "{}: {parts:?}",
            s.row.label
        );
        assert!(
            (s.lanes.total() - lanes).abs() <= 0.01 * lanes,
            "{} ×{}: Σ parts {} against workers × wall {lanes}",
            s.row.label,
            s.row.workers,
            s.lanes.total()
        );
        let shape = format!(
            "{} {}",
            s.row.scheduler,
            s.row.param("passes").unwrap_or_default()
        );
        if !shapes.contains(&shape) {
            shapes.push(shape);
        }
    }
    assert_eq!(shapes.len(), 5, "{shapes:?}");
    // The runs themselves: the workers' busy and idle time never exceed their lanes (a
    // sample of one render, `inner` = 1 by `min_sample_s = 0`), and a master's dispatch is
    // recorded only where a master ran.
    for r in &rows {
        assert_eq!(r.inner, 1);
        let lanes = r.workers as f64 * r.wall_s;
        assert!(
            r.work_s + r.idle_s <= 1.01 * lanes,
            "{} ×{}: busy {} + idle {} > workers × wall {lanes}",
            r.label,
            r.workers,
            r.work_s,
            r.idle_s
        );
        if r.scheduler != "master" {
            assert_eq!(r.dispatch_s, 0.0, "{}", r.label);
        }
    }
    // The chart is drawn from those parts, with the serial median as its reference.
    let svg = std::fs::read_to_string(res.join("plots/overhead_simple_32_16_2_spp_bvh.svg"))
        .expect("the overhead chart");
    assert!(svg.contains("serial median wall time"), "no reference line");
}

#[test]
fn a_negative_wall_time_is_a_one_line_error_naming_file_line_and_column() {
    let (dir, _) = crate::experiment::run_tiny(1);
    let res = results_dir(&dir.path().join("res"));
    let runs = res.join("runs.csv");
    let text = std::fs::read_to_string(&runs).unwrap();
    let head: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    let wall = head.iter().position(|c| *c == "wall_s").unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let mut cells: Vec<String> = lines[3].split(',').map(String::from).collect();
    cells[wall] = "-0.25".into();
    lines[3] = cells.join(",");
    std::fs::write(&runs, lines.join("\n") + "\n").unwrap();
    let before = std::fs::read(res.join("report.md")).unwrap();
    let out = Command::new(BIN).arg("plot").arg(&res).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(
        err.contains("runs.csv") && err.contains("line 4") && err.contains("wall_s"),
        "{err}"
    );
    assert!(!err.contains("internal error"), "{err}");
    assert_eq!(std::fs::read(res.join("report.md")).unwrap(), before);
}
