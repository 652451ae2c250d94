//! Usage errors as one line that names the flag and says what it takes, with a "did you mean"
//! from [`raysched::util::suggest`] for a misspelt flag, subcommand or value; and the command
//! line's own description as JSON (`raysched cli-spec`, what the CLI fuzzer enumerates).
//!
//! clap's own messages spread over several lines (possible values, tips, usage); only the
//! first is printed, so whatever names the flag or the fix must be on it.

use clap::error::{ContextKind, ContextValue, ErrorKind};
use clap::{Arg, Command};
use raysched::util::one_line::escape_controls;
use raysched::util::suggest::did_you_mean;
use std::ffi::OsString;

/// `e` as the one line printed on stderr, `error: …`.
pub(crate) fn one_line(e: &clap::Error, cmd: &Command, argv: &[OsString]) -> String {
    let text = |k: ContextKind| match e.get(k) {
        Some(ContextValue::String(s)) => s.clone(),
        Some(ContextValue::Strings(v)) => v.join(", "),
        _ => String::new(),
    };
    let list = |k: ContextKind| match e.get(k) {
        Some(ContextValue::Strings(v)) => v.clone(),
        Some(ContextValue::String(s)) => vec![s.clone()],
        _ => Vec::new(),
    };
    let sub = subcommand(cmd, argv);
    let line = match e.kind() {
        ErrorKind::UnknownArgument => {
            let arg = text(ContextKind::InvalidArg);
            if let Some(line) = hyphen_value(sub.unwrap_or(cmd), argv) {
                line
            } else {
                // clap names `-n` of `-nan`: the whole argument is what the user wrote.
                let arg = argv
                    .iter()
                    .filter_map(|a| a.to_str())
                    .find(|a| a.starts_with(arg.as_str()) && arg.starts_with('-'))
                    .map_or(arg.clone(), str::to_string);
                let name = arg.split('=').next().unwrap_or_default();
                let longs: Vec<String> = sub
                    .unwrap_or(cmd)
                    .get_arguments()
                    .filter(|a| !a.is_hide_set())
                    .filter_map(|a| a.get_long().map(|l| format!("--{l}")))
                    .collect();
                format!(
                    "unexpected argument '{}'{}",
                    escape_controls(&arg),
                    did_you_mean(name, longs.iter().map(String::as_str))
                )
            }
        }
        ErrorKind::InvalidSubcommand => {
            let name = text(ContextKind::InvalidSubcommand);
            let names: Vec<&str> = cmd
                .get_subcommands()
                .filter(|c| !c.is_hide_set())
                .map(Command::get_name)
                .collect();
            format!(
                "unknown command '{}'{} (commands: {})",
                escape_controls(&name),
                did_you_mean(&name, names.iter().copied()),
                names.join(", ")
            )
        }
        ErrorKind::InvalidValue => {
            let value = text(ContextKind::InvalidValue);
            let valid = list(ContextKind::ValidValue);
            let flag = text(ContextKind::InvalidArg);
            let takes = if valid.is_empty() {
                String::new()
            } else {
                format!(" (takes {})", valid.join(", "))
            };
            if value.is_empty() {
                format!("{flag}: needs a value{takes}")
            } else {
                format!(
                    "invalid value '{}' for '{flag}'{takes}{}",
                    escape_controls(&value),
                    did_you_mean(&value, valid.iter().map(String::as_str))
                )
            }
        }
        ErrorKind::ValueValidation => {
            let why = std::error::Error::source(e).map_or(String::new(), |s| format!(": {s}"));
            format!(
                "invalid value '{}' for '{}'{}",
                escape_controls(&text(ContextKind::InvalidValue)),
                text(ContextKind::InvalidArg),
                escape_controls(&why)
            )
        }
        ErrorKind::MissingRequiredArgument => {
            format!("missing {}", list(ContextKind::InvalidArg).join(", "))
        }
        ErrorKind::InvalidUtf8 => match non_utf8(sub.unwrap_or(cmd), argv) {
            Some(flag) => format!("{flag}: not valid UTF-8"),
            None => "an argument is not valid UTF-8".to_string(),
        },
        _ => {
            let rendered = e.to_string();
            let first = rendered.lines().next().unwrap_or("bad arguments");
            return escape_controls(first).into_owned();
        }
    };
    format!(
        "error: {}",
        line.split_whitespace().collect::<Vec<_>>().join(" ")
    )
}

