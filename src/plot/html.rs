//! `report.html`: `report.md` as one self-contained page (plots as inline SVG, tables sortable
//! by a few lines of inline script, nothing fetched), written beside it.

use super::Figure;
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

/// A table cell: sorts by the number it starts with (`data-v`) where it starts with one.
fn cell(tag: &str, text: &str) -> String {
    let lead: String = text
        .trim()
        .trim_start_matches('`')
        .chars()
        .take_while(|c| c.is_ascii_digit() || *c == '.' || *c == '-' || *c == '+')
        .collect();
    match lead.parse::<f64>() {
        Ok(v) if v.is_finite() && tag == "td" => {
            format!("<td data-v=\"{v}\">{}</td>", inline_md(text.trim()))
        }
        _ => format!("<{tag}>{}</{tag}>", inline_md(text.trim())),
    }
}

/// The cells of a Markdown table line `| a | b |`.
fn cells(line: &str) -> Vec<&str> {
    let t = line.trim();
    let t = t.strip_prefix('|').unwrap_or(t);
    let t = t.strip_suffix('|').unwrap_or(t);
    t.split('|').collect()
}

/// A Markdown table (its lines, the header first) as a sortable HTML table.
fn table(lines: &[&str]) -> String {
    let mut h = String::from("<table class=\"sortable\"><thead><tr>");
    for c in cells(lines[0]) {
        h += &cell("th", c);
    }
    h += "</tr></thead><tbody>\n";
    for l in lines.iter().skip(2) {
        h += "<tr>";
        for c in cells(l) {
            h += &cell("td", c);
        }
        h += "</tr>\n";
    }
    h + "</tbody></table>\n"
}

/// `![title](file)`: the figure's file, if the line is one.
fn image(line: &str) -> Option<&str> {
    let rest = line.strip_prefix("![")?;
    let open = rest.find("](")?;
    rest[open + 2..].strip_suffix(')')
}

/// `report.md`'s text as one self-contained page: headings, paragraphs, lists and tables as
/// they are (tables sortable by a click), each plot's SVG inline where the Markdown links its
/// PNG. Rendered from the Markdown itself, so the page holds every section and every number
/// the Markdown does. `staged` is where this drawing's SVGs are.
pub fn render(dir: &Path, staged: &Path, md: &str) -> String {
    let name = md
        .lines()
        .next()
        .and_then(|l| l.strip_prefix("# "))
        .unwrap_or("Experiment");
    let mut h = format!(
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\
         <meta name=\"viewport\" content=\"width=device-width\">\
         <title>{}</title><style>{STYLE}</style></head><body>\n",
        escape(&name.replace('`', ""))
    );
    let lines: Vec<&str> = md.lines().collect();
    let mut i = 0;
    let mut list = 0usize; // open <ul> levels
    let close_lists = |h: &mut String, list: &mut usize, to: usize| {
        while *list > to {
            *h += "</ul>\n";
            *list -= 1;
        }
    };
    while i < lines.len() {
        let l = lines[i];
        let item = l.trim_start().strip_prefix("- ");
        if item.is_none() {
            close_lists(&mut h, &mut list, 0);
        }
        if let Some(text) = item {
            let level = (l.len() - l.trim_start().len()) / 2 + 1;
            close_lists(&mut h, &mut list, level);
            while list < level {
                h += "<ul>\n";
                list += 1;
            }
            let _ = writeln!(h, "<li>{}</li>", inline_md(text));
        } else if l.starts_with('|') {
            let start = i;
            while i < lines.len() && lines[i].starts_with('|') {
                i += 1;
            }
            h += &table(&lines[start..i]);
            continue;
        } else if let Some(file) = image(l) {
            let fig = Figure {
                file: file.to_string(),
                title: String::new(),
                caption: String::new(),
            };
            if let Some(svg) = svg_of(dir, staged, &fig) {
                let _ = writeln!(h, "<figure>{svg}</figure>");
            }
        } else if let Some((hashes, text)) = l
            .split_once(' ')
            .filter(|(a, _)| !a.is_empty() && a.len() <= 4 && a.chars().all(|c| c == '#'))
        {
            let n = hashes.len();
            let _ = writeln!(h, "<h{n}>{}</h{n}>", inline_md(text));
        } else if !l.trim().is_empty() {
            let _ = writeln!(h, "<p>{}</p>", inline_md(l));
        }
        i += 1;
    }
    close_lists(&mut h, &mut list, 0);
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
