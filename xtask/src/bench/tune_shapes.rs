//! `bench tune-shapes`: a parameter sweep of the relaxation on a sphere and a torus: prints the nearest-neighbour CV
//! after relaxation for step sizes and σ adaptation.
//!
//! `cargo xtask bench tune-shapes`

use psi::particles::{DensityMode, ParticleParams, sample};
use psi::{AnalyticShape, Mpu, MpuParams};

pub(crate) fn run() -> anyhow::Result<()> {
    for shape in [
        AnalyticShape::Sphere { radius: 1.0 },
        AnalyticShape::Torus {
            major: 1.0,
            minor: 0.35,
        },
    ] {
        let mpu = Mpu::build(&shape.sample(30_000, 21), &MpuParams::paper())?;
        for uniform in [true, false] {
            for dt in [0.25, 0.3] {
                for adapt in [false, true] {
                    {
                        let mm = 0.5;
                        let p = ParticleParams {
                            density: if uniform {
                                DensityMode::Uniform
                            } else {
                                DensityMode::Adaptive
                            },
                            count: if uniform { Some(3000) } else { None },
                            dt,
                            adapt_sigma: adapt,
                            max_move: mm,
                            ..ParticleParams::paper()
                        };
                        let r = sample(&mpu, &p).report;
                        println!(
                            "{shape:?} uniform {uniform} dt {dt} adapt {adapt} mm {mm}: n {} cv {:.3} -> {:.3} min/mean {:.2} sim {:.3}s",
                            r.count,
                            r.before.spacing.cv,
                            r.after.spacing.cv,
                            r.after.spacing.min / r.after.spacing.mean,
                            r.simulate_seconds
                        );
                    }
                }
            }
        }
    }
    Ok(())
}
