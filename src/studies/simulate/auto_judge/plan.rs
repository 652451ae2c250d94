//! The verdict's experiment file and the run that judges every cell and writes the results.

use super::config::{fixed_grid, Config};
use super::corpus::{cells, Cell, CostMap, SYNTHETIC};
use super::verdict::{judge, summary, Verdict};
use crate::studies::simulate::config::SimConfigError;
use crate::studies::simulate::error::SimError;
use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::Path;

/// The experiment file of the verdict (`kind = "auto_verdict"`, experiments/auto.toml).
#[derive(Clone, Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Plan {
    /// Must be `auto_verdict`.
    pub kind: String,
    /// One line: what it judges.
    pub description: String,
    /// Worker counts of the equal, one-slow and slowing fleets.
    pub workers: Vec<usize>,
    /// Seconds of the mean pixel on a full-speed thread.
    pub unit_s: f64,
    /// Synthetic maps ([`SYNTHETIC`]).
    #[serde(default)]
    pub synthetic: Vec<String>,
    /// Their side, pixels (a power of two).
    #[serde(default = "default_side")]
    pub synthetic_side: u32,
    /// Measured maps ([`CostMap::from_text`]), relative to the file.
    #[serde(default)]
    pub maps: Vec<std::path::PathBuf>,
}

fn default_side() -> u32 {
    256
}

/// Is `text` an `auto_verdict` experiment? (`simulate` runs those in-process.)
pub fn is_verdict(text: &str) -> bool {
    toml::from_str::<toml::Table>(text)
        .ok()
        .and_then(|t| {
            t.get("kind")
                .and_then(|k| k.as_str().map(|k| k == "auto_verdict"))
        })
        .unwrap_or(false)
}

/// Read and check a plan and its maps: one-line errors naming the file and field.
pub fn load(path: &Path) -> Result<(Plan, Vec<CostMap>), SimConfigError> {
    let at = path.display().to_string();
    let file_error = |msg: String| SimConfigError::File {
        path: at.clone(),
        msg,
    };
    let field = |name: &str, msg: String| SimConfigError::Field {
        path: at.clone(),
        field: name.to_string(),
        msg,
    };
    let text = std::fs::read_to_string(path).map_err(|e| file_error(e.to_string()))?;
    let plan: Plan = toml::from_str(&text).map_err(|e| {
        file_error(
            e.to_string()
                .split_whitespace()
                .collect::<Vec<_>>()
                .join(" "),
        )
    })?;
    if plan.kind != "auto_verdict" {
        return Err(field("kind", "expected \"auto_verdict\"".into()));
    }
    if plan.workers.is_empty() || plan.workers.iter().any(|&p| p == 0 || p > 65536) {
        return Err(field("workers", "1 to 65536 each, at least one".into()));
    }
    if !(plan.unit_s.is_finite() && plan.unit_s > 0.0) {
        return Err(field("unit_s", "a positive number of seconds".into()));
    }
    if !plan.synthetic_side.is_power_of_two() || !(4..=2048).contains(&plan.synthetic_side) {
        return Err(field("synthetic_side", "a power of two, 4 to 2048".into()));
    }
    let mut maps = Vec::new();
    for s in &plan.synthetic {
        maps.push(CostMap::synthetic(s, plan.synthetic_side).ok_or_else(|| {
            field(
                "synthetic",
                format!("{s}: expected one of {}", SYNTHETIC.join(", ")),
            )
        })?);
    }
    let dir = path.parent().unwrap_or(Path::new("."));
    for m in &plan.maps {
        let file = dir.join(m);
        let text = std::fs::read_to_string(&file)
            .map_err(|e| field("maps", format!("{}: {e}", file.display())))?;
        let name = m.file_stem().map_or_else(
            || m.display().to_string(),
            |s| s.to_string_lossy().into_owned(),
        );
        maps.push(CostMap::from_text(&name, &text).map_err(|e| field("maps", e.to_string()))?);
    }
    if maps.is_empty() {
        return Err(field("synthetic, maps", "no cost map named".into()));
    }
    Ok((plan, maps))
}

/// What the verdict wrote.
pub struct Written {
    /// The summary line.
    pub summary: String,
    /// The worst cells, worst first, as table lines.
    pub worst: Vec<String>,
    /// Files written.
    pub files: Vec<std::path::PathBuf>,
}

/// Judge every cell of `plan` over `maps`; write `verdict.csv` (cell, best fixed
/// configuration, its wall, auto's, ratio), `fixed.csv` (every fixed configuration's worst
/// ratio to the best over all cells), `report.md` and `ratio.png` into `dir`.
pub fn run(
    plan: &Plan,
    maps: &[CostMap],
    dir: &std::path::Path,
    progress: bool,
) -> Result<Written, SimError> {
    std::fs::create_dir_all(dir)?;
    let cells = cells(maps, &plan.workers, plan.unit_s);
    let (verdicts, grids) = judge_cells(&cells, progress);
    let verdict_csv = dir.join("verdict.csv");
    crate::util::fs::write_atomic(&verdict_csv, verdict_table(&verdicts).as_bytes())?;
    let fixed = fixed_ranking(&verdicts, &cells, &grids);
    let mut fcsv = String::from("config,worst_ratio,cells\n");
    for (c, r, n) in &fixed {
        let _ = writeln!(fcsv, "{c},{r:.5},{n}");
    }
    let fixed_csv = dir.join("fixed.csv");
    crate::util::fs::write_atomic(&fixed_csv, fcsv.as_bytes())?;
    let line = summary(&verdicts);
    let worst = worst_lines(&verdicts);
    let md = report_text(plan, &line, &verdicts, &worst, &fixed);
    let report = dir.join("report.md");
    crate::util::fs::write_atomic(&report, md.as_bytes())?;
    let png = dir.join("ratio.png");
    plot_ratios(&png, &verdicts).map_err(SimError::Failed)?;
    Ok(Written {
        summary: line,
        worst,
        files: vec![verdict_csv, fixed_csv, report, png],
    })
}

