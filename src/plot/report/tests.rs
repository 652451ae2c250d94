//! The report drawn from synthetic runs: its answer, curves, warnings and verdict words.
use crate::studies::experiment::results::RunRow;

/// `reps` rows of one configuration; round r scales every wall time by the same drift.
fn rows(kind: &str, chunk: &str, px: u64, wall: f64) -> Vec<RunRow> {
    (0..12u32)
        .map(|rep| {
            let mut r = RunRow::example();
            r.experiment = "synthetic".into();
            r.scene = "box".into();
            r.width = 64;
            r.height = 64;
            r.spp = 1;
            r.tracer = "bvh".into();
            r.config = format!("{kind}-{chunk}");
            r.scheduler = kind.into();
            r.label = if kind == "serial" {
                "serial".into()
            } else {
                format!("{kind} chunk={chunk}")
            };
            r.chunk = (kind != "serial").then(|| chunk.into());
            r.chunk_px = (kind != "serial").then_some(px);
            r.workers = if kind == "serial" { 1 } else { 4 };
            r.repetition = rep;
            let drift = 1.0 + 0.05 * ((rep * 7 % 5) as f64 - 2.0);
            r.wall_s = wall * drift;
            r.serial_s = 1.0;
            r.rays = 4096;
            r.items = 4096 / px.max(1);
            r
        })
        .collect()
}

/// Writes `rows` as runs.csv in a fresh folder and redraws it; returns report.md.
fn report_of(rows: &[RunRow]) -> (tempfile::TempDir, String) {
    let dir = tempfile::tempdir().expect("temp dir");
    let mut csv = RunRow::header().join(",").into_bytes();
    csv.push(b'\n');
    for r in rows {
        csv.extend(r.to_line());
    }
    std::fs::write(dir.path().join("runs.csv"), csv).expect("written");
    crate::plot::redraw(dir.path()).expect("redrawn");
    let md = std::fs::read_to_string(dir.path().join("report.md")).expect("report.md");
    (dir, md)
}

#[test]
fn report_answers_without_a_per_ray_master() {
    let mut all = rows("serial", "", 0, 1.0);
    // self_scheduling: a clear optimum at chunk 4; static: flat from 4 to 16, slower at 1.
    for (c, px, w) in [("1", 1, 0.9), ("4", 16, 0.30), ("16", 256, 0.6)] {
        all.extend(rows("self_scheduling", c, px, w));
    }
    for (c, px, w) in [("1", 1, 0.8), ("4", 16, 0.40), ("16", 256, 0.40)] {
        all.extend(rows("static", c, px, w));
    }
    let (dir, md) = report_of(&all);
    assert!(
        !md.contains("the per-ray master"),
        "no per-ray master ran:\n{md}"
    );
    assert!(
        md.contains("fastest `self_scheduling chunk=4` (chunk 4 (16 px))"),
        "{md}"
    );
    assert!(
        md.contains("- **self_scheduling**: optimum at chunk 4 (16 px)"),
        "{md}"
    );
    assert!(
        md.contains("- **static**: flat from chunk 4 (16 px) to chunk 16 (256 px)"),
        "{md}"
    );
    assert!(md.contains("2.0× slower at chunk 1 (1 px)"), "{md}");
    // The full table: every configuration with its median and interval.
    let table = &md[md.find("## Every configuration").expect("full table")..];
    for label in [
        "self_scheduling chunk=1",
        "static chunk=16",
        "static chunk=1",
    ] {
        assert!(
            table.contains(&format!("| `{label}` |")),
            "{label}: {table}"
        );
    }
    assert!(dir.path().join("report.html").exists());
}

#[test]
fn warnings_come_first_and_the_per_ray_master_is_compared_where_it_ran() {
    let mut all = rows("serial", "", 0, 1.0);
    // Every configuration slower than serial: a warning.
    all.extend(rows("master", "1", 1, 3.0));
    for r in all.iter_mut().filter(|r| r.scheduler == "master") {
        r.params = crate::sched::param_columns()
            .iter()
            .map(|p| (p.name == "buffer").then(|| "2".to_string()))
            .collect();
    }
    all.extend(rows("self_scheduling", "4", 16, 1.5));
    let (_dir, md) = report_of(&all);
    let warn = md.find("## Warnings").expect("a warning");
    let answer = md.find("## Answer").expect("an answer");
    assert!(warn < answer, "{md}");
    assert!(md.contains("the per-ray master"), "{md}");
}

#[test]
fn configurations_beside_the_best_read_equivalent_or_not_shown_slower_never_tied() {
    // Round r's wall time, nearly the same in every round (±0.4 %).
    let steady = |rows: &mut Vec<RunRow>, f: &dyn Fn(u32) -> f64| {
        for r in rows {
            r.wall_s = 0.5 * (1.0 + 0.002 * f64::from(r.repetition % 5)) * f(r.repetition);
        }
    };
    let mut all = rows("serial", "", 0, 1.0);
    let mut best = rows("self_scheduling", "4", 16, 0.5);
    steady(&mut best, &|_| 1.0);
    // Every run's wall time the best's: equivalent within the default ±5 %.
    let mut same = rows("static", "4", 16, 0.5);
    steady(&mut same, &|_| 1.0);
    // 10 % faster or 30 % slower round by round: its interval reaches 1, equivalence undecided.
    let mut wide = rows("static", "1", 1, 0.5);
    steady(&mut wide, &|r| if r % 2 == 0 { 0.9 } else { 1.3 });
    // Twice as slow in every round: shown slower, not listed.
    let mut slow = rows("self_scheduling", "16", 256, 1.0);
    steady(&mut slow, &|_| 2.0);
    for v in [best, same, wide, slow] {
        all.extend(v);
    }
    let (_dir, md) = report_of(&all);
    let line = md
        .lines()
        .find(|l| l.starts_with("**box"))
        .unwrap_or_else(|| panic!("no answer line:\n{md}"));
    let eq = line
        .find("equivalent within ±5.0 % (two one-sided tests at 95 %): `static chunk=4`")
        .unwrap_or_else(|| panic!("{line}"));
    let not = line
        .find("not shown slower (")
        .unwrap_or_else(|| panic!("{line}"));
    assert!(eq < not, "{line}");
    assert!(line[not..].contains("`static chunk=1`"), "{line}");
    assert!(
        !line[eq..not].contains("`static chunk=1`"),
        "never both: {line}"
    );
    assert!(!line.contains("`self_scheduling chunk=16`"), "{line}");
    assert!(line.contains("Beside it, 2 of 3"), "{line}");
    assert!(!md.to_lowercase().contains("tied"), "{md}");
}
