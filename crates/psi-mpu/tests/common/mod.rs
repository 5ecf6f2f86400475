//! Inputs shared by the integration tests.

use glam::DVec3;
use psi_mpu::{BuildOptions, DEEP, Mpu, MpuFrame, MpuParams, PointFootprint};
use psi_octree::OrientedPoint;
use rand::RngExt;
use rand_pcg::Pcg64Mcg;

/// An open square patch in the z = 0 plane: a `side` × `side` grid of step `h` (world units),
/// each point moved by up to 0.15 h along x and y (two draws of `rng` a point), normals +z,
/// row by row.
/// Shape: `side`² points.
#[allow(dead_code)] // not every test file that shares this module samples a patch
pub(crate) fn jittered_patch(side: usize, h: f64, rng: &mut Pcg64Mcg) -> Vec<OrientedPoint> {
    (0..side * side)
        .map(|k| {
            let (i, j) = ((k % side) as f64, (k / side) as f64);
            let jitter = DVec3::new(rng.random::<f64>() - 0.5, rng.random::<f64>() - 0.5, 0.0);
            OrientedPoint {
                p: DVec3::new(i * h, j * h, 0.0) + 0.3 * h * jitter,
                n: DVec3::Z,
            }
        })
        .collect()
}

/// A uniform random position in the square [`lo`, `lo` + `span`]² of the z = 0 plane (world
/// units; x drawn first, then y).
#[allow(dead_code)] // not every test file that shares this module probes a square
pub(crate) fn in_square(lo: f64, span: f64, rng: &mut Pcg64Mcg) -> DVec3 {
    let x = lo + span * rng.random::<f64>();
    DVec3::new(x, lo + span * rng.random::<f64>(), 0.0)
}

/// An MPU over `subset` (the paper's parameters) in the whole input's `frame`, its points
/// carrying `carried` (what the whole input says of each) or, with `None`, taken as the input.
#[allow(dead_code)] // not every test file that shares this module thins its input
pub(crate) fn subset_mpu(
    subset: &[OrientedPoint],
    frame: MpuFrame,
    carried: Option<&[PointFootprint]>,
) -> Mpu {
    let options = BuildOptions {
        frame: Some(frame),
        whole_footprint: carried,
        ..Default::default()
    };
    Mpu::build_with(subset, &MpuParams::paper(), options).unwrap()
}

/// The thinned subset out of core keeps of `whole`'s points: every point within two hops of
/// the data's edge (the band) and every fourth of the others, each carrying the whole input's
/// footprint, thinned to the rate of the others. Returns the subset, what its points carry and
/// the band's size.
#[allow(dead_code)] // not every test file that shares this module thins its input
pub(crate) fn band_and_every_fourth(
    whole: &mut Mpu,
) -> (Vec<OrientedPoint>, Vec<PointFootprint>, usize) {
    whole.fill_footprint();
    let n = whole.points().len();
    let all: Vec<u32> = (0..n as u32).collect();
    let footprints = whole.point_footprints(&all, &|_, _| true);
    let kept: Vec<usize> = (0..n)
        .filter(|&i| footprints[i].hops() < DEEP || i % 4 == 0)
        .collect();
    let band = kept
        .iter()
        .filter(|&&i| footprints[i].hops() < DEEP)
        .count();
    let rate = (kept.len() - band) as f64 / (n - band) as f64;
    let subset = kept.iter().map(|&i| whole.points()[i]).collect();
    let carried = kept
        .iter()
        .map(|&i| footprints[i].thinned_to(rate, DEEP - 1))
        .collect();
    (subset, carried, band)
}
