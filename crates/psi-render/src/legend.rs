//! The legend: a colour bar with tick labels and a title, in a strip on the right of an
//! image.

use tiny_skia::{Color, Paint, Pixmap, PixmapPaint, Rect, Transform};

use crate::colormap::{finite_range, unit};
use crate::font::{draw_text, text_height, text_width, unit_for};
use crate::{Ramp, RenderError};

/// What a colour bar shows: a title, the ramp, and the values at its ends.
#[derive(Clone, Debug, PartialEq)]
pub struct Legend {
    /// Drawn above the bar (capitals, digits, σ and simple punctuation; see the crate docs).
    pub title: String,
    /// The ramp the colours came from.
    pub ramp: Ramp,
    /// The value at the bottom of the bar (t = 0 on the ramp).
    pub min: f64,
    /// The value at the top of the bar (t = 1).
    pub max: f64,
    /// One block per whole number from `min` to `max` (octree depths) instead of a
    /// continuous bar with rounded ticks; used when both ends are whole and at most 32 apart.
    pub discrete: bool,
}

impl Legend {
    /// The legend of [`crate::depth_colors`] for the same depths: "DEPTH", green to deep red,
    /// one block per level from the smallest to the largest finite depth.
    ///
    /// ```
    /// let legend = psi_render::Legend::depth(&[6.0, 9.0, 7.0]);
    /// assert_eq!((legend.min, legend.max, legend.discrete), (6.0, 9.0, true));
    /// ```
    pub fn depth(depth: &[f64]) -> Legend {
        let (min, max) = finite_range(depth).unwrap_or((0.0, 0.0));
        Legend {
            title: "DEPTH".to_owned(),
            ramp: Ramp::Depth,
            min,
            max,
            discrete: true,
        }
    }

    /// The legend of [`crate::sigma_colors`] for the same radii: "σ", a continuous bar.
    pub fn sigma(sigma: &[f64]) -> Legend {
        let (min, max) = finite_range(sigma).unwrap_or((0.0, 0.0));
        Legend {
            title: "σ".to_owned(),
            ramp: Ramp::Sequential,
            min,
            max,
            discrete: false,
        }
    }

    /// The whole numbers of a discrete bar, bottom to top; `None` for a continuous bar.
    fn blocks(&self) -> Option<Vec<f64>> {
        let whole = |v: f64| v.is_finite() && v.fract() == 0.0;
        (self.discrete
            && whole(self.min)
            && whole(self.max)
            && (0.0..=32.0).contains(&(self.max - self.min)))
        .then(|| {
            (0..=(self.max - self.min) as usize)
                .map(|k| self.min + k as f64)
                .collect()
        })
    }

    /// Tick values of a continuous bar (round numbers, at most six) and the decimals to show.
    fn ticks(&self) -> (Vec<f64>, usize) {
        let (lo, hi) = (self.min, self.max);
        if !(lo.is_finite() && hi.is_finite()) {
            return (Vec::new(), 0);
        }
        if hi <= lo {
            return (
                vec![lo],
                decimals_for(lo.abs().max(f64::MIN_POSITIVE) / 10.0),
            );
        }
        // The finest step of 1, 2 or 5 × 10^k that gives at most six ticks.
        let count = |step: f64| (hi / step + 1e-9).floor() - (lo / step - 1e-9).ceil() + 1.0;
        let mag = 10f64.powf(((hi - lo) / 10.0).log10().floor());
        let step = (0..12)
            .map(|k| [1.0, 2.0, 5.0][k % 3] * mag * 10f64.powi((k / 3) as i32))
            .find(|&s| count(s) <= 6.0)
            .unwrap_or(hi - lo);
        let first = (lo / step - 1e-9).ceil() as i64;
        let last = (hi / step + 1e-9).floor() as i64;
        let ticks = (first..=last).map(|k| k as f64 * step).collect();
        (ticks, decimals_for(step))
    }

