//! The particle set: structure-of-arrays state of the simulation.

use glam::DVec3;
use serde::{Deserialize, Serialize};

/// Particles on the surface (all arrays have the same length N).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
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

    /// Appends all of `other`'s particles.
    pub fn extend(&mut self, other: &Particles) {
        self.positions.extend_from_slice(&other.positions);
        self.normals.extend_from_slice(&other.normals);
        self.depth.extend_from_slice(&other.depth);
        self.sigma.extend_from_slice(&other.sigma);
        self.target.extend_from_slice(&other.target);
    }

    /// Keeps the particles for which `keep[i]` is true, in order.
    pub fn retain_mask(&mut self, keep: &[bool]) {
        let mut k = keep.iter();
        self.positions.retain(|_| *k.next().unwrap_or(&false));
        let mut k = keep.iter();
        self.normals.retain(|_| *k.next().unwrap_or(&false));
        let mut k = keep.iter();
        self.depth.retain(|_| *k.next().unwrap_or(&false));
        let mut k = keep.iter();
        self.sigma.retain(|_| *k.next().unwrap_or(&false));
        let mut k = keep.iter();
        self.target.retain(|_| *k.next().unwrap_or(&false));
    }

    /// A copy of the particles `range` (in order).
    pub fn range(&self, range: std::ops::Range<usize>) -> Particles {
        Particles {
            positions: self.positions[range.clone()].to_vec(),
            normals: self.normals[range.clone()].to_vec(),
            depth: self.depth[range.clone()].to_vec(),
            sigma: self.sigma[range.clone()].to_vec(),
            target: self.target[range].to_vec(),
        }
    }

    /// Splits off the particles from `at` on (returned, in order), keeping those before.
    pub fn split_off(&mut self, at: usize) -> Particles {
        Particles {
            positions: self.positions.split_off(at),
            normals: self.normals.split_off(at),
            depth: self.depth.split_off(at),
            sigma: self.sigma.split_off(at),
            target: self.target.split_off(at),
        }
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
