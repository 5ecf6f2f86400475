//! The preprocessing stage as a whole: the steps a real scan needs, in order, each one on or
//! off, with a report of what each did.

use std::time::Instant;

use glam::DVec3;
use psi_octree::{Aabb, Interrupted, Monitor, MortonIndex, OrientedPoint};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::drop_repeated::drop_repeated;
use crate::drop_strays::{OutlierReport, drop_strays, retain_kept};
use crate::estimate_noise::{estimate_noise_in, noise_and_reach_in};
use crate::estimate_normals::{estimate_normals_in, noise_level};
use crate::neighbour_graph::morton_index_of;
use crate::orient_from_level::orient_from_level;
use crate::orient_normals::{check_normal_consistency_in, orient_normals_in};
use crate::point_spread::spread_of;
use crate::{
    DenoiseReport, MeshCoarseness, NoiseEstimate, NormalConsistency, Spread, denoise_with,
    densify_mesh_with_sources, estimate_noise, inward_flip_notice, inward_votes, mesh_coarseness,
    orient_toward,
};

/// Ohtake's error threshold ε0 relative to the bounding-box diagonal D (algorithms.md §1.1):
/// the threshold never goes below it.
pub const PAPER_ERROR_REL: f64 = 0.005;

/// ε0 from a noise estimate σ: this many σ. The MPU's error is the largest Taubin distance of
/// the points in a cell's ball, and the largest of n Gaussian deviates is about
/// σ·√(2 ln n) — about 3σ for the balls of a leaf, 4σ for a coarse cell's thousands — so a
/// threshold below that splits cells on the noise alone.
pub const NOISE_ERROR_FACTOR: f64 = 4.0;

/// Given normals are inconsistent when more than this share of neighbouring pairs on a sheet
/// point to opposite sides ([`NormalConsistency::opposed_fraction`]). Such points are not
/// denoised unless reoriented first: denoising fits each point to the neighbours on its side.
pub const INCONSISTENT_NORMALS: f64 = 0.01;

/// Which steps run ([`PreprocessParams::scan`]: all of them).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PreprocessParams {
    /// Find and drop points no surface supports ([`crate::find_outliers`]), then stray
    /// clumps among the rest ([`crate::find_clumps`]).
    pub remove_outliers: bool,
    /// Estimate normals where the input has none ([`crate::estimate_normals`]); when off, such
    /// an input is refused by [`preprocess`].
    pub estimate_normals: bool,
    /// Orient estimated normals toward this sensor position (a single range scan) instead of
    /// by propagation.
    pub viewpoint: Option<DVec3>,
    /// Make given normals consistent by propagation ([`crate::orient_normals`]); estimated
    /// normals are always oriented.
    pub orient_given_normals: bool,
    /// Estimate the positions' noise and suggest ε0 from it ([`crate::estimate_noise`]).
    pub estimate_noise: bool,
    /// Where the noise would raise ε0 above the paper's, take it out of the positions first
    /// ([`crate::denoise`]; needs `estimate_noise`).
    pub denoise: bool,
    /// Add points on a coarse mesh's large triangles ([`crate::densify_mesh`]).
    pub densify_meshes: bool,
    /// Flip given normals that point inward as a whole ([`crate::inward_votes`]) to outward,
    /// so that f > 0 outside; off for a surface seen from inside (a room scanned from its
    /// middle), whose hull points face inward on purpose.
    #[serde(default)]
    pub flip_inward_normals: bool,
}

impl PreprocessParams {
    /// Every repair on: outliers removed, missing normals estimated and oriented by
    /// propagation, noise estimated; given normals kept as they are.
    pub fn scan() -> Self {
        Self {
            remove_outliers: true,
            estimate_normals: true,
            viewpoint: None,
            orient_given_normals: false,
            estimate_noise: true,
            denoise: true,
            densify_meshes: true,
            flip_inward_normals: true,
        }
    }

    /// Every step off: the points go to the MPU as read (the paper's set-up).
    pub fn none() -> Self {
        Self {
            remove_outliers: false,
            estimate_normals: false,
            viewpoint: None,
            orient_given_normals: false,
            estimate_noise: false,
            denoise: false,
            densify_meshes: false,
            flip_inward_normals: false,
        }
    }
}

