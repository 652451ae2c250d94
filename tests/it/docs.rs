//! The documentation holds together: every relative link and anchor of every Markdown file
//! resolves, the README stays a front door, and `results/README.md` indexes exactly the
//! published snapshots, each with its `SETUP.md`, within the size the tree may take.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// Every Markdown file of the tree, skipping build output, fetched dependencies, unpublished
/// runs and the generated `report.md` of published snapshots (they link plots that git does
/// not keep; `raysched plot` redraws them).
fn markdown_files() -> Vec<PathBuf> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        let Ok(entries) = std::fs::read_dir(dir) else {
            return;
        };
        for e in entries.flatten() {
            let p = e.path();
            let name = e.file_name().to_string_lossy().into_owned();
            if p.is_dir() {
                let rel = p.strip_prefix(root()).unwrap();
                let skip = name.starts_with('.')
                    || name.starts_with("target")
                    || name == "node_modules"
                    || rel.starts_with("results/runs");
                if !skip {
                    walk(&p, out);
                }
            } else if name.ends_with(".md")
                && !(name == "report.md" && p.starts_with(root().join("results")))
            {
                out.push(p);
            }
        }
    }
    let mut out = Vec::new();
    walk(root(), &mut out);
    out.sort();
    out
}

/// GitHub's anchor for a heading: lower case, punctuation other than `-` and `_` dropped,
/// spaces to `-`.
fn slug(heading: &str) -> String {
    let text: String = heading.replace('`', "");
    // A link inside a heading counts by its text.
    let mut plain = String::new();
    let mut chars = text.chars().peekable();
    while let Some(c) = chars.next() {
        if c == ']' && chars.peek() == Some(&'(') {
            for d in chars.by_ref() {
                if d == ')' {
                    break;
                }
            }
        } else if c != '[' {
            plain.push(c);
        }
    }
    plain
        .trim()
        .to_lowercase()
        .chars()
        .filter_map(|c| match c {
            ' ' => Some('-'),
            c if c.is_alphanumeric() || c == '-' || c == '_' => Some(c),
            _ => None,
        })
        .collect()
}

/// The anchors a Markdown file defines: its headings' slugs (with GitHub's `-1`, `-2` for
/// repeats) and explicit `<a id="…">` / `<a name="…">` tags.
fn anchors(text: &str) -> BTreeSet<String> {
    let mut set = BTreeSet::new();
    let mut fenced = false;
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
            continue;
        }
        if fenced {
            continue;
        }
        if let Some(h) = line.strip_prefix('#') {
            let h = h.trim_start_matches('#');
            if h.starts_with(' ') {
                let base = slug(h);
                let mut s = base.clone();
                let mut k = 1;
                while set.contains(&s) {
                    s = format!("{base}-{k}");
                    k += 1;
                }
                set.insert(s);
            }
        }
        for key in ["id=\"", "name=\""] {
            let mut rest = line;
            while let Some(i) = rest.find(key) {
                let after = &rest[i + key.len()..];
                if let Some(j) = after.find('"') {
                    set.insert(after[..j].to_string());
                }
                rest = &rest[i + key.len()..];
            }
        }
    }
    set
}

/// The link targets of a Markdown text (`[text](target)` and `![alt](target)`), outside code
/// blocks and code spans, with their line numbers.
fn links(text: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    let mut fenced = false;
    for (n, line) in text.lines().enumerate() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
            continue;
        }
        if fenced {
            continue;
        }
        // Drop code spans.
        let mut plain = String::new();
        let mut in_code = false;
        for c in line.chars() {
            if c == '`' {
                in_code = !in_code;
            } else if !in_code {
                plain.push(c);
            }
        }
        let mut rest = plain.as_str();
        while let Some(i) = rest.find("](") {
            let after = &rest[i + 2..];
            let Some(j) = after.find(')') else { break };
            let target = after[..j].split_whitespace().next().unwrap_or("");
            if !target.is_empty() {
                out.push((n + 1, target.to_string()));
            }
            rest = &after[j..];
        }
    }
    out
}

#[test]
fn slugs_follow_github() {
    assert_eq!(slug(" Choosing a granularity"), "choosing-a-granularity");
    assert_eq!(
        slug(" `kind = \"simulation\"` (`raysched simulate`, feature `simgrid`)"),
        "kind--simulation-raysched-simulate-feature-simgrid"
    );
    assert_eq!(slug(" 1. A scene"), "1-a-scene");
    assert_eq!(
        links("a [x](b.md#c) `[y](no.md)` ![i](p.png \"t\")"),
        [(1, "b.md#c".to_string()), (1, "p.png".to_string())]
    );
}

