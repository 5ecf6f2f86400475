//! `bench edit`: the cost of one local regeneration (`Scene::apply`) on a model, a brush applied
//! forth and back many times (for profiling with `perf record`): the small brush of the issue
//! "Local regeneration" (about 1 % of the bunny), or with `big` the one covering 5 % of it.
//!
//! `cargo xtask bench edit ../shared/models/bunny.ply 40 [big]`

use std::time::Instant;

use psi::regen::{Edit, Scene};
use psi::{DVec3, MpuParams, ParticleParams};

pub(crate) fn run(args: &[String]) -> anyhow::Result<()> {
    let mut args = args.iter().cloned();
    let points = super::load_model(args.next().as_ref())?;
    let rounds: usize = args.next().map_or(Ok(20), |a| a.parse())?;
    let (mut scene, _) = Scene::new(points, &MpuParams::paper(), &ParticleParams::paper())?;
    // The brushes of `cargo xtask reproduce-tables`: the small one, or with `big` the 5 % one.
    let big = args.next().is_some_and(|a| a == "big");
    let b = crate::edits::BRUSHES[usize::from(big)].1;
    let brush = |sign: f64| Edit::Brush {
        center: DVec3::new(b[0], b[1], b[2]),
        radius: b[3],
        displacement: DVec3::new(b[4], b[5], b[6]) * sign,
    };
    let mut times = Vec::new();
    let mut particle_times = Vec::new();
    for k in 0..rounds {
        let t = Instant::now();
        let r = scene.apply(&brush(if k % 2 == 0 { 1.0 } else { -1.0 }))?;
        times.push(t.elapsed().as_secs_f64());
        particle_times.push(r.particle_seconds);
        if k == 0 {
            println!("{r:?}");
        }
    }
    if rounds == 0 {
        return Ok(());
    }
    times.sort_by(f64::total_cmp);
    particle_times.sort_by(f64::total_cmp);
    println!(
        "apply: min {:.1} ms, median {:.1} ms over {rounds} (particles: median {:.1} ms)",
        1e3 * times[0],
        1e3 * times[rounds / 2],
        1e3 * particle_times[rounds / 2]
    );
    Ok(())
}
