//! `report.html` in a real browser: Debian's headless Chromium (`.ci/run` installs it) loads
//! the page of a small run; it must load without a console message, run its script to the
//! end, and show something. Without Chromium the tests say why they skip, except under CI
//! (`CI` set), where that is a failure.

use std::path::{Path, PathBuf};
use std::process::Command;

/// The browser, or `None` (after saying so) where it is absent outside CI.
fn chromium() -> Option<PathBuf> {
    let found = ["/usr/bin/chromium", "/usr/bin/chromium-browser"]
        .iter()
        .map(PathBuf::from)
        .find(|p| p.exists());
    match found {
        Some(p) => Some(p),
        None if std::env::var_os("CI").is_some() => {
            panic!("chromium not found under CI: .ci/run installs the `chromium` package")
        }
        None => {
            eprintln!("skipped: chromium is not installed (apt-get install chromium)");
            None
        }
    }
}

/// Chromium with the flags that work in a container, a fresh profile, and a time limit.
fn browser(bin: &Path, profile: &Path, extra: &[String], page: &Path) -> std::process::Output {
    let mut c = Command::new("timeout");
    c.arg("120").arg(bin).args([
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--enable-logging=stderr",
        "--v=0",
    ]);
    c.arg(format!("--user-data-dir={}", profile.display()));
    c.args(extra);
    c.arg(format!("file://{}", page.display()));
    c.output().expect("chromium runs")
}

/// Load `page`: Err with the reason where the console reported anything (an uncaught error
/// included) or the page's script did not reach its end (it marks `data-ready="yes"`).
fn load(bin: &Path, page: &Path) -> Result<(), String> {
    let profile = tempfile::tempdir().expect("profile dir");
    let out = browser(bin, profile.path(), &["--dump-dom".into()], page);
    let dom = String::from_utf8_lossy(&out.stdout);
    let log = String::from_utf8_lossy(&out.stderr);
    let console: Vec<&str> = log
        .lines()
        .filter(|l| l.contains(":CONSOLE(") || l.contains("Uncaught"))
        .collect();
    if !console.is_empty() {
        return Err(format!("console messages: {console:#?}"));
    }
    if !dom.contains("data-ready=\"yes\"") {
        return Err(format!(
            "the script did not finish (status {:?}); stderr: {log}",
            out.status
        ));
    }
    Ok(())
}

/// A screenshot of `page`: the share of its pixels that differ from the commonest colour.
fn ink(bin: &Path, page: &Path) -> f64 {
    let profile = tempfile::tempdir().expect("profile dir");
    let shot = profile.path().join("shot.png");
    let out = browser(
        bin,
        profile.path(),
        &[
            format!("--screenshot={}", shot.display()),
            "--window-size=1200,1600".into(),
            "--hide-scrollbars".into(),
        ],
        page,
    );
    let img = image::open(&shot)
        .unwrap_or_else(|e| {
            panic!(
                "{}: {e}; stderr: {}",
                shot.display(),
                String::from_utf8_lossy(&out.stderr)
            )
        })
        .to_rgb8();
    let mut counts = std::collections::HashMap::new();
    for p in img.pixels() {
        *counts.entry(p.0).or_insert(0usize) += 1;
    }
    let common = counts.values().copied().max().unwrap_or(0);
    let total = (img.width() * img.height()).max(1) as usize;
    (total - common) as f64 / total as f64
}

fn report_html(root: &Path) -> Option<PathBuf> {
    let p = root.join("report.html");
    if p.exists() {
        return Some(p);
    }
    std::fs::read_dir(root)
        .ok()?
        .flatten()
        .filter(|e| e.path().is_dir())
        .find_map(|e| report_html(&e.path()))
}

#[test]
fn report_html_loads_without_console_errors_and_is_not_blank() {
    let Some(bin) = chromium() else {
        return;
    };
    let (dir, _) = crate::experiment::run_tiny(2);
    let page = report_html(dir.path()).expect("`raysched run` wrote report.html");
    let html = std::fs::read_to_string(&page).expect("readable");
    // Self-contained: inline SVG, nothing fetched.
    assert!(html.contains("<svg"), "no inline plot");
    for remote in ["src=\"http", "href=\"http", "<link", "@import", "<img"] {
        assert!(
            !html.contains(remote),
            "report.html refers outside itself: {remote}"
        );
    }
    assert!(html.contains("class=\"sortable\""), "no sortable table");
    load(&bin, &page).unwrap_or_else(|e| panic!("{}: {e}", page.display()));
    let ink = ink(&bin, &page);
    assert!(
        ink > 0.02,
        "the screenshot is blank ({:.3} % ink)",
        ink * 100.0
    );
    // `raysched plot` writes it again from the CSV alone.
    std::fs::remove_file(&page).expect("removable");
    let folder = page.parent().expect("in a folder");
    let out = Command::new(env!("CARGO_BIN_EXE_raysched"))
        .arg("plot")
        .arg(folder)
        .output()
        .expect("raysched plot runs");
    crate::support::assert_ok(&out);
    assert!(page.exists(), "raysched plot did not write report.html");
}

#[test]
fn a_page_whose_script_throws_fails_the_check() {
    let Some(bin) = chromium() else {
        return;
    };
    let dir = tempfile::tempdir().expect("temp dir");
    let page = dir.path().join("broken.html");
    std::fs::write(
        &page,
        "<!DOCTYPE html><html><body><p>x</p><script>undefinedFunction();\
         document.body.setAttribute('data-ready', 'yes');</script></body></html>",
    )
    .expect("written");
    let err = load(&bin, &page).expect_err("a throwing script must fail the check");
    assert!(
        err.contains("Uncaught") || err.contains("did not finish"),
        "{err}"
    );
    let blank = dir.path().join("blank.html");
    std::fs::write(&blank, "<!DOCTYPE html><html><body></body></html>").expect("written");
    assert!(
        ink(&bin, &blank) < 0.001,
        "a blank page must count as blank"
    );
}
