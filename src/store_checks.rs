//! What a run out of core checks on its final store before the MPU, as the in-core
//! preprocessing checks its points after the outlier step (`psi_preprocess::preprocess`):
//! given normals that point inward as a whole are flipped outward (the votes gathered tile by
//! tile, [`InwardEvidence`]; the flip is the store's flag, [`TileStore::with_normals_negated`],
//! the files untouched), and the noise is estimated (`tile_noise.rs`), which sets the MPU's
//! error threshold ε0 as in core. Both bitwise the in-core steps on the same points. What they
//! found is kept in `<scratch>/checks.json` (written whole, then renamed; with the version of
//! its rules, [`CHECKS_VERSION`], so that checks an older psi made are made again), so a
//! cluster's tasks read the run's ε0 and store ([`out_of_core_store`]) and a resumed run does
//! not check again.
//! Given normals are checked for consistency in the noise's tiles (as in core, every
//! ⌈N/20 000⌉-th point's neighbours). Where the noise raises ε0 above the paper's, the points
//! are denoised as in core (`tile_denoise.rs`; not for given normals found inconsistent) into
//! a store of their own, which the MPU then reads ([`out_of_core_store`]), and the noise left is
//! estimated on it.

use std::path::Path;

use glam::DVec3;
use psi_mpu::MpuParams;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};

use psi_octree::{Monitor, OrientedPoint};
use psi_preprocess::{
    DenoiseReport, ErrorThreshold, INCONSISTENT_NORMALS, InwardEvidence, InwardVotes,
    NoiseEstimate, NormalConsistency, PAPER_ERROR_REL, error_threshold_for_noise,
};
use psi_tiles::{PointSource, TileStore, TileWithHalo};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::PsiError;
use crate::budget::OutOfCore;
use crate::prepare::error_rank_for;
use crate::tile_denoise::{DENOISED_DIR, DENOISED_FILE, denoise_store};
use crate::tile_noise::{TileVisit, store_consistency, store_noise};
use crate::tile_parts::Halos;
use crate::tile_parts::io_reason;

/// The checks' file in the scratch directory.
pub(crate) const CHECKS_FILE: &str = "checks.json";

/// The version of what the checks make and record, [`StoreChecks::version`]: checks of another
/// version (1, psi before the denoising out of core; 0, before versions) are made again.
pub const CHECKS_VERSION: u32 = 2;

/// Which checks a run asks for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ChecksWanted {
    /// The inward-normals check (given normals, `flip_inward_normals`).
    pub inward: bool,
    /// The noise estimate (`estimate_noise`, not for a mesh's points).
    pub noise: bool,
    /// Denoising where the noise calls for it (`denoise`).
    pub denoise: bool,
    /// The consistency check of given normals (made in the noise's tiles).
    #[serde(default)]
    pub consistency: bool,
}

/// What the checks found on a store.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StoreChecks {
    /// The version of the rules they were made by ([`CHECKS_VERSION`]; 0 when unrecorded).
    #[serde(default)]
    pub version: u32,
    /// The store they are of ([`TileStore::digest`]).
    pub store: String,
    /// The checks asked for.
    pub wanted: ChecksWanted,
    /// The inward check's votes (when it ran).
    pub inward: Option<InwardVotes>,
    /// Whether the normals pointed inward and are read flipped outward.
    pub inward_normals_flipped: bool,
    /// The noise estimate (when it ran).
    pub noise: Option<NoiseEstimate>,
    /// The noise relative to the diagonal D of the store's points.
    pub noise_rel: Option<f64>,
    /// Its IEEE bits, which a resumed run and a cluster's tasks read.
    #[serde(default)]
    pub noise_rel_bits: Option<u64>,
    /// The consistency check of given normals (when it ran).
    #[serde(default)]
    pub consistency: Option<NormalConsistency>,
    /// What denoising did (when the noise called for it: the points the MPU reads are then
    /// the store `<scratch>/denoised`).
    #[serde(default)]
    pub denoised: Option<DenoiseReport>,
    /// The store of the denoised points ([`TileStore::digest`]).
    #[serde(default)]
    pub denoised_store: Option<String>,
    /// The noise left after denoising relative to the diagonal D of the points before, as its
    /// IEEE bits (ε0 follows from it).
    #[serde(default)]
    pub noise_rel_after_bits: Option<u64>,
}