#[test]
fn every_relative_link_and_anchor_resolves() {
    let files = markdown_files();
    assert!(files.len() > 10, "{} Markdown files", files.len());
    let mut broken = Vec::new();
    for file in &files {
        let text = std::fs::read_to_string(file).unwrap();
        let rel = file.strip_prefix(root()).unwrap().display().to_string();
        for (line, target) in links(&text) {
            if target.contains("://") || target.starts_with("mailto:") {
                continue;
            }
            let (path, anchor) = match target.split_once('#') {
                Some((p, a)) => (p, Some(a)),
                None => (target.as_str(), None),
            };
            let dest = if path.is_empty() {
                file.clone()
            } else {
                file.parent().unwrap().join(path)
            };
            if !dest.exists() {
                broken.push(format!("{rel}:{line}: {target} (no such file)"));
                continue;
            }
            if let Some(a) = anchor {
                if dest.extension().is_some_and(|e| e == "md") {
                    let known = anchors(&std::fs::read_to_string(&dest).unwrap());
                    if !known.contains(a) {
                        broken.push(format!("{rel}:{line}: {target} (no such anchor)"));
                    }
                }
            }
        }
    }
    assert!(broken.is_empty(), "broken links:\n{}", broken.join("\n"));
}

#[test]
fn readme_is_a_front_door() {
    let readme = std::fs::read_to_string(root().join("README.md")).unwrap();
    let lines = readme.lines().count();
    assert!(lines <= 250, "README.md has {lines} lines (at most 250)");
    for needed in [
        "cargo run --release -- run experiments/quick.toml",
        "bash .ci/run",
        "docs/getting-started.md",
        "docs/concepts.md",
        "docs/findings.md",
    ] {
        assert!(readme.contains(needed), "README.md lacks {needed}");
    }
}

/// The snapshot names `results/README.md` lists in its index table (first column, in
/// backticks).
fn indexed_snapshots(index: &str) -> BTreeSet<String> {
    index
        .lines()
        .filter(|l| l.starts_with("| `"))
        .filter_map(|l| l[3..].split('`').next().map(str::to_string))
        .collect()
}

#[test]
fn results_index_lists_every_published_snapshot_with_its_setup() {
    let index = std::fs::read_to_string(root().join("results/README.md")).unwrap();
    let listed = indexed_snapshots(&index);
    let published = root().join("results/published");
    let folders: BTreeSet<String> = std::fs::read_dir(&published)
        .unwrap()
        .flatten()
        .filter(|e| e.path().is_dir())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(
        listed, folders,
        "results/README.md's index and results/published/ disagree"
    );
    for name in &folders {
        let setup = published.join(name).join("SETUP.md");
        let text = std::fs::read_to_string(&setup)
            .unwrap_or_else(|_| panic!("results/published/{name}/SETUP.md is missing"));
        for field in [
            "| machine |",
            "| date |",
            "| commit |",
            "| duration |",
            "```sh",
        ] {
            assert!(text.contains(field), "{name}/SETUP.md lacks {field}");
        }
        assert!(
            index.contains(&format!("(published/{name}/SETUP.md)")),
            "results/README.md does not link {name}/SETUP.md"
        );
    }
}

/// What git keeps under `results/` stays small enough to travel with the working tree, and
/// holds no scripts: an analysis worth keeping is a command or an example.
#[test]
fn published_results_stay_small_and_hold_no_scripts() {
    fn walk(dir: &Path, total: &mut u64, scripts: &mut Vec<PathBuf>) {
        for e in std::fs::read_dir(dir).unwrap().flatten() {
            let p = e.path();
            if p.is_dir() {
                if p.file_name().is_some_and(|n| n == "timelines") {
                    continue; // ignored by git
                }
                walk(&p, total, scripts);
            } else {
                let ext = p.extension().and_then(|e| e.to_str()).unwrap_or("");
                if ext == "svg" || ext == "exr" {
                    continue; // ignored by git
                }
                if ext == "py" || ext == "sh" {
                    scripts.push(p.clone());
                }
                *total += e.metadata().unwrap().len();
            }
        }
    }
    let (mut total, mut scripts) = (0, Vec::new());
    walk(&root().join("results/published"), &mut total, &mut scripts);
    assert!(scripts.is_empty(), "scripts under results/: {scripts:?}");
    assert!(
        total <= 10_000_000,
        "results/published holds {total} bytes (at most 10 MB)"
    );
}

