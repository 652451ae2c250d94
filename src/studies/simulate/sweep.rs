//! `raysched simulate`: measure the inputs once, simulate every platform × scheduler × worker
//! count in a child process each, write `sim_runs.csv`, `inputs.toml`, plots and `report.md`.

use super::config::{Platform, SimPlan};
use super::error::SimError;
pub use super::rows::{
    hidden_refill, load_average, master_h_text, simulate_one, write_rows, Inputs, SimRow,
};
use super::{plot, validate};
use crate::sched::SchedulerSpec;
use std::path::{Path, PathBuf};

/// Run the whole experiment; returns its results folder.
pub fn run(plan: &SimPlan, exe: &Path, out: &Path, quiet: bool) -> Result<PathBuf, SimError> {
    // The validation's measured runs are read first: a bad file fails before any measurement.
    let measured = match &plan.validation {
        Some((csv, _)) => Some(validate::measured_configs(csv)?),
        None => None,
    };
    let mpi_measured = mpi_measured(plan, measured.as_ref())?;
    let mut inputs = Inputs::measure(plan, &plan.overrides, &plan.specs, &[], quiet)?;
    let dir = out.join(&plan.name);
    std::fs::create_dir_all(dir.join("plots"))?;
    let rows = sweep(plan, exe, &mut inputs, &dir, quiet)?;
    let (validation, v_layouts) =
        validation(plan, exe, measured.as_ref(), mpi_measured.as_ref(), quiet)?;
    write_rows(&dir.join("sim_runs.csv"), &rows)?;
    let inputs_toml = format!(
        "# Measured inputs of every simulated run ({}).\nmachine = {:?}\nload_average = {:?}\nprobe_scene = {:?}\nprobe_pixels = {}\nprobe_timed_s = {}\nprobe_bulk_s = {}\nserial_s = {}\ncounter_s = {}\n[master_h_s]\n{}",
        plan.file.display(),
        crate::util::host::cpu_model(),
        load_average(),
        plan.scene.display().to_string(),
        inputs.pixels.cost_s.len(),
        inputs.pixels.timed_s,
        inputs.pixels.bulk_s,
        inputs.pixels.serial_s(),
        inputs.counter_s,
        inputs.master_h_s.iter().map(|(b, h)| format!("B{b} = {h}\n")).collect::<String>()
    ) + &layout_toml("layout_factor", &inputs.layout_factors())
        + &layout_toml("validation_layout_factor", &v_layouts);
    crate::util::fs::write_atomic(&dir.join("inputs.toml"), inputs_toml.as_bytes())?;
    write_report(plan, &dir, &rows, &inputs, validation.as_ref())?;
    Ok(dir)
}

/// Measured configurations and the scene settings they were rendered with.
type Measured = (Vec<validate::Measured>, crate::core::scene::SceneOverrides);

/// The MPI validation's measured runs (with their spinning twins), each transport with a
/// platform and the scene setting the local runs have.
fn mpi_measured(plan: &SimPlan, measured: Option<&Measured>) -> Result<Option<Measured>, SimError> {
    let Some((csv, platforms)) = &plan.mpi_validation else {
        return Ok(None);
    };
    let (mut configs, overrides) = validate::mpi_configs(csv)?;
    if let Some(spin) = &plan.mpi_spin {
        validate::attach_spin(&mut configs, &validate::mpi_configs(spin)?.0);
    }
    if let Some(m) = configs
        .iter()
        .find(|m| !platforms.contains_key(m.transport.as_deref().unwrap_or_default()))
    {
        return Err(SimError::Failed(format!(
            "{}: validation.mpi_platforms: no platform for transport '{}' of {}",
            plan.file.display(),
            m.transport.as_deref().unwrap_or_default(),
            csv.display()
        )));
    }
    if measured.is_some_and(|(_, o)| *o != overrides) {
        return Err(SimError::Failed(format!(
            "{}: the MPI runs render another scene setting than {}",
            csv.display(),
            plan.validation
                .as_ref()
                .map(|v| v.0.display().to_string())
                .unwrap_or_default()
        )));
    }
    Ok(Some((configs, overrides)))
}