    /// The labelled values with their labels, and where they sit on the bar (t ∈ [0, 1]).
    fn labels(&self) -> Vec<(f64, String)> {
        match self.blocks() {
            Some(blocks) => {
                let n = blocks.len() as f64;
                blocks
                    .iter()
                    .enumerate()
                    .map(|(k, v)| ((k as f64 + 0.5) / n, format!("{v}")))
                    .collect()
            }
            None => {
                let (ticks, decimals) = self.ticks();
                ticks
                    .into_iter()
                    .map(|v| (unit(v, self.min, self.max), format_value(v, decimals)))
                    .collect()
            }
        }
    }
}

/// Decimal places that show a tick step.
fn decimals_for(step: f64) -> usize {
    (-step.log10().floor()).clamp(0.0, 8.0) as usize
}

fn format_value(v: f64, decimals: usize) -> String {
    if v != 0.0 && (v.abs() >= 1e6 || v.abs() < 1e-5) {
        format!("{v:.1e}").to_uppercase()
    } else {
        format!("{v:.decimals$}")
    }
}

/// The legend's layout for an image `height` pixels tall.
struct Layout {
    unit: u32,
    pad: u32,
    bar_width: u32,
    bar_top: u32,
    bar_height: u32,
    width: u32,
}

fn layout(legend: &Legend, height: u32) -> Layout {
    let unit = unit_for(height);
    let pad = 5 * unit;
    let bar_width = 7 * unit;
    let label_width = legend
        .labels()
        .iter()
        .map(|(_, l)| text_width(l, unit))
        .max()
        .unwrap_or(0);
    let content = (bar_width + 4 * unit + label_width).max(text_width(&legend.title, unit));
    let bar_height = (height / 2).max(1);
    let bar_top = (height - bar_height) / 2 + 6 * unit;
    Layout {
        unit,
        pad,
        bar_width,
        bar_top: bar_top.min(height.saturating_sub(bar_height)),
        bar_height,
        width: content + 2 * pad,
    }
}

/// Width in pixels of the strip the legend needs beside an image `height` pixels tall.
pub(crate) fn strip_width(legend: &Legend, height: u32) -> u32 {
    layout(legend, height).width
}

/// Dark text on a light background, light text on a dark one.
pub(crate) fn ink(background: [u8; 4]) -> Color {
    let luma = 0.3 * f64::from(background[0])
        + 0.59 * f64::from(background[1])
        + 0.11 * f64::from(background[2]);
    if background[3] < 128 || luma >= 128.0 {
        Color::from_rgba8(35, 35, 35, 255)
    } else {
        Color::from_rgba8(225, 225, 225, 255)
    }
}

fn fill(pixmap: &mut Pixmap, x: f32, y: f32, w: f32, h: f32, color: Color) {
    let mut paint = Paint::default();
    paint.set_color(color);
    paint.anti_alias = false;
    if let Some(rect) = Rect::from_xywh(x, y, w, h) {
        pixmap.fill_rect(rect, &paint, Transform::identity(), None);
    }
}

fn rgb(c: [u8; 3]) -> Color {
    Color::from_rgba8(c[0], c[1], c[2], 255)
}

