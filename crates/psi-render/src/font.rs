//! A 5 × 7 bitmap font drawn with rectangles (tiny-skia has no text): digits, capital letters
//! (lower case is drawn as capitals), σ and a little punctuation.

use tiny_skia::{Color, Paint, Pixmap, Rect, Transform};

/// Glyph rows, top to bottom; bit 4 is the leftmost of the 5 columns.
fn glyph(c: char) -> Option<[u8; 7]> {
    let g = match c.to_ascii_uppercase() {
        '0' => [
            0b01110, 0b10001, 0b10011, 0b10101, 0b11001, 0b10001, 0b01110,
        ],
        '1' => [
            0b00100, 0b01100, 0b00100, 0b00100, 0b00100, 0b00100, 0b01110,
        ],
        '2' => [
            0b01110, 0b10001, 0b00001, 0b00010, 0b00100, 0b01000, 0b11111,
        ],
        '3' => [
            0b11111, 0b00010, 0b00100, 0b00010, 0b00001, 0b10001, 0b01110,
        ],
        '4' => [
            0b00010, 0b00110, 0b01010, 0b10010, 0b11111, 0b00010, 0b00010,
        ],
        '5' => [
            0b11111, 0b10000, 0b11110, 0b00001, 0b00001, 0b10001, 0b01110,
        ],
        '6' => [
            0b00110, 0b01000, 0b10000, 0b11110, 0b10001, 0b10001, 0b01110,
        ],
        '7' => [
            0b11111, 0b00001, 0b00010, 0b00100, 0b01000, 0b01000, 0b01000,
        ],
        '8' => [
            0b01110, 0b10001, 0b10001, 0b01110, 0b10001, 0b10001, 0b01110,
        ],
        '9' => [
            0b01110, 0b10001, 0b10001, 0b01111, 0b00001, 0b00010, 0b01100,
        ],
        'A' => [
            0b01110, 0b10001, 0b10001, 0b11111, 0b10001, 0b10001, 0b10001,
        ],
        'B' => [
            0b11110, 0b10001, 0b10001, 0b11110, 0b10001, 0b10001, 0b11110,
        ],
        'C' => [
            0b01110, 0b10001, 0b10000, 0b10000, 0b10000, 0b10001, 0b01110,
        ],
        'D' => [
            0b11100, 0b10010, 0b10001, 0b10001, 0b10001, 0b10010, 0b11100,
        ],
        'E' => [
            0b11111, 0b10000, 0b10000, 0b11110, 0b10000, 0b10000, 0b11111,
        ],
        'F' => [
            0b11111, 0b10000, 0b10000, 0b11110, 0b10000, 0b10000, 0b10000,
        ],
        'G' => [
            0b01110, 0b10001, 0b10000, 0b10111, 0b10001, 0b10001, 0b01111,
        ],
        'H' => [
            0b10001, 0b10001, 0b10001, 0b11111, 0b10001, 0b10001, 0b10001,
        ],
        'I' => [
            0b01110, 0b00100, 0b00100, 0b00100, 0b00100, 0b00100, 0b01110,
        ],
        'J' => [
            0b00111, 0b00010, 0b00010, 0b00010, 0b00010, 0b10010, 0b01100,
        ],
        'K' => [
            0b10001, 0b10010, 0b10100, 0b11000, 0b10100, 0b10010, 0b10001,
        ],
        'L' => [
            0b10000, 0b10000, 0b10000, 0b10000, 0b10000, 0b10000, 0b11111,
        ],
        'M' => [
            0b10001, 0b11011, 0b10101, 0b10101, 0b10001, 0b10001, 0b10001,
        ],
        'N' => [
            0b10001, 0b10001, 0b11001, 0b10101, 0b10011, 0b10001, 0b10001,
        ],
        'O' => [
            0b01110, 0b10001, 0b10001, 0b10001, 0b10001, 0b10001, 0b01110,
        ],
        'P' => [
            0b11110, 0b10001, 0b10001, 0b11110, 0b10000, 0b10000, 0b10000,
        ],
        'Q' => [
            0b01110, 0b10001, 0b10001, 0b10001, 0b10101, 0b10010, 0b01101,
        ],
        'R' => [
            0b11110, 0b10001, 0b10001, 0b11110, 0b10100, 0b10010, 0b10001,
        ],
        'S' => [
            0b01111, 0b10000, 0b10000, 0b01110, 0b00001, 0b00001, 0b11110,
        ],
        'T' => [
            0b11111, 0b00100, 0b00100, 0b00100, 0b00100, 0b00100, 0b00100,
        ],
        'U' => [
            0b10001, 0b10001, 0b10001, 0b10001, 0b10001, 0b10001, 0b01110,
        ],
        'V' => [
            0b10001, 0b10001, 0b10001, 0b10001, 0b10001, 0b01010, 0b00100,
        ],
        'W' => [
            0b10001, 0b10001, 0b10001, 0b10101, 0b10101, 0b10101, 0b01010,
        ],
        'X' => [
            0b10001, 0b10001, 0b01010, 0b00100, 0b01010, 0b10001, 0b10001,
        ],
        'Y' => [
            0b10001, 0b10001, 0b10001, 0b01010, 0b00100, 0b00100, 0b00100,
        ],
        'Z' => [
            0b11111, 0b00001, 0b00010, 0b00100, 0b01000, 0b10000, 0b11111,
        ],
        'σ' | 'Σ' => [
            0b00000, 0b00000, 0b01111, 0b10010, 0b10001, 0b10001, 0b01110,
        ],
        '.' => [
            0b00000, 0b00000, 0b00000, 0b00000, 0b00000, 0b01100, 0b01100,
        ],
        ',' => [
            0b00000, 0b00000, 0b00000, 0b00000, 0b01100, 0b00100, 0b01000,
        ],
        ':' => [
            0b00000, 0b01100, 0b01100, 0b00000, 0b01100, 0b01100, 0b00000,
        ],
        '-' => [
            0b00000, 0b00000, 0b00000, 0b01110, 0b00000, 0b00000, 0b00000,
        ],
        '+' => [
            0b00000, 0b00100, 0b00100, 0b11111, 0b00100, 0b00100, 0b00000,
        ],
        '=' => [
            0b00000, 0b00000, 0b11111, 0b00000, 0b11111, 0b00000, 0b00000,
        ],
        '/' => [
            0b00000, 0b00001, 0b00010, 0b00100, 0b01000, 0b10000, 0b00000,
        ],
        '(' => [
            0b00010, 0b00100, 0b01000, 0b01000, 0b01000, 0b00100, 0b00010,
        ],
        ')' => [
            0b01000, 0b00100, 0b00010, 0b00010, 0b00010, 0b00100, 0b01000,
        ],
        '%' => [
            0b11000, 0b11001, 0b00010, 0b00100, 0b01000, 0b10011, 0b00011,
        ],
        ' ' => [0; 7],
        _ => return None,
    };
    Some(g)
}