/// The MPU's parameters of a run out of core: `params`, its error threshold ε0 / D
/// `given_error` when given, else the one the run's checks set ([`StoreChecks::mpu_params`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OutOfCoreMpu {
    /// The parameters (their `error_rel` and `error_rank` are the run's to set).
    pub params: MpuParams,
    /// The error threshold ε0 / D given by the user.
    pub given_error: Option<f64>,
}

impl OutOfCoreMpu {
    /// The paper's parameters, the threshold set by the checks.
    pub fn paper() -> Self {
        OutOfCoreMpu {
            params: MpuParams::paper(),
            given_error: None,
        }
    }

    /// `params` with the threshold `given_error` when given.
    pub fn given(params: MpuParams, given_error: Option<f64>) -> Self {
        OutOfCoreMpu {
            params,
            given_error,
        }
    }
}

impl StoreChecks {
    /// The MPU's error threshold, as in core ([`psi_preprocess::PreprocessReport::error_threshold`]):
    /// `given` (ε0 / D) when given, else the noise's ([`error_threshold_for_noise`]) when it is
    /// above the paper's, else the paper's.
    pub fn error_threshold(&self, given: Option<f64>) -> ErrorThreshold {
        let suggested = self
            .noise_left()
            .map_or(PAPER_ERROR_REL, error_threshold_for_noise);
        ErrorThreshold::chosen(given, suggested)
    }

    /// `mpu`'s parameters with the error threshold ([`StoreChecks::error_threshold`]) and the
    /// cell error's rank the in-core run takes for the same points
    /// ([`crate::PreparedInput::error_rank`]; a mesh's points have no noise estimate here).
    pub fn mpu_params(&self, mpu: &OutOfCoreMpu) -> (MpuParams, ErrorThreshold) {
        let threshold = self.error_threshold(mpu.given_error);
        let params = MpuParams {
            error_rel: threshold.relative,
            error_rank: error_rank_for(false, self.noise_left(), threshold.relative),
            ..mpu.params
        };
        (params, threshold)
    }

    /// The noise left after denoising relative to the diagonal D of the points before (when
    /// they were denoised).
    pub fn noise_rel_after(&self) -> Option<f64> {
        self.noise_rel_after_bits.map(f64::from_bits)
    }

    /// The noise the MPU sees, relative to D: what denoising left, else the noise estimate's.
    fn noise_left(&self) -> Option<f64> {
        self.noise_rel_after().or(self.noise_rel)
    }

    /// The share (0..1) of neighbouring pairs whose given normals point to opposite sides, when
    /// it exceeds [`INCONSISTENT_NORMALS`] (as
    /// [`psi_preprocess::PreprocessReport::inconsistent_normals`]; such points are not
    /// denoised); `None` otherwise or when the normals were not checked.
    pub fn inconsistent_normals(&self) -> Option<f64> {
        self.consistency
            .map(|c| c.opposed_fraction())
            .filter(|&f| f > INCONSISTENT_NORMALS)
    }
}

/// The cube of tile `key` of `store` (world units, low and high corners).
fn tile_cube(store: &TileStore, key: [u32; 3]) -> (DVec3, DVec3) {
    let m = store.manifest();
    let edge = 2.0 * m.frame.root_half / f64::from(1u32 << m.depth);
    let low = m.frame.origin + m.frame.root_center - DVec3::splat(m.frame.root_half);
    let key = DVec3::from_array(key.map(f64::from));
    (low + key * edge, low + (key + 1.0) * edge)
}