/// The fixed grids, one per item count.
type Grids = HashMap<usize, Vec<Config>>;

/// Judge each cell against the fixed grid of its item count; also those grids.
fn judge_cells(cells: &[Cell], progress: bool) -> (Vec<Verdict>, Grids) {
    let mut verdicts = Vec::with_capacity(cells.len());
    let mut grids: Grids = Default::default();
    for (i, cell) in cells.iter().enumerate() {
        let n = cell.map.cost.len();
        let grid = grids.entry(n).or_insert_with(|| fixed_grid(n));
        let v = judge(cell, grid);
        if progress {
            eprintln!(
                "[{}/{}] {}: auto {:.4} against {} ({:.4})",
                i + 1,
                cells.len(),
                v.cell,
                v.ratio(),
                v.best.0,
                v.best.1
            );
        }
        verdicts.push(v);
    }
    (verdicts, grids)
}

/// `verdict.csv`: one line per cell.
fn verdict_table(verdicts: &[Verdict]) -> String {
    let mut csv = String::from("cell,best_fixed,best_fixed_s,auto_s,ratio\n");
    for v in verdicts {
        let _ = writeln!(
            csv,
            "{},{},{:.6e},{:.6e},{:.5}",
            v.cell,
            v.best.0,
            v.best.1,
            v.auto_s,
            v.ratio()
        );
    }
    csv
}

/// Every fixed configuration's worst ratio over the cells whose grid holds it (a chunk larger
/// than a map's items is not in that map's grid) and that count of cells, best first.
fn fixed_ranking(verdicts: &[Verdict], cells: &[Cell], grids: &Grids) -> Vec<(Config, f64, usize)> {
    let mut worst_of: HashMap<Config, (f64, usize)> = Default::default();
    for (v, cell) in verdicts.iter().zip(cells) {
        let grid = &grids[&cell.map.cost.len()];
        for (c, s) in grid.iter().zip(&v.fixed_s) {
            let e = worst_of.entry(*c).or_insert((0.0, 0));
            e.0 = e.0.max(s / v.best.1);
            e.1 += 1;
        }
    }
    let mut fixed: Vec<(Config, f64, usize)> =
        worst_of.into_iter().map(|(c, (r, n))| (c, r, n)).collect();
    fixed.sort_by(|a, b| {
        a.1.total_cmp(&b.1)
            .then(a.0.to_string().cmp(&b.0.to_string()))
    });
    fixed
}

/// The 12 worst cells, worst first, as markdown table lines.
fn worst_lines(verdicts: &[Verdict]) -> Vec<String> {
    let mut order: Vec<&Verdict> = verdicts.iter().collect();
    order.sort_by(|a, b| b.ratio().total_cmp(&a.ratio()));
    order
        .iter()
        .take(12)
        .map(|v| {
            format!(
                "| {} | {} | {:.4e} | {:.4e} | {:.4} |",
                v.cell,
                v.best.0,
                v.best.1,
                v.auto_s,
                v.ratio()
            )
        })
        .collect()
}

/// `report.md`: the summary, the worst cells and the best single fixed configurations.
fn report_text(
    plan: &Plan,
    line: &str,
    verdicts: &[Verdict],
    worst: &[String],
    fixed: &[(Config, f64, usize)],
) -> String {
    let within = verdicts.iter().filter(|v| v.ratio() <= 1.02).count();
    let mut md = format!(
        "# {}\n\n{line}\n\nWithin 1.02× of the best fixed configuration in {within} of {} cells.\n\n\
         ## Worst cells\n\n| cell | best fixed | its wall (s) | auto (s) | ratio |\n|---|---|---|---|---|\n",
        plan.description,
        verdicts.len()
    );
    for w in worst {
        let _ = writeln!(md, "{w}");
    }
    let _ = write!(
        md,
        "\n## Best single fixed configurations (worst ratio over every cell)\n\n\
         | configuration | worst ratio | cells |\n|---|---|---|\n"
    );
    for (c, r, n) in fixed.iter().take(10) {
        let _ = writeln!(md, "| {c} | {r:.4} | {n} |");
    }
    md
}

/// auto's ratio to the best fixed configuration, cell by cell, with the 1.02 goal.
fn plot_ratios(path: &std::path::Path, verdicts: &[Verdict]) -> Result<(), String> {
    use plotters::prelude::*;
    crate::plot::font::register_font();
    let pts = verdicts
        .iter()
        .enumerate()
        .map(|(i, v)| {
            let r = v.ratio();
            (i as f64, r, r, r)
        })
        .collect();
    let lines: crate::plot::Series = vec![("auto / best fixed".to_string(), pts)];
    let refs = [(1.02, "goal 1.02")];
    let spec = crate::plot::Lines {
        title: "auto against the best fixed configuration, per cell",
        x_desc: "cell (verdict.csv row)",
        y_desc: "wall ratio",
        x: crate::plot::axes::Scale::Linear,
        y: crate::plot::axes::Scale::Linear,
        ideal: false,
        refs: &refs,
        y_range: None,
        legend_w: 0,
    };
    let root = BitMapBackend::new(path, (1200, 560)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    crate::plot::line_chart(&root, &spec, &lines)?;
    root.present().map_err(|e| e.to_string())?;
    Ok(())
}
