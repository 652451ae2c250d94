//! Field checks of stage two: every error names the file and the field.

use crate::util::one_line::OneLine;
use glam::DVec3;

/// A bad scene: which file, which field (or line), and what is wrong with it; one line,
/// whatever bytes the file name holds ([`OneLine`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{}{}: {}{}{}", OneLine(path), line.map(|l| format!(":{l}")).unwrap_or_default(), OneLine(field), if field.is_empty() { "" } else { ": " }, OneLine(msg))]
pub struct SceneError {
    /// The scene file, as named in the error.
    pub path: String,
    /// 1-based line of a TOML syntax error; `None` for a field error.
    pub line: Option<usize>,
    /// The offending field as a dotted path (`shapes[1].radius`); empty when the error is about
    /// the whole file.
    pub field: String,
    /// What is wrong.
    pub msg: String,
}

/// `v` as an error shows it: 1e39, not forty digits.
fn short(v: f64) -> String {
    if v.is_finite() && v != 0.0 && !(1e-6..1e16).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        v.to_string()
    }
}

/// The file being checked, for errors.
pub(super) struct Ctx<'a> {
    pub path: &'a str,
}

impl Ctx<'_> {
    pub(crate) fn err(&self, field: impl Into<String>, msg: impl Into<String>) -> SceneError {
        SceneError {
            path: self.path.to_string(),
            line: None,
            field: field.into(),
            msg: msg.into(),
        }
    }
    /// `v` finite and within f32's range (render space is f32: 1e39 would become infinite).
    pub(crate) fn finite(&self, field: &str, v: f64) -> Result<f64, SceneError> {
        if v.is_finite() && v.abs() <= f32::MAX as f64 {
            Ok(v)
        } else {
            Err(self.err(
                field,
                format!(
                    "must be a finite number with |x| ≤ 3.4e38 (f32 range; got {})",
                    short(v)
                ),
            ))
        }
    }
    /// A position or direction once it is in render space (f32): an error on `field` when a
    /// placement or the camera offset took it out of f32's range.
    pub(crate) fn placed(&self, field: &str, v: DVec3) -> Result<glam::Vec3, SceneError> {
        let f = v.as_vec3();
        if f.is_finite() {
            Ok(f)
        } else {
            Err(self.err(
                field,
                format!("placed in render space at {v}, outside f32's range (|x| ≤ 3.4e38)"),
            ))
        }
    }
    pub(crate) fn vec3(&self, field: &str, v: [f64; 3]) -> Result<DVec3, SceneError> {
        for x in v {
            self.finite(field, x)?;
        }
        Ok(DVec3::from_array(v))
    }
    pub(crate) fn non_negative3(&self, field: &str, v: [f64; 3]) -> Result<DVec3, SceneError> {
        let d = self.vec3(field, v)?;
        if d.min_element() < 0.0 {
            return Err(self.err(field, format!("must be ≥ 0 (got {v:?})")));
        }
        Ok(d)
    }
    pub(crate) fn positive(&self, field: &str, v: f64) -> Result<f64, SceneError> {
        self.finite(field, v)?;
        if v <= 0.0 {
            return Err(self.err(field, format!("must be > 0 (got {v})")));
        }
        Ok(v)
    }
}

/// Where a TOML error is and what it says, in one line: `(line, column)` (1-based) of its
/// span, the dotted key it is about when one can be read off the text (`camera.origin`,
/// `shapes[1].radius`; empty when none), and the message with its line breaks removed (the
/// `toml` crate's messages for syntax errors span several lines).
pub fn toml_error_at(text: &str, e: &toml::de::Error) -> (Option<(usize, usize)>, String, String) {
    let msg = e.message().split_whitespace().collect::<Vec<_>>().join(" ");
    let msg = with_suggestion(msg);
    let Some(span) = e.span() else {
        return (None, String::new(), msg);
    };
    let at = floor_char_boundary(text, span.start.min(text.len()));
    let line_start = text[..at].rfind('\n').map_or(0, |i| i + 1);
    let line = text[..at].matches('\n').count() + 1;
    let col = text[line_start..at].chars().count() + 1;
    (Some((line, col)), key_at(text, line_start), msg)
}