/// The subcommand `argv` names (its first argument that is one), if any.
fn subcommand<'a>(cmd: &'a Command, argv: &[OsString]) -> Option<&'a Command> {
    argv.iter()
        .skip(1)
        .filter_map(|a| a.to_str())
        .find(|a| !a.starts_with('-'))
        .and_then(|name| cmd.find_subcommand(name))
}

/// The long flag (`--spp`) that takes a value, if `token` is one (`--spp` or `--spp=…`).
fn value_flag<'a>(cmd: &'a Command, token: &str) -> Option<&'a Arg> {
    let name = token.strip_prefix("--")?.split('=').next()?;
    cmd.get_arguments()
        .find(|a| a.get_long() == Some(name) && a.get_action().takes_values())
}

/// `--spp -inf`: a value beginning with `-` that is not a number is taken for a flag, and clap
/// blames `-i`. Say which flag lacks its value and how to give it.
fn hyphen_value(cmd: &Command, argv: &[OsString]) -> Option<String> {
    let args: Vec<&str> = argv.iter().map(|a| a.to_str().unwrap_or("")).collect();
    args.windows(2).find_map(|w| {
        let flag = value_flag(cmd, w[0]).filter(|_| !w[0].contains('='))?;
        let value = w[1];
        let is_flag = |t: &str| {
            t.strip_prefix("--")
                .and_then(|n| n.split('=').next())
                .is_some_and(|n| cmd.get_arguments().any(|a| a.get_long() == Some(n)))
        };
        (value.starts_with('-') && value.len() > 1 && !is_flag(value)).then(|| {
            let long = flag.get_long().unwrap_or_default();
            format!(
                "--{long}: needs a value; '{v}' was read as a flag (write --{long}={v} to give it as the value)",
                v = escape_controls(value)
            )
        })
    })
}

/// The flag whose value (or the argument itself) is not valid UTF-8.
fn non_utf8(cmd: &Command, argv: &[OsString]) -> Option<String> {
    let i = argv.iter().position(|a| a.to_str().is_none())?;
    let before = i.checked_sub(1).and_then(|j| argv[j].to_str());
    match before.and_then(|b| value_flag(cmd, b)) {
        Some(a) => Some(format!("--{}", a.get_long().unwrap_or_default())),
        None => Some(format!("argument {i} ('{}')", argv[i].to_string_lossy())),
    }
}

/// Every command and its arguments, from clap's definition: `[{"name", "args": [{"id",
/// "long", "positional", "takes_value", "required", "hidden", "values"}]}]`.
pub(crate) fn spec_json(cmd: &Command) -> String {
    let commands: Vec<serde_json::Value> = cmd
        .get_subcommands()
        .map(|c| {
            let args: Vec<serde_json::Value> = c
                .get_arguments()
                .filter(|a| !matches!(a.get_id().as_str(), "help" | "version"))
                .map(|a| {
                    serde_json::json!({
                        "id": a.get_id().as_str(),
                        "long": a.get_long(),
                        "positional": a.is_positional(),
                        "takes_value": a.get_action().takes_values(),
                        "required": a.is_required_set(),
                        "hidden": a.is_hide_set(),
                        "values": a
                            .get_possible_values()
                            .iter()
                            .map(|v| v.get_name().to_string())
                            .collect::<Vec<_>>(),
                    })
                })
                .collect();
            serde_json::json!({ "name": c.get_name(), "hidden": c.is_hide_set(), "args": args })
        })
        .collect();
    serde_json::Value::Array(commands).to_string()
}
