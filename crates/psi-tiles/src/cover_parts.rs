//! The ceiling on spacing out of core ([`psi_particles::cover_from`]): each pass of the dart
//! throw reads the input part by part ([`PointSource::parts`]: a store's tiles), in parallel,
//! and gathers only a part's open points. The darts do not depend on the parts, their order or
//! a point read twice ([`psi_particles::throw_darts_in_rounds`]), so they are those of the
//! whole input in memory.

use glam::DVec3;
use psi_particles::{CoverPoints, DartCells, Representatives};
use rayon::prelude::*;

use crate::{PointSource, TileError};

/// A [`PointSource`] as a dart throw's candidates: every point of it.
pub(crate) struct PartsCover<'a> {
    pub(crate) source: &'a dyn PointSource,
}

impl CoverPoints for PartsCover<'_> {
    type Error = TileError;

    fn representatives(
        &self,
        cells: &DartCells,
        open: &(dyn Fn(DVec3) -> bool + Sync),
    ) -> Result<Representatives, TileError> {
        // A part's cube grown by rounding (a point on a face read twice changes nothing).
        let margin = 1e-9 * self.source.frame().root_half;
        let parts: Vec<Result<Representatives, TileError>> = self
            .source
            .parts()
            .par_iter()
            .map(|&(center, half)| {
                let mut reps = Representatives::default();
                for p in self.source.gather_box_where(center, half, margin, open)? {
                    reps.offer(cells, p);
                }
                Ok(reps)
            })
            .collect();
        let mut all = Representatives::default();
        for reps in parts {
            all = all.merge(reps?);
        }
        Ok(all)
    }
}
