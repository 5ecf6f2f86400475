//! Generated scenes of flat parts (issue 28), each point labelled by the part it came from: an
//! open square sheet, a closed box, and a street (about 40 m of ground, a gabled building, a
//! tree), in metres, sampled area-uniformly from their triangles with isotropic Gaussian noise
//! and a seeded generator. The noiseless triangles are the reference surface.

use anyhow::Result;
use psi::{DVec3, TriangleMesh};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64Mcg;

use crate::surface_samples::{CUBE_FACES, TriangleSampler, random_unit, rotate};

/// A labelled part of a scene: its name and whether it is flat (a plane piece: the
/// nearest-neighbour CV of the particles near it is judged).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Part {
    pub(crate) name: &'static str,
    pub(crate) flat: bool,
}

/// A generated scene: the points (shape: N, world units) with their part (`labels`, shape: N,
/// indices into `parts`), and the noiseless surface they were sampled from.
pub(crate) struct FlatScene {
    pub(crate) name: String,
    /// What the scene is, for the report.
    pub(crate) about: String,
    pub(crate) parts: Vec<Part>,
    pub(crate) points: Vec<DVec3>,
    pub(crate) labels: Vec<u8>,
    pub(crate) reference: TriangleMesh,
}

/// Triangles of a scene being built, each with its part's label.
struct Builder {
    triangles: Vec<[DVec3; 3]>,
    labels: Vec<u8>,
}

impl Builder {
    fn new() -> Self {
        Self {
            triangles: Vec::new(),
            labels: Vec::new(),
        }
    }

    /// Adds the quadrilateral a b c d (corners in order, world units) as two triangles.
    fn quad(&mut self, label: u8, [a, b, c, d]: [DVec3; 4]) {
        self.triangles.extend([[a, b, c], [a, c, d]]);
        self.labels.extend([label, label]);
    }

    fn triangle(&mut self, label: u8, t: [DVec3; 3]) {
        self.triangles.push(t);
        self.labels.push(label);
    }

    /// `n` points area-uniform over the triangles, each moved by isotropic Gaussian noise of
    /// standard deviation `sigma` (world units) per axis; samples for which `reject(point,
    /// label)` holds (before noise) are drawn again. Returns the scene.
    fn sample(
        self,
        name: &str,
        about: String,
        parts: Vec<Part>,
        (n, sigma): (usize, f64),
        rng: &mut Pcg64Mcg,
        reject: impl Fn(DVec3, u8) -> bool,
    ) -> Result<FlatScene> {
        let sampler = TriangleSampler::new(self.triangles.clone())?;
        let mut points = Vec::with_capacity(n);
        let mut labels = Vec::with_capacity(n);
        while points.len() < n {
            let (p, k) = sampler.sample(rng);
            let label = self.labels[k];
            if reject(p.p, label) {
                continue;
            }
            points.push(p.p + sigma * psi::shapes::gaussian_vector(rng));
            labels.push(label);
        }
        let reference = TriangleMesh {
            vertices: self.triangles.iter().flatten().copied().collect(),
            faces: (0..self.triangles.len() as u32)
                .map(|t| [3 * t, 3 * t + 1, 3 * t + 2])
                .collect(),
        };
        Ok(FlatScene {
            name: name.to_owned(),
            about,
            parts,
            points,
            labels,
            reference,
        })
    }
}

/// An open square sheet of side 1 m, turned by a seeded random rotation about its centre at the
/// origin: 100 000 points with σ = 0.5 mm.
pub(crate) fn sheet(seed: u64) -> Result<FlatScene> {
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    let (axis, angle) = (
        random_unit(&mut rng),
        rng.random_range(0.0..std::f64::consts::PI),
    );
    let corner = |x: f64, y: f64| rotate(DVec3::new(x, y, 0.0), axis, angle);
    let mut b = Builder::new();
    b.quad(
        0,
        [
            corner(-0.5, -0.5),
            corner(0.5, -0.5),
            corner(0.5, 0.5),
            corner(-0.5, 0.5),
        ],
    );
    let parts = vec![Part {
        name: "sheet",
        flat: true,
    }];
    let about = "open 1 m square, turned at random; 100 000 points, σ = 0.5 mm".to_owned();
    b.sample("sheet", about, parts, (100_000, 5e-4), &mut rng, |_, _| {
        false
    })
}