/// Adds the points `points` (index, point) of tile `key` of `store` to `evidence`: along the
/// directions its cube may reach, the points read on the threads; merged under the lock.
fn add_tile(
    store: &TileStore,
    key: [u32; 3],
    points: &[(u64, OrientedPoint)],
    evidence: &Mutex<InwardEvidence>,
) {
    let n = store.manifest().population;
    let (lo, hi) = tile_cube(store, key);
    // Along most directions no point of an inner tile can be the extreme: its cube says so.
    let along = evidence
        .lock()
        .expect("not poisoned")
        .directions_reaching(lo, hi);
    let found = points
        .par_chunks(4096)
        .fold(
            || InwardEvidence::new(n),
            |mut e, chunk| {
                for &(i, p) in chunk {
                    e.add_along(i, p, &along);
                }
                e
            },
        )
        .reduce(|| InwardEvidence::new(n), InwardEvidence::merge);
    let mut e = evidence.lock().expect("not poisoned");
    *e = std::mem::replace(&mut *e, InwardEvidence::new(n)).merge(found);
}

/// The inward check's votes on `store`'s points as it reads them, tile file by tile file
/// (one held at a time). Progress: stage `"inward"`, tiles done of tiles.
fn store_inward_votes(store: &TileStore, monitor: &Monitor<'_>) -> Result<InwardVotes, String> {
    let m = store.manifest();
    let tiles = store.part_count();
    let evidence = Mutex::new(InwardEvidence::new(m.population));
    for part in 0..tiles {
        monitor.report("inward", part as u64, tiles as u64);
        monitor.check().map_err(|_| "interrupted".to_string())?;
        let points = store
            .part_where(part, &|_| true)
            .map_err(|e| e.to_string())?;
        add_tile(store, m.tiles[part].key, &points, &evidence);
    }
    monitor.report("inward", tiles as u64, tiles as u64);
    Ok(evidence.into_inner().expect("not poisoned").votes())
}

/// The checks of `wanted` on `store` (the final store in `options.scratch`): found in
/// `<scratch>/checks.json` when an earlier run made them on the same points (and the denoised
/// store they made is whole), else made and written there. Returns the store the MPU reads
/// (the denoised points', with `mpu`'s frame rules, when the noise called for denoising; else
/// `store`, its normals read flipped when they pointed inward) and the checks.
///
/// # Errors
///
/// [`PsiError::OutOfCore`] naming the store or the checks' file when either cannot be read or
/// written; interrupted.
pub(crate) fn check_store(
    store: TileStore,
    wanted: ChecksWanted,
    (options, mpu): (&OutOfCore, &MpuParams),
    monitor: &Monitor<'_>,
) -> Result<(TileStore, StoreChecks), PsiError> {
    let scratch = &options.scratch;
    let path = scratch.join(CHECKS_FILE);
    let dir = store.dir().to_path_buf();
    let fail = |reason: String| PsiError::OutOfCore {
        path: dir.clone(),
        reason,
    };
    let digest = store.digest();
    let found = read_checks(&path)
        .ok()
        .filter(|c| c.store == digest && c.wanted == wanted)
        .and_then(|c| Some((denoised_found(&c, scratch)?, c)));
    if let Some((denoised, checks)) = found {
        let store = match denoised {
            Some(denoised) => denoised,
            None => {
                // (A denoised store an earlier run on other points left.)
                remove_denoised(scratch).map_err(&fail)?;
                flagged(store, &checks, &path)?
            }
        };
        return Ok((store, checks));
    }
    // Whatever an earlier run's checks left, now stale (a run stopped while denoising).
    remove_denoised(scratch).map_err(&fail)?;
    // The votes read the normals as written (and the flag on disk says so).
    let store = store
        .with_normals_negated(false)
        .map_err(|e| fail(e.to_string()))?;
    let mut halos = Halos::new();
    let (inward, noise, consistency) =
        inward_and_noise(&store, (wanted, options.max_memory), &mut halos, monitor)?;
    let diagonal = store.manifest().frame.diagonal;
    let noise_rel = noise.filter(|_| diagonal > 0.0).map(|n| n.sigma / diagonal);
    let mut checks = StoreChecks {
        version: CHECKS_VERSION,
        store: digest,
        wanted,
        inward,
        inward_normals_flipped: inward.is_some_and(|v| v.inward()),
        noise,
        noise_rel,
        noise_rel_bits: noise_rel.map(f64::to_bits),
        consistency,
        denoised: None,
        denoised_store: None,
        noise_rel_after_bits: None,
    };
    let store = flagged(store, &checks, &path)?;
    // As in core: denoised where the noise raises ε0 above the paper's, unless given normals
    // point every way (each point would have few neighbours on its side).
    let inconsistent = consistency.is_some_and(|c| c.opposed_fraction() > INCONSISTENT_NORMALS);
    let calls = noise_rel.is_some_and(|r| error_threshold_for_noise(r) > PAPER_ERROR_REL);
    let mut denoised_store = None;
    let fail_denoising = |reason: String| PsiError::OutOfCore {
        path: scratch.join(DENOISED_DIR),
        reason,
    };
    if let Some(noise) = noise.filter(|_| wanted.denoise && calls && !inconsistent) {
        let at = (scratch.as_path(), mpu, options.max_memory);
        let made = denoise_store(&store, noise.sigma, at, &mut halos, monitor);
        match made.map_err(fail_denoising)? {
            Some((denoised, report)) => {
                let budget = (false, options.max_memory);
                let (after, _) = store_noise(&denoised, &mut Halos::new(), None, budget, monitor)
                    .map_err(fail_denoising)?;
                checks.denoised = Some(report);
                checks.denoised_store = Some(denoised.digest());
                checks.noise_rel_after_bits = Some((after.0.sigma / diagonal).to_bits());
                denoised_store = Some(denoised);
            }
            // As in core: too few points to move, the noise estimated again on the same ones.
            None => {
                checks.denoised = Some(DenoiseReport::default());
                checks.noise_rel_after_bits = checks.noise_rel_bits;
            }
        }
    }
    let text = serde_json::to_value(&checks).expect("serialisable");
    crate::save_json(&path, &text)?;
    Ok((denoised_store.unwrap_or(store), checks))
}

