//! The numerical stability suite (`raysched stability`; a fast subset runs in `cargo test`):
//! extreme scale and offset, grazing rays, near-coincident and degenerate geometry, rays
//! starting on edges and vertices, dielectrics, and stiff lighting. Each case renders a small
//! scene and compares an image mean with its expected value within 3σ, where σ comes from the
//! per-pixel sample variance ([`crate::core::render::Moments`]), and counts NaN/Inf samples.

pub mod cases;
pub mod paired;
pub mod transform;
pub mod watertight;

use crate::core::render::Moments;
use crate::core::scene::Scene;
use crate::core::tracer::Tracer;
use crate::studies::converge::reference::image_moments;
use crate::studies::converge::Reference;
use serde::Serialize;
use std::path::Path;

/// One row of the stability table.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CaseResult {
    /// The kind of hazard tested (e.g. `degenerate`, `dielectric`).
    pub group: String,
    /// What this case checks, in words.
    pub case: String,
    /// Expected value: a channel-averaged image mean, or a count.
    pub expected: f64,
    /// Measured value, in the same unit as `expected`.
    pub measured: f64,
    /// Standard error of `measured − expected` (0 for counts).
    pub sigma: f64,
    /// `|measured − expected| / |expected|` (the absolute difference when `expected` is 0).
    pub rel_error: f64,
    /// NaN/Inf samples (dropped and counted, never written).
    pub nonfinite: u64,
    /// Pixels further than 5σ (+ tolerance) from their own expected value.
    pub outlier_pixels: u64,
    /// Whether the case passed: normally within 3σ (+ [`REL_TOL`]) with no NaN/Inf sample and
    /// at most 1 % outlier pixels; a count case passes when the counts are equal.
    pub pass: bool,
    /// `false`: reported only (e.g. t = 1e8), the suite does not fail on it.
    pub required: bool,
    /// Free-text detail: what was compared, or why the case could not run.
    pub note: String,
}

/// Image size and samples of every case.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Budget {
    /// Width and height of every case's image, in pixels.
    pub size: u32,
    /// Samples per pixel (some cases use a multiple of it).
    pub spp: u32,
    /// Render threads.
    pub threads: usize,
    /// `true`: the short list of transforms (the `cargo test` subset).
    pub quick: bool,
}

impl Budget {
    /// The small budget of the `cargo test` subset: 24×24 pixels, 8 spp, 2 threads.
    pub const QUICK: Self = Self {
        size: 24,
        spp: 8,
        threads: 2,
        quick: true,
    };
}

/// Relative tolerance added to 3σ: f32 rounding of the image and the references' quadrature.
pub const REL_TOL: f64 = 1e-4;

/// Per-pixel mean (dropped samples count as 0, exactly as `render_item`) and variance of
/// that mean, channel-averaged.
pub fn pixel_stats(m: &Moments, spp: u32) -> Vec<(f64, f64)> {
    let n = spp as f64;
    m.sums
        .iter()
        .zip(&m.sq_sums)
        .map(|(s, q)| {
            let mean = (s[0] + s[1] + s[2]) / (3.0 * n);
            let var: f64 = (0..3)
                .map(|c| {
                    let mu = s[c] / n;
                    ((q[c] / n - mu * mu).max(0.0)) / (n - 1.0).max(1.0)
                })
                .sum::<f64>()
                / 3.0;
            (mean, var)
        })
        .collect()
}

// A private constructor of one table row: every field is a column, a struct would only rename them.
#[allow(clippy::too_many_arguments)]
fn verdict(
    group: &str,
    case: &str,
    expected: f64,
    measured: f64,
    sigma: f64,
    nonfinite: u64,
    outliers: u64,
    pixels: usize,
    note: String,
) -> CaseResult {
    let diff = (measured - expected).abs();
    let rel_error = if expected != 0.0 {
        diff / expected.abs()
    } else {
        diff
    };
    // 1 % of the pixels may sit beyond 5σ: σ itself is estimated from few samples.
    let outliers_ok = outliers as f64 <= 0.01 * pixels as f64;
    let pass = measured.is_finite()
        && diff <= 3.0 * sigma + REL_TOL * expected.abs() + 1e-12
        && nonfinite == 0
        && outliers_ok;
    CaseResult {
        group: group.into(),
        case: case.into(),
        expected,
        measured,
        sigma,
        rel_error,
        nonfinite,
        outlier_pixels: outliers,
        pass,
        required: true,
        note,
    }
}

