//! The image a render starts from: the background, and the area left for the model once the
//! legend strip is reserved.

use tiny_skia::{Color, Pixmap};

use crate::legend::{draw_legend, strip_width};
use crate::{RenderError, RenderParams};

/// A `scale`× larger pixmap (scale ≥ 1, for supersampling) filled with the background, and the
/// model's pixel area `[x0, y0, x1, y1]` in it.
pub(crate) fn canvas(params: &RenderParams, scale: u32) -> Result<(Pixmap, [f64; 4]), RenderError> {
    let size = params.size;
    let invalid = RenderError::InvalidSize {
        width: size,
        height: size,
    };
    if size == 0 || size > 1 << 14 {
        return Err(invalid);
    }
    let full = size.checked_mul(scale).ok_or(invalid.clone())?;
    let mut pixmap = Pixmap::new(full, full).ok_or(invalid)?;
    pixmap.fill(background(params.background));
    let strip = params
        .legend
        .as_ref()
        .map_or(0, |l| strip_width(l, size).min(size / 2));
    let width = f64::from((size - strip) * scale);
    Ok((pixmap, [0.0, 0.0, width, f64::from(full)]))
}

/// Draws the legend of `params` (if any) into its strip of a `params.size` pixmap.
pub(crate) fn finish(pixmap: &mut Pixmap, params: &RenderParams) {
    if let Some(legend) = &params.legend {
        let strip = strip_width(legend, params.size).min(params.size / 2);
        draw_legend(pixmap, legend, params.size - strip, params.background);
    }
}

pub(crate) fn background(c: [u8; 4]) -> Color {
    Color::from_rgba8(c[0], c[1], c[2], c[3])
}
