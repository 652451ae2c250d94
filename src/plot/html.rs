//! `report.html`: the report as one self-contained page (plots as inline SVG, tables sortable
//! by a few lines of inline script, nothing fetched), written beside `report.md`.

use super::compare::speedup_text;
use super::report::{answer, chunk_curves, chunk_words_pub as chunk_words};
use super::Figure;
use crate::experiment::summary::Summary;
use std::fmt::Write;
use std::path::Path;

/// `<`, `>`, `&` and quotes escaped.
pub fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// The report's Markdown sentences as HTML: escaped, `code` and **bold** kept.
fn inline_md(s: &str) -> String {
    let e = escape(s);
    let mut out = String::new();
    let (mut code, mut bold) = (false, false);
    let mut chars = e.chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '`' => {
                out += if code { "</code>" } else { "<code>" };
                code = !code;
            }
            '*' if chars.peek() == Some(&'*') && !code => {
                chars.next();
                out += if bold { "</b>" } else { "<b>" };
                bold = !bold;
            }
            c => out.push(c),
        }
    }
    if code {
        out += "</code>";
    }
    if bold {
        out += "</b>";
    }
    out
}

/// The SVG of `fig`: beside its staged PNG in `staged`, else in the results folder `dir`.
fn svg_of(dir: &Path, staged: &Path, fig: &Figure) -> Option<String> {
    let name = Path::new(&fig.file).with_extension("svg");
    let file = name.file_name()?;
    [staged.join(file), dir.join(&name)]
        .iter()
        .find_map(|p| std::fs::read_to_string(p).ok())
        .map(|s| match s.find("<svg") {
            Some(i) => s[i..].to_string(),
            None => String::new(),
        })
}

const STYLE: &str =
    "body{font-family:sans-serif;max-width:1100px;margin:1em auto;padding:0 1em;color:#111}\
table{border-collapse:collapse;font-size:13px;margin:.5em 0}\
th,td{border:1px solid #bbb;padding:2px 6px;text-align:left}\
th{background:#eee;cursor:pointer;user-select:none}\
th[aria-sort=ascending]::after{content:' ▲'}th[aria-sort=descending]::after{content:' ▼'}\
.warn{background:#fff3cd;border:1px solid #e0b000;padding:.5em 1em}\
figure{margin:1em 0}figure svg{max-width:100%;height:auto}figcaption{font-size:13px;color:#333}\
code{background:#f3f3f3;padding:0 2px}";

/// Sorts a table by the clicked column: numbers (`data-v`) numerically, the rest as text.
const SCRIPT: &str = r#"
document.querySelectorAll('table.sortable').forEach(function (t) {
  t.querySelectorAll('th').forEach(function (th, col) {
    th.addEventListener('click', function () {
      var asc = th.getAttribute('aria-sort') !== 'ascending';
      t.querySelectorAll('th').forEach(function (h) { h.removeAttribute('aria-sort'); });
      th.setAttribute('aria-sort', asc ? 'ascending' : 'descending');
      var body = t.tBodies[0];
      var rows = Array.prototype.slice.call(body.rows);
      var key = function (r) {
        var c = r.cells[col];
        var v = c.getAttribute('data-v');
        return v !== null ? parseFloat(v) : c.textContent;
      };
      rows.sort(function (a, b) {
        var x = key(a), y = key(b);
        var d = (typeof x === 'number' && typeof y === 'number') ? x - y : String(x).localeCompare(String(y));
        return asc ? d : -d;
      });
      rows.forEach(function (r) { body.appendChild(r); });
    });
  });
});
document.body.setAttribute('data-ready', 'yes');
"#;

/// A cell that sorts by the number `v`.
fn num(text: String, v: f64) -> String {
    format!(
        "<td data-v=\"{}\">{}</td>",
        if v.is_finite() { v } else { 0.0 },
        escape(&text)
    )
}