/// What happened to the normals.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NormalTreatment {
    /// Kept as given.
    Given,
    /// Given, then made consistent by propagation.
    GivenReoriented,
    /// Estimated, then oriented by propagation over a neighbour graph.
    EstimatedPropagated,
    /// Estimated, then oriented toward the sensor.
    EstimatedTowardViewpoint,
}

/// A triangle mesh the points were taken from, borrowed.
#[derive(Clone, Copy, Debug)]
pub struct MeshRef<'a> {
    /// Vertex positions (shape: V), world units.
    pub vertices: &'a [DVec3],
    /// Triangles (shape: F), indices into `vertices`, counter-clockwise seen from outside.
    pub faces: &'a [[u32; 3]],
}

/// What [`preprocess`] works on.
#[derive(Clone, Debug)]
pub struct ScanInput<'a> {
    /// The points (shape: N, world units): unit normals, or all zero when `normals_given` is
    /// false.
    pub points: Vec<OrientedPoint>,
    /// Whether the points carry normals.
    pub normals_given: bool,
    /// Where the points come from.
    pub origin: PointOrigin<'a>,
}

/// Where the points of a [`ScanInput`] come from. A mesh's triangles are taken as the surface:
/// its points are not searched for outliers (the connectivity supports them), nor denoised,
/// nor is ε0 raised for noise (a coarse mesh's quadric residuals measure its coarseness).
#[derive(Clone, Copy, Debug)]
pub enum PointOrigin<'a> {
    /// A scan or any point cloud: every step applies.
    Scan,
    /// A mesh's vertices (with per-vertex normals).
    MeshVertices,
    /// A mesh's triangles, one point per triangle at its centroid with the face normal; a
    /// coarse mesh gets more points on its large triangles.
    MeshCentroids(MeshRef<'a>),
}

impl PointOrigin<'_> {
    /// Whether the points come from a triangle mesh.
    pub fn is_mesh(&self) -> bool {
        !matches!(self, PointOrigin::Scan)
    }
}

/// The mesh step's result.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct MeshReport {
    /// How coarse the mesh is.
    pub coarseness: MeshCoarseness,
    /// Points added on its large triangles.
    pub points_added: usize,
}

/// Where an MPU error threshold comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ThresholdSource {
    /// Given by the user.
    User,
    /// Set from the noise estimate ([`NOISE_ERROR_FACTOR`] × σ).
    Noise,
    /// The paper's 0.005.
    Paper,
}

/// An MPU error threshold ε0 relative to D and where it comes from.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ErrorThreshold {
    /// ε0 / D.
    pub relative: f64,
    /// Where it comes from.
    pub source: ThresholdSource,
}

impl ErrorThreshold {
    /// The threshold to use: `user`'s (ε0 / D) when given, else `suggested` (what the noise
    /// suggests, [`error_threshold_for_noise`]) when it is above the paper's, else the paper's.
    pub fn chosen(user: Option<f64>, suggested: f64) -> ErrorThreshold {
        let (relative, source) = match user {
            Some(user) => (user, ThresholdSource::User),
            None if suggested > PAPER_ERROR_REL => (suggested, ThresholdSource::Noise),
            None => (PAPER_ERROR_REL, ThresholdSource::Paper),
        };
        ErrorThreshold { relative, source }
    }
}