/// A closed box of 1 × 0.7 × 0.5 m centred at the origin, turned by a seeded random rotation:
/// 150 000 points with σ = 0.5 mm, labelled by face.
pub(crate) fn box_scene(seed: u64) -> Result<FlatScene> {
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    let (axis, angle) = (
        random_unit(&mut rng),
        rng.random_range(0.0..std::f64::consts::PI),
    );
    let half = DVec3::new(0.5, 0.35, 0.25);
    let corner = |i: usize| {
        let s = DVec3::new(
            if i & 1 == 0 { -1.0 } else { 1.0 },
            if i & 2 == 0 { -1.0 } else { 1.0 },
            if i & 4 == 0 { -1.0 } else { 1.0 },
        );
        rotate(s * half, axis, angle)
    };
    let mut b = Builder::new();
    for q in CUBE_FACES {
        b.quad(0, q.map(corner));
    }
    let parts = vec![Part {
        name: "face",
        flat: true,
    }];
    let about =
        "closed 1 × 0.7 × 0.5 m box, turned at random; 150 000 points, σ = 0.5 mm".to_owned();
    b.sample("box", about, parts, (150_000, 5e-4), &mut rng, |_, _| false)
}

/// Labels of the street scene's parts.
const GROUND: u8 = 0;
const WALL: u8 = 1;
const ROOF: u8 = 2;
const TREE: u8 = 3;

