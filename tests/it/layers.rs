//! No two files of `src/` import each other, directly or around a circle: the crate stays in
//! layers, a lower module never reaching up into a higher one (issue 51).
//!
//! The graph is read from the source text: a file imports another when it names a path into it,
//! in a `use` tree or inline (`crate::…`, `super::…`, `self::…`, `raysched::…`, or a child
//! module's name). A path ends at the deepest module that is a file, and an item that file only
//! re-exports (`pub use`) is followed to the file that defines it. Comments and strings are not
//! read. The circles are the graph's strongly connected components of more than one file.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// A token of Rust source, as much of it as the import graph needs.
#[derive(Clone, Debug, PartialEq)]
enum Tok {
    Ident(String),
    /// `::`
    Sep,
    Open,
    Close,
    Semi,
    Comma,
    Star,
    Other(char),
}

/// The tokens of `text`, without comments, strings, char literals and numbers' insides, and
/// the line (from 1) each starts on.
fn lex(text: &str) -> (Vec<Tok>, Vec<usize>) {
    let c: Vec<char> = text.chars().collect();
    let mut out = Vec::new();
    let mut lines: Vec<usize> = Vec::new();
    // The line of the character at `pos`, counted forward as `i` moves.
    let (mut line, mut pos) = (1usize, 0usize);
    let mut i = 0;
    // Skips a string whose opening `"` is at `i`, ending after `#` × hashes.
    let skip_str = |mut i: usize, hashes: usize, raw: bool| -> usize {
        i += 1;
        while i < c.len() {
            if !raw && c[i] == '\\' {
                i += 2;
                continue;
            }
            if c[i] == '"' && (0..hashes).all(|h| c.get(i + 1 + h) == Some(&'#')) {
                return i + 1 + hashes;
            }
            i += 1;
        }
        i
    };
    while i < c.len() {
        // Tokens pushed by the last step start on the line where that step began.
        lines.resize(out.len(), line);
        while pos < i {
            line += usize::from(c[pos] == '\n');
            pos += 1;
        }
        let ch = c[i];
        if ch.is_whitespace() {
            i += 1;
        } else if ch == '/' && c.get(i + 1) == Some(&'/') {
            while i < c.len() && c[i] != '\n' {
                i += 1;
            }
        } else if ch == '/' && c.get(i + 1) == Some(&'*') {
            let mut depth = 0;
            while i < c.len() {
                if c[i] == '/' && c.get(i + 1) == Some(&'*') {
                    depth += 1;
                    i += 2;
                } else if c[i] == '*' && c.get(i + 1) == Some(&'/') {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    i += 1;
                }
            }
        } else if ch == '"' {
            i = skip_str(i, 0, false);
            out.push(Tok::Other('"'));
        } else if ch == '\'' {
            // A char literal ('x', '\n', '\u{1F600}') or a lifetime ('a).
            if c.get(i + 1) == Some(&'\\') {
                i += 2;
                while i < c.len() && c[i] != '\'' {
                    i += 1;
                }
                i += 1;
            } else if c.get(i + 2) == Some(&'\'') {
                i += 3;
            } else {
                i += 1;
            }
            out.push(Tok::Other('\''));
        } else if ch.is_alphabetic() || ch == '_' {
            let start = i;
            while i < c.len() && (c[i].is_alphanumeric() || c[i] == '_') {
                i += 1;
            }
            let word: String = c[start..i].iter().collect();
            let raw_str = matches!(word.as_str(), "r" | "br" | "cr")
                && matches!(c.get(i), Some('"') | Some('#'));
            if raw_str {
                let mut hashes = 0;
                while c.get(i + hashes) == Some(&'#') {
                    hashes += 1;
                }
                if c.get(i + hashes) == Some(&'"') {
                    i = skip_str(i + hashes, hashes, true);
                    out.push(Tok::Other('"'));
                    continue;
                }
            }
            if matches!(word.as_str(), "b" | "c") && c.get(i) == Some(&'"') {
                i = skip_str(i, 0, false);
                out.push(Tok::Other('"'));
                continue;
            }
            out.push(Tok::Ident(word));
        } else if ch.is_ascii_digit() {
            while i < c.len() && (c[i].is_alphanumeric() || c[i] == '_') {
                i += 1;
            }
            out.push(Tok::Other('0'));
        } else {
            i += 1;
            out.push(match ch {
                ':' if c.get(i) == Some(&':') => {
                    i += 1;
                    Tok::Sep
                }
                '{' => Tok::Open,
                '}' => Tok::Close,
                ';' => Tok::Semi,
                ',' => Tok::Comma,
                '*' => Tok::Star,
                _ => Tok::Other(ch),
            });
        }
    }
    lines.resize(out.len(), line);
    (out, lines)
}