/// What [`preprocess`] did, step by step.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PreprocessReport {
    /// Points given.
    pub points_in: usize,
    /// Points passed on (to the MPU).
    pub points_out: usize,
    /// The mesh step, when the points came from a mesh and the step ran.
    pub mesh: Option<MeshReport>,
    /// The outlier step, when it ran.
    pub outliers: Option<OutlierReport>,
    /// Points left out before the outlier step as repeats of an earlier point's position.
    #[serde(default)]
    pub repeated: usize,
    /// What happened to the normals.
    pub normals: NormalTreatment,
    /// Normals flipped by an orientation step.
    pub normals_flipped: usize,
    /// Whether given normals pointed inward as a whole and were all flipped outward
    /// ([`PreprocessParams::flip_inward_normals`]).
    #[serde(default)]
    pub inward_normals_flipped: bool,
    /// Same-sheet neighbour pairs with opposed normals, given normals only (before any
    /// reorientation).
    pub consistency: Option<NormalConsistency>,
    /// The noise estimate, when it ran.
    pub noise: Option<NoiseEstimate>,
    /// The noise relative to the bounding-box diagonal D of the points passed on.
    pub noise_rel: Option<f64>,
    /// The denoising step, when the noise called for it.
    pub denoised: Option<DenoiseReport>,
    /// The noise left after denoising, relative to D.
    pub noise_rel_after: Option<f64>,
    /// The MPU error threshold ε0 relative to D that the data suggest: the paper's 0.005, or
    /// [`NOISE_ERROR_FACTOR`] × the noise (left after denoising) when that is larger.
    pub error_rel: f64,
    /// Seconds of each step that ran (zero for a step that did not).
    pub seconds: StepSeconds,
}

/// Seconds per step (0 for a step that did not run).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct StepSeconds {
    /// Judging a mesh's coarseness and adding points.
    pub mesh: f64,
    /// Finding outliers.
    pub outliers: f64,
    /// Estimating, checking and orienting normals.
    pub normals: f64,
    /// Estimating the noise (before and after denoising).
    pub noise: f64,
    /// Denoising.
    pub denoise: f64,
}

/// The points after preprocessing and the report.
#[derive(Clone, Debug)]
pub struct Preprocessed {
    /// The points for the MPU (shape: M, world units, unit normals): fewer than the input's
    /// where outliers or points without a normal were dropped, more where a coarse mesh was
    /// densified.
    pub points: Vec<OrientedPoint>,
    /// What each step did.
    pub report: PreprocessReport,
    /// For each point, the index of the input point it came from (shape: M): a point left in
    /// keeps its index, a point added on a coarse mesh's triangle takes that triangle's point.
    /// Attributes follow the points by it ([`psi_octree::PointAttributes::select`]).
    pub source: Vec<u32>,
}

/// Why [`preprocess`] could not prepare the points.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum PreprocessError {
    /// The points have no normals and normal estimation is off.
    ///
    /// ```
    /// use psi_octree::OrientedPoint;
    /// use psi_preprocess::{preprocess, PointOrigin, PreprocessError, PreprocessParams, ScanInput};
    /// let points = vec![OrientedPoint { p: glam::DVec3::ZERO, n: glam::DVec3::ZERO }; 20];
    /// let input = ScanInput { points, normals_given: false, origin: PointOrigin::Scan };
    /// let err = preprocess(input, &PreprocessParams::none()).unwrap_err();
    /// assert_eq!(err, PreprocessError::NoNormals);
    /// ```
    #[error("the points have no normals and normal estimation is off")]
    NoNormals,
    /// The points make no surface: coincident, collinear or beyond double precision's reach.
    #[error("{}", match .0 {
        Spread::Coincident => "all points coincide: they make no surface",
        Spread::Unbounded => "the points spread too far for double precision (coordinates beyond about 1e154): scale them or leave the far ones out",
        _ => "all points lie on one straight line: they make no surface",
    })]
    NoSurface(Spread),
    /// The caller stopped the work ([`psi_octree::Monitor`]).
    #[error("preprocessing was interrupted")]
    Interrupted(#[from] Interrupted),
}

impl PreprocessReport {
    /// The notice for normals flipped outward ([`PreprocessReport::inward_normals_flipped`]),
    /// naming the input; the caller adds how to keep them.
    pub fn inward_notice(&self, name: &str) -> Option<String> {
        self.inward_normals_flipped
            .then(|| inward_flip_notice(name))
    }

