//! Wiring a file's points to the preprocessing stage: `psi-io`'s [`PointCloudFile`] to
//! `psi-preprocess`'s [`ScanInput`], and the built-in model dressed as such a file. No algorithm
//! here.

use psi_io::{NormalSource, PointCloudFile};
use psi_octree::{Monitor, OrientedPoint, PointAttributes};
use psi_preprocess::{
    MeshRef, PointOrigin, PreprocessError, PreprocessParams, PreprocessReport, Preprocessed,
    ScanInput,
};

/// A point set read and prepared for the MPU: what the CLI and the Python package build an
/// MPU or a scene from.
#[derive(Clone, Debug)]
pub struct PreparedInput {
    /// The input's name: the file as given, `builtin`, or the caller's name for arrays.
    pub name: String,
    /// Points read, before preprocessing.
    pub points_read: usize,
    /// The points for the MPU (shape M, world units, unit normals).
    pub points: Vec<OrientedPoint>,
    /// What preprocessing did.
    pub report: PreprocessReport,
    /// The reports' `input` object ([`crate::report::input_json`]).
    pub json: serde_json::Value,
    /// The file's colours, intensities and classes, following the points (aligned with
    /// `points`: a point left in keeps its own, a point added on a mesh's triangle takes its
    /// triangle's); empty when the file has none.
    pub attributes: PointAttributes,
}

impl PreparedInput {
    /// How an MPU of these points measures a cell's error ([`psi_mpu::MpuParams::error_rank`]):
    /// an order statistic at [`ERROR_RANK_POINTS`] points per rank for a noisy point cloud (its
    /// positions are measurements, and a denser one reaches further into their noise), the
    /// largest distance (`None`, the paper) for a mesh (its triangles are the surface) and for
    /// a cloud whose estimated noise (after denoising, when it was denoised) is under
    /// [`RANKED_NOISE`] of the error threshold `error_rel` (relative to D), where the largest of
    /// a million noise deviations, about 5σ, moves the error by at most 5 % of ε0.
    pub fn error_rank(&self, error_rel: f64) -> Option<usize> {
        let mesh = self.json["faces"].as_u64().is_some_and(|f| f > 0);
        let noise = self.report.noise_rel_after.or(self.report.noise_rel);
        error_rank_for(mesh, noise, error_rel)
    }
}

/// [`PreparedInput::error_rank`] of a mesh's points (`mesh`) or a point cloud's whose noise,
/// relative to D, is `noise_rel` (`None`: not estimated), for the error threshold `error_rel`.
pub(crate) fn error_rank_for(mesh: bool, noise_rel: Option<f64>, error_rel: f64) -> Option<usize> {
    let noisy = noise_rel.is_some_and(|n| n >= RANKED_NOISE * error_rel);
    (!mesh && noisy).then_some(ERROR_RANK_POINTS)
}

/// Points per rank of a noisy point cloud's cell error ([`PreparedInput::error_rank`]): about
/// what a leaf's ball holds in the paper's models (notes: 2026-11-25-density-invariance).
pub const ERROR_RANK_POINTS: usize = 256;

/// The estimated noise, as a share of the error threshold, from which a point cloud's cell
/// error is ranked ([`PreparedInput::error_rank`]).
pub const RANKED_NOISE: f64 = 0.01;

/// Prepares the points of `file`, named `name`, for the MPU ([`prepare_points`]) and
/// describes them for reports; the file's mesh, if any, is dropped once used. `monitor` sees
/// the preprocessing steps and may stop them ([`psi_preprocess::preprocess_with`]).
///
/// ```
/// let file = psi::builtin_file(2000);
/// let params = psi::preprocess::PreprocessParams::scan();
/// let monitor = psi::octree::Monitor::silent();
/// let input = psi::prepare_input("builtin".into(), file, &params, &monitor).unwrap();
/// assert_eq!((input.points_read, input.json["points_read"].as_u64()), (2000, Some(2000)));
/// ```
///
/// # Errors
///
/// As [`prepare_points`].
pub fn prepare_input(
    name: String,
    mut file: PointCloudFile,
    params: &PreprocessParams,
    monitor: &Monitor<'_>,
) -> Result<PreparedInput, PreprocessError> {
    let points_read = file.points.len();
    let prepared = prepare_points(&mut file, params, monitor)?;
    let json = crate::report::input_json(&crate::report::InputFacts {
        name: &name,
        file: &file,
        points_read,
        points: &prepared.points,
        prep: &prepared.report,
    });
    let attributes = file.attributes.select(&prepared.source);
    Ok(PreparedInput {
        name,
        points_read,
        points: prepared.points,
        report: prepared.report,
        json,
        attributes,
    })
}

/// Prepares the points of `file` for the MPU with [`psi_preprocess::preprocess`], moving them
/// out of it (`file.points` is left empty; the rest of `file` stays): its normals count as
/// given unless the file had none, and points read from a mesh are marked as such (with the
/// mesh itself when they are its triangles' centroids, for densification).
///
/// ```
/// let mut file = psi_io::read_points(b"0 0 0\n1 0 0\n", psi_io::Format::Xyz, &psi::ReadOptions::paper()).unwrap();
/// let params = psi::preprocess::PreprocessParams::none();
/// // Positions without normals, estimation off: refused.
/// assert!(psi::prepare_points(&mut file, &params, &psi::octree::Monitor::silent()).is_err());
/// ```
///
/// # Errors
///
/// [`PreprocessError::NoNormals`] for a file without normals when estimation is off.
pub fn prepare_points(
    file: &mut PointCloudFile,
    params: &PreprocessParams,
    monitor: &Monitor<'_>,
) -> Result<Preprocessed, PreprocessError> {
    let origin = match (&file.mesh, file.normals) {
        (Some(m), NormalSource::Faces) => PointOrigin::MeshCentroids(MeshRef {
            vertices: &m.vertices,
            faces: &m.faces,
        }),
        (Some(_), _) => PointOrigin::MeshVertices,
        (None, _) => PointOrigin::Scan,
    };
    let input = ScanInput {
        points: std::mem::take(&mut file.points),
        normals_given: file.normals != NormalSource::Missing,
        origin,
    };
    psi_preprocess::preprocess_with(input, params, monitor)
}

/// The built-in model (`psi_shapes::sample_builtin` with its fixed seed) as a file of `n`
/// oriented points would give it: normals from the file, no mesh. This is what every command
/// reads when it is given no input.
///
/// ```
/// let file = psi::builtin_file(1000);
/// assert_eq!((file.points.len(), file.vertices, file.faces), (1000, 1000, 0));
/// ```
pub fn builtin_file(n: usize) -> PointCloudFile {
    builtin_file_with(n, &Monitor::silent())
}

/// [`builtin_file`], its sampling stopping early once `monitor`'s stop flag is set (the caller
/// checks the flag and discards the file).
pub fn builtin_file_with(n: usize, monitor: &Monitor<'_>) -> PointCloudFile {
    PointCloudFile {
        points: psi_shapes::sample_builtin_with(n, psi_shapes::BUILTIN_MODEL_SEED, monitor),
        normals: NormalSource::File,
        vertices: n,
        faces: 0,
        degenerate_faces: 0,
        dropped_points: 0,
        mesh: None,
        attributes: Default::default(),
        source: Default::default(),
    }
}
