//! A scene: control points, their MPU and their particles, updated locally by edits (paper §6).

use std::time::Instant;

use glam::DVec3;
use psi_mpu::{BuildOptions, Mpu, MpuBuffers, MpuFrame, MpuParams, Reuse};
use psi_octree::{Aabb, Monitor, OrientedPoint, PointAttributes};
use psi_particles::{
    DensityField, ParticleParams, Particles, SampleReport, measure_quality, seed_leaves,
    transfer_attributes,
};
use rayon::prelude::*;

use crate::brush_points::brushed_points;
use crate::cover_leaves::cover_refit_leaves;
use crate::settle::{Pending, cpu_now};
use crate::{Edit, RegenError, RegenReport, SettleReport, mark_cells};

/// Control points, MPU and particles kept consistent under edits.
#[derive(Clone, Debug)]
pub struct Scene {
    mpu: Mpu,
    particles: Particles,
    /// The control points' attributes (aligned with `mpu.points()`) and the particles' (aligned
    /// with `particles`, from [`transfer_attributes`]); empty when the input had none.
    attributes: PointAttributes,
    particle_attributes: PointAttributes,
    field: DensityField,
    mpu_params: MpuParams,
    particle_params: ParticleParams,
    /// Memory the next edit builds its MPU in: the arrays of the MPU it replaced last, or
    /// fresh ones touched when the scene was made (with a copy of the points, in step), so
    /// that no edit (the first included) pays for new pages or a copy of every point (the
    /// price: one more MPU's worth of memory; notes: local regeneration).
    spare: MpuBuffers,
    /// The last stroke's relaxation when it is still settling ([`Scene::apply_deferred`]).
    pending: Option<Pending>,
    /// Where `spare`'s points and positions (the MPU before this one's) differ from this MPU's
    /// when the last edit was a brush: the points it moved. `None`: unknown.
    spare_lag: Option<Vec<u32>>,
}

impl Scene {
    /// Builds the MPU of `points` and samples it (the full pipeline). Returns the scene and the
    /// sampling report.
    pub fn new(
        points: Vec<OrientedPoint>,
        mpu_params: &MpuParams,
        particle_params: &ParticleParams,
    ) -> Result<(Scene, SampleReport), RegenError> {
        let none = PointAttributes::default();
        Self::new_with(
            points,
            none,
            mpu_params,
            particle_params,
            &Monitor::silent(),
        )
    }

    /// [`Scene::new`] with the points' `attributes` (aligned with `points`, or empty), which
    /// edits carry along and the particles take ([`transfer_attributes`]), reporting the MPU
    /// build and the sampling to `monitor` and returning [`RegenError::Interrupted`] once its
    /// stop flag is set.
    pub fn new_with(
        points: Vec<OrientedPoint>,
        attributes: PointAttributes,
        mpu_params: &MpuParams,
        particle_params: &ParticleParams,
        monitor: &Monitor<'_>,
    ) -> Result<(Scene, SampleReport), RegenError> {
        check_attributes(&attributes, points.len())?;
        let options = BuildOptions {
            monitor: *monitor,
            ..Default::default()
        };
        let mpu = Mpu::build_with(points, mpu_params, options)?;
        let run = psi_particles::sample_with(&mpu, particle_params, monitor)?;
        let particle_attributes = transfer_attributes(&mpu, &run.particles, &attributes);
        let field = run.report.density;
        let spare = MpuBuffers::in_step_with(&mpu);
        let scene = Scene {
            spare_lag: Some(Vec::new()),
            pending: None,
            spare,
            mpu,
            attributes,
            particle_attributes,
            particles: run.particles,
            field,
            mpu_params: *mpu_params,
            particle_params: *particle_params,
        };
        Ok((scene, run.report))
    }