/// Draws `legend` in the strip of the pixmap starting at column `x0` (the strip's width is
/// [`strip_width`] for the pixmap's height).
pub(crate) fn draw_legend(pixmap: &mut Pixmap, legend: &Legend, x0: u32, background: [u8; 4]) {
    let l = layout(legend, pixmap.height());
    let ink = ink(background);
    let u = l.unit as f32;
    let (bx, by) = ((x0 + l.pad) as f32, l.bar_top as f32);
    let (bw, bh) = (l.bar_width as f32, l.bar_height as f32);
    draw_text(
        pixmap,
        &legend.title,
        bx,
        by - (text_height(l.unit) + 3 * l.unit) as f32,
        l.unit,
        ink,
    );
    match legend.blocks() {
        Some(blocks) => {
            let n = blocks.len() as f32;
            for (k, &v) in blocks.iter().enumerate() {
                let color = legend.ramp.color(unit(v, legend.min, legend.max));
                let top = (by + bh * (1.0 - (k as f32 + 1.0) / n)).round();
                let bottom = (by + bh * (1.0 - k as f32 / n)).round();
                fill(pixmap, bx, top, bw, bottom - top, rgb(color));
                if k > 0 {
                    fill(pixmap, bx, bottom - 1.0, bw, 1.0, ink);
                }
            }
        }
        None => {
            for row in 0..l.bar_height {
                let t = 1.0 - (f64::from(row) + 0.5) / f64::from(l.bar_height);
                fill(
                    pixmap,
                    bx,
                    by + row as f32,
                    bw,
                    1.0,
                    rgb(legend.ramp.color(t)),
                );
            }
        }
    }
    // Outline.
    let line = 1.0f32.max((u / 2.0).floor());
    fill(pixmap, bx - line, by - line, bw + 2.0 * line, line, ink);
    fill(pixmap, bx - line, by + bh, bw + 2.0 * line, line, ink);
    fill(pixmap, bx - line, by, line, bh, ink);
    fill(pixmap, bx + bw, by, line, bh, ink);
    // Ticks and labels; labels that would overlap the previous one are skipped.
    let text_h = text_height(l.unit) as f32;
    let mut last_top = f32::INFINITY;
    for (t, label) in legend.labels() {
        let y = by + bh * (1.0 - t as f32);
        let top = (y - text_h / 2.0).round();
        if top + text_h + u > last_top {
            continue;
        }
        last_top = top;
        fill(
            pixmap,
            bx + bw,
            (y - line / 2.0).round(),
            2.0 * u,
            line,
            ink,
        );
        draw_text(pixmap, &label, bx + bw + 4.0 * u, top, l.unit, ink);
    }
}

/// A copy of `image` widened on the right by a strip with `legend` on `background` (sRGB and
/// alpha). Use it to give one legend to several panels put [`crate::side_by_side`].
///
/// ```
/// use psi_render::{append_legend, Legend};
/// let image = tiny_skia::Pixmap::new(400, 300).unwrap();
/// let with = append_legend(&image, &Legend::depth(&[5.0, 8.0]), [255; 4]).unwrap();
/// assert!(with.width() > 400 && with.height() == 300);
/// ```
pub fn append_legend(
    image: &Pixmap,
    legend: &Legend,
    background: [u8; 4],
) -> Result<Pixmap, RenderError> {
    let strip = strip_width(legend, image.height());
    let (width, height) = (image.width() + strip, image.height());
    let mut out = Pixmap::new(width, height).ok_or(RenderError::InvalidSize { width, height })?;
    out.fill(Color::from_rgba8(
        background[0],
        background[1],
        background[2],
        background[3],
    ));
    out.draw_pixmap(
        0,
        0,
        image.as_ref(),
        &PixmapPaint::default(),
        Transform::identity(),
        None,
    );
    draw_legend(&mut out, legend, image.width(), background);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn continuous_ticks_are_round_and_inside() {
        let legend = Legend::sigma(&[0.00123, 0.00391]);
        let (ticks, decimals) = legend.ticks();
        assert_eq!(decimals, 4);
        assert!(ticks.len() >= 3 && ticks.len() <= 7, "{ticks:?}");
        assert!(ticks.iter().all(|&t| (0.00123..=0.00391).contains(&t)));
        let labels: Vec<String> = legend.labels().into_iter().map(|l| l.1).collect();
        assert_eq!(labels[0], "0.0015");
    }

    #[test]
    fn discrete_blocks_cover_whole_depths() {
        let legend = Legend::depth(&[7.0, 3.0, 5.0]);
        assert_eq!(legend.blocks(), Some(vec![3.0, 4.0, 5.0, 6.0, 7.0]));
        let labels = legend.labels();
        assert_eq!(labels[0].1, "3");
        assert_eq!(labels[4].1, "7");
        assert!(Legend::depth(&[0.5, 2.0]).blocks().is_none());
        assert_eq!(Legend::depth(&[]).blocks(), Some(vec![0.0]));
    }
}
