//! Field checks of stage two: every error names the file and the field.

use glam::DVec3;

/// A bad scene: which file, which field (or line), and what is wrong with it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{path}{}: {field}{}{msg}", line.map(|l| format!(":{l}")).unwrap_or_default(), if field.is_empty() { "" } else { ": " })]
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
    pub(crate) fn finite(&self, field: &str, v: f64) -> Result<f64, SceneError> {
        if v.is_finite() {
            Ok(v)
        } else {
            Err(self.err(field, format!("must be a finite number (got {v})")))
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