    /// A scene from its state: `points` (shape N, world units, unit normals) whose MPU is built
    /// from scratch in `frame` with `mpu_params`, and `particles` sampled on it with
    /// `particle_params` and the density `field` (what [`Scene::points`], [`Scene::mpu`],
    /// [`Scene::particles`], [`Scene::density`] and the parameter accessors give; the points'
    /// normals are taken as the MPU's own, unit already). The MPU equals the one the state was
    /// taken from (a local rebuild equals a build from scratch in its frame).
    pub fn from_state(
        points: Vec<OrientedPoint>,
        frame: MpuFrame,
        mpu_params: &MpuParams,
        particle_params: &ParticleParams,
        particles: Particles,
        field: DensityField,
        attributes: [PointAttributes; 2],
    ) -> Result<Scene, RegenError> {
        let [attributes, particle_attributes] = attributes;
        check_attributes(&attributes, points.len())?;
        check_attributes(&particle_attributes, particles.len())?;
        let options = BuildOptions {
            frame: Some(frame),
            unit_normals: true,
            ..Default::default()
        };
        let mpu = Mpu::build_with(points, mpu_params, options)?;
        Ok(Scene {
            spare_lag: Some(Vec::new()),
            pending: None,
            spare: MpuBuffers::in_step_with(&mpu),
            mpu,
            particles,
            attributes,
            particle_attributes,
            field,
            mpu_params: *mpu_params,
            particle_params: *particle_params,
        })
    }

    /// The MPU parameters every rebuild uses.
    pub fn mpu_params(&self) -> &MpuParams {
        &self.mpu_params
    }

    /// The sampling parameters every regeneration uses.
    pub fn particle_params(&self) -> &ParticleParams {
        &self.particle_params
    }

    /// The control points (world units, unit normals).
    pub fn points(&self) -> &[OrientedPoint] {
        self.mpu.points()
    }

    /// The current MPU.
    pub fn mpu(&self) -> &Mpu {
        &self.mpu
    }

    /// The current particles.
    pub fn particles(&self) -> &Particles {
        &self.particles
    }

    /// The control points' attributes (aligned with [`Scene::points`]; empty without any).
    pub fn attributes(&self) -> &PointAttributes {
        &self.attributes
    }

    /// The particles' attributes (aligned with [`Scene::particles`]; empty without any).
    pub fn particle_attributes(&self) -> &PointAttributes {
        &self.particle_attributes
    }

    /// The density field fixed at the first sampling.
    pub fn density(&self) -> &DensityField {
        &self.field
    }

    /// An MPU built from scratch on the current points in the scene's frame (the oracle local
    /// regeneration must equal).
    pub fn rebuild_from_scratch(&self) -> Result<Mpu, RegenError> {
        let options = BuildOptions {
            frame: Some(*self.mpu.frame()),
            unit_normals: true,
            ..Default::default()
        };
        Ok(Mpu::build_with(
            self.mpu.points(),
            &self.mpu_params,
            options,
        )?)
    }

    /// Applies `edit`: marks the cells whose fit radius holds a changed point, refits only those
    /// (and any new cells below them), deletes the particles in marked leaves, seeds the new
    /// marked leaves and relaxes only the new particles, the others fixed, rejecting moves that
    /// leave the marked leaves. On error the scene is unchanged.
    pub fn apply(&mut self, edit: &Edit) -> Result<RegenReport, RegenError> {
        self.apply_with(edit, &Monitor::silent())
    }

    /// [`Scene::apply`], stopping with [`RegenError::Interrupted`] once `monitor`'s stop flag is
    /// set (checked per refitted cell, per relaxation iteration and before the result replaces
    /// the scene's state, which an interrupted edit leaves unchanged).
    pub fn apply_with(
        &mut self,
        edit: &Edit,
        monitor: &Monitor<'_>,
    ) -> Result<RegenReport, RegenError> {
        self.apply_attributed(edit, &PointAttributes::default(), monitor)
    }

    /// [`Scene::apply_with`], the points an edit adds (a replacement's or an insertion's)
    /// carrying `added` (aligned with them, or empty: then the defaults of
    /// [`PointAttributes::extend`] where the scene has attributes). The points an edit keeps
    /// keep theirs; particles the edit regenerates take theirs from the points near them.
    pub fn apply_attributed(
        &mut self,
        edit: &Edit,
        added: &PointAttributes,
        monitor: &Monitor<'_>,
    ) -> Result<RegenReport, RegenError> {
        self.apply_deferred(edit, added, usize::MAX, monitor)
    }

