//! Development aid: relaxation parameter sweep on a model file (default: the shared bunny),
//! printing per-level nearest-neighbour CV and surface adherence.
//!
//! `cargo run --release --example tune_relaxation -- ../shared/models/bunny.ply`

use psi::{Mpu, MpuParams, ParticleParams};

fn main() -> anyhow::Result<()> {
    let path = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "../shared/models/bunny.ply".into());
    let points = psi::load_points(std::path::Path::new(&path), &psi::ReadOptions::paper())?.points;
    let mpu = Mpu::build(&points, &MpuParams::paper())?;
    for momentum in [0.7] {
        for dt in [0.3] {
            let params = ParticleParams {
                momentum,
                dt,
                ..ParticleParams::paper()
            };
            let run = psi::sample(&mpu, &params);
            let d = mpu.diagonal();
            let mut worst: Vec<(f64, f64, f64, u8)> = run
                .particles
                .positions
                .iter()
                .zip(&run.particles.depth)
                .map(|(x, dep)| {
                    let (f, g) = mpu.value_and_gradient(*x);
                    (f.abs() / g.length() / d, f.abs() / d, g.length(), *dep)
                })
                .collect();
            worst.sort_by(|a, b| b.0.total_cmp(&a.0));
            if std::env::var_os("PROBE").is_some() {
                let mut idx: Vec<usize> = (0..run.particles.len()).collect();
                idx.sort_by(|&a, &b| {
                    let r = |i: usize| {
                        let (f, g) = mpu.value_and_gradient(run.particles.positions[i]);
                        f.abs() / g.length()
                    };
                    r(b).total_cmp(&r(a))
                });
                let x = run.particles.positions[idx[0]];
                let (f, g) = mpu.value_and_gradient(x);
                let dir = -f.signum() * g.normalize();
                println!(
                    "probe: f {f:e} |g| {:.3} sigma {:e}",
                    g.length(),
                    run.particles.sigma[idx[0]]
                );
                for k in 0..12 {
                    let t = 1e-6 * d * 2f64.powi(k);
                    let (fp, gp) = mpu.value_and_gradient(x + t * dir);
                    println!(
                        "  t {t:.2e}: f {fp:+.3e} |g| {:.3} g·dir {:+.3}",
                        gp.length(),
                        gp.normalize().dot(dir)
                    );
                }
            }
            let bad = worst.iter().filter(|w| w.0 > 1e-4).count();
            println!(
                "{bad} particles above 1e-4 D; worst (|f|/|g|, |f|, |g|, depth): {:?}",
                &worst[..5.min(worst.len())]
            );
            let r = run.report;
            let levels: Vec<String> = r
                .after
                .levels
                .iter()
                .map(|l| format!("{}:{:.3}", l.depth, l.spacing.cv))
                .collect();
            println!(
                "momentum {momentum} dt {dt}: cv {:.3} levels {} max|f|/|g| {:.1e} sim {:.3}s",
                r.after.spacing.cv,
                levels.join(" "),
                r.after.max_surface_distance,
                r.simulate_seconds
            );
        }
    }
    Ok(())
}
