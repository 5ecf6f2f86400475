//! `bench eval`: the cost of one `value_and_gradient` on a model's MPU at points near the surface.
//!
//! `cargo xtask bench eval ../shared/models/bunny.ply`

use std::hint::black_box;
use std::time::Instant;

use psi::{Mpu, MpuParams};

pub(crate) fn run(args: &[String]) -> anyhow::Result<()> {
    let points = super::load_model(args.first())?;
    let name = args.first().map_or("bunny.ply", String::as_str);
    let mpu = Mpu::build(&points, &MpuParams::paper())?;
    let d = mpu.diagonal();
    let queries: Vec<_> = points
        .iter()
        .step_by(7)
        .map(|p| p.p + 1e-3 * d * p.n)
        .collect();
    let mut visited = 0usize;
    let mut leaves = 0usize;
    for q in &queries {
        mpu.octree()
            .for_each_support_cell(*q - mpu.frame_origin(), |c, _| {
                visited += 1;
                leaves += usize::from(mpu.octree().cell(c).is_leaf());
            });
    }
    for _ in 0..3 {
        let t = Instant::now();
        for q in &queries {
            black_box(mpu.value_and_gradient(*q));
        }
        let per = t.elapsed().as_secs_f64() / queries.len() as f64;
        println!(
            "{name}: {:.0} ns per value_and_gradient; {:.1} cells in support, {:.1} leaves",
            per * 1e9,
            visited as f64 / queries.len() as f64,
            leaves as f64 / queries.len() as f64
        );
    }
    Ok(())
}
