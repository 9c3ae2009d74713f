//! Progress bars (indicatif) behind the library's `Progress` trait.

use std::sync::Mutex;

use indicatif::{ProgressBar, ProgressStyle};

const STEP_TEMPLATE: &str = "{msg:>22} [{bar:40}] {pos}/{len} ({elapsed}, eta {eta})";

/// One bar at a time, replaced at each `begin`.
pub struct Bars {
    bar: Mutex<Option<ProgressBar>>,
    template: &'static str,
}

impl Default for Bars {
    fn default() -> Self {
        Bars::with_template(STEP_TEMPLATE)
    }
}

impl Bars {
    /// Bars drawn with an indicatif template.
    pub fn with_template(template: &'static str) -> Self {
        Bars {
            bar: Mutex::new(None),
            template,
        }
    }

    /// Print a line above the bar (or to stderr when there is none).
    pub fn println(&self, line: &str) {
        match self.bar.lock().ok().as_deref().and_then(|b| b.clone()) {
            Some(b) if !b.is_hidden() => b.println(line),
            _ => eprintln!("{line}"),
        }
    }
}

impl shrad::Progress for Bars {
    fn begin(&self, label: &str, total: u64) {
        let bar = ProgressBar::new(total);
        bar.set_style(
            ProgressStyle::with_template(self.template)
                .unwrap_or_else(|_| ProgressStyle::default_bar())
                .progress_chars("=> "),
        );
        bar.set_message(label.to_string());
        bar.enable_steady_tick(std::time::Duration::from_millis(500));
        if let Ok(mut b) = self.bar.lock() {
            *b = Some(bar);
        }
    }
    fn advance(&self, n: u64) {
        if let Ok(b) = self.bar.lock() {
            if let Some(b) = b.as_ref() {
                b.inc(n);
            }
        }
    }
    fn end(&self) {
        if let Ok(mut b) = self.bar.lock() {
            if let Some(b) = b.take() {
                b.finish_and_clear();
            }
        }
    }
}