/// The inward check's votes (when `wanted`), the noise estimate and the consistency of given
/// normals (when `wanted`, in the noise's tiles) of `store`'s points, its tiles' halos kept
/// in `halos`; the noise reads ahead within `max_memory` bytes ([`store_noise`]).
fn inward_and_noise(
    store: &TileStore,
    (wanted, max_memory): (ChecksWanted, u64),
    halos: &mut Halos,
    monitor: &Monitor<'_>,
) -> Result<CheckedNoise, PsiError> {
    let fail = |reason: String| PsiError::OutOfCore {
        path: store.dir().to_path_buf(),
        reason,
    };
    // The inward check's evidence from the noise's tiles when both run (one read).
    let evidence = Mutex::new(InwardEvidence::new(store.manifest().population));
    let visited = AtomicBool::new(false);
    let visit = |key: [u32; 3], tile: &TileWithHalo| {
        let own: Vec<(u64, OrientedPoint)> = tile.own_points().map(|(i, p)| (i, *p)).collect();
        add_tile(store, key, &own, &evidence);
        visited.store(true, Ordering::Relaxed);
    };
    let (noise, consistency) = if wanted.noise {
        let visit: Option<&TileVisit<'_>> = wanted.inward.then_some(&visit);
        let (noise, consistency) = store_noise(
            store,
            halos,
            visit,
            (wanted.consistency, max_memory),
            monitor,
        )
        .map_err(fail)?;
        (Some(noise.0), consistency)
    } else if wanted.consistency {
        let counted = store_consistency(store, halos, monitor).map_err(fail)?;
        (None, Some(counted))
    } else {
        (None, None)
    };
    // (Fewer than 7 points have no noise round: their votes by a pass of their own.)
    let inward = match (wanted.inward, visited.load(Ordering::Relaxed)) {
        (false, _) => None,
        (true, true) => Some(evidence.into_inner().expect("not poisoned").votes()),
        (true, false) => Some(store_inward_votes(store, monitor).map_err(fail)?),
    };
    Ok((inward, noise, consistency))
}

