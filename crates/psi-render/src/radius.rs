//! A splat radius for points that carry none.

use glam::DVec3;

/// A single disk radius (world units) that roughly covers a surface sampled by `positions`
/// (shape: N, world units) without holes, for point sets that carry no σ: 0.6 × D / √N, D the
/// bounding-box diagonal. On a sphere N samples are about D / √N apart. Returns 0 without
/// finite positions, and D / 100 for a single point.
///
/// ```
/// use glam::DVec3;
/// let r = psi_render::uniform_radius(&[DVec3::ZERO, DVec3::new(3.0, 4.0, 0.0)]);
/// assert!((r - 0.6 * 5.0 / 2f64.sqrt()).abs() < 1e-12);
/// ```
pub fn uniform_radius(positions: &[DVec3]) -> f64 {
    let finite: Vec<DVec3> = positions
        .iter()
        .copied()
        .filter(|p| p.is_finite())
        .collect();
    let Some(&first) = finite.first() else {
        return 0.0;
    };
    let (lo, hi) = finite
        .iter()
        .fold((first, first), |(lo, hi), &p| (lo.min(p), hi.max(p)));
    let diagonal = (hi - lo).length();
    if finite.len() == 1 || diagonal == 0.0 {
        return if diagonal > 0.0 {
            diagonal / 100.0
        } else {
            0.01
        };
    }
    0.6 * diagonal / (finite.len() as f64).sqrt()
}

/// The splat radius of each of `positions` (shape N, world units): its `sigma` when the points
/// carry one (psi's particles: σ is half the spacing), else half of [`uniform_radius`] for all
/// (the estimate covers the surface, a spacing across, so halved to match σ).
///
/// ```
/// use glam::DVec3;
/// let p = [DVec3::ZERO, DVec3::new(3.0, 4.0, 0.0)];
/// assert_eq!(psi_render::splat_radii(&p, Some(&[1.0, 2.0])), vec![1.0, 2.0]);
/// let r = psi_render::uniform_radius(&p);
/// assert_eq!(psi_render::splat_radii(&p, None), vec![0.5 * r; 2]);
/// ```
pub fn splat_radii(positions: &[DVec3], sigma: Option<&[f64]>) -> Vec<f64> {
    match sigma {
        Some(s) => s.to_vec(),
        None => vec![0.5 * uniform_radius(positions); positions.len()],
    }
}
