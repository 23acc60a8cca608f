//! Progress bars on stderr.

use indicatif::{ProgressBar, ProgressStyle};

/// A progress bar drawn with the indicatif `template` on stderr, or a hidden
/// one when `quiet`.
pub fn progress_bar(quiet: bool, template: &str) -> ProgressBar {
    if quiet {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(0);
    bar.set_style(ProgressStyle::with_template(template).expect("valid template"));
    bar
}
