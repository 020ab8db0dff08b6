//! Progress lines of long commands: how much is done, and an estimate of the time left from
//! the time per unit so far.

use std::time::Duration;

/// "1:05 left" (minutes:seconds) from `elapsed` for `done` of `total` units, or "done".
/// Before any unit is done there is nothing to estimate from: "? left".
pub fn eta(elapsed: Duration, done: usize, total: usize) -> String {
    if done >= total {
        return "done".into();
    }
    if done == 0 {
        return "? left".into();
    }
    let left = elapsed.as_secs_f64() / done as f64 * (total - done) as f64;
    format!("{} left", clock(left))
}

/// "0:41 elapsed, about 5:02 left": the time left estimated from the units measured up to
/// the last checkpoint (`at`: the time and the units done then), where units finish in
/// bursts (a matrix group's cells all end with its rounds) and the time of one burst's
/// first unit says nothing of the rest.
pub fn elapsed_and_left(
    elapsed: Duration,
    at: Option<(Duration, usize)>,
    done: usize,
    total: usize,
) -> String {
    let left = match at {
        _ if done >= total => "done".to_string(),
        Some((t, n)) if n > 0 => {
            let per_unit = t.as_secs_f64() / n as f64;
            let left = per_unit * (total - done) as f64;
            format!("about {} left", clock(left))
        }
        _ => "time left: after the first group".to_string(),
    };
    format!("{} elapsed, {left}", clock(elapsed.as_secs_f64()))
}

/// Seconds as minutes:seconds.
pub fn clock(seconds: f64) -> String {
    let s = seconds.max(0.0).round() as u64;
    format!("{}:{:02}", s / 60, s % 60)
}

/// A count of units done out of a total, shown on stderr: on a terminal a bar with the
/// time left and the unit at work on a line of its own; off a terminal (a log, CI, a pipe)
/// one line per unit done, with the count and the time left. Hidden, it shows nothing.
pub struct Bar {
    bar: indicatif::ProgressBar,
    lines: bool,
    total: usize,
    done: usize,
    started: std::time::Instant,
    /// The time and units done at the last checkpoint (`checkpoint`).
    checkpoint: Option<(Duration, usize)>,
}

impl Bar {
    pub fn new(shown: bool, total: usize) -> Bar {
        use std::io::IsTerminal;
        let terminal = shown && std::io::stderr().is_terminal();
        let bar = if terminal {
            indicatif::ProgressBar::new(total as u64)
        } else {
            indicatif::ProgressBar::hidden()
        };
        bar.set_style(
            indicatif::ProgressStyle::with_template("[{bar:30}] {pos}/{len}, {prefix}\n{wide_msg}")
                .expect("valid template")
                .progress_chars("=> "),
        );
        Bar {
            bar,
            lines: shown && !terminal,
            total,
            done: 0,
            started: std::time::Instant::now(),
            checkpoint: None,
        }
    }

    /// Units finish in bursts: estimate the time left from the units done by now.
    pub fn checkpoint(&mut self) {
        self.checkpoint = Some((self.started.elapsed(), self.done));
        self.bar.set_prefix(self.times());
    }

    fn times(&self) -> String {
        elapsed_and_left(
            self.started.elapsed(),
            self.checkpoint,
            self.done,
            self.total,
        )
    }

    /// One unit done: `what` it was and how it ended.
    pub fn done(&mut self, what: &str) {
        self.done += 1;
        self.bar.inc(1);
        self.bar.set_prefix(self.times());
        if self.lines {
            eprintln!("[{}/{}] {what}; {}", self.done, self.total, self.times());
        }
    }

    /// What is at work now (on a terminal only: off one, each unit says so when done).
    pub fn status(&self, what: String) {
        self.bar.set_message(what);
    }

    /// A line of its own, above the bar.
    pub fn println(&self, line: String) {
        if self.bar.is_hidden() {
            eprintln!("{line}");
        } else {
            self.bar.println(line);
        }
    }

    pub fn finish(&self) {
        self.bar.finish_and_clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_estimate_is_the_time_per_unit_times_the_units_left() {
        assert_eq!(eta(Duration::from_secs(10), 2, 5), "0:15 left");
        assert_eq!(eta(Duration::from_secs(10), 0, 5), "? left");
        assert_eq!(eta(Duration::from_secs(10), 5, 5), "done");
        assert_eq!(clock(125.4), "2:05");
    }

    /// The estimate comes from the checkpoint, not from the units that ended since: ten
    /// units in 100 s at the checkpoint, 20 done of 50 by 101 s (a burst), 30 left at 10 s
    /// each.
    #[test]
    fn the_estimate_waits_for_a_checkpoint() {
        let s = Duration::from_secs;
        assert_eq!(
            elapsed_and_left(s(101), Some((s(100), 10)), 20, 50),
            "1:41 elapsed, about 5:00 left"
        );
        assert_eq!(
            elapsed_and_left(s(30), None, 1, 50),
            "0:30 elapsed, time left: after the first group"
        );
        assert_eq!(elapsed_and_left(s(30), None, 5, 5), "0:30 elapsed, done");
    }
}