    /// The MPU error threshold to use: `user`'s when given, else the one the noise suggests
    /// when it is above the paper's, else the paper's.
    ///
    /// ```
    /// use psi_preprocess::{preprocess, PointOrigin, PreprocessParams, ScanInput, ThresholdSource};
    /// let points = psi_shapes::AnalyticShape::Sphere { radius: 1.0 }.sample(2000, 1);
    /// let input = ScanInput { points, normals_given: true, origin: PointOrigin::Scan };
    /// let done = preprocess(input, &PreprocessParams::scan()).unwrap();
    /// assert_eq!(done.report.error_threshold(None).source, ThresholdSource::Paper);
    /// assert_eq!(done.report.error_threshold(Some(0.01)).relative, 0.01);
    /// ```
    pub fn error_threshold(&self, user: Option<f64>) -> ErrorThreshold {
        ErrorThreshold::chosen(user, self.error_rel)
    }
    /// The share (0..1) of neighbouring pairs whose given normals point to opposite sides,
    /// when it exceeds [`INCONSISTENT_NORMALS`] and the normals were kept as given (such
    /// normals are not denoised; `orient_given_normals` repairs them); `None` otherwise.
    pub fn inconsistent_normals(&self) -> Option<f64> {
        opposed_beyond_limit(self.consistency, self.normals)
    }
}

/// The share of opposed neighbouring normals when `consistency` exceeds
/// [`INCONSISTENT_NORMALS`] and the normals were kept as given; `None` otherwise.
fn opposed_beyond_limit(
    consistency: Option<NormalConsistency>,
    normals: NormalTreatment,
) -> Option<f64> {
    consistency
        .map(|c| c.opposed_fraction())
        .filter(|&f| f > INCONSISTENT_NORMALS && normals == NormalTreatment::Given)
}

/// ε0 relative to D for a noise of `noise_rel` × D: the paper's 0.005, or
/// [`NOISE_ERROR_FACTOR`] × the noise when that is larger.
pub fn error_threshold_for_noise(noise_rel: f64) -> f64 {
    (NOISE_ERROR_FACTOR * noise_rel).max(PAPER_ERROR_REL)
}

/// Prepares `input`'s points for the MPU, as `params` say, in this order: a coarse mesh's
/// large triangles given more points; outliers, then stray clumps among the rest, removed (not
/// for a mesh); normals estimated and oriented (toward `params.viewpoint`, else by
/// propagation) when there are none, else checked for consistency and, with
/// `params.orient_given_normals`, reoriented; the noise estimated; where it would raise the
/// error threshold above the paper's, the points denoised and the noise estimated again (not
/// for a mesh, nor for given normals found inconsistent — more than [`INCONSISTENT_NORMALS`]
/// opposed — and not reoriented); the error threshold the noise left suggests (the paper's for
/// a mesh). Deterministic and independent of the thread count.
///
/// # Errors
///
/// [`PreprocessError::NoNormals`] when the points have no normals and estimation is off.
///
/// ```
/// use psi_preprocess::{preprocess, PointOrigin, PreprocessParams, NormalTreatment, ScanInput};
/// use psi_shapes::AnalyticShape;
///
/// // A sphere's positions alone: normals estimated and oriented outward.
/// let truth = AnalyticShape::Sphere { radius: 1.0 }.sample(5000, 1);
/// let bare = truth.iter().map(|p| psi_octree::OrientedPoint { p: p.p, n: glam::DVec3::ZERO }).collect();
/// let input = ScanInput { points: bare, normals_given: false, origin: PointOrigin::Scan };
/// let done = preprocess(input, &PreprocessParams::scan()).unwrap();
/// assert_eq!(done.report.normals, NormalTreatment::EstimatedPropagated);
/// assert_eq!(done.report.outliers.unwrap().removed, 0);
/// assert!(done.points.iter().zip(&truth).all(|(a, b)| a.n.dot(b.n) > 0.9));
/// assert_eq!(done.report.error_rel, 0.005); // clean: the paper's threshold
/// ```
pub fn preprocess(
    input: ScanInput<'_>,
    params: &PreprocessParams,
) -> Result<Preprocessed, PreprocessError> {
    preprocess_with(input, params, &Monitor::silent())
}

