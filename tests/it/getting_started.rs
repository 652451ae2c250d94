//! `docs/getting-started.md` as written: every fenced `sh` block, in order, in one `bash`
//! session in an empty folder, with the built `raysched` first on `PATH`.

use std::path::Path;
use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_raysched");

/// The fenced blocks of `markdown` whose info string is `lang`, in order.
pub(crate) fn fenced_blocks(markdown: &str, lang: &str) -> Vec<String> {
    let mut blocks = Vec::new();
    let mut current: Option<String> = None;
    for line in markdown.lines() {
        let fence = line.trim_start().starts_with("```");
        match (&mut current, fence) {
            (None, true) => {
                if line.trim_start().trim_start_matches('`').trim() == lang {
                    current = Some(String::new());
                } else {
                    // A block of another language: skip to its end.
                    current = Some("\u{0}skip".into());
                }
            }
            (Some(b), true) => {
                if !b.starts_with('\u{0}') {
                    blocks.push(std::mem::take(b));
                }
                current = None;
            }
            (Some(b), false) => {
                if !b.starts_with('\u{0}') {
                    b.push_str(line);
                    b.push('\n');
                }
            }
            (None, false) => {}
        }
    }
    blocks
}

#[test]
fn fenced_blocks_take_only_the_language_asked_for() {
    let md = "text\n```sh\necho a\n```\n```toml\nx = 1\n```\n```sh\necho b\necho c\n```\n";
    assert_eq!(fenced_blocks(md, "sh"), ["echo a\n", "echo b\necho c\n"]);
    assert_eq!(fenced_blocks(md, "toml"), ["x = 1\n"]);
}

#[test]
fn getting_started_commands_run_as_written() {
    let doc = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/getting-started.md");
    let text = std::fs::read_to_string(&doc).unwrap();
    let blocks = fenced_blocks(&text, "sh");
    assert!(blocks.len() >= 6, "{} sh blocks", blocks.len());
    let script = format!("set -euo pipefail\n{}", blocks.join("\n"));
    assert!(
        script.contains("raysched compare"),
        "the guide ends with compare"
    );

    let dir = tempfile::tempdir().unwrap();
    let bin_dir = Path::new(BIN).parent().unwrap();
    let path = format!(
        "{}:{}",
        bin_dir.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let out = Command::new("bash")
        .arg("-c")
        .arg(&script)
        .current_dir(dir.path())
        .env("PATH", path)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "docs/getting-started.md failed:\n--- stdout\n{}\n--- stderr\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    for f in [
        "my_scene.exr",
        "my_scene.png",
        "my_scene_heat.png",
        "results/a/mine/report.md",
        "results/b/mine/runs.csv",
    ] {
        assert!(dir.path().join(f).exists(), "{f} was not written");
    }
}
