//! Shared helpers of the line-based text formats (OBJ, XYZ): numbered lines, tokens, numbers.

use crate::error::ReadError;

/// The lines of `bytes` with their 1-based numbers, without the `\n` / `\r\n` line break.
pub(crate) fn numbered_lines(bytes: &[u8]) -> impl Iterator<Item = (usize, &[u8])> {
    bytes
        .split(|&b| b == b'\n')
        .enumerate()
        .map(|(i, line)| (i + 1, line.strip_suffix(b"\r").unwrap_or(line)))
}

/// Whether the input holds nothing but ASCII whitespace.
pub(crate) fn is_blank(bytes: &[u8]) -> bool {
    bytes.iter().all(u8::is_ascii_whitespace)
}

/// The line as text; a [`ReadError::Line`] when it is not UTF-8.
pub(crate) fn line_str(line: &[u8], number: usize) -> Result<&str, ReadError> {
    std::str::from_utf8(line).map_err(|_| ReadError::Line {
        line: number,
        reason: "not valid UTF-8 text".to_owned(),
    })
}

/// A token shortened for an error message.
pub(crate) fn quoted(token: &str) -> String {
    const MAX: usize = 40;
    if token.chars().count() <= MAX {
        format!("{token:?}")
    } else {
        let head: String = token.chars().take(MAX).collect();
        format!("{head:?}...")
    }
}

/// Parses a decimal number (Rust float syntax; `nan`/`inf` parse and are rejected later as
/// non-finite by the caller).
pub(crate) fn parse_number(token: &str, number: usize) -> Result<f64, ReadError> {
    token.parse::<f64>().map_err(|_| ReadError::Line {
        line: number,
        reason: format!("{} is not a number", quoted(token)),
    })
}