/// [`preprocess`], reporting each step that runs to `monitor` as a stage (`"densify"`,
/// `"outliers"`, `"normals"`, `"orient"` (when estimated normals are oriented by
/// propagation), `"noise"`, `"denoise"`, each 0 then 1 of 1, in that order) and returning
/// [`PreprocessError::Interrupted`] between steps once its stop flag is set. A run that
/// completes equals [`preprocess`]'s.
pub fn preprocess_with(
    input: ScanInput<'_>,
    params: &PreprocessParams,
    monitor: &Monitor<'_>,
) -> Result<Preprocessed, PreprocessError> {
    let step = |stage: &str, done: u64| -> Result<(), Interrupted> {
        monitor.check()?;
        monitor.report(stage, done, 1);
        Ok(())
    };
    let ScanInput {
        mut points,
        normals_given,
        origin,
    } = input;
    if !normals_given && !params.estimate_normals {
        return Err(PreprocessError::NoNormals);
    }
    match spread_of(points.len(), &|i| points[i].p) {
        Spread::Surface => {}
        degenerate => return Err(PreprocessError::NoSurface(degenerate)),
    }
    let _span = tracing::info_span!("preprocess", points = points.len()).entered();
    let points_in = points.len();
    let mut seconds = StepSeconds::default();
    // The input point each point came from (its triangle's, for a densified point).
    let mut source: Vec<u32> = (0..points_in as u32).into_par_iter().collect();

    let mut mesh_report = None;
    if let PointOrigin::MeshCentroids(m) = origin
        && params.densify_meshes
    {
        step("densify", 0)?;
        let t = Instant::now();
        if let Some(coarseness) = mesh_coarseness(m.vertices, m.faces) {
            let (extra, from) = coarseness
                .max_area
                .map(|a| densify_mesh_with_sources(m.vertices, m.faces, a))
                .unwrap_or_default();
            mesh_report = Some(MeshReport {
                coarseness,
                points_added: extra.len(),
            });
            points.extend(extra);
            source.extend(from);
        }
        seconds.mesh = t.elapsed().as_secs_f64();
        step("densify", 1)?;
    }

    // One Morton index of the points serves the neighbour searches below: made once, carried
    // through the steps that drop points (`MortonIndex::retained`, no second sort; its answers
    // are a fresh index's), made again only after the orientation (which frees it for its
    // graphs) or denoising (which moves the points).
    let mut index: Option<MortonIndex> = None;
    let (mut outliers, mut repeated) = (None, 0);
    if params.remove_outliers && !origin.is_mesh() {
        step("outliers", 0)?;
        let t = Instant::now();
        let all = morton_index_of(&points);
        let (dropped, all) = drop_repeated(&mut points, &mut source, all);
        repeated = dropped;
        let (report, kept) = drop_strays(&mut points, &mut source, normals_given, all, monitor)?;
        (outliers, index) = (Some(report), Some(kept));
        seconds.outliers = t.elapsed().as_secs_f64();
        step("outliers", 1)?;
    }

    step("normals", 0)?;
    let t = Instant::now();
    let mut consistency = None;
    // The noise estimate of the points as they are after the normals, when made before them.
    let mut noise_before_normals = None;
    let mut normals_flipped = 0;
    let mut inward_normals_flipped = false;
    let normals = if normals_given {
        let at = index.get_or_insert_with(|| morton_index_of(&points));
        let check = check_normal_consistency_in(&points, at, crate::CONSISTENCY_QUERIES);
        consistency = Some(check);
        monitor.check()?;
        if params.orient_given_normals {
            // (The orientation takes the index: its graphs need the memory.)
            let at = index.take().unwrap_or_else(|| morton_index_of(&points));
            normals_flipped = orient_normals_in(&mut points, at, monitor);
            monitor.check()?;
            NormalTreatment::GivenReoriented
        } else {
            if params.flip_inward_normals && inward_votes(&points).inward() {
                for p in &mut points {
                    p.n = -p.n;
                }
                normals_flipped = points.len();
                inward_normals_flipped = true;
            }
            NormalTreatment::Given
        }
    } else {
        let at = index.get_or_insert_with(|| morton_index_of(&points));
        // The noise sets the neighbourhoods' scale; the noise step below reads the same
        // points when every point gets a normal.
        let positions: Vec<DVec3> = points.iter().map(|p| p.p).collect();
        let (noise, reach) = noise_and_reach_in(&positions, at);
        drop(positions);
        let level = noise_level(noise.sigma, reach);
        let estimated = estimate_normals_in(points.len(), at, level, monitor);
        monitor.check()?;
        points
            .par_iter_mut()
            .zip(estimated)
            .for_each(|(p, n)| p.n = n);
        // A point whose neighbourhood gave no plane is dropped: it has no normal to fit with.
        let has_normal: Vec<bool> = points.par_iter().map(|p| p.n != DVec3::ZERO).collect();
        if has_normal.iter().all(|&h| h) {
            noise_before_normals = Some(noise);
        }
        retain_kept(&mut points, &mut source, &has_normal);
        if has_normal.iter().any(|h| !h) {
            *at = at.retained(&has_normal);
        }
        match params.viewpoint {
            Some(v) => {
                normals_flipped = orient_toward(&mut points, v);
                NormalTreatment::EstimatedTowardViewpoint
            }
            None => {
                // Its own stage, after the estimation's (each stage is one block).
                step("normals", 1)?;
                step("orient", 0)?;
                let at = index.take().unwrap_or_else(|| morton_index_of(&points));
                normals_flipped = orient_from_level(&mut points, at, level, monitor);
                monitor.check()?;
                NormalTreatment::EstimatedPropagated
            }
        }
    };
    seconds.normals = t.elapsed().as_secs_f64();
    let oriented = !normals_given && params.viewpoint.is_none();
    step(if oriented { "orient" } else { "normals" }, 1)?;

    let mut noise = None;
    let mut noise_rel = None;
    let mut denoised = None;
    let mut noise_rel_after = None;
    let mut error_rel = PAPER_ERROR_REL;
    if params.estimate_noise {
        step("noise", 0)?;
        let t = Instant::now();
        let estimate = match noise_before_normals {
            Some(estimate) => estimate,
            None => {
                let positions: Vec<DVec3> = points.par_iter().map(|p| p.p).collect();
                let at = index.get_or_insert_with(|| MortonIndex::new(&positions));
                estimate_noise_in(&positions, at)
            }
        };
        let diagonal =
            Aabb::from_positions_at(points.len(), &|i| points[i].p).map_or(0.0, |b| b.diagonal());
        if diagonal > 0.0 {
            let rel = estimate.sigma / diagonal;
            noise_rel = Some(rel);
            error_rel = error_threshold_for_noise(rel);
        }
        noise = Some(estimate);
        seconds.noise = t.elapsed().as_secs_f64();
        step("noise", 1)?;
        // Given normals pointing every way would leave each point few neighbours on its side.
        let inconsistent = opposed_beyond_limit(consistency, normals).is_some();
        if origin.is_mesh() {
            // The triangles are the surface: their residuals are no noise to fit around.
            error_rel = PAPER_ERROR_REL;
        } else if params.denoise && error_rel > PAPER_ERROR_REL && !inconsistent {
            step("denoise", 0)?;
            let t = Instant::now();
            // Denoising moves the points: the index no longer describes them.
            drop(index.take());
            denoised = Some(denoise_with(&mut points, estimate.sigma, monitor));
            monitor.check()?;
            seconds.denoise = t.elapsed().as_secs_f64();
            let t = Instant::now();
            let positions: Vec<DVec3> = points.iter().map(|p| p.p).collect();
            let rel = estimate_noise(&positions).sigma / diagonal;
            noise_rel_after = Some(rel);
            error_rel = error_threshold_for_noise(rel);
            seconds.noise += t.elapsed().as_secs_f64();
            step("denoise", 1)?;
        }
    }

    Ok(Preprocessed {
        report: PreprocessReport {
            points_in,
            points_out: points.len(),
            mesh: mesh_report,
            outliers,
            repeated,
            normals,
            normals_flipped,
            inward_normals_flipped,
            consistency,
            noise,
            noise_rel,
            denoised,
            noise_rel_after,
            error_rel,
            seconds,
        },
        points,
        source,
    })
}

#[cfg(test)]
#[path = "preprocess_tests.rs"]
mod tests;
