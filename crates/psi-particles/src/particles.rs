//! The particle set: structure-of-arrays state of the simulation.

use glam::DVec3;

/// Particles on the surface (all arrays have the same length N).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Particles {
    /// Positions, world units.
    pub positions: Vec<DVec3>,
    /// Unit normals ∇f/|∇f| at the positions.
    pub normals: Vec<DVec3>,
    /// Depth of the octree leaf containing each particle.
    pub depth: Vec<u8>,
    /// Current repulsion radius σ_i, world units.
    pub sigma: Vec<f64>,
    /// Target radius σ̂_i (half the desired spacing), world units.
    pub target: Vec<f64>,
}

impl Particles {
    /// Number of particles.
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// Appends one particle.
    pub fn push(&mut self, p: DVec3, n: DVec3, depth: u8, sigma: f64) {
        self.positions.push(p);
        self.normals.push(n);
        self.depth.push(depth);
        self.sigma.push(sigma);
        self.target.push(sigma);
    }
}