/// Hand-written scheduler counts and id lists drift each time a kind is added: README.md,
/// docs/concepts.md and docs/experiment-format.md hold neither (the generated
/// docs/reference/schedulers.md does: see `reference.rs`). The README's sentence on `quick`
/// names the kinds `experiments/quick.toml` runs, every one of them, and no "every scheduler".
#[test]
fn scheduler_counts_and_id_lists_are_generated_not_written() {
    use raysched::sched::SchedulerKind;
    let ids: Vec<&str> = SchedulerKind::ALL.iter().map(|k| k.id()).collect();
    const NUMBERS: [&str; 19] = [
        "two",
        "three",
        "four",
        "five",
        "six",
        "seven",
        "eight",
        "nine",
        "ten",
        "eleven",
        "twelve",
        "thirteen",
        "fourteen",
        "fifteen",
        "sixteen",
        "seventeen",
        "eighteen",
        "nineteen",
        "twenty",
    ];
    let is_number = |w: &str| NUMBERS.contains(&w) || w.parse::<u32>().is_ok_and(|n| n > 1);
    let mut found = Vec::new();
    for doc in ["README.md", "docs/concepts.md", "docs/experiment-format.md"] {
        let text = std::fs::read_to_string(root().join(doc)).unwrap();
        // A paragraph, or one table row: where a hand-written list would sit.
        let units = text
            .split("\n\n")
            .flat_map(|p| {
                if p.trim_start().starts_with('|') {
                    p.lines().map(str::to_owned).collect::<Vec<_>>()
                } else {
                    vec![p.to_owned()]
                }
            })
            .collect::<Vec<_>>();
        for unit in &units {
            let named = ids
                .iter()
                .filter(|id| unit.contains(&format!("`{id}`")))
                .count();
            if named > ids.len() / 2 {
                found.push(format!("{doc}: a list of {named} scheduler ids: {unit}"));
            }
            let words: Vec<String> = unit
                .split(|c: char| !c.is_alphanumeric())
                .filter(|w| !w.is_empty())
                .map(str::to_lowercase)
                .collect();
            for w in words.windows(2) {
                let counted = is_number(&w[0])
                    && ["scheduler", "schedulers", "kinds", "ids", "policies"]
                        .contains(&w[1].as_str());
                if counted || (w[0] == "among" && is_number(&w[1])) {
                    found.push(format!("{doc}: a count '{} {}'", w[0], w[1]));
                }
            }
        }
    }
    assert!(found.is_empty(), "{}", found.join("\n"));
    let readme = std::fs::read_to_string(root().join("README.md")).unwrap();
    let quick_para = readme
        .split("\n\n")
        .find(|p| p.contains("the `quick` experiment"))
        .expect("the README introduces the quick experiment");
    assert!(
        !quick_para.contains("every scheduler"),
        "quick.toml does not run every kind: {quick_para}"
    );
    let quick: toml::Value =
        toml::from_str(&std::fs::read_to_string(root().join("experiments/quick.toml")).unwrap())
            .unwrap();
    let said = quick_para.replace(['-', '\n'], "_").replace(' ', "_");
    for s in quick["schedulers"].as_array().unwrap() {
        let kind = s["kind"].as_str().unwrap();
        assert!(
            said.contains(kind),
            "the README's quick sentence leaves out {kind}: {quick_para}"
        );
    }
}

/// The bless command docs/extending.md gives runs the reference test on the release profile
/// (a checkout that built only `--release` reuses its dependencies) and its filter selects
/// `reference::reference_pages_match_the_code`.
#[test]
fn the_bless_command_in_extending_md_selects_the_reference_test_on_release() {
    let text = std::fs::read_to_string(root().join("docs/extending.md")).unwrap();
    let cmd = text
        .split('`')
        .find(|s| s.starts_with("RAYSCHED_BLESS=1 cargo test"))
        .expect("extending.md gives the bless command");
    let words: Vec<&str> = cmd.split_whitespace().collect();
    assert!(words.contains(&"--release"), "{cmd}");
    let at = words.iter().position(|w| *w == "--test").expect("--test");
    assert_eq!(words.get(at + 1), Some(&"it"), "{cmd}");
    let filter = words.get(at + 2).expect("a test filter");
    assert!(
        "reference::reference_pages_match_the_code".contains(filter),
        "{cmd}"
    );
}
