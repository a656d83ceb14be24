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
        builder
            .fmt_fields(message_only())
            .event_format(Human)
            .try_init()
    };
}

/// People read the message; the structured fields are for --log-json.
fn message_only() -> impl for<'w> tracing_subscriber::fmt::FormatFields<'w> + 'static {
    tracing_subscriber::fmt::format::debug_fn(|w, field, value| {
        if field.name() == "message" {
            write!(w, "{value:?}")
        } else {
            Ok(())
        }
    })
}

/// A log line for people: the messages of the spans it is in, then its
/// own ("size 21: close: done in 5.92 s"), no ANSI codes. The default
/// format printed the span's name and fields ("size{size 21}: …").
struct Human;

impl<S, N> tracing_subscriber::fmt::FormatEvent<S, N> for Human
where
    S: tracing::Subscriber + for<'a> tracing_subscriber::registry::LookupSpan<'a>,
    N: for<'a> tracing_subscriber::fmt::FormatFields<'a> + 'static,
{
    fn format_event(
        &self,
        ctx: &tracing_subscriber::fmt::FmtContext<'_, S, N>,
        mut w: tracing_subscriber::fmt::format::Writer<'_>,
        event: &tracing::Event<'_>,
    ) -> std::fmt::Result {
        if let Some(scope) = ctx.event_scope() {
            for span in scope.from_root() {
                let ext = span.extensions();
                if let Some(f) = ext.get::<tracing_subscriber::fmt::FormattedFields<N>>()
                    && !f.is_empty()
                {
                    write!(w, "{f}: ")?;
                }
            }
        }
        ctx.field_format().format_fields(w.by_ref(), event)?;
        writeln!(w)
    }
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
        if let Ok(style) = ProgressStyle::with_template(
            "{prefix:>10} [{bar:30}] {percent:>3}% {elapsed}, about {eta} left",
        ) {
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

    /// Where the bar stands (fraction in [0, 1], to 0.001).
    pub fn position(&self) -> f64 {
        self.bar.position() as f64 / 1000.0
    }

    pub fn set(&self, fraction: f64) {
        self.bar
            .set_position((fraction.clamp(0.0, 1.0) * 1000.0) as u64);
    }

    /// Run `f` (a log line) with the bar cleared, so the line does not land
    /// on the bar's row.
    pub fn suspend<R>(&self, f: impl FnOnce() -> R) -> R {
        self.bar.suspend(f)
    }

    pub fn finish(&self) {
        self.bar.finish_and_clear();
    }
}

#[cfg(test)]
mod human_tests {
    use std::sync::{Arc, Mutex};

    use super::*;

    #[derive(Clone, Default)]
    struct Buffer(Arc<Mutex<Vec<u8>>>);

    impl std::io::Write for Buffer {
        fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
            self.0.lock().unwrap().extend_from_slice(b);
            Ok(b.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    #[test]
    fn a_line_in_a_span_starts_with_the_spans_message_not_its_name_and_fields() {
        let buf = Buffer::default();
        let sink = buf.clone();
        let subscriber = tracing_subscriber::fmt()
            .with_writer(move || sink.clone())
            .with_ansi(false)
            .fmt_fields(message_only())
            .event_format(Human)
            .finish();
        tracing::subscriber::with_default(subscriber, || {
            tracing::info!(stage = "segment", "segment: running");
            let _s = tracing::info_span!("size", message = %format!("size {}", 21)).entered();
            tracing::info!(stage = "close", "close: done in 5.92 s");
        });
        let text = String::from_utf8(buf.0.lock().unwrap().clone()).unwrap();
        assert_eq!(text, "segment: running\nsize 21: close: done in 5.92 s\n");
    }
}
