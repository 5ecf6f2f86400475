//! Particles tile by tile against the whole sampling (the oracle): bitwise the same seeds, and
//! bitwise the same particles when every point fits the relaxation; with a thinned data test
//! the same count before the ceiling on spacing (within 1 % after it) and quality (per-level
//! spacing CV within 5 %, on the surface), and no seam
//! (spacing CV, relative to each particle's target, near tile faces at most 1.1 × elsewhere).

use glam::DVec3;
use psi_mpu::{Mpu, MpuFrame, MpuParams};
use psi_octree::{Monitor, OrientedPoint};
use psi_particles::{
    ParticleParams, Particles, initialize, measure_quality, nearest_neighbour_distances, sample,
};
use psi_shapes::{AnalyticShape, assert_near, gaussian_vector};
use psi_tiles::{PointsInMemory, TileParams, decide_tiled, sample_tiled};
use rand::SeedableRng;
use rand_pcg::Pcg64Mcg;

/// The per-level spacing CV with a third of the points in the data test within this factor of
/// the whole sampling's either way (issue 26). A third of these inputs is a few points a
/// particle, too few for the subset's own test (`OWN_TEST_POINTS_PER_PARTICLE`), so they take
/// the lenient one (docs/notes/2026-11-28-unmeasured-own-test.md); with the data test's floor
/// neither run refuses moves into the gaps of the sampling. (A tenth, about one point a
/// particle, has gaps the particles' own size, which the floor does not cover:
/// docs/notes/2026-12-02-data-floor.md.)
const CV_RATIO: f64 = 1.05;

fn cv(v: &[f64]) -> f64 {
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n).sqrt() / mean
}

/// Spacing CV of the particles within `width` of a face of the tiles at `depth`, and of the
/// others: each particle's nearest-neighbour distance over its target σ̂, so that the CV
/// measures the spacing's evenness within each level and not the mix of levels near the
/// faces (which follows the surface's curvature, not the tiling).
fn seam_cvs(p: &Particles, frame: &MpuFrame, depth: u8, width: f64) -> (f64, f64) {
    let nn = nearest_neighbour_distances(&p.positions);
    let edge = 2.0 * frame.root_half / f64::from(1u32 << depth);
    let low = frame.root_center - DVec3::splat(frame.root_half) + frame.origin;
    let (mut near, mut far) = (Vec::new(), Vec::new());
    for ((x, d), sigma) in p.positions.iter().zip(nn).zip(&p.target) {
        let t = (*x - low) / edge;
        let to_face = (t - t.round()).abs().min_element() * edge;
        if to_face < width {
            near.push(d / sigma)
        } else {
            far.push(d / sigma)
        }
    }
    assert!(
        near.len() > 50 && far.len() > 50,
        "{} near, {} far",
        near.len(),
        far.len()
    );
    (cv(&near), cv(&far))
}

