//! Progress and verbosity: progress bars on stderr for the MPU build and the relaxation when
//! stderr is a terminal (silent otherwise), `--quiet` to silence the summary, `-v` for timings
//! (the library's tracing spans — MPU build, seeding, relaxation, local regeneration — printed
//! with their durations by the subscriber `main` installs, plus the stages that have no span).

use std::io::IsTerminal;
use std::time::Duration;

use indicatif::{ProgressBar, ProgressStyle};

/// How much the command reports.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Ui {
    pub(crate) quiet: bool,
    pub(crate) verbose: bool,
}

impl Ui {
    fn bars(&self) -> bool {
        !self.quiet && std::io::stderr().is_terminal()
    }

    /// A bar over `total` steps labelled `what`, or a hidden one.
    pub(crate) fn bar(&self, what: &str, total: u64) -> ProgressBar {
        self.bar_with(
            what,
            total,
            "{prefix:>12} [{bar:30}] {pos}/{len} {msg} ({elapsed})",
        )
    }

    /// [`Ui::bar`] that also shows the time left in the current stage (long runs out of core:
    /// tiles done of all, with the time left).
    pub(crate) fn bar_with_eta(&self, what: &str, total: u64) -> ProgressBar {
        let template = "{prefix:>12} [{bar:30}] {pos}/{len} {msg} ({elapsed}, about {eta} left)";
        self.bar_with(what, total, template)
    }

    fn bar_with(&self, what: &str, total: u64, template: &str) -> ProgressBar {
        if !self.bars() {
            return ProgressBar::hidden();
        }
        let bar = ProgressBar::new(total);
        let style = ProgressStyle::with_template(template)
            .map(|s| s.progress_chars("=> "))
            .unwrap_or_else(|_| ProgressStyle::default_bar());
        bar.set_style(style);
        bar.set_prefix(what.to_owned());
        bar.enable_steady_tick(Duration::from_millis(200));
        bar
    }

    /// Prints the run's summary line unless `--quiet`.
    pub(crate) fn summary(&self, line: &str) {
        if !self.quiet {
            println!("{line}");
        }
    }

    /// Prints a notice on stderr unless `--quiet`.
    pub(crate) fn notice(&self, line: &str) {
        if !self.quiet {
            eprintln!("psi: {line}");
        }
    }

    /// Prints a timing line on stderr with `-v`.
    pub(crate) fn timing(&self, what: &str, seconds: f64) {
        if self.verbose {
            eprintln!("psi: {what}: {seconds:.4} s");
        }
    }
}

/// Builds an MPU with a progress bar over the octree levels.
pub(crate) fn build_mpu(
    ui: Ui,
    points: &[psi::OrientedPoint],
    params: &psi::MpuParams,
) -> Result<psi::Mpu, psi::MpuError> {
    // The build's own work before its first level (the frame, the point index) is the MPU's.
    crate::stage_clock::enter("mpu");
    let bar = ui.bar("MPU levels", u64::from(params.max_depth) + 1);
    let observe = |stage: &str, done: u64, total: u64| {
        crate::stage_clock::observe(stage, done, total);
        bar.set_position(done)
    };
    let options = psi::mpu::BuildOptions {
        monitor: psi::octree::Monitor::new(Some(&observe), None),
        ..Default::default()
    };
    let mpu = psi::Mpu::build_with(points, params, options);
    bar.finish_and_clear();
    mpu
}

/// Samples with a progress bar over the relaxation iterations.
pub(crate) fn sample(ui: Ui, mpu: &psi::Mpu, params: &psi::ParticleParams) -> psi::Sampling {
    crate::stage_clock::enter("seed");
    let bar = ui.bar("relaxation", params.iterations as u64);
    let observe = |stage: &str, done: u64, total: u64| {
        crate::stage_clock::observe(stage, done, total);
        if stage == "relax" {
            bar.set_position(done)
        }
    };
    let monitor = psi::octree::Monitor::new(Some(&observe), None);
    let run = psi::particles::sample_with(mpu, params, &monitor)
        .expect("a monitor without a stop flag never stops");
    bar.finish_and_clear();
    run
}