/// Which crate of the package a file belongs to: the library or the `raysched` binary
/// (`src/main.rs` and `src/app/`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Krate {
    Lib,
    Bin,
}

/// A module: its crate and its path from the crate root.
type ModPath = (Krate, Vec<String>);

/// One leaf of a `use` tree or one inline path, made absolute.
#[derive(Clone, Debug)]
struct PathRef {
    path: ModPath,
    /// `pub use`: the name under which the current module re-exports the leaf.
    export: Option<String>,
    /// The line the path starts on.
    line: usize,
}

/// The module of each file (relative to `src/`, `/`-separated).
fn module_of(file: &str) -> Option<ModPath> {
    let stem = file.strip_suffix(".rs")?;
    let mut parts: Vec<String> = stem.split('/').map(str::to_string).collect();
    match parts.last().map(String::as_str) {
        Some("mod") => {
            parts.pop();
        }
        Some("lib") | Some("main") if parts.len() == 1 => parts.clear(),
        _ => {}
    }
    let krate = if file == "main.rs" || file.starts_with("app/") {
        Krate::Bin
    } else {
        Krate::Lib
    };
    Some((krate, parts))
}

/// A leaf of a `use` tree: its path, the name it binds, and the index of its last token.
type Leaf = (Vec<String>, String, usize);

/// Parses one `use` tree starting at `toks[*i]`, pushing each leaf as a path under `prefix`
/// (`*` and `self` leave the prefix itself). Leaves `*i` after the tree.
fn use_tree(toks: &[Tok], i: &mut usize, prefix: Vec<String>, out: &mut Vec<Leaf>) {
    let mut path = prefix;
    loop {
        match toks.get(*i) {
            Some(Tok::Sep) => *i += 1,
            Some(Tok::Ident(w)) => {
                let w = w.clone();
                *i += 1;
                let at = *i - 1;
                if w == "self" && !path.is_empty() {
                    let name = path.last().cloned().unwrap_or_default();
                    let name = alias(toks, i).unwrap_or(name);
                    out.push((path, name, at));
                    return;
                }
                path.push(w);
                if toks.get(*i) != Some(&Tok::Sep) {
                    let name = alias(toks, i).unwrap_or_else(|| path.last().cloned().unwrap());
                    out.push((path, name, at));
                    return;
                }
            }
            Some(Tok::Star) => {
                *i += 1;
                out.push((path, "*".to_string(), *i - 1));
                return;
            }
            Some(Tok::Open) => {
                *i += 1;
                while !matches!(toks.get(*i), Some(Tok::Close) | None) {
                    use_tree(toks, i, path.clone(), out);
                    if toks.get(*i) == Some(&Tok::Comma) {
                        *i += 1;
                    }
                }
                *i += 1;
                return;
            }
            _ => return,
        }
    }
}

/// `as name` after a use leaf, consumed.
fn alias(toks: &[Tok], i: &mut usize) -> Option<String> {
    if toks.get(*i) == Some(&Tok::Ident("as".into())) {
        if let Some(Tok::Ident(n)) = toks.get(*i + 1) {
            *i += 2;
            return Some(n.clone());
        }
    }
    None
}

/// Does `#[cfg(test)]` start at `toks[i]`?
fn is_cfg_test(toks: &[Tok], i: usize) -> bool {
    let want = [
        Tok::Other('#'),
        Tok::Other('['),
        Tok::Ident("cfg".into()),
        Tok::Other('('),
        Tok::Ident("test".into()),
        Tok::Other(')'),
        Tok::Other(']'),
    ];
    toks.get(i..i + want.len()) == Some(&want[..])
}

