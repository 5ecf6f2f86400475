//! Pictures side by side, each with a caption above it.

use tiny_skia::{Pixmap, PixmapPaint, Transform};

use crate::RenderError;
use crate::canvas::background;
use crate::font::{draw_text, text_height, text_width, unit_for};
use crate::legend::ink;

/// Puts `panels` (image, caption) in a row, left to right, with a caption band above and a
/// small gap between them, on `background` (sRGB and alpha). Captions are drawn with the
/// crate's bitmap font (capitals, digits, σ, simple punctuation), centred over their panel.
///
/// The result is (sum of widths + gaps) × (tallest height + caption band) pixels.
///
/// # Errors
///
/// [`RenderError::NoPanels`] for an empty list, [`RenderError::InvalidSize`] if the row would
/// be too large.
///
/// ```
/// let a = tiny_skia::Pixmap::new(200, 200).unwrap();
/// let row = psi_render::side_by_side(&[(&a, "UNIFORM"), (&a, "ADAPTIVE")], [255; 4]).unwrap();
/// assert!(row.width() > 400 && row.height() > 200);
/// ```
pub fn side_by_side(panels: &[(&Pixmap, &str)], bg: [u8; 4]) -> Result<Pixmap, RenderError> {
    let tallest = panels
        .iter()
        .map(|(p, _)| p.height())
        .max()
        .ok_or(RenderError::NoPanels)?;
    let unit = unit_for(tallest);
    let band = text_height(unit) + 8 * unit;
    let gap = 4 * unit;
    let width =
        panels.iter().map(|(p, _)| p.width()).sum::<u32>() + gap * (panels.len() as u32 - 1);
    let height = tallest + band;
    let mut out = Pixmap::new(width, height).ok_or(RenderError::InvalidSize { width, height })?;
    out.fill(background(bg));
    let ink = ink(bg);
    let mut x = 0;
    for (panel, caption) in panels {
        out.draw_pixmap(
            x as i32,
            band as i32,
            panel.as_ref(),
            &PixmapPaint::default(),
            Transform::identity(),
            None,
        );
        let w = text_width(caption, unit);
        let left = x as f32 + (panel.width() as f32 - w as f32) / 2.0;
        draw_text(
            &mut out,
            caption,
            left.max(0.0).round(),
            (5 * unit) as f32,
            unit,
            ink,
        );
        x += panel.width() + gap;
    }
    Ok(out)
}
