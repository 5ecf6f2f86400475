//! A brush's new points in the time of the points it reaches: the candidates from the MPU's
//! kd-tree, and the points array taken from the spare buffers (the MPU before the current one)
//! brought up to date where it differs, instead of a copy of every point.

use psi_mpu::{Mpu, MpuBuffers};

use crate::edit::Tracked;
use crate::{Edit, RegenError};

/// The new points of brush `edit` on `mpu`'s points: the candidates from the kd-tree, the
/// buffer `spare` (the MPU before `mpu`, whose points differ from `mpu`'s at `lag`; `None`:
/// unknown) brought up to date. Returns the points, the changed positions (old and new), the
/// moved indices and, when the buffer was in step, the indices where it now differs from the
/// points the spare positions were made from ([`psi_mpu::BuildOptions::synced`]). A refused
/// brush leaves `spare` as it was.
pub(crate) fn brushed_points(
    mpu: &Mpu,
    spare: &mut MpuBuffers,
    edit: &Edit,
    lag: Option<&[u32]>,
) -> Result<(Tracked, Option<Vec<u32>>), RegenError> {
    let Edit::Brush { center, radius, .. } = edit else {
        unreachable!("only brushes come here");
    };
    // (A margin: the kd-tree measures in the local frame, the brush in world units.)
    let mut candidates = Vec::new();
    mpu.inputs_within(*center, radius * (1.0 + 1e-9), &mut candidates);
    let moves = edit
        .brush_moves(mpu.points(), &candidates)
        .expect("a brush")?;
    let current = mpu.points();
    let mut points = spare.take_synced_points();
    let synced = match lag {
        Some(lag) if points.len() == current.len() => {
            for &i in lag {
                points[i as usize] = current[i as usize];
            }
            let mut s = lag.to_vec();
            s.extend(moves.iter().map(|m| m.0));
            s.sort_unstable();
            s.dedup();
            Some(s)
        }
        _ => {
            points.clear();
            points.extend_from_slice(current);
            None
        }
    };
    let mut changed = Vec::with_capacity(2 * moves.len());
    for &(i, q) in &moves {
        changed.push(current[i as usize].p);
        changed.push(q.p);
        points[i as usize] = q;
    }
    let moved = moves.iter().map(|m| m.0).collect();
    Ok(((points, changed, moved), synced))
}