/// The index after the item starting at `toks[i]` (after its attributes): after its first `;`
/// outside braces, or after the brace that closes its first `{`.
fn item_end(toks: &[Tok], mut i: usize) -> usize {
    let mut depth = 0usize;
    while i < toks.len() {
        match toks[i] {
            Tok::Open => depth += 1,
            Tok::Close => {
                depth = depth.saturating_sub(1);
                if depth == 0 {
                    return i + 1;
                }
            }
            Tok::Semi if depth == 0 => return i + 1,
            _ => {}
        }
        i += 1;
    }
    i
}

/// The paths one file names, made absolute. `children` says which modules exist, so that a
/// path may start at a child module of the current one.
fn paths_of(file: &str, text: &str, modules: &BTreeSet<ModPath>) -> Vec<PathRef> {
    let Some((krate, here)) = module_of(file) else {
        return Vec::new();
    };
    let (toks, lines) = lex(text);
    // The module at each depth: the file's, then its inline `mod name { … }` blocks.
    let mut scope: Vec<(Vec<String>, usize)> = vec![(here, 0)];
    let mut depth = 0usize;
    let mut out = Vec::new();
    let ident = |k: usize| match toks.get(k) {
        Some(Tok::Ident(w)) => Some(w.as_str()),
        _ => None,
    };
    // Makes a relative path absolute from module `cur`; `None` for std, external crates and
    // local names.
    let absolute = |cur: &[String], rel: &[String]| -> Option<ModPath> {
        let mut it = rel.iter().peekable();
        let mut base: Vec<String>;
        let mut k = krate;
        match it.peek().map(|s| s.as_str()) {
            Some("crate") => {
                it.next();
                base = Vec::new();
            }
            Some("raysched") => {
                it.next();
                base = Vec::new();
                k = Krate::Lib;
            }
            Some("self") => {
                it.next();
                base = cur.to_vec();
            }
            Some("super") => base = cur.to_vec(),
            Some(first) => {
                let mut child = cur.to_vec();
                child.push(first.to_string());
                if !modules.contains(&(krate, child)) {
                    return None;
                }
                base = cur.to_vec();
            }
            None => return None,
        }
        while it.peek().map(|s| s.as_str()) == Some("super") {
            it.next();
            base.pop()?;
        }
        base.extend(it.cloned());
        Some((k, base))
    };
    let mut i = 0;
    while i < toks.len() {
        let cur = scope.last().unwrap().0.clone();
        if is_cfg_test(&toks, i) {
            i = item_end(&toks, i + 7);
            continue;
        }
        match &toks[i] {
            Tok::Open => depth += 1,
            Tok::Close => {
                depth = depth.saturating_sub(1);
                if scope.len() > 1 && scope.last().unwrap().1 == depth {
                    scope.pop();
                }
            }
            Tok::Ident(w) if w == "mod" => {
                if let (Some(name), Some(Tok::Open)) = (ident(i + 1), toks.get(i + 2)) {
                    let mut inner = cur.clone();
                    inner.push(name.to_string());
                    scope.push((inner, depth + 1));
                    depth += 1;
                    i += 3;
                    continue;
                }
            }
            Tok::Ident(w) if w == "use" => {
                // `pub use` or `pub(…) use` re-exports.
                let public = ident(i.wrapping_sub(1)) == Some("pub")
                    || (toks.get(i.wrapping_sub(1)) == Some(&Tok::Other(')'))
                        && (2..6).any(|b| ident(i.wrapping_sub(b)) == Some("pub")));
                let mut j = i + 1;
                let mut leaves = Vec::new();
                use_tree(&toks, &mut j, Vec::new(), &mut leaves);
                for (rel, name, at) in leaves {
                    if let Some(path) = absolute(&cur, &rel) {
                        let export = public.then_some(name);
                        let line = lines[at];
                        out.push(PathRef { path, export, line });
                    }
                }
                i = j;
                continue;
            }
            Tok::Ident(_)
                if toks.get(i + 1) == Some(&Tok::Sep)
                    && toks.get(i.wrapping_sub(1)) != Some(&Tok::Sep) =>
            {
                let mut rel = Vec::new();
                let mut j = i;
                while let Some(w) = ident(j) {
                    rel.push(w.to_string());
                    if toks.get(j + 1) != Some(&Tok::Sep) {
                        break;
                    }
                    j += 2;
                }
                if let Some(path) = absolute(&cur, &rel) {
                    let line = lines[i];
                    out.push(PathRef {
                        path,
                        export: None,
                        line,
                    });
                }
                i = j + 1;
                continue;
            }
            _ => {}
        }
        i += 1;
    }
    out
}