fn check(points: &[OrientedPoint], depth: u8, seam: bool) {
    let mparams = MpuParams::paper();
    // With the ceiling on spacing (the default), its passes reading the points tile by tile;
    // the relaxation's thinned data test is judged without it (below).
    let covered = ParticleParams::paper();
    let pparams = ParticleParams {
        max_spacing: Some(f64::INFINITY),
        ..covered
    };
    let whole = Mpu::build(points, &mparams).unwrap();
    let expected_seeds = initialize(&whole, &pparams).particles;
    let expected = sample(&whole, &pparams);
    let expected_covered = sample(&whole, &covered);
    let tiles = TileParams {
        depth,
        halo: 0.25,
        ..TileParams::default()
    };
    let decisions = decide_tiled(points, &mparams, &tiles, &Monitor::silent()).unwrap();
    let source = PointsInMemory::new(points, decisions.frame, depth);
    let run = |relax_points: usize, params: &ParticleParams| {
        sample_tiled(
            &source,
            &decisions,
            &mparams,
            params,
            relax_points,
            &Monitor::silent(),
        )
        .unwrap()
    };

    // Every point fits: the relaxation is the whole sampling's, bit for bit, and so is the
    // ceiling's cover.
    let exact = run(points.len(), &covered);
    assert_eq!(
        exact.seeds, expected_seeds,
        "seeds bitwise, in the same order"
    );
    assert_eq!(
        exact.particles, expected_covered.particles,
        "particles bitwise"
    );
    assert_eq!(exact.field, expected_covered.report.density);
    let cover = &exact.report.cover;
    assert_eq!(cover.added, expected_covered.report.added_by_ceiling);
    assert_eq!(cover.removed, expected_covered.report.replaced_by_ceiling);
    assert_eq!(exact.report.relax_points, points.len());
    assert!(exact.report.regions >= 8, "{:?}", exact.report);
    assert_eq!(exact.after, measure_quality(&whole, &exact.particles));

    // A third of the points fit: the data test reads about a third of them. With the ceiling,
    // its darts follow the relaxed positions: about as many.
    let thinned_covered = run(points.len() / 3, &covered);
    let ratio = thinned_covered.particles.len() as f64 / expected_covered.particles.len() as f64;
    assert!((0.98..=1.02).contains(&ratio), "{ratio}");
    let tiled = run(points.len() / 3, &pparams);
    assert_eq!(tiled.seeds, expected_seeds);
    assert_eq!(tiled.particles.len(), expected.particles.len());
    assert!(
        tiled.report.relax_points > 0 && tiled.report.relax_points <= points.len() / 2,
        "{:?}",
        tiled.report
    );
    let a = measure_quality(&whole, &expected.particles);
    let b = measure_quality(&whole, &tiled.particles);
    // The report's quality, measured on the thinned MPU, is the whole MPU's (f is the same).
    assert_eq!(tiled.after.spacing, b.spacing);
    assert_eq!(tiled.after.levels, b.levels);
    assert_near!(
        tiled.after.max_surface_distance,
        b.max_surface_distance,
        psi_shapes::tolerance::EXACT
    );
    assert!(
        b.max_surface_distance < 1e-4,
        "{} D",
        b.max_surface_distance
    );
    for (la, lb) in a.levels.iter().zip(&b.levels) {
        if la.spacing.count >= 100 {
            let ratio = lb.spacing.cv / la.spacing.cv;
            assert!(
                (1.0 / CV_RATIO..=CV_RATIO).contains(&ratio),
                "depth {}: tiled CV {} against {}",
                la.depth,
                lb.spacing.cv,
                la.spacing.cv
            );
        }
    }
    if !seam {
        return;
    }
    // One relaxation of all particles: nothing marks the tile faces.
    let (near, far) = seam_cvs(
        &tiled.particles,
        &decisions.frame,
        depth,
        2.0 * b.spacing.mean,
    );
    let (near0, far0) = seam_cvs(
        &expected.particles,
        &decisions.frame,
        depth,
        2.0 * b.spacing.mean,
    );
    assert!(
        near / far <= 1.1 * near0 / far0,
        "seam {near}/{far} against {near0}/{far0}"
    );
}

#[test]
fn a_torus_sampled_by_tiles_has_the_whole_samplings_seeds_and_count() {
    let mut points = AnalyticShape::Torus {
        major: 1.0,
        minor: 0.35,
    }
    .sample(40_000, 9);
    let mut rng = Pcg64Mcg::seed_from_u64(4);
    for p in &mut points {
        p.p += 1e-3 * gaussian_vector(&mut rng);
    }
    // (Tiles only four leaves wide: nearly every particle is near a face, no seam statistic.)
    check(&points, 1, false);
}

#[test]
fn an_ellipsoid_sampled_by_tiles_has_the_whole_samplings_seeds_and_count() {
    let points = AnalyticShape::Ellipsoid {
        radii: DVec3::new(1.0, 0.6, 0.3),
    }
    .sample(30_000, 5);
    check(&points, 2, true);
}

#[test]
fn the_tiled_particles_do_not_depend_on_the_thread_count() {
    let points = AnalyticShape::Ellipsoid {
        radii: DVec3::new(1.0, 0.7, 0.4),
    }
    .sample(20_000, 11);
    let mparams = MpuParams::paper();
    let pparams = ParticleParams::paper();
    let tiles = TileParams {
        depth: 2,
        halo: 0.25,
        ..TileParams::default()
    };
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| {
                let d = decide_tiled(&points, &mparams, &tiles, &Monitor::silent()).unwrap();
                let source = PointsInMemory::new(&points, d.frame, 2);
                sample_tiled(&source, &d, &mparams, &pparams, 2000, &Monitor::silent()).unwrap()
            })
    };
    let (one, two) = (run(1), run(2));
    assert!(one.report.relax_points < points.len());
    assert!(one.report.regions >= 8 && !one.particles.is_empty());
    assert_eq!(one.particles, two.particles, "bitwise, in the same order");
}

