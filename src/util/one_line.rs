//! Error text stays on one line: a file name may hold any byte but `/` and NUL, a newline
//! included, and an error that names it must still be one line (the contract of every
//! refusal: one line, exit code 2).

use std::borrow::Cow;
use std::fmt;

/// `s` with every control character (newline, tab, escape, …) written as its Rust escape
/// (`\n`, `\t`, `\u{1b}`); unchanged, without a copy, where it has none.
pub fn escape_controls(s: &str) -> Cow<'_, str> {
    if !s.chars().any(char::is_control) {
        return Cow::Borrowed(s);
    }
    let mut out = String::with_capacity(s.len() + 8);
    for c in s.chars() {
        if c.is_control() {
            out.extend(c.escape_default());
        } else {
            out.push(c);
        }
    }
    Cow::Owned(out)
}

/// Displays a string through [`escape_controls`] (for `thiserror` format strings).
pub struct OneLine<'a>(pub &'a str);

impl fmt::Display for OneLine<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&escape_controls(self.0))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn control_characters_are_escaped_and_plain_text_is_not_copied() {
        assert_eq!(
            escape_controls("co\nell\t.toml\u{1b}"),
            "co\\nell\\t.toml\\u{1b}"
        );
        assert!(matches!(escape_controls("scenes/é.toml"), Cow::Borrowed(_)));
        assert_eq!(OneLine("a\r\nb").to_string(), "a\\r\\nb");
    }
}
