//! A generated multi-view range scan of a mesh (issue 28): k sensors around the model each see
//! the surface through the single-view ray cast (`visibility.rs`), each view is moved by its own
//! small rigid registration error, grazing returns stand off along their rays, and the views
//! are merged, x y z only, in view order (as a merged scanner output is).
//!
//! Per view, with its own seeded stream: area-uniform samples of the mesh ([`MultiViewParams`]'s
//! `samples_per_view`, with face normals), each kept with probability cos θ (θ between its
//! normal and the ray to the sensor: a range image's density per area falls with the incidence
//! angle) when the sensor sees it; of the kept points with cos θ < `grazing_cos`, a share
//! `grazing_share` moves along its ray by a distance drawn in `standoff` (either sign: a mixed
//! pixel lands in front of or behind the surface); then the view's pose error: a rotation about
//! a random axis through the model's centre and a translation in a random direction, each moving
//! no point by more than half the view's error magnitude m, m drawn uniformly in `pose_error`,
//! so that no point of the view moves by more than m.

use anyhow::{Context, Result};
use parry3d_f64::shape::TriMesh;
use psi::{Aabb, DVec3, TriangleMesh};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64Mcg;

use crate::surface_samples::{TriangleSampler, random_unit, rotate};
use crate::visibility::visible;

/// How a multi-view scan is made; lengths are fractions of the mesh's bounding-box diagonal D.
#[derive(Clone, Copy, Debug)]
pub(crate) struct MultiViewParams {
    /// Sensors, spread over a sphere around the model (a Fibonacci sphere, turned by a seeded
    /// random rotation).
    pub(crate) views: usize,
    /// The sensors' distance from the model's centre, in D.
    pub(crate) distance: f64,
    /// Area-uniform samples of the whole mesh drawn per view before visibility and the
    /// incidence thinning keep a part of them.
    pub(crate) samples_per_view: usize,
    /// Range of a view's pose error magnitude m (the largest displacement of its points), in D.
    pub(crate) pose_error: (f64, f64),
    /// |n·ray| below which a return is grazing.
    pub(crate) grazing_cos: f64,
    /// Share of the grazing returns that stand off along their ray.
    pub(crate) grazing_share: f64,
    /// Range of the stand-off distance along the ray, in D.
    pub(crate) standoff: (f64, f64),
}

impl MultiViewParams {
    /// Issue 28's set-up for a mesh of `faces` triangles: 10 views at 2 D, as many samples per
    /// view as the mesh has triangles (the merged scan holds about 1.5× as many points), pose
    /// errors of 0.05–0.2 % D, half of the returns with |n·ray| < 0.15 standing off by
    /// 1–5 × 1e-3 D.
    pub(crate) fn issue_28(faces: usize) -> Self {
        Self {
            views: 10,
            distance: 2.0,
            samples_per_view: faces,
            pose_error: (0.0005, 0.002),
            grazing_cos: 0.15,
            grazing_share: 0.5,
            standoff: (1e-3, 5e-3),
        }
    }
}

/// One view of a [`MultiView`]: where its sensor was and what was done to its points.
#[derive(Clone, Debug)]
pub(crate) struct View {
    /// Sensor position, world units (3).
    pub(crate) sensor: [f64; 3],
    /// Points of the view in the merged scan.
    pub(crate) points: usize,
    /// Grazing returns moved along their ray.
    pub(crate) grazing_moved: usize,
    /// The pose error magnitude m drawn, in D.
    pub(crate) pose_error: f64,
    /// Mean and largest displacement of the view's points by the pose error, in D.
    pub(crate) mean_displacement: f64,
    pub(crate) max_displacement: f64,
}

impl View {
    /// The view as a JSON object (the fields' names and units as above).
    pub(crate) fn to_json(&self) -> serde_json::Value {
        serde_json::json!({
            "sensor": self.sensor,
            "points": self.points,
            "grazing_moved": self.grazing_moved,
            "pose_error": self.pose_error,
            "mean_displacement": self.mean_displacement,
            "max_displacement": self.max_displacement,
        })
    }
}

/// A merged multi-view scan: positions (shape: N, world units, in view order) and its views.
pub(crate) struct MultiView {
    pub(crate) points: Vec<DVec3>,
    pub(crate) views: Vec<View>,
}

/// Sensor directions: `k` unit vectors of a Fibonacci sphere (nearly even over the sphere).
fn fibonacci_directions(k: usize) -> Vec<DVec3> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..k)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / k as f64;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = golden * i as f64;
            DVec3::new(r * phi.cos(), r * phi.sin(), z)
        })
        .collect()
}

