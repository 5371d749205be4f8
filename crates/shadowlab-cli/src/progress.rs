//! Progress bars for long steps (hidden when the output is not a terminal).

use indicatif::{ProgressBar, ProgressStyle};

/// A bar counting `total` units with a message.
pub fn bar(total: u64, message: &str) -> ProgressBar {
    let bar = ProgressBar::new(total);
    bar.set_style(
        ProgressStyle::with_template("{msg:<28} {bar:32.cyan/blue} {percent:>3}% {elapsed_precise} eta {eta}")
            .expect("valid template")
            .progress_chars("█▉▊▋▌▍▎▏ "),
    );
    bar.set_message(message.to_owned());
    bar
}