/// An import edge: the names the importing file takes from the imported one.
type Edges = BTreeMap<String, BTreeMap<String, BTreeSet<String>>>;

/// Is `module` the root or a `mod.rs` of a module that holds `file`? A file is part of the
/// modules above it: it may use their items without that counting as an import (the parent
/// declares its children, and uses theirs as it likes).
fn is_ancestor(module: &str, file: &str) -> bool {
    match module {
        "lib.rs" | "main.rs" => true,
        _ => module
            .strip_suffix("mod.rs")
            .is_some_and(|dir| file.starts_with(dir) && file != module),
    }
}

/// One import: the importing file and the line of the path, the imported file and the item
/// named there.
#[derive(Clone, Debug)]
struct Import {
    from: String,
    line: usize,
    to: String,
    item: String,
}

/// The file → file import graph of the files `(path relative to src/, text)`.
fn import_graph(files: &[(String, String)]) -> Edges {
    let mut edges = Edges::new();
    for i in imports(files) {
        let names = edges.entry(i.from).or_default().entry(i.to).or_default();
        names.insert(i.item);
    }
    edges
}

/// Every import of the files `(path relative to src/, text)` from one file into another (not
/// into a module above it, [`is_ancestor`]).
fn imports(files: &[(String, String)]) -> Vec<Import> {
    let file_of: BTreeMap<ModPath, String> = files
        .iter()
        .filter_map(|(f, _)| Some((module_of(f)?, f.clone())))
        .collect();
    let modules: BTreeSet<ModPath> = file_of.keys().cloned().collect();
    let refs: BTreeMap<String, Vec<PathRef>> = files
        .iter()
        .map(|(f, t)| (f.clone(), paths_of(f, t, &modules)))
        .collect();
    // Each file's re-exports: exported name → the path it stands for.
    let exports: BTreeMap<&str, BTreeMap<&str, &ModPath>> = refs
        .iter()
        .map(|(f, rs)| {
            let names = rs
                .iter()
                .filter_map(|r| Some((r.export.as_deref()?, &r.path)))
                .collect();
            (f.as_str(), names)
        })
        .collect();
    // The file a path leads to, and the item it names there.
    fn resolve(
        path: &ModPath,
        file_of: &BTreeMap<ModPath, String>,
        exports: &BTreeMap<&str, BTreeMap<&str, &ModPath>>,
        hops: usize,
    ) -> Option<(String, String)> {
        let (k, segs) = path;
        let n = (0..=segs.len())
            .rev()
            .find(|&n| file_of.contains_key(&(*k, segs[..n].to_vec())))?;
        let file = &file_of[&(*k, segs[..n].to_vec())];
        let Some(item) = segs.get(n) else {
            return Some((file.clone(), segs.last().cloned().unwrap_or_default()));
        };
        if hops < 8 {
            if let Some(target) = exports
                .get(file.as_str())
                .and_then(|e| e.get(item.as_str()))
            {
                if let Some(found) = resolve(target, file_of, exports, hops + 1) {
                    return Some(found);
                }
            }
        }
        Some((file.clone(), item.clone()))
    }
    let mut out = Vec::new();
    for (from, rs) in &refs {
        for r in rs {
            if let Some((to, item)) = resolve(&r.path, &file_of, &exports, 0) {
                if &to != from && !is_ancestor(&to, from) {
                    out.push(Import {
                        from: from.clone(),
                        line: r.line,
                        to,
                        item,
                    });
                }
            }
        }
    }
    out
}

