//! The values a scheduler run is described by — granularity ([`Chunk`]), hand-out [`Order`],
//! the master's [`Requeue`] policy and [`Wait`] strategy — and the machinery that turns a
//! kind's parameter struct into CLI flags, TOML keys and CSV columns ([`Params`]).
//!
//! Every value has one text form: what the CLI and TOML accept and what CSV files hold.

use serde::{Deserialize, Serialize};
use std::fmt;
use std::time::Duration;

/// A bad scheduler value: the field (TOML key, or flag without its dashes) and why.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{field}: {msg}")]
pub struct SpecError {
    /// The parameter's name as in TOML (`buffer`, `guided_k`, `workers`, …).
    pub field: String,
    /// What is wrong, with the value that was given.
    pub msg: String,
}

/// A parameter's text that does not parse: what was expected, with the value given. The
/// caller names the field ([`Params::set`] turns it into a [`SpecError`]).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{msg}")]
pub struct ValueError {
    /// What is wrong, with the value that was given.
    pub msg: String,
}

impl ValueError {
    /// The error `msg`.
    pub fn new(msg: impl Into<String>) -> Self {
        Self { msg: msg.into() }
    }
}

pub(crate) fn err(field: &str, msg: impl Into<String>) -> SpecError {
    SpecError {
        field: field.to_string(),
        msg: msg.into(),
    }
}

pub use crate::util::limits::MAX_COUNT;
use crate::util::limits::MAX_IMAGE_SIDE;

/// A value a scheduler parameter can hold, with its one text form.
pub trait ParamValue: Sized {
    /// Parse the text form; the message says what was expected.
    fn parse_value(text: &str) -> Result<Self, ValueError>;
    /// The text form, as CSV files and config keys hold it.
    fn show(&self) -> String;
}

/// Counts (buffer sizes, grabs, divisors): 1 ≤ n ≤ [`MAX_COUNT`].
impl ParamValue for usize {
    fn parse_value(text: &str) -> Result<Self, ValueError> {
        let v: i64 = text
            .trim()
            .parse()
            .map_err(|_| ValueError::new(format!("'{text}': expected a whole number")))?;
        if (1..=MAX_COUNT as i64).contains(&v) {
            Ok(v as usize)
        } else {
            Err(ValueError::new(format!(
                "must be between 1 and {MAX_COUNT} (got {v})"
            )))
        }
    }
    fn show(&self) -> String {
        self.to_string()
    }
}

/// What [`Params`] knows of one parameter: enough to spell its flag, key, column and help.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ParamInfo {
    /// TOML key and CSV column; the CLI flag is `--` + this with `_` → `-`.
    pub name: &'static str,
    /// What it does for the kind that has it.
    pub help: &'static str,
    /// The short name in run labels (`B` for the buffer), or `None` to leave it out.
    pub label: Option<&'static str>,
}

impl ParamInfo {
    /// The command-line flag without its leading dashes.
    pub fn flag(&self) -> String {
        self.name.replace('_', "-")
    }
}

/// A scheduler kind's parameters, reachable by name: what lets the CLI, the experiment grid
/// and the CSV files be derived from one struct. Implemented by [`scheduler_params!`].
pub trait Params {
    /// Every parameter, in column order.
    fn info(&self) -> &'static [ParamInfo];
    /// Set `name` from its text form. `Ok(false)`: this kind has no such parameter.
    ///
    /// # Errors
    /// The text does not parse: a [`SpecError`] naming `name`.
    fn set(&mut self, name: &str, text: &str) -> Result<bool, SpecError>;
    /// The text form of `name`, or `None` when this kind has no such parameter.
    fn get(&self, name: &str) -> Option<String>;
}

