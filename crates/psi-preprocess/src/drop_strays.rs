//! The stray points of a scan left out: the outlier search ([`crate::find_outliers`]), then
//! the clump search ([`crate::find_clumps`]) among the points it kept, over one Morton index
//! retained as points leave.

use glam::DVec3;
use psi_octree::{Interrupted, Monitor, MortonIndex, OrientedPoint};
use serde::{Deserialize, Serialize};

use crate::find_clumps::find_clumps_in;
use crate::find_outliers::{NormalOf, find_outliers_in};

/// The outlier step's result.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct OutlierReport {
    /// Points dropped.
    pub removed: usize,
    /// Of those, farther than a few sample spacings from every surface point.
    pub far: usize,
    /// Of those, near the data but off the surface it describes.
    pub off_surface: usize,
    /// Of those, in small groups lying apart from the rest, off its surface (stray clumps).
    #[serde(default)]
    pub clumps: usize,
}

/// Leaves the outliers and stray clumps out of `points` (shape: N; normals read when
/// `normals_given`) and of `source` (shape: N, their input indices), given `index`, the Morton
/// index of the points' positions (freed once the clump search has its own). Returns what was left out and the index of the points kept
/// (no second sort: [`MortonIndex::retained`]). `Err` once `monitor`'s flag is set (the points
/// are then as given).
pub(crate) fn drop_strays(
    points: &mut Vec<OrientedPoint>,
    source: &mut Vec<u32>,
    normals_given: bool,
    index: MortonIndex,
    monitor: &Monitor<'_>,
) -> Result<(OutlierReport, MortonIndex), Interrupted> {
    // (Read from the points where needed: no copy of the normals at the search's peak.)
    let normal_of = |i: usize| points[i].n;
    let normal_of = normals_given.then_some(&normal_of as &NormalOf<'_>);
    let found = find_outliers_in(&index, points.len(), normal_of, monitor);
    monitor.check()?;
    // Stray clumps support themselves: judged as groups, among the points left.
    let left: Vec<bool> = found.mask.iter().map(|m| !m).collect();
    let positions: Vec<DVec3> = points
        .iter()
        .zip(&left)
        .filter_map(|(p, &l)| l.then_some(p.p))
        .collect();
    let left_index = index.retained(&left);
    drop(index);
    let clumps = find_clumps_in(&positions, &left_index, monitor);
    monitor.check()?;
    let unclumped: Vec<bool> = clumps.mask.iter().map(|m| !m).collect();
    let kept_index = left_index.retained(&unclumped);
    let mut clumped = clumps.mask.iter(); // over the points left: `||` skips the others
    let keep: Vec<bool> = found
        .mask
        .iter()
        .map(|&m| !(m || clumped.next() == Some(&true)))
        .collect();
    retain_kept(points, source, &keep);
    let report = OutlierReport {
        removed: found.count() + clumps.points,
        far: found.far,
        off_surface: found.off_surface,
        clumps: clumps.points,
    };
    Ok((report, kept_index))
}

/// Keeps the points of `points` (shape: N) and their input indices `source` (shape: N) for
/// which `keep` (shape: N) holds, in order.
pub(crate) fn retain_kept(points: &mut Vec<OrientedPoint>, source: &mut Vec<u32>, keep: &[bool]) {
    let mut kept = keep.iter();
    points.retain(|_| *kept.next().unwrap_or(&true));
    let mut kept = keep.iter();
    source.retain(|_| *kept.next().unwrap_or(&true));
}