/// Render `scene` and compare it with `reference` over the reference's exact pixels.
pub fn against_reference<T: Tracer + ?Sized>(
    group: &str,
    case: &str,
    scene: &Scene,
    tracer: &T,
    reference: &Reference,
    budget: &Budget,
) -> CaseResult {
    let spp = scene.settings.spp;
    let m = image_moments(scene, tracer, 0..spp, false, budget.threads);
    let stats = pixel_stats(&m, spp);
    let (mut sum_m, mut sum_e, mut var, mut k, mut outliers) = (0.0, 0.0, 0.0, 0usize, 0u64);
    for (i, (mean, v)) in stats.iter().enumerate() {
        if !reference.exact[i] {
            continue;
        }
        let r = reference.image.data[i];
        let e = (r[0] + r[1] + r[2]) as f64 / 3.0;
        sum_m += mean;
        sum_e += e;
        var += v;
        k += 1;
        if (mean - e).abs() > 5.0 * v.sqrt() + REL_TOL * e.abs() + 1e-6 {
            outliers += 1;
        }
    }
    if k == 0 {
        let mut r = verdict(
            group,
            case,
            0.0,
            f64::NAN,
            0.0,
            m.nonfinite,
            0,
            0,
            String::new(),
        );
        r.note = "no exact reference pixel".into();
        r.pass = false;
        return r;
    }
    let kf = k as f64;
    verdict(
        group,
        case,
        sum_e / kf,
        sum_m / kf,
        var.sqrt() / kf,
        m.nonfinite,
        outliers,
        k,
        format!("{} ref, {k} exact px, {spp} spp", reference.kind.label()),
    )
}

/// Render two scenes of the same size and compare their image means and their pixels.
///
/// σ is the standard error of the mean pixel difference, from the spread of the per-pixel
/// differences: pixels draw independent random numbers, so this holds for independent renders
/// and for paired ones (same seed, same paths) alike. For a paired render it is the size of the
/// actual difference (≈1e-7 of the mean for a transform that changes nothing) rather than the σ
/// of two independent images (a few per cent of the Cornell mean at 24², 8 spp), so a 1 %
/// bias fails.
pub fn against_scene<T: Tracer + ?Sized, U: Tracer + ?Sized>(
    group: &str,
    case: &str,
    scene: &Scene,
    tracer: &T,
    baseline: &Scene,
    baseline_tracer: &U,
    budget: &Budget,
) -> CaseResult {
    let a = image_moments(scene, tracer, 0..scene.settings.spp, false, budget.threads);
    let b = image_moments(
        baseline,
        baseline_tracer,
        0..baseline.settings.spp,
        false,
        budget.threads,
    );
    let sa = pixel_stats(&a, scene.settings.spp);
    let sb = pixel_stats(&b, baseline.settings.spp);
    let n = sa.len().min(sb.len()).max(1) as f64;
    let (mut ma, mut mb, mut outliers) = (0.0, 0.0, 0u64);
    for ((xa, va), (xb, vb)) in sa.iter().zip(&sb) {
        ma += xa;
        mb += xb;
        if (xa - xb).abs() > 5.0 * (va + vb).sqrt() + REL_TOL * xb.abs() + 1e-6 {
            outliers += 1;
        }
    }
    let mean_diff = (ma - mb) / n;
    let spread: f64 = sa
        .iter()
        .zip(&sb)
        .map(|((xa, _), (xb, _))| (xa - xb - mean_diff).powi(2))
        .sum();
    let sigma = (spread / (n * (n - 1.0).max(1.0))).sqrt();
    verdict(
        group,
        case,
        mb / n,
        ma / n,
        sigma,
        a.nonfinite + b.nonfinite,
        outliers,
        sa.len(),
        format!("vs untransformed/baseline, {} spp", scene.settings.spp),
    )
}

