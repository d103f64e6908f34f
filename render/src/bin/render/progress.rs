//! Progress on stderr: indicatif's bar on a terminal; elsewhere (a farm log, a pipe, a file) one plain
//! line at most every `interval` seconds and one when the last tile finishes, because a bar redrawn
//! with carriage returns is unreadable in a log and a log that stays silent until the end tells an
//! operator nothing.

use render::Progress;
use std::io::Write;
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// Where progress goes.
pub enum Reporter {
    /// A terminal: the bar.
    Bar(indicatif::ProgressBar),
    /// Anything else: periodic lines.
    Lines(Lines),
}

impl Reporter {
    /// The bar if stderr is a terminal, else lines every `interval`.
    pub fn for_stderr(terminal: bool, interval: Duration) -> Self {
        if terminal {
            let bar = indicatif::ProgressBar::new(0);
            bar.set_style(
                indicatif::ProgressStyle::with_template(
                    "{bar:40} {pos}/{len} tiles {elapsed_precise} eta {eta}",
                )
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
            );
            Reporter::Bar(bar)
        } else {
            Reporter::Lines(Lines::new(interval))
        }
    }

    /// Reports `p` (called from the worker threads).
    pub fn report(&self, p: Progress) {
        match self {
            Reporter::Bar(bar) => {
                bar.set_length(p.samples_total);
                bar.set_position(p.samples_done);
            }
            Reporter::Lines(lines) => {
                if let Some(line) = lines.due(p, Instant::now()) {
                    // A log line lost to a closed pipe must not fail the render.
                    let _ = writeln!(std::io::stderr().lock(), "{line}");
                }
            }
        }
    }

    /// Clears the bar once the render is done.
    pub fn finish(&self) {
        if let Reporter::Bar(bar) = self {
            bar.finish_and_clear();
        }
    }
}

/// Periodic progress lines: the render's start and the time of the last line printed.
pub struct Lines {
    start: Instant,
    interval: Duration,
    last: Mutex<Option<Instant>>,
}

impl Lines {
    /// Lines at most every `interval`, the clock starting now.
    pub fn new(interval: Duration) -> Self {
        Lines { start: Instant::now(), interval, last: Mutex::new(None) }
    }

    /// The line to print for `p` at `now`, if one is due: the first report after `interval` since
    /// the last line (or the start), and always the last tile's.
    pub fn due(&self, p: Progress, now: Instant) -> Option<String> {
        let mut last = self.last.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
        let since = now.saturating_duration_since(last.unwrap_or(self.start));
        let finished = p.samples_done == p.samples_total;
        if !finished && since < self.interval {
            return None;
        }
        *last = Some(now);
        Some(line(p, now.saturating_duration_since(self.start)))
    }
}

/// `render: 42.0% (1.2/2.9 Msamples), 12.3 s elapsed, eta 17.0 s, 0.10 Msamples/s`; the ETA assumes
/// the remaining samples go at the rate so far.
pub fn line(p: Progress, elapsed: Duration) -> String {
    let fraction = if p.samples_total == 0 { 1.0 } else { p.samples_done as f64 / p.samples_total as f64 };
    let seconds = elapsed.as_secs_f64();
    let rate = if seconds > 0.0 { p.samples_done as f64 / seconds } else { 0.0 };
    let eta = if rate > 0.0 {
        format!("{:.1} s", (p.samples_total - p.samples_done) as f64 / rate)
    } else {
        "unknown".to_string()
    };
    format!(
        "render: {:.1}% ({:.1}/{:.1} Msamples), {seconds:.1} s elapsed, eta {eta}, {:.2} Msamples/s",
        100.0 * fraction,
        p.samples_done as f64 / 1e6,
        p.samples_total as f64 / 1e6,
        rate / 1e6,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(tiles_done: usize, samples_done: u64) -> Progress {
        Progress { tiles_done, tiles_total: 4, samples_done, samples_total: 4_000_000 }
    }

    #[test]
    fn lines_name_percent_elapsed_eta_and_rate() {
        let line = line(at(1, 1_000_000), Duration::from_secs(2));
        assert_eq!(line, "render: 25.0% (1.0/4.0 Msamples), 2.0 s elapsed, eta 6.0 s, 0.50 Msamples/s");
    }

    #[test]
    fn lines_come_at_most_every_interval_and_always_at_the_end() {
        let lines = Lines::new(Duration::from_secs(10));
        let t0 = lines.start;
        assert_eq!(lines.due(at(1, 1), t0 + Duration::from_secs(3)), None, "too early");
        let first = lines.due(at(2, 2), t0 + Duration::from_secs(11)).expect("due after 10 s");
        assert!(first.starts_with("render: 0.0% (0.0/4.0 Msamples), 11.0 s"), "{first}");
        assert_eq!(lines.due(at(3, 3), t0 + Duration::from_secs(15)), None, "4 s after the last line");
        let last = lines.due(at(4, 4_000_000), t0 + Duration::from_secs(16)).expect("the last tile always");
        assert!(last.starts_with("render: 100.0% (4.0/4.0 Msamples)"), "{last}");
    }
}