/// The circles of the graph: its strongly connected components of more than one file, each
/// sorted, with the edges inside it (Tarjan's algorithm).
fn circles(edges: &Edges) -> Vec<Vec<String>> {
    struct Tarjan<'a> {
        edges: &'a Edges,
        index: BTreeMap<&'a str, usize>,
        low: BTreeMap<&'a str, usize>,
        stack: Vec<&'a str>,
        on_stack: BTreeSet<&'a str>,
        found: Vec<Vec<String>>,
    }
    impl<'a> Tarjan<'a> {
        fn visit(&mut self, v: &'a str) {
            let n = self.index.len();
            self.index.insert(v, n);
            self.low.insert(v, n);
            self.stack.push(v);
            self.on_stack.insert(v);
            for w in self.edges.get(v).into_iter().flat_map(|m| m.keys()) {
                let w = w.as_str();
                if !self.index.contains_key(w) {
                    self.visit(w);
                    let lw = self.low[w];
                    let lv = self.low.get_mut(v).unwrap();
                    *lv = (*lv).min(lw);
                } else if self.on_stack.contains(w) {
                    let iw = self.index[w];
                    let lv = self.low.get_mut(v).unwrap();
                    *lv = (*lv).min(iw);
                }
            }
            if self.low[v] == self.index[v] {
                let mut comp = Vec::new();
                loop {
                    let w = self.stack.pop().unwrap();
                    self.on_stack.remove(w);
                    comp.push(w.to_string());
                    if w == v {
                        break;
                    }
                }
                if comp.len() > 1 {
                    comp.sort();
                    self.found.push(comp);
                }
            }
        }
    }
    let mut t = Tarjan {
        edges,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on_stack: BTreeSet::new(),
        found: Vec::new(),
    };
    for v in edges.keys() {
        if !t.index.contains_key(v.as_str()) {
            t.visit(v);
        }
    }
    t.found.sort();
    t.found
}

/// Each circle as lines `a.rs -> b.rs: names`, for a failure message.
fn describe(edges: &Edges, circles: &[Vec<String>]) -> String {
    let mut s = String::new();
    for (n, comp) in circles.iter().enumerate() {
        s += &format!(
            "circle {} ({} files): {}\n",
            n + 1,
            comp.len(),
            comp.join(", ")
        );
        for from in comp {
            for (to, names) in edges.get(from).into_iter().flatten() {
                if comp.contains(to) {
                    let names: Vec<&str> = names.iter().map(String::as_str).collect();
                    s += &format!("  {from} -> {to}: {}\n", names.join(", "));
                }
            }
        }
    }
    s
}

/// Every `.rs` file under `dir`, as (path relative to `dir`, text).
fn sources(dir: &Path) -> Vec<(String, String)> {
    fn walk(root: &Path, dir: &Path, out: &mut Vec<(String, String)>) {
        let mut entries: Vec<_> = std::fs::read_dir(dir).unwrap().flatten().collect();
        entries.sort_by_key(|e| e.path());
        for e in entries {
            let p = e.path();
            if p.is_dir() {
                walk(root, &p, out);
            } else if p.extension().is_some_and(|x| x == "rs") {
                let rel = p
                    .strip_prefix(root)
                    .unwrap()
                    .to_string_lossy()
                    .replace('\\', "/");
                out.push((rel, std::fs::read_to_string(&p).unwrap()));
            }
        }
    }
    let mut out = Vec::new();
    walk(dir, dir, &mut out);
    out
}

#[test]
fn no_two_files_import_each_other() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let files = sources(&src);
    assert!(files.len() > 100, "read only {} files of src/", files.len());
    let edges = import_graph(&files);
    // The graph is read at all: the run path reaches the schedulers.
    assert!(edges["studies/experiment/run/mod.rs"]
        .keys()
        .any(|f| f.starts_with("sched/")));
    let found = circles(&edges);
    assert!(
        found.is_empty(),
        "import circles in src/:\n{}",
        describe(&edges, &found)
    );
}