/// Below this ratio of image-mean variances (tiny light / large light) the equal-power case
/// fails: its point is a light with the same mean and a far larger variance.
pub const EQUAL_POWER_MIN_VAR_RATIO: f64 = 10.0;

/// Two renders that must have the same image mean but may differ pixel by pixel (a tiny
/// bright light and a large dim one of the same power): means within 3σ (combined standard
/// error), no NaN/Inf, and the `stiff` render's variance of the mean at least
/// [`EQUAL_POWER_MIN_VAR_RATIO`] times the `mild` one's. The ratio is in the note.
pub fn equal_power<T: Tracer + ?Sized, U: Tracer + ?Sized>(
    group: &str,
    case: &str,
    stiff: (&Scene, &T),
    mild: (&Scene, &U),
    budget: &Budget,
) -> CaseResult {
    // (image mean, variance of that mean, NaN/Inf samples, pixels)
    let stats = |scene: &Scene, m: Moments| {
        let st = pixel_stats(&m, scene.settings.spp);
        let n = st.len().max(1) as f64;
        let mean = st.iter().map(|p| p.0).sum::<f64>() / n;
        let var = st.iter().map(|p| p.1).sum::<f64>() / (n * n);
        (mean, var, m.nonfinite, st.len())
    };
    let spp = |s: &Scene| 0..s.settings.spp;
    let a = image_moments(stiff.0, stiff.1, spp(stiff.0), false, budget.threads);
    let b = image_moments(mild.0, mild.1, spp(mild.0), false, budget.threads);
    let (ms, vs, ns, pixels) = stats(stiff.0, a);
    let (mm, vm, nm, _) = stats(mild.0, b);
    let ratio = if vm > 0.0 { vs / vm } else { f64::INFINITY };
    let mut r = verdict(
        group,
        case,
        mm,
        ms,
        (vs + vm).sqrt(),
        ns + nm,
        0,
        pixels,
        format!(
            "vs large light of equal power; variance of the mean tiny/large = {ratio:.3e} \
             (σ {:.2e} / {:.2e}), {} / {} spp",
            vs.sqrt(),
            vm.sqrt(),
            stiff.0.settings.spp,
            mild.0.settings.spp
        ),
    );
    r.pass &= ratio >= EQUAL_POWER_MIN_VAR_RATIO;
    r
}

/// An exact count (e.g. degenerate triangles skipped): pass when equal.
pub fn count_case(group: &str, case: &str, expected: u64, measured: u64, note: &str) -> CaseResult {
    let mut r = verdict(
        group,
        case,
        expected as f64,
        measured as f64,
        0.0,
        0,
        0,
        1,
        note.into(),
    );
    r.pass = expected == measured;
    r
}

/// A case that could not run: a required failure carrying the reason.
fn failed(group: &str, case: &str, msg: String) -> CaseResult {
    CaseResult {
        group: group.into(),
        case: case.into(),
        expected: f64::NAN,
        measured: f64::NAN,
        sigma: 0.0,
        rel_error: f64::NAN,
        nonfinite: 0,
        outlier_pixels: 0,
        pass: false,
        required: true,
        note: msg,
    }
}

/// Write the table as CSV.
///
/// # Errors
/// I/O or CSV errors.
pub fn write_csv(path: &Path, rows: &[CaseResult]) -> Result<(), crate::util::csv_out::CsvError> {
    crate::util::csv_out::write_rows(path, rows)
}

/// The table as markdown.
pub fn markdown(rows: &[CaseResult]) -> String {
    let mut s = String::from(
        "| group | case | expected | measured | σ | rel. error | NaN/Inf | outlier px | result | note |\n|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        let result = match (r.pass, r.required) {
            (true, _) => "pass",
            (false, true) => "**FAIL**",
            (false, false) => "fail (report only)",
        };
        s.push_str(&format!(
            "| {} | {} | {:.6} | {:.6} | {:.2e} | {:.2e} | {} | {} | {} | {} |\n",
            r.group,
            r.case,
            r.expected,
            r.measured,
            r.sigma,
            r.rel_error,
            r.nonfinite,
            r.outlier_pixels,
            result,
            r.note.replace('|', "/")
        ));
    }
    s
}
