//! `runs.json` and `summary.json`: the CSVs in a form other tools read without guessing column
//! types. The schema is in docs/results-schema.md; `schema` names its version.

use super::results::RunRow;
use super::summary::Summary;
use crate::sched::param_columns;
use crate::util::fs::{write_atomic, WriteError};
use serde_json::{json, Map, Value};
use std::path::{Path, PathBuf};

/// The schema id of runs.json.
pub const RUNS_SCHEMA: &str = "raysched.runs/1";
/// The schema id of summary.json.
pub const SUMMARY_SCHEMA: &str = "raysched.summary/1";

/// A row as a JSON object: every runs.csv column, the scheduler parameters under `params`.
pub fn row_json(r: &RunRow) -> Value {
    let mut v = serde_json::to_value(r).expect("a RunRow serialises");
    let params: Map<String, Value> = param_columns()
        .iter()
        .zip(&r.params)
        .filter_map(|(p, v)| v.as_ref().map(|v| (p.name.to_string(), json!(v))))
        .collect();
    if let Value::Object(m) = &mut v {
        m.insert("params".into(), Value::Object(params));
        // The per-source settings and shares, by column name (empty cells left out).
        let sourcing: Map<String, Value> = super::results::sourcing_columns()
            .zip(&r.sourcing)
            .filter_map(|(n, v)| v.as_ref().map(|v| (n.to_string(), json!(v))))
            .collect();
        m.insert("sourcing".into(), Value::Object(sourcing));
    }
    v
}

/// A summary as a JSON object (its configuration's columns under `config`).
pub fn summary_json(s: &Summary) -> Value {
    let r = &s.row;
    let num = |x: f64| if x.is_finite() { json!(x) } else { Value::Null };
    json!({
        "config": r.config,
        "label": r.label,
        "group": s.group(),
        "scene": r.scene,
        "tracer": r.tracer,
        "scheduler": r.scheduler,
        "chunk": r.chunk,
        "chunk_px": r.chunk_px,
        "workers": r.workers,
        "sources": r.sources,
        "params": row_json(r)["params"],
        "n": s.n,
        "inner": s.inner,
        "wall_s": {
            "median": num(s.wall_median),
            "mean": num(s.wall_mean),
            "sd": num(s.wall_sd),
            "min": num(s.wall_min),
            "max": num(s.wall_max),
            "median_ci95": [num(s.wall_median_ci.0), num(s.wall_median_ci.1)],
            "ci_half_rel": num(s.ci_half_rel),
            "outliers": s.outliers,
        },
        "speedup": s.speedup.map(|x| json!({
            "value": num(x.value), "ci95": [num(x.lo), num(x.hi)], "pairs": x.n
        })),
        "efficiency_median": num(s.efficiency_median),
        "load_max": s.load_max,
        "identical": s.identical,
        "agrees": s.agrees,
        "shares": crate::sched::SourceKind::ALL
            .iter()
            .zip(&s.shares)
            .filter_map(|(k, sh)| sh.map(|x| (k.id().to_string(), json!({
                "pixel_share": num(x.pixel_share), "items": num(x.items), "busy_s": num(x.busy_s)
            }))))
            .collect::<Map<String, Value>>(),
        "predicted_wall_s": r.predicted_wall_s,
    })
}

/// Write `dir/runs.json` and `dir/summary.json`; returns their paths.
///
/// # Errors
/// Writing either file failed (the file named).
pub fn write_json(
    dir: &Path,
    rows: &[RunRow],
    sums: &[Summary],
) -> Result<Vec<PathBuf>, WriteError> {
    let runs =
        json!({"schema": RUNS_SCHEMA, "rows": rows.iter().map(row_json).collect::<Vec<_>>()});
    let summary = json!({
        "schema": SUMMARY_SCHEMA,
        "configurations": sums.iter().map(summary_json).collect::<Vec<_>>()
    });
    let mut out = Vec::new();
    for (name, v) in [("runs.json", runs), ("summary.json", summary)] {
        let p = dir.join(name);
        let text = serde_json::to_string_pretty(&v).map_err(|e| WriteError {
            path: p.clone(),
            io: e.into(),
        })?;
        write_atomic(&p, text.as_bytes())?;
        out.push(p);
    }
    Ok(out)
}