/// What [`inward_and_noise`] found.
type CheckedNoise = (
    Option<InwardVotes>,
    Option<NoiseEstimate>,
    Option<NormalConsistency>,
);

/// `store` with its normals read flipped when `checks` found them inward (the flag on disk).
fn flagged(store: TileStore, checks: &StoreChecks, path: &Path) -> Result<TileStore, PsiError> {
    store
        .with_normals_negated(checks.inward_normals_flipped)
        .map_err(|e| PsiError::OutOfCore {
            path: path.to_path_buf(),
            reason: e.to_string(),
        })
}

/// The denoised store `checks` made, found whole in `scratch` (`Some(None)` when they made
/// none; `None` when it is missing or other than they made).
fn denoised_found(checks: &StoreChecks, scratch: &Path) -> Option<Option<TileStore>> {
    match &checks.denoised_store {
        None => Some(None),
        Some(digest) => TileStore::open(&scratch.join(DENOISED_DIR))
            .ok()
            .filter(|s| &s.digest() == digest)
            .map(Some),
    }
}

/// Removes from `scratch` the denoised store and the moves' file, when there.
fn remove_denoised(scratch: &Path) -> Result<(), String> {
    let dir = scratch.join(DENOISED_DIR);
    if dir.exists() {
        std::fs::remove_dir_all(&dir).map_err(|e| io_reason(&dir, &e))?;
    }
    let file = scratch.join(DENOISED_FILE);
    if file.exists() {
        std::fs::remove_file(&file).map_err(|e| io_reason(&file, &e))?;
    }
    Ok(())
}

/// The checks in the file at `path`, the noise's share of D as its bits say (a JSON number
/// need not read back to the same bits, and ε0 follows from it). Checks of another version
/// than [`CHECKS_VERSION`] are an error (they are made again).
fn read_checks(path: &Path) -> Result<StoreChecks, String> {
    let text = std::fs::read_to_string(path).map_err(|e| e.to_string())?;
    let mut checks: StoreChecks = serde_json::from_str(&text).map_err(|e| e.to_string())?;
    if checks.version != CHECKS_VERSION {
        return Err(format!(
            "made by another psi (version {} of the checks, not {CHECKS_VERSION})",
            checks.version
        ));
    }
    if checks.noise_rel.is_some() != checks.noise_rel_bits.is_some() {
        return Err("the noise's share without its bits".into());
    }
    checks.noise_rel = checks.noise_rel_bits.map(f64::from_bits);
    Ok(checks)
}

/// The store the MPU of the run out of core whose scratch directory is `scratch` reads, and
/// its parameters: `mpu`'s with the error threshold and rank its checks set
/// ([`StoreChecks::mpu_params`]), as a cluster's tasks take them after the checks' task. The
/// store is the denoised points' when the checks denoised them, else the final store (its
/// normals read flipped when they pointed inward).
///
/// # Errors
///
/// [`PsiError::OutOfCore`] naming the store or the checks' file when the store cannot be
/// opened, the checks are missing or were made on other points, or their denoised store is
/// missing or other than they made.
pub fn out_of_core_store(
    scratch: &Path,
    mpu: &OutOfCoreMpu,
) -> Result<(TileStore, MpuParams), PsiError> {
    let dir = scratch.join("tiles");
    let store = TileStore::open(&dir).map_err(|e| PsiError::OutOfCore {
        path: dir.clone(),
        reason: e.to_string(),
    })?;
    let path = scratch.join(CHECKS_FILE);
    let checks = read_checks(&path)
        .ok()
        .filter(|c| c.store == store.digest())
        .ok_or_else(|| PsiError::OutOfCore {
            path: path.clone(),
            reason: "missing, made on other points or by another psi: the checks' task runs first"
                .into(),
        })?;
    let denoised = denoised_found(&checks, scratch).ok_or_else(|| PsiError::OutOfCore {
        path: scratch.join(DENOISED_DIR),
        reason: "the denoised store the checks made is missing or was changed".into(),
    })?;
    Ok((denoised.unwrap_or(store), checks.mpu_params(mpu).0))
}
