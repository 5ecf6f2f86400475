//! LZF decompression (Marc Lehmann's liblzf format), as PCL's `binary_compressed` PCD data
//! uses it. The stream is a sequence of runs, each starting with a control byte `c`:
//!
//! * `c < 32`: a literal run of `c + 1` bytes copied from the input;
//! * otherwise a back-reference: length `c >> 5` (when 7, plus the next byte), plus 2, and
//!   distance `((c & 31) << 8) + next byte + 1` back from the end of the output; the copy may
//!   overlap its own output (byte by byte).

/// The most output one input byte can give: a 3-byte back-reference copies at most
/// 7 + 255 + 2 = 264 bytes.
pub(crate) const MAX_EXPANSION: u64 = 88;

/// Decompresses `input`, which must decode to exactly `expected` bytes.
///
/// # Errors
///
/// A message saying where the stream is malformed: a run past the end of the input, a
/// back-reference before the start of the output, or a length other than `expected`.
pub(crate) fn decompress(input: &[u8], expected: usize) -> Result<Vec<u8>, String> {
    let mut out: Vec<u8> = Vec::with_capacity(expected);
    let mut ip = 0;
    while ip < input.len() {
        let ctrl = usize::from(input[ip]);
        ip += 1;
        if ctrl < 32 {
            let len = ctrl + 1;
            let Some(literal) = input.get(ip..ip + len) else {
                return Err(format!("a literal run at byte {} passes the end", ip - 1));
            };
            if out.len() + len > expected {
                return Err(format!("the data decodes to more than {expected} bytes"));
            }
            out.extend_from_slice(literal);
            ip += len;
        } else {
            let at = ip - 1;
            let mut len = ctrl >> 5;
            if len == 7 {
                let Some(&extra) = input.get(ip) else {
                    return Err(format!("a back-reference at byte {at} passes the end"));
                };
                len += usize::from(extra);
                ip += 1;
            }
            len += 2;
            let Some(&low) = input.get(ip) else {
                return Err(format!("a back-reference at byte {at} passes the end"));
            };
            ip += 1;
            let distance = ((ctrl & 31) << 8) + usize::from(low) + 1;
            if distance > out.len() {
                return Err(format!(
                    "a back-reference at byte {at} points {distance} bytes back, before the start"
                ));
            }
            if out.len() + len > expected {
                return Err(format!("the data decodes to more than {expected} bytes"));
            }
            let start = out.len() - distance;
            for k in 0..len {
                let byte = out[start + k];
                out.push(byte);
            }
        }
    }
    if out.len() != expected {
        return Err(format!(
            "the data decodes to {} bytes, not {expected}",
            out.len()
        ));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn literal_and_back_references_decode() {
        // "abc", then 6 bytes from 3 back (overlapping), then "X", then 10 bytes from 10
        // back: a long back-reference (length field 7, extra byte 1).
        let compressed = [
            0x02, b'a', b'b', b'c', // literal "abc"
            0x80, 0x02, // length 4 + 2 = 6, distance 2 + 1 = 3
            0x00, b'X', // literal "X"
            0xE0, 0x01, 0x09, // length 7 + 1 + 2 = 10, distance 9 + 1 = 10
        ];
        let out = decompress(&compressed, 20).unwrap();
        assert_eq!(out, b"abcabcabcXabcabcabcX");
    }

    #[test]
    fn malformed_streams_are_errors() {
        assert!(decompress(&[0x05, b'a'], 6).is_err()); // literal past the end
        assert!(decompress(&[0x00, b'a', 0x20, 0x05], 4).is_err()); // before the start
        assert!(decompress(&[0x00, b'a'], 2).is_err()); // too short
        assert!(decompress(&[0x01, b'a', b'b'], 1).is_err()); // too long
        assert!(decompress(&[0xE0], 9).is_err()); // cut inside a back-reference
        assert_eq!(decompress(&[], 0).unwrap(), Vec::<u8>::new());
    }
}