/// The multi-view scan of `mesh` (its parry copy `shape` for the ray casts) made by `params`
/// from `seed` (same seed, same points).
pub(crate) fn multiview_scan(
    mesh: &TriangleMesh,
    shape: &TriMesh,
    params: &MultiViewParams,
    seed: u64,
) -> Result<MultiView> {
    let sampler = TriangleSampler::from_mesh(mesh)?;
    let bounds = Aabb::from_points(mesh.vertices.iter().copied()).context("empty mesh")?;
    let (centre, diag) = (bounds.center(), bounds.diagonal());
    // The largest distance from the centre to the surface: a rotation by angle a moves no point
    // by more than a·radius.
    let radius = mesh
        .vertices
        .iter()
        .map(|v| v.distance(centre))
        .fold(0.0, f64::max);
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    let (turn_axis, turn_angle) = (
        random_unit(&mut rng),
        rng.random_range(0.0..std::f64::consts::TAU),
    );
    let mut points = Vec::new();
    let mut views = Vec::new();
    for (v, dir) in fibonacci_directions(params.views).into_iter().enumerate() {
        let sensor = centre + params.distance * diag * rotate(dir, turn_axis, turn_angle);
        let mut vr =
            Pcg64Mcg::seed_from_u64(seed.wrapping_mul(1_000_003).wrapping_add(v as u64 + 1));
        // Incidence thinning first (cheap, sequential: the draws stay in order), then the ray
        // casts in parallel.
        let candidates: Vec<_> = sampler
            .samples(params.samples_per_view, &mut vr)
            .into_iter()
            .filter(|p| {
                let cos = p.n.dot((sensor - p.p).normalize_or_zero());
                cos > 0.0 && vr.random::<f64>() < cos
            })
            .collect();
        let seen = visible(&candidates, shape, sensor);
        let m = vr.random_range(params.pose_error.0..=params.pose_error.1) * diag;
        let (axis, shift) = (random_unit(&mut vr), random_unit(&mut vr) * (0.5 * m));
        let angle = 0.5 * m / radius.max(f64::MIN_POSITIVE);
        let mut grazing_moved = 0;
        let (mut sum, mut max) = (0.0, 0.0f64);
        for p in &seen {
            let ray = (p.p - sensor).normalize();
            let mut q = p.p;
            if p.n.dot(ray).abs() < params.grazing_cos && vr.random::<f64>() < params.grazing_share
            {
                let d = vr.random_range(params.standoff.0..=params.standoff.1) * diag;
                let sign = if vr.random::<bool>() { 1.0 } else { -1.0 };
                q += sign * d * ray;
                grazing_moved += 1;
            }
            let moved = centre + rotate(q - centre, axis, angle) + shift;
            let disp = moved.distance(q);
            sum += disp;
            max = max.max(disp);
            points.push(moved);
        }
        views.push(View {
            sensor: sensor.to_array(),
            points: seen.len(),
            grazing_moved,
            pose_error: m / diag,
            mean_displacement: sum / seen.len().max(1) as f64 / diag,
            max_displacement: max / diag,
        });
    }
    Ok(MultiView { points, views })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fibonacci_directions_are_unit_and_spread() {
        let d = fibonacci_directions(10);
        assert!(d.iter().all(|v| (v.length() - 1.0).abs() < 1e-12));
        assert!(d.iter().sum::<DVec3>().length() < 0.5);
    }

    /// A cube seen from ten sensors: every face is seen, the pose errors stay in their range and
    /// move no point by more than m, and the same seed gives the same points.
    #[test]
    fn a_cube_scan_is_seeded_and_bounded() {
        let v: Vec<DVec3> = (0..8)
            .map(|i| DVec3::new((i & 1) as f64, (i >> 1 & 1) as f64, (i >> 2 & 1) as f64))
            .collect();
        let faces = crate::surface_samples::CUBE_FACES
            .iter()
            .map(|q| q.map(|i| i as u32))
            .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
            .collect();
        let mesh = TriangleMesh { vertices: v, faces };
        let shape = TriMesh::new(mesh.vertices.clone(), mesh.faces.clone()).unwrap();
        let params = MultiViewParams {
            samples_per_view: 2000,
            ..MultiViewParams::issue_28(12)
        };
        let a = multiview_scan(&mesh, &shape, &params, 4).unwrap();
        let b = multiview_scan(&mesh, &shape, &params, 4).unwrap();
        assert_eq!(a.points, b.points);
        assert_eq!(a.views.len(), 10);
        for view in &a.views {
            assert!((0.0005..=0.002).contains(&view.pose_error));
            assert!(view.max_displacement <= view.pose_error * (1.0 + 1e-9));
        }
        // Every point is near the cube's surface: pose error plus stand-off at most.
        let diag = 3f64.sqrt();
        for p in &a.points {
            let inside = p.clamp(DVec3::ZERO, DVec3::ONE);
            let to_faces = (inside.min_element()).min(1.0 - inside.max_element());
            let off = p.distance(inside).max(to_faces);
            assert!(off <= (0.002 + 0.005) * diag + 1e-12, "{p}");
        }
    }
}
