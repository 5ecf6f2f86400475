//! `bench relax`: times `rounds` samplings (seeding + 20 iterations), each of a freshly built
//! MPU, and prints the median simulation time and the per-level CV (for profiling the
//! relaxation alone). With `warm` as third argument every round samples one MPU, whose lazily
//! filled tables (the footprint's per-point table, the evaluation's candidate lists) are then
//! full after the first round: the difference is their cost. With `prefill`, every round's
//! fresh MPU has its footprint table filled for every input point before the clock starts:
//! the difference to a plain run is what filling it during the relaxation costs.
//!
//! `cargo xtask bench relax ../shared/models/bunny.ply 9 [warm|prefill]`

use psi::{Mpu, MpuParams, ParticleParams};

pub(crate) fn run(args: &[String]) -> anyhow::Result<()> {
    let mut args = args.iter().cloned();
    let points = super::load_model(args.next().as_ref())?;
    let rounds: usize = args.next().map_or(Ok(9), |s| s.parse())?;
    let mode = args.next().unwrap_or_default();
    anyhow::ensure!(
        ["", "warm", "prefill"].contains(&mode.as_str()),
        "third argument: warm or prefill, not {mode:?}"
    );
    let warm = mode == "warm";
    let prefill = mode == "prefill";
    let params = ParticleParams::paper();
    let mut times = Vec::new();
    // CPU seconds of each sampling (both threads; measured apart from the host's steal time,
    // which moves the wall clock on a shared VM).
    let mut cpu = Vec::new();
    let mut last = None;
    let shared = warm
        .then(|| Mpu::build(&points, &MpuParams::paper()))
        .transpose()?;
    for _ in 0..rounds {
        // Unless warm, a fresh MPU each round: its lazily filled caches (input spacing,
        // interior points) start empty, as in one `psi sample` run (unless `prefill` fills the
        // footprint table below).
        let fresh = match &shared {
            Some(_) => None,
            None => Some(Mpu::build(&points, &MpuParams::paper())?),
        };
        let mpu = fresh.as_ref().or(shared.as_ref()).expect("one of the two");
        if prefill {
            use rayon::prelude::*;
            (0..mpu.points().len() as u32)
                .into_par_iter()
                .for_each(|q| _ = mpu.input_spacing(q));
        }
        let before = cpu_seconds();
        let run = psi::particles::sample(mpu, &params);
        cpu.push(cpu_seconds().zip(before).map_or(f64::NAN, |(a, b)| a - b));
        times.push(run.report.simulate_seconds);
        last = Some(run);
    }
    times.sort_by(f64::total_cmp);
    if let Some(run) = last {
        let levels: Vec<String> = run
            .report
            .after
            .levels
            .iter()
            .map(|l| format!("{}:{}/{:.3}", l.depth, l.spacing.count, l.spacing.cv))
            .collect();
        let cpu_mean = cpu.iter().sum::<f64>() / cpu.len().max(1) as f64;
        println!(
            "particles {} simulate median {:.4} s (min {:.4}; sampling CPU {:.3} s) levels {}",
            run.report.count,
            times[times.len() / 2],
            times[0],
            cpu_mean,
            levels.join(" ")
        );
    }
    Ok(())
}

/// User + system CPU seconds of this process so far (Linux `/proc/self/stat`; `None` elsewhere).
fn cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    let fields: Vec<&str> = stat[stat.rfind(')')? + 2..].split_whitespace().collect();
    let ticks = fields.get(11)?.parse::<f64>().ok()? + fields.get(12)?.parse::<f64>().ok()?;
    // Linux reports these in clock ticks of 1/100 s.
    Some(ticks / 100.0)
}