/// Every platform × scheduler × worker count, `sim_runs.csv` rewritten after each row.
fn sweep(
    plan: &SimPlan,
    exe: &Path,
    inputs: &mut Inputs,
    dir: &Path,
    quiet: bool,
) -> Result<Vec<SimRow>, SimError> {
    let mut rows = Vec::new();
    for p in &plan.platforms {
        for spec in &plan.specs {
            for &w in &plan.workers {
                let spec = SchedulerSpec {
                    workers: w,
                    ..spec.clone()
                };
                let row = simulate_one(inputs, plan, exe, p, &spec)?;
                if !quiet {
                    println!(
                        "{} {} workers={}: wall {:.4} s, speedup {:.2} ({:.1} s to simulate){}",
                        p.name,
                        spec.label(),
                        w,
                        row.out.wall_s,
                        row.speedup(),
                        row.out.host_s,
                        row.out
                            .error
                            .as_deref()
                            .map(|e| format!(" — {e}"))
                            .unwrap_or_default()
                    );
                }
                rows.push(row);
                // Every row so far, so that a sweep cut short leaves what it simulated.
                write_rows(&dir.join("sim_runs.csv"), &rows)?;
            }
        }
    }
    Ok(rows)
}

/// Layout factors keyed (chunk, order, threads).
type LayoutFactors = Vec<(String, String, usize, f64)>;

/// The validation against the measured runs (local and MPI), and the layout factors its
/// inputs measured; nothing without measured runs.
fn validation(
    plan: &SimPlan,
    exe: &Path,
    measured: Option<&Measured>,
    mpi_measured: Option<&Measured>,
    quiet: bool,
) -> Result<(Option<validate::Validation>, LayoutFactors), SimError> {
    let mut pairs: Vec<(validate::Measured, Platform)> = Vec::new();
    let mut scene = None;
    if let (Some((_, platform)), Some((configs, overrides))) = (&plan.validation, measured) {
        pairs.extend(configs.iter().map(|m| (m.clone(), platform.clone())));
        scene = Some(overrides.clone());
    }
    if let (Some((_, platforms)), Some((configs, overrides))) = (&plan.mpi_validation, mpi_measured)
    {
        for m in configs {
            let t = m.transport.as_deref().unwrap_or_default();
            pairs.push((m.clone(), platforms[t].clone()));
        }
        scene = Some(overrides.clone());
    }
    let Some(overrides) = scene else {
        return Ok((None, Vec::new()));
    };
    let specs: Vec<SchedulerSpec> = pairs.iter().map(|m| m.0.spec.clone()).collect();
    // This machine's runs: each worker count's items costed with that many threads (or ranks)
    // rendering at once.
    let mut counts: Vec<usize> = specs.iter().map(|s| s.workers).collect();
    counts.sort_unstable();
    counts.dedup();
    let mut v_inputs = Inputs::measure(plan, &overrides, &specs, &counts, quiet)?;
    let v = validate::compare(&pairs, &mut v_inputs, plan, exe, quiet)?;
    Ok((Some(v), v_inputs.layout_factors()))
}

/// The plots and `report.md`.
fn write_report(
    plan: &SimPlan,
    dir: &Path,
    rows: &[SimRow],
    inputs: &Inputs,
    validation: Option<&validate::Validation>,
) -> Result<(), SimError> {
    let mut figures = plot::draw(&dir.join("plots"), rows, inputs)?;
    let mut report = format!(
        "# {} (simulated with SimGrid)\n\n{}\n\n",
        plan.name, plan.description
    );
    if let Some(v) = validation {
        validate::write(dir, v)?;
        figures.extend(plot::validation(&dir.join("plots"), v)?);
        report += &validate::markdown(v);
    }
    report += &plot::saturation_markdown(rows, inputs);
    report += &plot::summary_markdown(rows, inputs);
    for f in &figures {
        report += &format!("\n![{f}](plots/{f})\n");
    }
    crate::util::fs::write_atomic(&dir.join("report.md"), report.as_bytes())?;
    Ok(())
}

/// A TOML table of layout factors, keyed "chunk order threads" (nothing without any).
fn layout_toml(table: &str, factors: &[(String, String, usize, f64)]) -> String {
    if factors.is_empty() {
        return String::new();
    }
    let rows: String = factors
        .iter()
        .map(|(c, o, t, k)| format!("\"{c} {o} {t}\" = {k}\n"))
        .collect();
    format!("# Each item layout's cost against rows (chunk, order, threads rendering).\n[{table}]\n{rows}")
}
