//! Progress of a long check on standard error, for a person watching a terminal.

use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;

/// A progress bar over `total` programs: drawn on standard error when it is a terminal
/// and there is more than one program, hidden otherwise (pipes, CI logs and tests see
/// nothing). It clears itself when finished.
pub fn progress_bar(total: usize) -> ProgressBar {
    if total < 2 || !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(total as u64);
    if let Ok(style) =
        ProgressStyle::with_template("checking {pos}/{len} programs {wide_bar} {elapsed}")
    {
        bar.set_style(style);
    }
    bar
}