    /// [`Scene::apply_attributed`] for an interactive frame: the previous stroke's relaxation
    /// is first finished if it is still settling, then the points are edited, the MPU rebuilt
    /// locally and the regenerated particles seeded, and only `frame_iterations` of their
    /// relaxation run (e.g. [`crate::FRAME_ITERATIONS`]); [`Scene::settle`] runs the rest over
    /// the following frames. Settling is counted in iterations, never in time: a session of
    /// deferred strokes and settles gives bitwise the particles of the same session applied
    /// eagerly, for any thread count. Until settled, [`Scene::particles`] shows the stroke's
    /// particles part-way and their attributes are the defaults.
    pub fn apply_deferred(
        &mut self,
        edit: &Edit,
        added: &PointAttributes,
        frame_iterations: usize,
        monitor: &Monitor<'_>,
    ) -> Result<RegenReport, RegenError> {
        check_attributes(added, edit.added())?;
        let c0 = cpu_now();
        // The previous stroke finishes first, as it would have eagerly.
        let (settle_seconds, settle_cpu_seconds) = if self.pending.is_some() {
            let s = self.settle(usize::MAX);
            (s.seconds, s.cpu_seconds)
        } else {
            (0.0, 0.0)
        };
        // (No pass over the points when there are no attributes to carry.)
        let mut attributes = PointAttributes::default();
        if !(self.attributes.is_empty() && added.is_empty()) {
            let survivors = edit.survivors(self.mpu.points());
            attributes = self.attributes.select(&survivors);
            attributes.extend(survivors.len(), added, edit.added());
        }
        let _span = tracing::info_span!("local_regeneration").entered();
        let t0 = Instant::now();
        let lag = self.spare_lag.take();
        let ((points, changed, moved), synced) = match edit {
            Edit::Brush { .. } => {
                match brushed_points(&self.mpu, &mut self.spare, edit, lag.as_deref()) {
                    Ok(done) => done,
                    Err(e) => {
                        // Refused before anything changed: the spare stays in step.
                        self.spare_lag = lag;
                        return Err(e);
                    }
                }
            }
            _ => (
                edit.apply_tracked(self.mpu.points(), self.spare.take_points())?,
                None,
            ),
        };
        let root = *self.mpu.octree().root();
        let origin = self.mpu.frame_origin();
        let inside = if synced.is_some() {
            // Only the moved points can have left.
            changed.iter().all(|&p| root.contains(p - origin))
        } else {
            points.iter().all(|p| root.contains(p.p - origin))
        };
        if !inside {
            // The edit left the root cube: start again in a new frame.
            let (scene, _) = Scene::new_with(
                points,
                attributes,
                &self.mpu_params,
                &self.particle_params,
                monitor,
            )?;
            let report = RegenReport {
                marked_cells: self.mpu.octree().cells().len(),
                refit_cells: scene.mpu.octree().cells().len(),
                particles_removed: self.particles.len(),
                particles_regenerated: scene.particles.len(),
                points: scene.points().len(),
                full_rebuild: true,
                settle_seconds,
                settle_cpu_seconds,
                seconds: t0.elapsed().as_secs_f64() + settle_seconds,
                cpu_seconds: cpu_now() - c0,
                ..Default::default()
            };
            monitor.claim_commit()?;
            *self = scene;
            return Ok(report);
        }
        let edit_seconds = t0.elapsed().as_secs_f64();
        let marked_old = mark_cells(&self.mpu, &changed);
        let mark_seconds = t0.elapsed().as_secs_f64() - edit_seconds;

        // Carrying the footprint table checks the entries near the changed positions, a fresh
        // one writes 64 bytes a point in order: carry below 1 changed position in 16 points
        // (near the measured break-even: notes 2026-11-25-edit-index, 2026-11-27-edit-balls;
        // both give the same answers). Every brush may carry, the first of a scene too: the
        // scene then keeps one table from stroke to stroke, and no stroke frees a second
        // (64 bytes a point: 9 ms on the David stand-in, docs/notes/2026-11-29-edit-hitches.md).
        let carry = matches!(edit, Edit::Brush { .. }) && 16 * changed.len() < points.len();
        let options = BuildOptions {
            frame: Some(*self.mpu.frame()),
            reuse: Some(Reuse {
                old: &self.mpu,
                marked: &marked_old,
                indices_kept: edit.keeps_indices(),
                moved: matches!(edit, Edit::Brush { .. }).then_some(&moved[..]),
            }),
            buffers: std::mem::take(&mut self.spare),
            // The kept points' normals are the MPU's own and the edit's new ones are unit: no
            // renormalisation, so a build from `points()` repeats this MPU bit for bit.
            unit_normals: true,
            known_cells: None,
            known_within: None,
            synced: synced.as_deref(),
            // A brush carries the footprint table over (below) when that is the cheaper way.
            carry_footprint: carry,
            whole_footprint: None,
            monitor: *monitor,
        };
        // The entries of the footprint table the brush may have changed are found while the
        // MPU is built (they read only the earlier MPU, which nothing queries meanwhile).
        let (built, stale) = rayon::join(
            || Mpu::build_with(points, &self.mpu_params, options),
            || carry.then(|| self.mpu.stale_footprint(&changed)),
        );
        let mut mpu = built?;
        if let Some(stale) = stale {
            mpu.carry_stale_footprint(&mut self.mpu, stale);
        }
        // New cells that were fitted again: not present before, or marked; and the leaves
        // among them and among the marked cells (lists, so that the passes below follow the
        // edit, not the model).
        let refit: Vec<bool> = mpu.refit_flags().to_vec();
        let leaves_of = |m: &Mpu, flags: &[bool]| -> Vec<u32> {
            (0..flags.len() as u32)
                .filter(|&c| flags[c as usize] && m.octree().cell(c).is_leaf())
                .collect()
        };
        let refit_leaves = leaves_of(&mpu, &refit);
        let marked_leaves = leaves_of(&self.mpu, &marked_old);
        let mpu_seconds = t0.elapsed().as_secs_f64();

        let t1 = Instant::now();
        // Keep the particles whose old leaf is unmarked and whose new leaf was not refitted.
        // Outside a box around those leaves the answer is yes without a lookup.
        // (Local frame; the refitted leaves' box also bounds the relaxation below.)
        let refit_box = Aabb::from_points(leaf_corners(&mpu, &refit_leaves));
        let changed_leaves = Aabb::from_points(
            leaf_corners(&self.mpu, &marked_leaves)
                .chain(refit_box.iter().flat_map(|b| [b.min, b.max])),
        );
        let keep: Vec<bool> = self
            .particles
            .positions
            .par_iter()
            .map(|&x| {
                let y = x - origin;
                if y.is_finite()
                    && !changed_leaves.is_some_and(|b| b.contains(y))
                    && root.contains(y)
                {
                    return true;
                }
                let old = self
                    .mpu
                    .leaf_containing(x)
                    .is_some_and(|l| !marked_old[l as usize]);
                let new = mpu.leaf_containing(x).is_some_and(|l| !refit[l as usize]);
                old && new
            })
            .collect();
        let mut particles = self.particles.clone();
        particles.retain_mask(&keep);
        let kept = particles.len();
        let kept_ids: Vec<u32> = (0..keep.len() as u32)
            .filter(|&i| keep[i as usize])
            .collect();
        let mut particle_attributes = self.particle_attributes.select(&kept_ids);
        let leaves: Vec<u32> = refit_leaves
            .into_iter()
            .filter(|&l| mpu.is_surface_leaf(l))
            .collect();
        particles.extend(&seed_leaves(
            &mpu,
            &leaves,
            &self.field,
            &self.particle_params,
        ));
        let (darts, regenerated) = cover_refit_leaves(
            &mpu,
            &mut particles,
            kept,
            &self.field,
            &self.particle_params,
            &leaves,
            &attributes,
            &mut particle_attributes,
        );
        // Relax only the new particles; the kept ones are fixed neighbours (relax indexes them
        // once and skips their updates). Moves must stay in refitted leaves, which the box of
        // those leaves bounds (world units).
        let bounds = refit_box.map(|b| Aabb {
            min: b.min + origin,
            max: b.max + origin,
        });
        let mut pending = Pending::start(
            &mpu,
            &mut particles,
            &self.field,
            &self.particle_params,
            refit.clone(),
            bounds,
            kept + darts,
        );
        pending.run(
            &mpu,
            &mut particles,
            &self.field,
            &self.particle_params,
            frame_iterations,
            monitor,
        );
        // A stopped edit leaves the scene as it was: the footprint table goes back.
        let give_back = |scene: &mut Scene, mut mpu: Mpu| {
            if carry {
                scene.mpu.carry_footprint(&mut mpu, &changed);
            }
        };
        if let Err(e) = monitor.check() {
            give_back(self, mpu);
            return Err(e.into());
        }
        let mut pending = Some(pending);
        if pending
            .as_ref()
            .is_some_and(|p| p.remaining(&self.particle_params) == 0)
        {
            pending.take().expect("present").finish(
                &mpu,
                &mut particles,
                &self.field,
                &self.particle_params,
                &attributes,
                &mut particle_attributes,
            );
            // (As when a settle completes the stroke.)
            mpu.compact();
        }
        let pending_iterations = pending
            .as_ref()
            .map_or(0, |p| p.remaining(&self.particle_params));
        let particle_seconds = t1.elapsed().as_secs_f64();
        // From here on the edit is committed: a stop request now comes too late.
        if let Err(e) = monitor.check().and_then(|()| monitor.claim_commit()) {
            give_back(self, mpu);
            return Err(e.into());
        }

        let report = RegenReport {
            marked_cells: marked_old.iter().filter(|m| **m).count(),
            refit_cells: refit.iter().filter(|m| **m).count(),
            particles_removed: self.particles.len() - kept,
            particles_regenerated: regenerated,
            points: mpu.points().len(),
            full_rebuild: false,
            mpu_seconds,
            edit_seconds,
            mark_seconds,
            particle_seconds,
            settle_seconds,
            settle_cpu_seconds,
            seconds: t0.elapsed().as_secs_f64() + settle_seconds,
            cpu_seconds: cpu_now() - c0,
            pending_iterations,
        };
        self.spare = std::mem::replace(&mut self.mpu, mpu).into_buffers();
        // The MPU just replaced differs from the new one where the brush moved points.
        self.spare_lag = matches!(edit, Edit::Brush { .. }).then_some(moved);
        self.particles = particles;
        self.attributes = attributes;
        self.particle_attributes = particle_attributes;
        self.pending = pending;
        Ok(report)
    }

