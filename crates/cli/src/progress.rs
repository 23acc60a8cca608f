//! Progress on stderr: a bar on a terminal, a line every few seconds in a
//! log (stderr redirected to a file, a batch system's output), or nothing.
//!
//! `PLSR_PROGRESS=bar|lines|none` chooses; by default a terminal gets the
//! bar and anything else lines, at most one every `PLSR_PROGRESS_SECONDS`
//! (default 10). `--quiet` hides it whatever the choice.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle, TermLike};
use std::io::IsTerminal;
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// How often a log gets a progress line, unless `PLSR_PROGRESS_SECONDS`
/// says otherwise.
const LINE_EVERY: Duration = Duration::from_secs(10);

/// The interval between progress lines: `PLSR_PROGRESS_SECONDS` (a
/// non-negative number) or [`LINE_EVERY`].
fn line_every() -> Duration {
    let Ok(text) = std::env::var("PLSR_PROGRESS_SECONDS") else {
        return LINE_EVERY;
    };
    match text.trim().parse::<f64>() {
        Ok(s) if s.is_finite() && (0.0..1e9).contains(&s) => Duration::from_secs_f64(s),
        _ => {
            warn_once(&format!(
                "PLSR_PROGRESS_SECONDS={text}: expected a number of seconds (using {})",
                LINE_EVERY.as_secs()
            ));
            LINE_EVERY
        }
    }
}

/// Prints a warning about the progress settings, once per process (a
/// command may show several bars).
fn warn_once(message: &str) {
    static WARNED: std::sync::Mutex<Vec<String>> = std::sync::Mutex::new(Vec::new());
    let mut warned = WARNED.lock().unwrap_or_else(|p| p.into_inner());
    if !warned.iter().any(|m| m == message) {
        eprintln!("plsr: warning: {message}");
        warned.push(message.to_string());
    }
}

/// How progress is shown.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Style {
    Bar,
    Lines,
    None,
}

/// The style `PLSR_PROGRESS` asks for, or the default for this stderr.
fn style() -> Style {
    let terminal = std::io::stderr().is_terminal();
    let default = if terminal { Style::Bar } else { Style::Lines };
    match std::env::var("PLSR_PROGRESS").as_deref() {
        Ok("bar") if terminal => Style::Bar,
        Ok("bar") => {
            warn_once("PLSR_PROGRESS=bar: stderr is not a terminal, where a bar cannot be drawn (using lines)");
            Style::Lines
        }
        Ok("lines") => Style::Lines,
        Ok("none") => Style::None,
        Ok(other) => {
            warn_once(&format!(
                "PLSR_PROGRESS={other}: expected bar, lines or none (using {})",
                if terminal { "bar" } else { "lines" }
            ));
            default
        }
        Err(_) => default,
    }
}

/// A progress bar drawn with the indicatif `template` on stderr, as lines
/// in a log, or a hidden one when `quiet` (see the module docs).
pub fn progress_bar(quiet: bool, template: &str) -> ProgressBar {
    let style = if quiet { Style::None } else { style() };
    if style == Style::None {
        return ProgressBar::hidden();
    }
    let (target, template) = match style {
        // A log gets no spinner and no bar: the counts and times say it.
        Style::Lines => (
            ProgressDrawTarget::term_like_with_hz(Box::new(Lines::new(line_every())), 4),
            template
                .replace("{spinner} ", "")
                .replace("{wide_bar} ", ""),
        ),
        _ => (ProgressDrawTarget::stderr(), template.to_string()),
    };
    let bar = ProgressBar::with_draw_target(Some(0), target);
    bar.set_style(ProgressStyle::with_template(&template).expect("valid template"));
    bar
}

/// A terminal that prints what it is asked to draw as a whole line on
/// stderr, at most once every `every`, the first `every` after it is made
/// (work shorter than that prints no progress).
#[derive(Debug)]
struct Lines {
    every: Duration,
    /// When the last line was printed, and what it said.
    last: Mutex<(Instant, String)>,
}

impl Lines {
    fn new(every: Duration) -> Lines {
        Lines {
            every,
            last: Mutex::new((Instant::now(), String::new())),
        }
    }

    /// The line to print for a draw of `s`, if one is due (never the
    /// same line twice in a row).
    fn due<'a>(&self, s: &'a str) -> Option<&'a str> {
        let s = s.trim_end();
        if s.trim().is_empty() {
            return None;
        }
        let mut last = self.last.lock().unwrap_or_else(|p| p.into_inner());
        if last.0.elapsed() < self.every || last.1 == s {
            return None;
        }
        *last = (Instant::now(), s.to_string());
        Some(s)
    }

    fn emit(&self, s: &str) -> std::io::Result<()> {
        if let Some(line) = self.due(s) {
            eprintln!("{line}");
        }
        Ok(())
    }
}

impl TermLike for Lines {
    fn width(&self) -> u16 {
        // Wide enough that no line is cut.
        1000
    }
    fn move_cursor_up(&self, _: usize) -> std::io::Result<()> {
        Ok(())
    }
    fn move_cursor_down(&self, _: usize) -> std::io::Result<()> {
        Ok(())
    }
    fn move_cursor_right(&self, _: usize) -> std::io::Result<()> {
        Ok(())
    }
    fn move_cursor_left(&self, _: usize) -> std::io::Result<()> {
        Ok(())
    }
    fn write_line(&self, s: &str) -> std::io::Result<()> {
        self.emit(s)
    }
    fn write_str(&self, s: &str) -> std::io::Result<()> {
        self.emit(s)
    }
    fn clear_line(&self) -> std::io::Result<()> {
        Ok(())
    }
    fn flush(&self) -> std::io::Result<()> {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_line_is_due_once_per_interval_and_never_blank() {
        let lines = Lines::new(Duration::from_secs(3600));
        assert_eq!(lines.due("[00:00:01] 1/4 tiles (eta 3s)"), None);
        let lines = Lines::new(Duration::ZERO);
        assert_eq!(lines.due("   "), None);
        assert_eq!(
            lines.due("[00:00:01] 1/4 tiles  \n"),
            Some("[00:00:01] 1/4 tiles")
        );
        assert_eq!(
            lines.due("[00:00:02] 2/4 tiles"),
            Some("[00:00:02] 2/4 tiles")
        );
        // A redraw of the same state prints nothing, even with no interval.
        assert_eq!(lines.due("[00:00:02] 2/4 tiles"), None);
    }
}