/// Width of `text` in pixels at `unit` pixels per font pixel (6 units per character, the
/// last one's gap not counted).
pub(crate) fn text_width(text: &str, unit: u32) -> u32 {
    (6 * text.chars().count() as u32).saturating_sub(1) * unit
}

/// Height of a line of text, pixels.
pub(crate) fn text_height(unit: u32) -> u32 {
    7 * unit
}

/// Draws `text` with its top-left corner at pixel (`x`, `y`), each font pixel a square of
/// `unit` pixels in `color`. Characters without a glyph are drawn as an empty box.
pub(crate) fn draw_text(pixmap: &mut Pixmap, text: &str, x: f32, y: f32, unit: u32, color: Color) {
    let mut paint = Paint::default();
    paint.set_color(color);
    paint.anti_alias = false;
    let u = unit as f32;
    let unknown = [
        0b11111, 0b10001, 0b10001, 0b10001, 0b10001, 0b10001, 0b11111,
    ];
    for (k, c) in text.chars().enumerate() {
        let rows = glyph(c).unwrap_or(unknown);
        let left = x + 6.0 * u * k as f32;
        for (r, bits) in rows.iter().enumerate() {
            // One rectangle per run of set bits.
            let mut col = 0;
            while col < 5 {
                if bits & (0b10000 >> col) == 0 {
                    col += 1;
                    continue;
                }
                let start = col;
                while col < 5 && bits & (0b10000 >> col) != 0 {
                    col += 1;
                }
                if let Some(rect) = Rect::from_xywh(
                    left + u * start as f32,
                    y + u * r as f32,
                    u * (col - start) as f32,
                    u,
                ) {
                    pixmap.fill_rect(rect, &paint, Transform::identity(), None);
                }
            }
        }
    }
}

/// The font unit (pixels per font pixel) for an image whose shorter side is `side` pixels:
/// 2 at 540 to 809 px, 3 from 810 px, at least 1.
pub(crate) fn unit_for(side: u32) -> u32 {
    (side / 270).max(1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_glyph_is_five_columns_and_distinct() {
        let chars = "0123456789ABCDEFGHIJKLMNOPQRSTUVWXYZσ.,:-+=/()%";
        let mut seen = std::collections::HashSet::new();
        for c in chars.chars() {
            let g = glyph(c).unwrap();
            assert!(g.iter().all(|&r| r < 32), "{c}");
            assert!(seen.insert(g), "{c} looks like another glyph");
        }
        assert_eq!(glyph('a'), glyph('A'));
        assert!(glyph('@').is_none());
    }

    #[test]
    fn text_is_drawn_inside_its_box() {
        let mut p = Pixmap::new(40, 20).unwrap();
        draw_text(&mut p, "1.5", 2.0, 3.0, 2, Color::BLACK);
        let w = text_width("1.5", 2);
        assert_eq!(w, 34);
        for y in 0..20 {
            for x in 0..40 {
                let inside = (2..2 + w).contains(&x) && (3..3 + text_height(2)).contains(&y);
                if !inside {
                    assert_eq!(p.pixel(x, y).unwrap().alpha(), 0, "({x}, {y})");
                }
            }
        }
        assert!(p.pixels().iter().any(|c| c.alpha() == 255));
    }
}
