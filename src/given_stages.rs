//! The stores of a run whose points have normals: as given, or, for the outlier step
//! (`tile_outliers.rs`), all points first and then the points its verdicts (`strays.bin`)
//! keep. The partition's public steps (`partition.rs`) take the stage, so that a cluster's
//! tasks write each store in parts.

use std::path::Path;

use crate::PsiError;
use crate::budget::OutOfCore;
use crate::input_points::{Normals, Points};
use crate::tile_parts::RecordFile;

/// The outlier step's verdicts in the scratch directory: a byte a point of the store of all
/// points, by its index (kept: 0).
pub(crate) const STRAYS_FILE: &str = "strays.bin";

/// The keep test of the outlier step's `verdicts` (`strays.bin` open): a point is kept when
/// its verdict is 0, by its index in the store of all points.
pub(crate) fn kept_by(verdicts: &RecordFile<1>) -> impl Fn(u64) -> Result<bool, String> + Sync {
    |i| verdicts.get(i).map(|v| v[0] == 0)
}

/// Which store of a run whose points have normals a partition writes ([`crate::partition_start`],
/// [`crate::partition_part`], [`crate::partition_assemble`]): the points as given (`tiles/`,
/// with `--keep-outliers`), or for the outlier step all points first (`all/`), then the points
/// its verdicts keep (`tiles/`, reading `strays.bin`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GivenStage {
    /// Every point, into the final store.
    Plain,
    /// Every point, into the outlier step's store.
    All,
    /// The points the outlier step keeps, into the final store.
    Kept,
}

/// `f` with the directory and the points of `stage` of the run in `options.scratch` (for
/// [`GivenStage::Kept`], `strays.bin` open while `f` runs).
pub(crate) fn with_given_stage<T>(
    options: &OutOfCore,
    stage: GivenStage,
    f: impl FnOnce(&Path, Points<'_>) -> Result<T, PsiError>,
) -> Result<T, PsiError> {
    let scratch = &options.scratch;
    match stage {
        GivenStage::Plain => f(&scratch.join("tiles"), Points::all(Normals::Given)),
        GivenStage::All => f(&scratch.join("all"), Points::all(Normals::Given)),
        GivenStage::Kept => {
            let path = scratch.join(STRAYS_FILE);
            let verdicts = RecordFile::<1>::open(&path).map_err(|reason| PsiError::OutOfCore {
                path: path.clone(),
                reason,
            })?;
            let keep = kept_by(&verdicts);
            let points = Points {
                normals: Normals::Given,
                keep: Some(&keep),
            };
            f(&scratch.join("tiles"), points)
        }
    }
}