/// A street in metres (z up): 40 × 24 m of flat ground at z = 0; a building of 14 × 9 m turned
/// 15° about z, walls 8 m high, a gabled roof with its ridge 3 m above the eaves (the gable
/// triangles are wall); a tree: a lumpy ellipsoidal crown (radii 3.2, 3.0, 2.6 m, centre 6.8 m
/// up) on a trunk 0.25 m in radius. 760 000 points area-uniform over what a scanner could reach
/// (no ground under the building), σ = 1 cm, seeded. The ground's reference triangles run under
/// the building too.
pub(crate) fn street(seed: u64) -> Result<FlatScene> {
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    let mut b = Builder::new();
    let at = |x: f64, y: f64, z: f64| DVec3::new(x, y, z);
    b.quad(
        GROUND,
        [
            at(-20.0, -12.0, 0.0),
            at(20.0, -12.0, 0.0),
            at(20.0, 12.0, 0.0),
            at(-20.0, 12.0, 0.0),
        ],
    );
    // The building in its own frame (u along the ridge, v across), turned and moved.
    let (centre, turn) = (DVec3::new(6.0, 3.0, 0.0), 15f64.to_radians());
    let (hu, hv, eave, ridge) = (7.0, 4.5, 8.0, 11.0);
    let house = |u: f64, v: f64, z: f64| centre + rotate(DVec3::new(u, v, z), DVec3::Z, turn);
    let footprint = [(-hu, -hv), (hu, -hv), (hu, hv), (-hu, hv)];
    for k in 0..4 {
        let ((u0, v0), (u1, v1)) = (footprint[k], footprint[(k + 1) % 4]);
        b.quad(
            WALL,
            [
                house(u0, v0, 0.0),
                house(u1, v1, 0.0),
                house(u1, v1, eave),
                house(u0, v0, eave),
            ],
        );
    }
    for u in [-hu, hu] {
        b.triangle(
            WALL,
            [
                house(u, -hv, eave),
                house(u, hv, eave),
                house(u, 0.0, ridge),
            ],
        );
    }
    for v in [-hv, hv] {
        b.quad(
            ROOF,
            [
                house(-hu, v, eave),
                house(hu, v, eave),
                house(hu, 0.0, ridge),
                house(-hu, 0.0, ridge),
            ],
        );
    }
    // The tree: a crown from a latitude-longitude grid, radii modulated by a few lumps, and a
    // 32-sided trunk.
    let (tree, radii) = (DVec3::new(-11.0, -6.0, 6.8), DVec3::new(3.2, 3.0, 2.6));
    let (nu, nv) = (96, 48);
    let crown = |i: usize, j: usize| {
        let (phi, theta) = (
            std::f64::consts::TAU * i as f64 / nu as f64,
            std::f64::consts::PI * j as f64 / nv as f64,
        );
        let lump = 1.0 + 0.08 * (3.0 * theta).sin() * (4.0 * phi).sin();
        let dir = DVec3::new(
            theta.sin() * phi.cos(),
            theta.sin() * phi.sin(),
            theta.cos(),
        );
        tree + lump * dir * radii
    };
    for i in 0..nu {
        for j in 0..nv {
            let (a, c) = (crown(i, j), crown(i + 1, j + 1));
            let (b1, d) = (crown(i, j + 1), crown(i + 1, j));
            if j > 0 {
                b.triangle(TREE, [a, b1, d]);
            }
            if j + 1 < nv {
                b.triangle(TREE, [b1, c, d]);
            }
        }
    }
    let (trunk_r, trunk_top) = (0.25, 4.3);
    for i in 0..32 {
        let ring = |k: usize, z: f64| {
            let phi = std::f64::consts::TAU * k as f64 / 32.0;
            DVec3::new(
                tree.x + trunk_r * phi.cos(),
                tree.y + trunk_r * phi.sin(),
                z,
            )
        };
        b.quad(
            TREE,
            [
                ring(i, 0.0),
                ring(i + 1, 0.0),
                ring(i + 1, trunk_top),
                ring(i, trunk_top),
            ],
        );
    }
    let parts = vec![
        Part {
            name: "ground",
            flat: true,
        },
        Part {
            name: "wall",
            flat: true,
        },
        Part {
            name: "roof",
            flat: true,
        },
        Part {
            name: "tree",
            flat: false,
        },
    ];
    // Ground under the building is not seen.
    let under_house = move |p: DVec3, label: u8| {
        let local = rotate(p - centre, DVec3::Z, -turn);
        label == GROUND && local.x.abs() < hu && local.y.abs() < hv
    };
    let about = "40 × 24 m ground, gabled building, tree; 760 000 points, σ = 1 cm (m)".to_owned();
    b.sample(
        "street",
        about,
        parts,
        (760_000, 0.01),
        &mut rng,
        under_house,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_street_is_seeded_labelled_and_near_its_reference() {
        let a = street(2).unwrap();
        assert_eq!(a.points.len(), 760_000);
        assert_eq!(a.points, street(2).unwrap().points);
        let count = |l: u8| a.labels.iter().filter(|x| **x == l).count();
        // Each part gets a share near its area's (ground 834 m², walls 395, roof 151, tree ~120).
        for (label, lo, hi) in [
            (GROUND, 0.50, 0.62),
            (WALL, 0.23, 0.30),
            (ROOF, 0.08, 0.12),
            (TREE, 0.05, 0.10),
        ] {
            let share = count(label) as f64 / a.points.len() as f64;
            assert!((lo..hi).contains(&share), "label {label}: {share}");
        }
        // No ground point under the building; noise within 6σ in z for ground points.
        for (p, l) in a.points.iter().zip(&a.labels) {
            if *l == GROUND {
                assert!(p.z.abs() < 0.06);
            }
        }
    }

    #[test]
    fn sheet_and_box_points_lie_within_their_noise_of_the_surface() {
        let s = sheet(1).unwrap();
        let n = s.reference.faces.len();
        assert_eq!(n, 2);
        let [a, b, c] = s.reference.faces[0].map(|i| s.reference.vertices[i as usize]);
        let normal = (b - a).cross(c - a).normalize();
        assert!(
            s.points
                .iter()
                .all(|p| (p - a).dot(normal).abs() < 6.0 * 5e-4)
        );
        let bx = box_scene(1).unwrap();
        assert_eq!(bx.reference.faces.len(), 12);
        assert_eq!(bx.points.len(), 150_000);
    }
}