/// serde's "unknown field `samles`, expected one of `spp`, …" (or variant) with the nearest
/// expected name after the unknown one: "unknown field `samles` (did you mean `samples`?), …".
fn with_suggestion(msg: String) -> String {
    let Some(rest) = ["unknown field `", "unknown variant `"]
        .iter()
        .find_map(|p| msg.find(p).map(|i| i + p.len()))
    else {
        return msg;
    };
    let Some(end) = msg[rest..].find('`').map(|i| rest + i) else {
        return msg;
    };
    let Some(expected) = msg[end..].find("expected").map(|i| end + i) else {
        return msg;
    };
    let names: Vec<&str> = msg[expected..].split('`').skip(1).step_by(2).collect();
    match crate::util::suggest::nearest(&msg[rest..end], names) {
        Some(n) => format!("{} (did you mean `{n}`?){}", &msg[..=end], &msg[end + 1..]),
        None => msg,
    }
}

fn floor_char_boundary(text: &str, mut i: usize) -> usize {
    while !text.is_char_boundary(i) {
        i -= 1;
    }
    i
}

/// The dotted key of the line starting at byte `line_start`: the last table header above it or
/// on it (`[[shapes]]` counted, so `shapes[1]`) joined with the line's own `key =`, if any.
fn key_at(text: &str, line_start: usize) -> String {
    let mut table = String::new();
    let mut counts = std::collections::BTreeMap::<String, usize>::new();
    // The line itself may be a header: an error about a whole table points at it.
    let line_end = text[line_start..]
        .find('\n')
        .map_or(text.len(), |i| line_start + i);
    for l in text[..line_end].lines() {
        let l = l.trim();
        if let Some(name) = l.strip_prefix("[[").and_then(|r| r.split_once("]]")) {
            let name = name.0.trim().to_string();
            let n = counts.entry(name.clone()).or_insert(0);
            table = format!("{name}[{n}]");
            *n += 1;
        } else if let Some(name) = l.strip_prefix('[').and_then(|r| r.split_once(']')) {
            table = name.0.trim().to_string();
        }
    }
    let this = text[line_start..].lines().next().unwrap_or("");
    let key = this
        .split_once('=')
        .map(|(k, _)| k.trim())
        .filter(|k| {
            !k.is_empty()
                && k.chars()
                    .all(|c| c.is_ascii_alphanumeric() || "_-.\"".contains(c))
        })
        .unwrap_or("");
    match (table.is_empty(), key.is_empty()) {
        (_, true) => table,
        (true, false) => key.to_string(),
        (false, false) => format!("{table}.{key}"),
    }
}

/// Keys whose value is a 3-vector wherever they appear in a scene file.
const VEC3_KEYS: &[&str] = &[
    "origin",
    "target",
    "up",
    "reflectance",
    "even",
    "odd",
    "emission",
    "center",
    "position",
    "intensity",
    "radiance",
    "axis",
    "translate",
];

/// Every vector of a raw scene table has its length (3, or 4×4 for `matrix`), so that an
/// `origin` with 4 components or a colour with 2 is an error naming the key, not a message
/// about the table around it (or, for plain struct fields, silently cut to 3).
pub(super) fn vector_lengths(v: &toml::Value, at: &str) -> Result<(), (String, String)> {
    let join = |k: &str| {
        if at.is_empty() {
            k.to_string()
        } else {
            format!("{at}.{k}")
        }
    };
    match v {
        toml::Value::Table(t) => {
            for (k, v) in t {
                let field = join(k);
                if let toml::Value::Array(a) = v {
                    let len = |n: usize, what: &str| {
                        Err((field.clone(), format!("{what} (got {} values)", n)))
                    };
                    if VEC3_KEYS.contains(&k.as_str()) && a.len() != 3 {
                        return len(a.len(), "must have exactly 3 components");
                    }
                    if k == "scale" && a.len() != 3 {
                        return len(a.len(), "must be one number or exactly 3");
                    }
                    if k == "matrix" {
                        if a.len() != 4 {
                            return len(a.len(), "must have exactly 4 rows");
                        }
                        for (r, row) in a.iter().enumerate() {
                            if let toml::Value::Array(row) = row {
                                if row.len() != 4 {
                                    return Err((
                                        format!("{field}[{r}]"),
                                        format!("must have exactly 4 values (got {})", row.len()),
                                    ));
                                }
                            }
                        }
                    }
                }
                vector_lengths(v, &field)?;
            }
            Ok(())
        }
        toml::Value::Array(a) => {
            for (i, v) in a.iter().enumerate() {
                vector_lengths(v, &format!("{at}[{i}]"))?;
            }
            Ok(())
        }
        _ => Ok(()),
    }
}
