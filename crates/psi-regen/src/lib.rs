//! # psi-regen
//!
//! Local regeneration after shape edits (paper §6): an [`Edit`] changes the control points; the
//! cells whose fit radius holds a changed point are refitted (the rest are reused — provably
//! unchanged, since a cell's fit depends only on the points within that radius), the particles
//! in marked leaves are deleted, the new marked leaves are seeded and only those particles are
//! relaxed, the others fixed, moves leaving the marked leaves rejected.
//!
//! ```
//! use glam::DVec3;
//! use psi_mpu::MpuParams;
//! use psi_shapes::AnalyticShape;
//! use psi_particles::ParticleParams;
//! use psi_regen::{Edit, Scene};
//!
//! let points = AnalyticShape::Sphere { radius: 1.0 }.sample(6000, 2);
//! let (mut scene, _) = Scene::new(points, &MpuParams::paper(), &ParticleParams::paper()).unwrap();
//! let before = scene.particles().clone();
//! let report = scene
//!     .apply(&Edit::Brush { center: DVec3::Z, radius: 0.3, displacement: DVec3::new(0.0, 0.0, 0.1) })
//!     .unwrap();
//! assert!(report.marked_cells > 0 && report.marked_cells < scene.mpu().octree().cells().len());
//! // Particles far from the brush did not move.
//! let far = |p: &DVec3| (*p - DVec3::Z).length() > 1.2;
//! let kept: Vec<_> = before.positions.iter().filter(|p| far(p)).collect();
//! let now: Vec<_> = scene.particles().positions.iter().filter(|p| far(p)).collect();
//! assert_eq!(kept, now);
//! ```

mod brush_points;
mod cover_leaves;
mod edit;
mod error;
mod mark_cells;
mod regen_report;
mod scene;
mod settle;

pub use edit::Edit;
pub use error::RegenError;
pub use mark_cells::{mark_cells, mark_cells_brute_force};
pub use regen_report::RegenReport;
pub use scene::Scene;
pub use settle::{FRAME_ITERATIONS, SettleReport};
