//! `bench tune`: relaxation constants varied one at a time on a model file (default: the
//! shared bunny), printing the overall and per-level nearest-neighbour CV, the worst
//! |f|/|∇f| (over D) and the simulation time of each setting (the neighbour searches give the
//! same particles, so their lines differ only in time).
//!
//! `cargo xtask bench tune ../shared/models/bunny.ply`

use psi::particles::NeighbourSearch;
use psi::{Mpu, MpuParams, ParticleParams};

pub(crate) fn run(args: &[String]) -> anyhow::Result<()> {
    let points = super::load_model(args.first())?;
    let mpu = Mpu::build(&points, &MpuParams::paper())?;
    let base = ParticleParams::paper();
    let settings = [
        ("paper", base),
        (
            "momentum 0.6",
            ParticleParams {
                momentum: 0.6,
                ..base
            },
        ),
        (
            "momentum 0.8",
            ParticleParams {
                momentum: 0.8,
                ..base
            },
        ),
        ("dt 0.25", ParticleParams { dt: 0.25, ..base }),
        ("dt 0.35", ParticleParams { dt: 0.35, ..base }),
        ("rho 5", ParticleParams { rho: 5.0, ..base }),
        ("rho 30", ParticleParams { rho: 30.0, ..base }),
        (
            "sigma step 0.03",
            ParticleParams {
                sigma_dt: 0.03,
                ..base
            },
        ),
        (
            "sigma step 0.2",
            ParticleParams {
                sigma_dt: 0.2,
                ..base
            },
        ),
        (
            "cross 1.5, 1",
            ParticleParams {
                cross_level_exponents: (1.5, 1.0),
                ..base
            },
        ),
        (
            "cross 2.5, 1",
            ParticleParams {
                cross_level_exponents: (2.5, 1.0),
                ..base
            },
        ),
        (
            "cross 2, 0.5",
            ParticleParams {
                cross_level_exponents: (2.0, 0.5),
                ..base
            },
        ),
        (
            "cross 2, 1.5",
            ParticleParams {
                cross_level_exponents: (2.0, 1.5),
                ..base
            },
        ),
        (
            "no sigma adapt",
            ParticleParams {
                adapt_sigma: false,
                ..base
            },
        ),
        (
            "clamp 0.8-1.25",
            ParticleParams {
                sigma_clamp: (0.8, 1.25),
                ..base
            },
        ),
        (
            "clamp 0.9-1.1",
            ParticleParams {
                sigma_clamp: (0.9, 1.1),
                ..base
            },
        ),
        (
            "max move 0.3",
            ParticleParams {
                max_move: 0.3,
                ..base
            },
        ),
        (
            "kd-tree neighbours",
            ParticleParams {
                neighbours: NeighbourSearch::KdTree,
                ..base
            },
        ),
        (
            "octree neighbours",
            ParticleParams {
                neighbours: NeighbourSearch::Octree,
                ..base
            },
        ),
        (
            "radius 2.5 sigma",
            ParticleParams {
                neighbour_radius: 2.5,
                ..base
            },
        ),
    ];
    // One run first, untimed: the first pays for the MPU's lazily filled tables.
    psi::sample(&mpu, &base);
    for (name, params) in settings {
        let r = psi::sample(&mpu, &params).report;
        let levels: Vec<String> = r
            .after
            .levels
            .iter()
            .map(|l| format!("{}:{:.3}", l.depth, l.spacing.cv))
            .collect();
        println!(
            "{name:18} cv {:.3}  levels {}  max |f|/|grad f| {:.1e} D  sim {:.3} s",
            r.after.spacing.cv,
            levels.join(" "),
            r.after.max_surface_distance,
            r.simulate_seconds
        );
    }
    Ok(())
}