/// A small crate whose files are given as (path, text).
fn planted(files: &[(&str, &str)]) -> Vec<(String, String)> {
    files
        .iter()
        .map(|(f, t)| (f.to_string(), t.to_string()))
        .collect()
}

#[test]
fn a_planted_circle_is_found_and_named() {
    // a -> b through a `use` of an item b re-exports from its child; b/inner -> a inline.
    let files = planted(&[
        ("lib.rs", "pub mod a; pub mod b;"),
        (
            "a.rs",
            "use crate::b::Thing;\npub fn f() -> Thing { Thing }",
        ),
        ("b/mod.rs", "mod inner;\npub use inner::Thing;"),
        (
            "b/inner.rs",
            "pub struct Thing;\nfn g() { super::super::a::f(); }",
        ),
        (
            "c.rs",
            "use crate::a::f; // crate::c2::x in a comment\nconst S: &str = \"crate::b::Thing\";",
        ),
    ]);
    let edges = import_graph(&files);
    assert_eq!(edges["a.rs"].keys().collect::<Vec<_>>(), ["b/inner.rs"]);
    assert_eq!(
        edges["b/inner.rs"]["a.rs"],
        BTreeSet::from(["f".to_string()])
    );
    assert_eq!(edges["c.rs"].keys().collect::<Vec<_>>(), ["a.rs"]);
    let found = circles(&edges);
    assert_eq!(found, [vec!["a.rs".to_string(), "b/inner.rs".to_string()]]);
    let text = describe(&edges, &found);
    assert!(text.contains("a.rs -> b/inner.rs: Thing"), "{text}");
    assert!(text.contains("b/inner.rs -> a.rs: f"), "{text}");
}

#[test]
fn layers_without_a_circle_pass() {
    // Two files importing a third, and an inline test module's `use super::*`, make no circle.
    let files = planted(&[
        ("lib.rs", "pub mod low; pub mod mid; pub mod top;"),
        (
            "low.rs",
            "pub fn base() {}\n#[cfg(test)]\nmod tests { use super::*; }",
        ),
        (
            "mid.rs",
            "use crate::low::{self, base};\npub fn m() { base(); low::base(); }",
        ),
        (
            "top.rs",
            "use crate::{low::base, mid::m};\nfn t() { base(); m(); }",
        ),
    ]);
    let edges = import_graph(&files);
    assert_eq!(edges["top.rs"].len(), 2);
    assert!(!edges.contains_key("low.rs"));
    assert!(circles(&edges).is_empty());
}

/// The layers of `src/`, bottom → top: a file may import from its own layer and the layers
/// below it, never from one above. Each layer lists its rooms, a room being a path under `src/`
/// (a folder ending in `/`, or a file); a file belongs to the room of the longest path that
/// holds it. The crate roots (`lib.rs`, `main.rs`) declare every module and sit above all.
/// A move of folders rewrites these paths (`/work/notes/layout.sh` does), nothing else.
const LAYERS: &[(&str, &[&str])] = &[
    (
        "base",
        &[
            "util/",
            "util/hash.rs",
            "util/rng.rs",
            "util/limits.rs",
            "util/provenance.rs",
        ],
    ),
    ("geometry", &["core/mod.rs", "core/geometry.rs"]),
    ("scene", &["core/scene/"]),
    ("tracer", &["core/tracer/"]),
    ("render", &["core/render/"]),
    ("gpu", &["core/gpu/"]),
    ("metrics", &["core/metrics/"]),
    ("source", &["source/"]),
    ("sched", &["sched/"]),
    // The drawing kit: axes, fonts, styles and raster output, read by every study's charts.
    (
        "drawing",
        &[
            "plot/axes.rs",
            "plot/font.rs",
            "plot/style.rs",
            "plot/raster.rs",
        ],
    ),
    ("profile", &["studies/mod.rs", "studies/profile/"]),
    ("model", &["studies/model/"]),
    ("convergence", &["studies/converge/", "studies/stability/"]),
    ("experiment", &["studies/experiment/"]),
    ("plot", &["plot/"]),
    (
        "simulation",
        &["studies/simulate/", "studies/simulate/simgrid/"],
    ),
    ("launch", &["mpi/"]),
    ("reference", &["reference.rs"]),
    ("app", &["app/"]),
];