/// Declares a kind's parameter struct: each field with its doc (the help text), its label and
/// its default. Generates the struct, a `const DEFAULT` preset, `Default` and [`Params`].
macro_rules! scheduler_params {
    (
        $(#[$meta:meta])*
        pub struct $name:ident {
            $( $( #[doc = $help:literal] )+ $field:ident : $ty:ty = $default:expr, label $label:expr; )*
        }
    ) => {
        $(#[$meta])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
        pub struct $name {
            $( $( #[doc = $help] )+ pub $field: $ty, )*
        }

        impl $name {
            /// The defaults: the same from the CLI and from an experiment file.
            pub const DEFAULT: Self = Self { $( $field: $default, )* };
        }

        impl Default for $name {
            fn default() -> Self {
                Self::DEFAULT
            }
        }

        impl $crate::sched::param::Params for $name {
            fn info(&self) -> &'static [$crate::sched::param::ParamInfo] {
                const INFO: &[$crate::sched::param::ParamInfo] = &[$(
                    $crate::sched::param::ParamInfo {
                        name: stringify!($field),
                        help: concat!($($help),+).trim_ascii(),
                        label: $label,
                    },
                )*];
                INFO
            }
            #[allow(clippy::match_single_binding)] // a kind without parameters
            fn set(
                &mut self,
                name: &str,
                text: &str,
            ) -> Result<bool, $crate::sched::param::SpecError> {
                #[allow(unused_imports)]
                use $crate::sched::param::ParamValue;
                let _ = text;
                match name {
                    $( stringify!($field) => {
                        self.$field = <$ty>::parse_value(text)
                            .map_err(|e| $crate::sched::param::err(name, e.msg))?;
                        Ok(true)
                    } )*
                    _ => Ok(false),
                }
            }
            #[allow(clippy::match_single_binding)]
            fn get(&self, name: &str) -> Option<String> {
                #[allow(unused_imports)]
                use $crate::sched::param::ParamValue;
                match name {
                    $( stringify!($field) => Some(self.$field.show()), )*
                    _ => None,
                }
            }
        }
    };
}
pub(crate) use scheduler_params;

/// Granularity: how many pixels make one work item.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Chunk {
    /// A w×h tile (1×1 = one pixel = per-ray granularity).
    Tile {
        /// Tile width in pixels.
        w: u32,
        /// Tile height in pixels.
        h: u32,
    },
    /// Bands of `n` full rows.
    Rows(u32),
    /// The whole image as one item: one item per frame of an animation (the coarsest item).
    /// Parsed from `frame` or `frames`.
    Frame,
}

impl Chunk {
    /// `1`, `16` (16×16), `8x4`, `rows:4`, `frame` (alias `frames`: one whole frame per item
    /// is what `frame` already means on an animation; one id is written to CSVs).
    pub fn parse(s: &str) -> Result<Self, SpecError> {
        let bad = |m: &str| err("chunk", format!("'{s}': {m}"));
        let pos = |t: &str| -> Result<u32, SpecError> {
            match t.trim().parse::<u64>() {
                Ok(0) => Err(bad("sizes must be ≥ 1 (chunk 0 has no pixels)")),
                Ok(v) if v <= MAX_IMAGE_SIDE as u64 => Ok(v as u32),
                Ok(v) => Err(bad(&format!(
                    "sizes must be ≤ {MAX_IMAGE_SIDE}, the largest image side (got {v})"
                ))),
                Err(_) => Err(bad("expected N, WxH, rows:N, frame or frames")),
            }
        };
        let s = s.trim();
        if s == "frame" || s == "frames" {
            Ok(Self::Frame)
        } else if let Some(n) = s.strip_prefix("rows:") {
            Ok(Self::Rows(pos(n)?))
        } else if let Some((w, h)) = s.split_once(['x', '×']) {
            Ok(Self::Tile {
                w: pos(w)?,
                h: pos(h)?,
            })
        } else {
            let n = pos(s)?;
            Ok(Self::Tile { w: n, h: n })
        }
    }

    /// Pixels per item on an image of this width and height (edge items may be smaller).
    pub fn pixels(&self, width: u32, height: u32) -> u64 {
        match *self {
            Self::Tile { w, h } => w.min(width) as u64 * h.min(height) as u64,
            Self::Rows(n) => width as u64 * n.min(height) as u64,
            Self::Frame => width as u64 * height as u64,
        }
    }
}

impl fmt::Display for Chunk {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Tile { w, h } if w == h => write!(f, "{w}"),
            Self::Tile { w, h } => write!(f, "{w}x{h}"),
            Self::Rows(n) => write!(f, "rows:{n}"),
            Self::Frame => write!(f, "frame"),
        }
    }
}

/// Declares a value enum with snake_case ids: `ALL`, `id()`, `from_id()` and [`ParamValue`].
/// The `impl` form gives an enum defined elsewhere (where it is used) its ids.
macro_rules! id_enum {
    (
        $(#[$meta:meta])* pub enum $name:ident ($field:literal, $what:literal) {
            $( $(#[doc = $doc:literal])* $variant:ident = $id:literal, )*
        }
    ) => {
        $(#[$meta])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
        #[serde(rename_all = "snake_case")]
        pub enum $name {
            $( $(#[doc = $doc])* $variant, )*
        }
        impl $name {
            /// What the value means: its doc comment, one line (the reference pages' text).
            pub fn doc(self) -> String {
                let lines: &[&str] = match self {
                    $( Self::$variant => &[$($doc),*], )*
                };
                lines.iter().map(|l| l.trim()).collect::<Vec<_>>().join(" ")
            }
        }
        id_enum!(impl $name ($field, $what) { $( $variant = $id, )* });
    };
    (impl $name:ident ($field:literal, $what:literal) { $( $variant:ident = $id:literal, )* }) => {
        impl $name {
            /// Every value, in the order help texts list them.
            pub const ALL: [$name; [$(stringify!($variant)),*].len()] = [$(Self::$variant,)*];
            /// The stable snake_case id (CLI, TOML, CSV).
            pub const fn id(self) -> &'static str {
                match self {
                    $( Self::$variant => $id, )*
                }
            }
            /// The value whose id is `s`; the error lists the ids.
            pub fn from_id(s: &str) -> Result<Self, SpecError> {
                Self::ALL.into_iter().find(|v| v.id() == s).ok_or_else(|| {
                    err(
                        $field,
                        format!(
                            concat!("unknown ", $what, " '{}'{} (expected {})"),
                            s,
                            $crate::util::suggest::did_you_mean(s, Self::ALL.iter().map(|v| v.id())),
                            one_of(&Self::ALL.iter().map(|v| v.id()).collect::<Vec<_>>())
                        ),
                    )
                })
            }
        }

        impl ParamValue for $name {
            fn parse_value(text: &str) -> Result<Self, $crate::sched::param::ValueError> {
                Self::from_id(text.trim()).map_err(|e| $crate::sched::param::ValueError::new(e.msg))
            }
            fn show(&self) -> String {
                self.id().to_string()
            }
        }
    };
}
pub(crate) use id_enum;

/// `a, b or c`.
pub(crate) fn one_of(ids: &[&str]) -> String {
    match ids {
        [] => String::new(),
        [one] => one.to_string(),
        [init @ .., last] => format!("{} or {last}", init.join(", ")),
    }
}

id_enum! {
    /// The order items are generated (and so handed out) in.
    pub enum Order("order", "order") {
        /// Row by row, left to right.
        Scanline = "scanline",
        /// Along a Z-order curve.
        Morton = "morton",
        /// Along a Hilbert curve.
        Hilbert = "hilbert",
        /// Outward from the centre cell in a square spiral (Mitsuba's block order: the centre
        /// of the image, where the subject usually is, first).
        Spiral = "spiral",
        /// Stratified: the cells by their Morton index with its bits reversed, so the first 4
        /// cells lie one in each quadrant, the first 16 one in each sixteenth, and any run of
        /// consecutive items samples the whole image evenly (a scattered decomposition,
        /// Nicol & Saltz 1990). The default of the rules that hand out a share of what is
        /// left at once (the factoring family, guided): their analysis assumes item costs
        /// independent of their position in the order, which a hot spot in scanline order is not.
        Scatter = "scatter",
        /// Stratified over small blocks: the image cut into blocks of at least
        /// [`BLOCK_PX`](super::decompose::BLOCK_PX)² pixels, the blocks in `scatter` order and
        /// the cells inside each block consecutive in scanline order. A run of one block's
        /// cells (16 one-pixel items) is coherent, runs of many blocks still sample the whole
        /// image evenly; cells of ≥ 4×4 pixels are their own blocks, so over them it is
        /// `scatter`. A hot spot of few blocks is shared in whole blocks, so less evenly.
        ScatterBlocks = "scatter_blocks",
    }
}

id_enum! {
    /// Where weighted factoring's per-worker weights come from.
    pub enum Weights("weights", "weight source") {
        /// From the run's known slowdown ([`Slow`]): a worker slowed F× gets weight 1/F
        /// (all weights equal when no worker is slowed).
        Known = "known",
        /// Measured online: each worker's time per item over its first chunk, then fixed.
        Measured = "measured",
    }
}

id_enum! {
    /// Who runs the master's passes (results in, sources topped up to B).
    pub enum Passes("passes", "master pass runner") {
        /// A thread of its own that renders nothing: the founding design, for every kind of
        /// compute source.
        Thread = "thread",
        /// The local worker threads, each for itself under one lock whenever it reports
        /// (`sched::exec::locked_master`): no hand-out crosses threads. Local threads only.
        Workers = "workers",
    }
}

/// A heterogeneous run on one machine: the first `workers` workers run every item `factor`×
/// as long (they render it, then spin for `factor − 1` times its render time), so they are
/// a known factor slower than the others. Text form `none` or `K:F` (`1:4`: one worker at a
/// quarter speed).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Slow {
    /// How many workers (the lowest ids) are slowed; 0: none.
    pub workers: u32,
    /// How many times longer each of their items takes (≥ 1).
    pub factor: f64,
}

impl Slow {
    /// No worker slowed.
    pub const NONE: Self = Self {
        workers: 0,
        factor: 1.0,
    };

    /// Is any worker slowed?
    pub fn is_none(&self) -> bool {
        self.workers == 0 || self.factor == 1.0
    }

    /// The slowdown factor of worker `id` (1 for an unslowed one).
    pub fn factor_of(&self, id: usize) -> f64 {
        if (id as u64) < self.workers as u64 {
            self.factor
        } else {
            1.0
        }
    }

    /// `none` or `K:F` with K ≥ 1 workers and 1 ≤ F ≤ 1000.
    pub fn parse(s: &str) -> Result<Self, SpecError> {
        let bad = || {
            err(
                "slow",
                format!(
                    "'{s}': expected none or K:F (K slowed workers, each F× slower, 1 ≤ F ≤ 1000)"
                ),
            )
        };
        let t = s.trim();
        if t == "none" {
            return Ok(Self::NONE);
        }
        let (k, f) = t.split_once(':').ok_or_else(bad)?;
        let k: u32 = k.trim().parse().map_err(|_| bad())?;
        let f: f64 = f.trim().parse().map_err(|_| bad())?;
        if k == 0 || k as usize > MAX_COUNT || !(1.0..=1000.0).contains(&f) {
            return Err(bad());
        }
        Ok(Self {
            workers: k,
            factor: f,
        })
    }
}

impl Default for Slow {
    fn default() -> Self {
        Self::NONE
    }
}

impl fmt::Display for Slow {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.is_none() {
            write!(f, "none")
        } else {
            write!(f, "{}:{}", self.workers, self.factor)
        }
    }
}

/// The master's wait strategy lives with the doorbell it drives (`source`); its ids are here.
pub use crate::source::Wait;

id_enum!(impl Wait ("wait", "wait strategy") {
    Spin = "spin",
    Yield = "yield",
    Block = "block",
});

/// How sources hand the master's results back lives with the sources (`source`); its ids are
/// here.
pub use crate::source::Returns;

id_enum!(impl Returns ("returns", "result return") {
    Item = "item",
    HandOut = "hand_out",
});

/// When the master may hand an outstanding item out again.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Requeue {
    /// Whenever the master meets the unfinished item again in its queue: a handed-out item
    /// goes to the back of the queue and is handed out again when it comes round. Written
    /// `seed` (the founding design's policy; CSV files and experiments use that spelling),
    /// `revisit` is accepted too.
    Revisit,
    /// Only once it has been outstanding this long.
    Timeout(Duration),
    /// Never: a lost item stays lost (the run fails with a count of lost items).
    Never,
}

impl Requeue {
    /// `seed` (also spelled `revisit`), `never`, `timeout:<ms>`.
    pub fn parse(s: &str) -> Result<Self, SpecError> {
        match s.trim() {
            "revisit" | "seed" => Ok(Self::Revisit),
            "never" => Ok(Self::Never),
            t => match t.strip_prefix("timeout:").map(|ms| ms.parse::<u64>()) {
                Some(Ok(ms)) if ms > 0 => Ok(Self::Timeout(Duration::from_millis(ms))),
                _ => Err(err(
                    "requeue",
                    format!(
                        "'{s}': expected seed (alias revisit), never or timeout:<ms> with ms ≥ 1"
                    ),
                )),
            },
        }
    }
}

impl fmt::Display for Requeue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Revisit => write!(f, "seed"),
            Self::Never => write!(f, "never"),
            Self::Timeout(d) => write!(f, "timeout:{}", d.as_millis()),
        }
    }
}

