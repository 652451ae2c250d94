//! Progress of a run: a bar on a terminal, plain periodic lines elsewhere (a log, CI), both
//! counting timed samples against an upper bound that shrinks as configurations finish early.

use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::time::{Duration, Instant};

/// Seconds between two plain progress lines.
const LINE_EVERY: Duration = Duration::from_secs(10);

/// The run's progress display.
pub struct Progress {
    bar: Option<ProgressBar>,
    plain: bool,
    started: Instant,
    last_line: Instant,
    done: u64,
    bound: u64,
    message: String,
}

impl Progress {
    /// A bar (stderr is a terminal), plain lines (it is not), or nothing (`quiet`); `bound` is
    /// the most samples the run can take.
    pub fn new(quiet: bool, bound: u64) -> Self {
        let tty = std::io::stderr().is_terminal();
        let bar = (!quiet && tty).then(|| {
            let b = ProgressBar::new(bound);
            b.set_style(
                ProgressStyle::with_template(
                    "{bar:20} {pos}/≤{len} · {elapsed} · ETA ≤{eta} · {msg}",
                )
                .expect("valid template"),
            );
            b
        });
        Self {
            bar,
            plain: !quiet && !tty,
            started: Instant::now(),
            last_line: Instant::now(),
            done: 0,
            bound,
            message: String::new(),
        }
    }

    /// The configuration being measured.
    pub fn set_message(&mut self, msg: String) {
        if let Some(b) = &self.bar {
            b.set_message(msg.clone());
        }
        self.message = msg;
    }

    /// The most samples the run can still reach, counting those done.
    pub fn set_bound(&mut self, bound: u64) {
        self.bound = bound.max(self.done);
        if let Some(b) = &self.bar {
            b.set_length(self.bound);
        }
    }

    /// One sample done.
    pub fn inc(&mut self) {
        self.done += 1;
        if let Some(b) = &self.bar {
            b.inc(1);
        }
        if self.plain && self.last_line.elapsed() >= LINE_EVERY {
            self.last_line = Instant::now();
            eprintln!("{}", self.line());
        }
    }

    /// The plain progress line, at most 80 columns.
    pub fn line(&self) -> String {
        let el = self.started.elapsed().as_secs_f64();
        let eta = if self.done > 0 {
            el / self.done as f64 * (self.bound - self.done) as f64
        } else {
            0.0
        };
        let head = format!(
            "{}/≤{} samples, {} elapsed, ETA ≤{} · ",
            self.done,
            self.bound,
            clock(el),
            clock(eta)
        );
        let room = 80usize.saturating_sub(head.chars().count());
        let msg: String = self.message.chars().take(room).collect();
        head + &msg
    }

    /// Print a line without breaking the bar.
    pub fn println(&self, text: &str) {
        match &self.bar {
            Some(b) => b.suspend(|| eprintln!("{text}")),
            None => eprintln!("{text}"),
        }
    }

    /// The run is over after `measured` samples: the bar ends on that count.
    pub fn finish(&mut self, measured: usize) {
        self.set_bound(measured as u64);
        if let Some(b) = &self.bar {
            b.finish_and_clear();
        }
    }
}

/// `m:ss` (or `h:mm:ss`).
fn clock(s: f64) -> String {
    let s = s.max(0.0).round() as u64;
    if s >= 3600 {
        format!("{}:{:02}:{:02}", s / 3600, s / 60 % 60, s % 60)
    } else {
        format!("{}:{:02}", s / 60, s % 60)
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn plain_lines_fit_80_columns() {
        let mut p = super::Progress::new(true, 1000);
        p.set_message(
            "cornell_box · bvh · work_stealing chunk=frame order=scanline grab=1 ×2 and more"
                .repeat(3),
        );
        p.inc();
        let l = p.line();
        assert!(l.chars().count() <= 80, "{l}");
        assert!(l.starts_with("1/≤1000 samples, 0:00 elapsed"), "{l}");
        assert_eq!(super::clock(3725.0), "1:02:05");
    }
}