    /// Relaxation iterations the last stroke's particles still have to run (0 when settled).
    pub fn pending_iterations(&self) -> usize {
        self.pending
            .as_ref()
            .map_or(0, |p| p.remaining(&self.particle_params))
    }

    /// Runs up to `iterations` more iterations of the last stroke's relaxation, and finishes
    /// it (polish, close pairs, attributes) once none is left. Does nothing when settled.
    pub fn settle(&mut self, iterations: usize) -> SettleReport {
        let t0 = Instant::now();
        let c0 = cpu_now();
        let mut ran = 0;
        if let Some(pending) = self.pending.as_mut() {
            let silent = Monitor::silent();
            let (mpu, field, params) = (&self.mpu, &self.field, &self.particle_params);
            ran = pending.run(mpu, &mut self.particles, field, params, iterations, &silent);
            if pending.remaining(params) == 0 {
                let pending = self.pending.take().expect("present");
                let (points, particle_attributes) =
                    (&self.attributes, &mut self.particle_attributes);
                pending.finish(
                    mpu,
                    &mut self.particles,
                    field,
                    params,
                    points,
                    particle_attributes,
                );
                // The stroke is complete: the MPU's upkeep is done here, between frames.
                self.mpu.compact();
            }
        }
        SettleReport {
            iterations: ran,
            pending_iterations: self.pending_iterations(),
            seconds: t0.elapsed().as_secs_f64(),
            cpu_seconds: cpu_now() - c0,
        }
    }

    /// Quality figures of the current particles.
    pub fn quality(&self) -> psi_particles::Quality {
        measure_quality(&self.mpu, &self.particles)
    }
}

/// Refuses attributes whose present columns are not `n` long.
fn check_attributes(attributes: &PointAttributes, n: usize) -> Result<(), RegenError> {
    if attributes.fits(n) {
        Ok(())
    } else {
        Err(RegenError::BadEdit(format!(
            "attributes for {} points given for {n}",
            attributes.len().unwrap_or(0)
        )))
    }
}

/// Opposite corners (local frame) of the leaves `leaves` of `mpu`, grown by a rounding margin.
fn leaf_corners<'a>(mpu: &'a Mpu, leaves: &'a [u32]) -> impl Iterator<Item = DVec3> + 'a {
    let margin = 1e-9 * mpu.octree().root().half;
    leaves.iter().flat_map(move |&l| {
        let c = mpu.octree().cell(l);
        let h = DVec3::splat(c.half + margin);
        [c.center - h, c.center + h]
    })
}