/// Every configuration of a group as a sortable table.
fn table(sums: &[&Summary]) -> String {
    let mut h = String::from("<table class=\"sortable\"><thead><tr><th>configuration</th><th>scheduler</th><th>chunk</th><th>workers</th><th>median wall (s)</th><th>95 % CI of median (s)</th><th>speedup (95 % CI)</th><th>efficiency</th><th>runs</th></tr></thead><tbody>\n");
    for s in sums {
        let speed = s.speedup.map_or(s.speedup_median, |r| r.value);
        let _ = writeln!(
            h,
            "<tr><td><code>{}</code></td><td>{}</td>{}{}{}{}{}{}{}</tr>",
            escape(&s.row.label),
            escape(&s.row.scheduler),
            num(chunk_words(s), s.row.chunk_px.unwrap_or(0) as f64),
            num(s.row.workers.to_string(), s.row.workers as f64),
            num(format!("{:.4}", s.wall_median), s.wall_median),
            num(
                format!("{:.4} – {:.4}", s.wall_median_ci.0, s.wall_median_ci.1),
                s.wall_median_ci.0
            ),
            num(speedup_text(s), speed),
            num(
                format!("{:.0} %", s.efficiency_median * 100.0),
                s.efficiency_median
            ),
            num(s.n.to_string(), s.n as f64),
        );
    }
    h + "</tbody></table>\n"
}

/// The page: warnings first, then per scene the answer, the chunk curves in words and the
/// full table, then every figure inline. `staged` is where this drawing's SVGs are.
pub fn render(
    dir: &Path,
    staged: &Path,
    warnings: &[String],
    sums: &[Summary],
    figs: &[Figure],
) -> String {
    let name = sums
        .first()
        .map_or("experiment", |s| s.row.experiment.as_str());
    let mut h = format!(
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\
         <meta name=\"viewport\" content=\"width=device-width\">\
         <title>Experiment {n}</title><style>{STYLE}</style></head><body>\n<h1>Experiment <code>{n}</code></h1>\n",
        n = escape(name)
    );
    if !warnings.is_empty() {
        h += "<div class=\"warn\"><h2>Warnings</h2><ul>\n";
        for w in warnings {
            let _ = writeln!(h, "<li>{}</li>", inline_md(w));
        }
        h += "</ul></div>\n";
    }
    let mut groups: Vec<String> = Vec::new();
    for s in sums {
        if !groups.contains(&s.group()) {
            groups.push(s.group());
        }
    }
    h += "<h2>Answer</h2>\n";
    for g in &groups {
        let in_g: Vec<&Summary> = sums
            .iter()
            .filter(|s| &s.group() == g && !s.row.on_mpi() && !s.row.is_serial())
            .collect();
        if in_g.is_empty() {
            continue;
        }
        let _ = writeln!(h, "<h3>{}</h3>", escape(g));
        if let Some(a) = answer(g, &in_g) {
            let _ = writeln!(h, "<p>{}</p>", inline_md(&a));
        }
        let curves = chunk_curves(&in_g);
        if !curves.is_empty() {
            h += "<ul>\n";
            for c in curves {
                let _ = writeln!(h, "<li>{}</li>", inline_md(c.trim_start_matches("- ")));
            }
            h += "</ul>\n";
        }
        h += "<p>Every configuration (click a column to sort):</p>\n";
        h += &table(&in_g);
    }
    if !figs.is_empty() {
        h += "<h2>Plots</h2>\n";
    }
    for f in figs {
        let Some(svg) = svg_of(dir, staged, f) else {
            continue;
        };
        let _ = writeln!(
            h,
            "<figure><h3>{}</h3>{svg}<figcaption>{}</figcaption></figure>",
            escape(&f.title),
            inline_md(&f.caption)
        );
    }
    h += "<p>Data: <code>runs.csv</code>, <code>summary.csv</code>, <code>meta.toml</code>; <code>report.md</code> has the machine and the full text. Regenerate with <code>raysched plot &lt;this folder&gt;</code>.</p>\n";
    let _ = write!(h, "<script>{SCRIPT}</script>\n</body></html>\n");
    h
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn markdown_marks_become_tags_and_text_is_escaped() {
        assert_eq!(
            inline_md("**a** `<b>` & c"),
            "<b>a</b> <code>&lt;b&gt;</code> &amp; c"
        );
    }
}
