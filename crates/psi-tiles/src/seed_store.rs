//! An octant's seeds out of core ([`crate::seed_octant`] on a [`TileStore`]), kept in a file of
//! their own in the store's directory (`record_file.rs`), so that a cluster seeds the octants
//! as tasks and the relaxation, a task after them, reads their files; a run that resumes takes
//! the intact files of the same store, decisions and parameters.

use psi_mpu::MpuParams;
use psi_octree::Monitor;
use psi_particles::ParticleParams;
use sha2::{Digest, Sha256};

use crate::decide_store::fingerprint;
use crate::record_file::{read_record, write_record};
use crate::{
    OctantSeeds, PointSource, SEED_MARGIN, TileError, TileParams, TileStore, TiledDecisions,
    seed_octant,
};

/// What the seeds files hold, in their fingerprint: a file of another layout or thinning is
/// made again. Changed with anything that changes which points the seeding keeps
/// (`thinning.rs`, `ThinnedData::keep_from_region`), besides the two constants named with it.
const SEEDS_FORMAT: &str = "thinned data with each point's need, the needs first (2)";

/// The seeds of the octant `octant` (key at depth 1) of the MPU `decisions` describe (decided
/// from `store` with `mpu_params` and `tiles`), with `params` and the relaxation's budget of
/// `relax_points` input points: from the octant's seeds file
/// when it is intact and made from the same, else seeded from `store` and written.
///
/// Errors as [`seed_octant`], and a file that cannot be written.
#[allow(clippy::too_many_arguments)]
pub fn seed_store_octant(
    store: &TileStore,
    tiles: &TileParams,
    decisions: &TiledDecisions,
    mpu_params: &MpuParams,
    params: &ParticleParams,
    relax_points: usize,
    octant: [u32; 3],
    monitor: &Monitor<'_>,
) -> Result<OctantSeeds, TileError> {
    let mut h = Sha256::new();
    h.update(fingerprint(store, mpu_params, tiles));
    h.update(format!(
        "{params:?} {SEED_MARGIN} {relax_points} {SEEDS_FORMAT} {} {}",
        crate::thinning::SUBSET_SPACING_PER_FLOOR,
        crate::thinning::AREA_PER_LEAF_FACE
    ));
    let print: String = h.finalize().iter().map(|b| format!("{b:02x}")).collect();
    let path = store.dir().join(format!(
        "seeds-{}-{}-{}.bin",
        octant[0], octant[1], octant[2]
    ));
    if let Some(seeds) = read_record(&path, &print) {
        return Ok(seeds);
    }
    let source: &dyn PointSource = store;
    let seeds = seed_octant(
        source,
        decisions,
        mpu_params,
        params,
        relax_points,
        octant,
        monitor,
    )?;
    write_record(&path, &print, &seeds)?;
    Ok(seeds)
}