#[test]
fn several_seeds_a_leaf_tile_by_tile_are_the_whole_samplings() {
    // k = 3: leaves with fewer points than that take random positions projected by Newton
    // steps (keyed by the leaf's index), which the regions must give as the whole does.
    let points = AnalyticShape::Torus {
        major: 1.0,
        minor: 0.3,
    }
    .sample(6000, 13);
    let mparams = MpuParams::paper();
    let pparams = ParticleParams {
        k: 3,
        max_spacing: Some(f64::INFINITY),
        ..ParticleParams::paper()
    };
    let whole = Mpu::build(&points, &mparams).unwrap();
    let expected = initialize(&whole, &pparams).particles;
    let sparse_leaves = whole
        .surface_leaves()
        .filter(|&l| whole.octree().points_in(l).len() < 3)
        .count();
    assert!(sparse_leaves > 0, "no leaf takes a random seed");
    let decisions = decide_tiled(
        &points,
        &mparams,
        &TileParams::at_depth(2),
        &Monitor::silent(),
    )
    .unwrap();
    let source = PointsInMemory::new(&points, decisions.frame, 2);
    let tiled = sample_tiled(
        &source,
        &decisions,
        &mparams,
        &pparams,
        points.len(),
        &Monitor::silent(),
    )
    .unwrap();
    assert!(tiled.report.regions >= 8, "{:?}", tiled.report);
    assert_eq!(tiled.seeds, expected, "seeds bitwise, in the same order");
}

/// A box's faces are planes, fitted by big cells that seed few particles: the ceiling on
/// spacing adds darts over them. Tile by tile its passes read the points tile by tile, and
/// the particles are the whole sampling's bitwise when every point fits; with a third of them
/// in the relaxation, the same count within 3 % and every input point covered.
#[test]
fn a_box_covered_tile_by_tile_is_covered_as_a_whole() {
    let points = AnalyticShape::Box {
        half: DVec3::new(1.0, 0.7, 0.4),
    }
    .sample(30_000, 3);
    let mparams = MpuParams::paper();
    let pparams = ParticleParams::paper();
    let whole = Mpu::build(&points, &mparams).unwrap();
    let expected = sample(&whole, &pparams);
    let added = expected.report.added_by_ceiling;
    assert!(added > 100, "{added} darts");
    let ceiling = expected.report.density.ceiling.unwrap();
    let decisions = decide_tiled(
        &points,
        &mparams,
        &TileParams::at_depth(2),
        &Monitor::silent(),
    )
    .unwrap();
    let source = PointsInMemory::new(&points, decisions.frame, 2);
    let run = |relax_points: usize| {
        sample_tiled(
            &source,
            &decisions,
            &mparams,
            &pparams,
            relax_points,
            &Monitor::silent(),
        )
        .unwrap()
    };
    let exact = run(points.len());
    assert_eq!(exact.particles, expected.particles, "particles bitwise");
    assert_eq!(exact.report.cover.added, added);
    assert_eq!(
        exact.report.cover.removed,
        expected.report.replaced_by_ceiling
    );
    assert!(exact.report.cover.passes >= 3, "{:?}", exact.report.cover);
    assert_eq!(exact.field, expected.report.density);

    let thinned = run(points.len() / 3);
    assert!(thinned.report.relax_points < points.len() / 2);
    let ratio = thinned.particles.len() as f64 / expected.particles.len() as f64;
    assert!((0.97..=1.03).contains(&ratio), "{ratio}");
    let grid = psi_particles::ParticleGrid::new(&thinned.particles.positions, ceiling);
    let uncovered = points
        .iter()
        .filter(|p| !grid.any_within(p.p, ceiling))
        .count();
    assert_eq!(
        uncovered, 0,
        "points farther than the ceiling from every particle"
    );
}
