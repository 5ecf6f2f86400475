//! The ceiling on spacing out of core ([`psi_particles::cover_from`]): each pass of the dart
//! throw reads the input part by part ([`PointSource::part_where`]: a store's tile files), in
//! parallel, and holds only a part's open points and the representatives. The darts do not
//! depend on the parts or their order ([`psi_particles::throw_darts_in_rounds`]), so they are
//! those of the whole input in memory.

use glam::DVec3;
use psi_octree::Monitor;
use psi_particles::{CoverPoints, DartCells, Representatives};
use rayon::prelude::*;

use crate::{PointSource, TileError};

/// A [`PointSource`] as a dart throw's candidates: every point of it, read part by part; a
/// pass stops at a part boundary once `monitor`'s stop flag is set.
pub(crate) struct PartsCover<'a> {
    pub(crate) source: &'a dyn PointSource,
    pub(crate) monitor: &'a Monitor<'a>,
}

impl CoverPoints for PartsCover<'_> {
    type Error = TileError;

    fn representatives(
        &self,
        cells: &DartCells,
        open: &(dyn Fn(DVec3) -> bool + Sync),
    ) -> Result<Representatives, TileError> {
        (0..self.source.part_count())
            .into_par_iter()
            .map(|part| {
                self.monitor.check()?;
                let mut reps = Representatives::default();
                for (index, p) in self.source.part_where(part, open)? {
                    reps.offer(cells, index, p);
                }
                Ok(reps)
            })
            .try_reduce(Representatives::default, |a, b| Ok(a.merge(b)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use psi_mpu::MpuFrame;
    use psi_octree::OrientedPoint;
    use psi_particles::throw_darts_in_rounds;

    use crate::PointsInMemory;

    /// Every point offered in one part, by index.
    struct Whole<'a>(&'a [OrientedPoint]);

    impl CoverPoints for Whole<'_> {
        type Error = ();
        fn representatives(
            &self,
            cells: &DartCells,
            open: &(dyn Fn(DVec3) -> bool + Sync),
        ) -> Result<Representatives, ()> {
            let mut reps = Representatives::default();
            for (i, p) in self.0.iter().enumerate().filter(|(_, p)| open(p.p)) {
                reps.offer(cells, i as u64, *p);
            }
            Ok(reps)
        }
    }

    /// A plane through the tiles' faces (points on them, and on the faces across it): read
    /// bucket by bucket at depth 2, the darts of every point read whole.
    #[test]
    fn darts_from_the_parts_are_those_of_the_whole() {
        let frame = MpuFrame {
            origin: DVec3::ZERO,
            root_center: DVec3::ZERO,
            root_half: 1.0,
            diagonal: 2.0 * 3f64.sqrt(),
        };
        let mut points = Vec::new();
        for i in 0..=120 {
            for j in 0..=120 {
                // Every 30th line lies on a face between tiles (edge 0.5).
                let (x, y) = (-1.0 + i as f64 / 60.0, -1.0 + j as f64 / 60.0);
                let z = if (i + j) % 7 == 0 { 0.0 } else { 0.01 * x * y };
                points.push(OrientedPoint {
                    p: DVec3::new(x, y, z),
                    n: DVec3::Z,
                });
            }
        }
        let source = PointsInMemory::new(&points, frame, 2);
        let silent = Monitor::silent();
        let parts = PartsCover {
            source: &source,
            monitor: &silent,
        };
        assert!(parts.source.part_count() == 64);
        let cells = DartCells::for_radius(frame.origin, 0.15, 3);
        let keep = |p: DVec3| p.x < 0.7;
        let from_parts = parts.representatives(&cells, &keep).unwrap();
        assert_eq!(
            Ok(from_parts),
            Whole(&points).representatives(&cells, &keep)
        );
        let (want, _) = throw_darts_in_rounds(&Whole(&points), &keep, &cells, None).unwrap();
        let (got, passes) = throw_darts_in_rounds(&parts, &keep, &cells, None).unwrap();
        assert!(want.len() > 20 && passes >= 2);
        assert_eq!(got, want);
    }
}