/// The layer (index into [`LAYERS`]) and room of `file`; `None` for the crate roots and for
/// a file no room holds.
fn layer_of<'a>(layers: &[(&str, &[&'a str])], file: &str) -> Option<(usize, &'a str)> {
    layers
        .iter()
        .enumerate()
        .flat_map(|(n, (_, rooms))| rooms.iter().map(move |r| (n, *r)))
        .filter(|(_, r)| file == *r || (r.ends_with('/') && file.starts_with(r)))
        .max_by_key(|(_, r)| r.len())
}

/// Every import from a lower layer into a higher one, as a line `file:line: layer → layer:
/// imported file (item)`.
fn upward(layers: &[(&str, &[&str])], imports: &[Import]) -> Vec<String> {
    let mut out: Vec<String> = imports
        .iter()
        .filter_map(|i| {
            let (lf, _) = layer_of(layers, &i.from)?;
            let (lt, _) = layer_of(layers, &i.to)?;
            (lf < lt).then(|| {
                format!(
                    "src/{}:{}: {} imports {} from src/{} ({}, a higher layer)",
                    i.from, i.line, layers[lf].0, i.item, i.to, layers[lt].0
                )
            })
        })
        .collect();
    out.sort();
    out.dedup();
    out
}

#[test]
fn no_file_imports_from_a_higher_layer() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let files = sources(&src);
    // Every file sits in a room, and every room of the table exists: a new folder is placed
    // on purpose, a moved one is not checked by a stale path.
    let roots = ["lib.rs", "main.rs"];
    let homeless: Vec<&str> = files
        .iter()
        .map(|(f, _)| f.as_str())
        .filter(|f| !roots.contains(f) && layer_of(LAYERS, f).is_none())
        .collect();
    assert!(homeless.is_empty(), "files in no layer: {homeless:?}");
    for (_, rooms) in LAYERS {
        for r in *rooms {
            assert!(
                files.iter().any(|(f, _)| f == r || f.starts_with(r)),
                "layer table names {r}, which holds no file of src/"
            );
        }
    }
    let all = imports(&files);
    // The check reads something: the run path imports from the layers below it.
    let down = all
        .iter()
        .filter(|i| i.from.starts_with("sched/") && i.to.starts_with("source/"))
        .count();
    assert!(down > 0, "no import of sched/ from source/ found");
    let up = upward(LAYERS, &all);
    assert!(
        up.is_empty(),
        "{} imports reach up a layer (layers bottom → top: {}):\n{}",
        up.len(),
        LAYERS.iter().map(|l| l.0).collect::<Vec<_>>().join(" < "),
        up.join("\n")
    );
}

#[test]
fn a_planted_upward_import_is_found_with_its_line() {
    let files = planted(&[
        ("lib.rs", "pub mod low; pub mod high;"),
        ("high.rs", "use crate::low::base;\npub fn h() { base(); }"),
        (
            "low/mod.rs",
            "mod deep;\npub fn base() {}\n#[cfg(test)]\nmod tests { use crate::high::h; }",
        ),
        ("low/deep.rs", "pub fn d() {\n\n    crate::high::h();\n}"),
    ]);
    let layers: &[(&str, &[&str])] = &[("low", &["low/"]), ("high", &["high.rs"])];
    let up = upward(layers, &imports(&files));
    // The inline test module's import is not the library's; the body's is, on line 3.
    assert_eq!(
        up,
        ["src/low/deep.rs:3: low imports h from src/high.rs (high, a higher layer)"]
    );
    // Turned around, the same crate is in order but for high.rs's import.
    let flipped: &[(&str, &[&str])] = &[("high", &["high.rs"]), ("low", &["low/"])];
    assert_eq!(
        upward(flipped, &imports(&files)),
        ["src/high.rs:1: high imports base from src/low/mod.rs (low, a higher layer)"]
    );
}
