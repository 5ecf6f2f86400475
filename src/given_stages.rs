//! The stores of a run whose points have normals: as given, or, for the outlier step
//! (`tile_outliers.rs`), all points first and then the points its verdicts (`strays.bin`)
//! keep. The partition's public steps (`partition.rs`) take the stage, so that a cluster's
//! tasks write each store in parts.

use std::fs::{self, File};
use std::io::Read;
use std::path::{Path, PathBuf};

use crate::PsiError;
use crate::budget::OutOfCore;
use psi_tiles::TileStore;

use crate::input_points::{KeptFrom, Normals, Points};
use crate::tile_parts::RecordFile;

/// The outlier step's verdicts in the scratch directory: a byte a point of the store of all
/// points, by its index (kept: 0).
pub(crate) const STRAYS_FILE: &str = "strays.bin";

/// Where `strays.bin`'s source is recorded: the source of the store its verdicts are of, and
/// [`VERDICTS_KIND`].
pub(crate) fn strays_source(scratch: &Path) -> PathBuf {
    scratch.join("strays.source")
}

/// What `strays.source` adds to the store's source: the verdicts include the stray clumps
/// (an earlier psi's, without them, are made again).
pub(crate) const VERDICTS_KIND: &str = "\nverdicts: outliers and stray clumps";

/// What `strays.source` holds for verdicts of the store whose source is `source`.
pub(crate) fn verdicts_source(source: &str) -> String {
    format!("{source}{VERDICTS_KIND}")
}

/// At most this many strays are listed for [`stray_indices`] (8 bytes each).
const LISTED_STRAYS: usize = 1 << 21;

/// The indices of the points `strays.bin` at `path` leaves out, ascending, read in one pass
/// (a lookup among them is quick where the file's own windows would be read again for every
/// scattered index); `None` when it cannot be read or they are more than [`LISTED_STRAYS`].
pub(crate) fn stray_indices(path: &Path) -> Option<Vec<u64>> {
    let mut file = File::open(path).ok()?;
    let mut buffer = vec![0u8; 1 << 20];
    let (mut out, mut at) = (Vec::new(), 0u64);
    loop {
        let n = file.read(&mut buffer).ok()?;
        if n == 0 {
            return Some(out);
        }
        for (k, _) in buffer[..n].iter().enumerate().filter(|(_, b)| **b != 0) {
            if out.len() == LISTED_STRAYS {
                return None;
            }
            out.push(at + k as u64);
        }
        at += n as u64;
    }
}

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
/// [`GivenStage::Kept`], `strays.bin` open while `f` runs; with `plans`, when `f` starts a
/// store, the kept points' bounds readable from the store of all points, [`KeptFrom`]).
pub(crate) fn with_given_stage<T>(
    options: &OutOfCore,
    (stage, plans): (GivenStage, bool),
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
            // The store of all points these verdicts are of, while it is there: the kept
            // points' bounds come from it (`partition.rs` checks that it is of the same input).
            let all = plans
                .then(|| TileStore::open(&scratch.join("all")).ok())
                .flatten();
            let strays = all.as_ref().and_then(|_| stray_indices(&path));
            let kept_from = all
                .as_ref()
                .zip(strays.as_deref())
                .filter(|(store, _)| {
                    let m = store.manifest();
                    let source = fs::read_to_string(strays_source(scratch));
                    let whole = fs::metadata(&path).is_ok_and(|f| f.len() == m.population);
                    whole && source.is_ok_and(|s| s == verdicts_source(&m.source))
                })
                .map(|(store, strays)| KeptFrom { store, strays });
            let points = Points {
                normals: Normals::Given,
                keep: Some(&keep),
                kept_from,
            };
            f(&scratch.join("tiles"), points)
        }
    }
}
