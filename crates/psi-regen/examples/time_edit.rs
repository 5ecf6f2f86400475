//! Times the pieces of one local edit on the built-in model (development aid).
use std::time::Instant;

use glam::DVec3;
use psi_mpu::{Mpu, MpuParams, Reuse};
use psi_regen::{Edit, mark_cells};

fn main() {
    let points = psi_octree::builtin_model();
    let params = MpuParams::paper();
    let mpu = Mpu::build(&points, &params).unwrap();
    let edit = Edit::Brush {
        center: points[100].p,
        radius: 0.08,
        displacement: DVec3::new(0.0, 0.0, 0.02),
    };
    for _ in 0..3 {
        let t = Instant::now();
        let (new, changed) = edit.apply(mpu.points()).unwrap();
        let t_apply = t.elapsed();
        let t = Instant::now();
        let marked = mark_cells(&mpu, &changed);
        let t_mark = t.elapsed();
        let t = Instant::now();
        let local = Mpu::build_in_frame(
            &new,
            &params,
            mpu.frame(),
            Some(Reuse {
                old: &mpu,
                marked: &marked,
            }),
        )
        .unwrap();
        let t_build = t.elapsed();
        let t = Instant::now();
        let _index = psi_octree::PointIndex::new(&new.iter().map(|p| p.p).collect::<Vec<_>>());
        let t_index = t.elapsed();
        println!(
            "apply {:?} mark {:?} ({} marked) local build {:?} (of which kd index ~{:?}); full build {:.3} s",
            t_apply,
            t_mark,
            marked.iter().filter(|m| **m).count(),
            t_build,
            t_index,
            mpu.report().seconds
        );
        let _ = local;
    }
}
