//! The cost model end to end: `raysched advise` on a tiny scene, and an experiment with
//! `predict = true` recording each configuration's prediction and reporting it. No timing is
//! asserted: only that every candidate is predicted, the parts add up, and a best is named.

use crate::support::assert_ok;
use raysched::experiment::results::read_runs;
use std::path::Path;
use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_raysched");

fn simple() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/simple.toml")
}

/// A 16×16 copy of the simple scene (advise takes the scene's own size).
fn tiny_scene(dir: &Path) -> std::path::PathBuf {
    let text = std::fs::read_to_string(simple()).unwrap();
    let text = text
        .lines()
        .map(|l| {
            let t = l.trim_start();
            if t.starts_with("width") {
                "width = 16".to_string()
            } else if t.starts_with("height") {
                "height = 16".to_string()
            } else {
                l.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join("\n");
    let p = dir.join("tiny.toml");
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn advise_predicts_every_candidate_and_names_a_best() {
    let dir = tempfile::tempdir().unwrap();
    let scene = tiny_scene(dir.path());
    let out = Command::new(BIN)
        .arg("advise")
        .arg(&scene)
        .args(["--workers", "2", "--spp", "2", "--chunks", "1,4,frame"])
        .args([
            "--scheduler",
            "static,self_scheduling,factoring,master,pbrt",
        ])
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_ok(&out);
    // 4 schedulers × 3 chunks + pbrt once (it picks its own tile).
    let rows: Vec<&str> = stdout
        .lines()
        .filter(|l| l.contains(" ms ") && !l.starts_with("  ") && !l.starts_with("best"))
        .collect();
    assert_eq!(rows.len(), 13, "{stdout}");
    for r in &rows {
        // predicted = work + hand-out + refill + imbalance (printed to 1 µs).
        let f: Vec<f64> = r
            .split_whitespace()
            .filter_map(|t| t.parse::<f64>().ok())
            .collect();
        let (items, wall, parts) = (f[f.len() - 6], f[f.len() - 5], &f[f.len() - 4..]);
        assert!(items >= 1.0 && wall > 0.0, "{r}");
        assert!((parts.iter().sum::<f64>() - wall).abs() < 0.01, "{r}");
    }
    assert!(
        rows.iter()
            .any(|r| r.starts_with("pbrt") && r.contains("auto:")),
        "{stdout}"
    );
    let frame = rows
        .iter()
        .find(|r| r.starts_with("static") && r.contains("frame"));
    assert!(frame.is_some_and(|r| r.contains(" 1 ")), "{stdout}");
    assert!(stdout.lines().any(|l| l.starts_with("best: ")), "{stdout}");
    assert!(
        stdout
            .lines()
            .any(|l| l.starts_with("flat: ") || l.starts_with("a clear optimum")),
        "{stdout}"
    );
    assert!(stdout.contains("refill period r"), "{stdout}");
}

#[test]
fn predict_true_records_predictions_and_the_report_compares_them() {
    let dir = tempfile::tempdir().unwrap();
    let exp = dir.path().join("pred.toml");
    std::fs::write(
        &exp,
        format!(
            r#"name = "pred"
repetitions = 1
ci_target = 0
min_sample_s = 0
workers = [2]
timeline = false
predict = true
[[scenes]]
path = "{}"
width = 16
height = 16
spp = 1
[[schedulers]]
kind = "master"
chunk = ["1", "4"]
[[schedulers]]
kind = "self_scheduling"
chunk = ["1", "4"]
"#,
            simple().display()
        ),
    )
    .unwrap();
    let out = Command::new(BIN)
        .args(["run", exp.to_str().unwrap(), "--quiet", "--out", "res"])
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert_ok(&out);
    let res = dir.path().join("res/pred");
    let (rows, _) = read_runs(&res.join("runs.csv")).unwrap();
    assert_eq!(rows.len(), 5);
    for r in &rows {
        let want = r.scheduler != "serial";
        assert_eq!(r.predicted_wall_s.is_some(), want, "{}", r.label);
        if let (Some(w), Some(h), Some(i)) = (
            r.predicted_wall_s,
            r.predicted_handout_s,
            r.predicted_imbalance_s,
        ) {
            assert!(w > 0.0 && h >= 0.0 && w >= h + i - 1e-12, "{}", r.label);
        }
    }
    let report = std::fs::read_to_string(res.join("report.md")).unwrap();
    assert!(
        report.contains("## Cost model: predicted against measured"),
        "{report}"
    );
    assert!(report.contains("The model's pick"), "{report}");
    assert!(
        report.contains("The cost model predicts the per-ray master"),
        "{report}"
    );
    assert!(res.join("plots").read_dir().unwrap().any(|f| f
        .unwrap()
        .file_name()
        .to_string_lossy()
        .starts_with("predicted_")));
}