impl ParamValue for Requeue {
    fn parse_value(text: &str) -> Result<Self, ValueError> {
        Self::parse(text).map_err(|e| ValueError::new(e.msg))
    }
    fn show(&self) -> String {
        self.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chunk_parsing() {
        assert_eq!(Chunk::parse("1").unwrap(), Chunk::Tile { w: 1, h: 1 });
        assert_eq!(Chunk::parse("8x4").unwrap(), Chunk::Tile { w: 8, h: 4 });
        assert_eq!(Chunk::parse("rows:3").unwrap(), Chunk::Rows(3));
        assert_eq!(Chunk::parse("frame").unwrap(), Chunk::Frame);
        assert_eq!(Chunk::parse("frames").unwrap(), Chunk::Frame);
        for bad in ["0", "0x4", "rows:0", "x", ""] {
            assert!(Chunk::parse(bad).is_err(), "{bad}");
        }
        for c in ["1", "8x4", "rows:3", "frame"] {
            assert_eq!(Chunk::parse(c).unwrap().to_string(), c);
        }
    }

    #[test]
    fn requeue_parsing() {
        assert_eq!(Requeue::parse("revisit").unwrap(), Requeue::Revisit);
        assert_eq!(Requeue::parse("seed").unwrap(), Requeue::Revisit);
        assert_eq!(
            Requeue::parse("timeout:50").unwrap(),
            Requeue::Timeout(Duration::from_millis(50))
        );
        assert!(Requeue::parse("timeout:0").is_err());
        assert!(Requeue::parse("later").is_err());
        for r in ["seed", "never", "timeout:50"] {
            assert_eq!(Requeue::parse(r).unwrap().show(), r);
        }
    }

    #[test]
    fn ids_round_trip_and_unknown_ids_are_errors() {
        for o in Order::ALL {
            assert_eq!(Order::from_id(o.id()).unwrap(), o);
        }
        for w in Wait::ALL {
            assert_eq!(Wait::parse_value(&w.show()).unwrap(), w);
        }
        assert_eq!(
            Order::from_id("zigzag").unwrap_err().msg,
            "unknown order 'zigzag' (expected scanline, morton, hilbert, spiral, scatter or scatter_blocks)"
        );
        assert_eq!(
            Wait::from_id("nap").unwrap_err().msg,
            "unknown wait strategy 'nap' (expected spin, yield or block)"
        );
    }

    #[test]
    fn slow_parsing() {
        assert_eq!(Slow::parse("none").unwrap(), Slow::NONE);
        let s = Slow::parse("1:4").unwrap();
        assert_eq!((s.workers, s.factor), (1, 4.0));
        assert_eq!((s.factor_of(0), s.factor_of(1)), (4.0, 1.0));
        assert_eq!(s.to_string(), "1:4");
        assert_eq!(Slow::parse("2:1.5").unwrap().to_string(), "2:1.5");
        for bad in ["0:4", "1:0.5", "1", "a:b", "1:2000", ""] {
            assert_eq!(Slow::parse(bad).unwrap_err().field, "slow", "{bad}");
        }
    }

    #[test]
    fn counts_are_bounded() {
        assert_eq!(usize::parse_value("3"), Ok(3));
        assert!(usize::parse_value("0").unwrap_err().msg.contains("got 0"));
        assert!(usize::parse_value("1048577").is_err());
        assert!(usize::parse_value("two")
            .unwrap_err()
            .msg
            .contains("whole number"));
    }
}
