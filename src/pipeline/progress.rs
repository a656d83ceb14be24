//! Progress bars and log set-up. Bars are drawn only on an interactive
//! terminal and never with `--quiet` or `--log-json`, so schedulers and CI
//! logs see clean lines.

use std::io::IsTerminal;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// How the process reports what it does.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct LogMode {
    pub quiet: bool,
    pub json: bool,
}

/// Install the global log subscriber (stderr). Safe to call more than once.
pub fn init_logging(mode: LogMode) {
    let level = if mode.quiet {
        tracing::Level::WARN
    } else {
        tracing::Level::INFO
    };
    let builder = tracing_subscriber::fmt()
        .with_writer(std::io::stderr)
        .with_max_level(level)
        .with_target(false);
    let _ = if mode.json {
        builder
            .json()
            .flatten_event(true)
            .with_current_span(false)
            .with_span_list(false)
            .try_init()
    } else {
        // People read the message; the structured fields are for --log-json.
        let message_only = tracing_subscriber::fmt::format::debug_fn(|w, field, value| {
            if field.name() == "message" {
                write!(w, "{value:?}")
            } else {
                Ok(())
            }
        });
        builder
            .without_time()
            .with_ansi(std::io::stderr().is_terminal())
            .with_level(false)
            .fmt_fields(message_only)
            .try_init()
    };
}

/// A progress bar for one stage's long work (fraction in [0, 1]).
#[derive(Debug, Clone)]
pub struct Progress {
    bar: ProgressBar,
}

impl Progress {
    pub fn new(label: &str, mode: LogMode) -> Self {
        let visible = !mode.quiet && !mode.json && std::io::stderr().is_terminal();
        let bar = ProgressBar::with_draw_target(
            Some(1000),
            if visible {
                ProgressDrawTarget::stderr()
            } else {
                ProgressDrawTarget::hidden()
            },
        );
        if let Ok(style) =
            ProgressStyle::with_template("{prefix:>10} [{bar:30}] {percent:>3}% {elapsed}")
        {
            bar.set_style(style.progress_chars("=> "));
        }
        bar.set_prefix(label.to_string());
        Self { bar }
    }

    /// A bar that never draws (tests, library use).
    pub fn hidden() -> Self {
        Self {
            bar: ProgressBar::hidden(),
        }
    }

    pub fn set(&self, fraction: f64) {
        self.bar
            .set_position((fraction.clamp(0.0, 1.0) * 1000.0) as u64);
    }

    pub fn finish(&self) {
        self.bar.finish_and_clear();
    }
}
