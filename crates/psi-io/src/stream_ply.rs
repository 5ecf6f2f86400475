//! A PLY point cloud (a `vertex` element first, no faces) read in chunks of records, binary
//! (either byte order) or ASCII: the positions and normals [`crate::read_points`] reads from
//! the whole file. Meshes (faces need every vertex) and other layouts are refused here and read
//! whole by the caller.

use std::io::{BufRead, BufReader, Read};
use std::ops::ControlFlow;

use glam::DVec3;

use crate::error::ReadError;
use crate::format::Format;
use crate::point_chunk::{PointChunk, StreamEnd, StreamHeader, emit_if_full, emit_rest, io_error};

/// A scalar property type and its size in bytes.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(name: &str) -> Option<Scalar> {
        Some(match name {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    /// The value of `bytes` (its size) as the whole reader widens it.
    fn binary(self, b: &[u8], little: bool) -> f64 {
        macro_rules! num {
            ($t:ty, $n:expr) => {{
                let a: [u8; $n] = b[..$n].try_into().expect("sized");
                if little {
                    <$t>::from_le_bytes(a)
                } else {
                    <$t>::from_be_bytes(a)
                }
            }};
        }
        match self {
            Scalar::I8 => f64::from(b[0] as i8),
            Scalar::U8 => f64::from(b[0]),
            Scalar::I16 => f64::from(num!(i16, 2)),
            Scalar::U16 => f64::from(num!(u16, 2)),
            Scalar::I32 => f64::from(num!(i32, 4)),
            Scalar::U32 => f64::from(num!(u32, 4)),
            Scalar::F32 => f64::from(num!(f32, 4)),
            Scalar::F64 => num!(f64, 8),
        }
    }

    /// The value of an ASCII token, parsed as the property's type and widened.
    fn text(self, t: &str) -> Option<f64> {
        Some(match self {
            Scalar::I8 => f64::from(t.parse::<i8>().ok()?),
            Scalar::U8 => f64::from(t.parse::<u8>().ok()?),
            Scalar::I16 => f64::from(t.parse::<i16>().ok()?),
            Scalar::U16 => f64::from(t.parse::<u16>().ok()?),
            Scalar::I32 => f64::from(t.parse::<i32>().ok()?),
            Scalar::U32 => f64::from(t.parse::<u32>().ok()?),
            Scalar::F32 => f64::from(t.parse::<f32>().ok()?),
            Scalar::F64 => t.parse::<f64>().ok()?,
        })
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Encoding {
    Ascii,
    Little,
    Big,
}

/// An opened PLY point cloud, positioned at its vertex records.
pub(crate) struct PlyStream<R: Read> {
    input: BufReader<R>,
    encoding: Encoding,
    count: u64,
    /// Per property: type, and which of x y z nx ny nz it is (6: none).
    properties: Vec<(Scalar, usize)>,
    record: usize,
}

fn refuse(reason: impl Into<String>) -> ReadError {
    ReadError::Header {
        reason: reason.into(),
    }
}

/// Reads the header; refuses (so the caller reads the file whole) anything but a point cloud
/// whose first element is `vertex` with scalar properties `x y z` (and `nx ny nz`).
pub(crate) fn open<R: Read>(input: R) -> Result<(StreamHeader, PlyStream<R>), ReadError> {
    let mut input = BufReader::new(input);
    let mut line = String::new();
    let read_line = |input: &mut BufReader<R>, line: &mut String| -> Result<(), ReadError> {
        line.clear();
        let n = input
            .by_ref()
            .take(1 << 16)
            .read_line(line)
            .map_err(io_error)?;
        if n == 0 {
            return Err(refuse("the header ends before `end_header`"));
        }
        Ok(())
    };
    read_line(&mut input, &mut line)?;
    if line.trim() != "ply" {
        return Err(refuse("not a PLY file"));
    }
    let mut encoding = None;
    let mut elements: Vec<(String, u64)> = Vec::new();
    let mut properties = Vec::new();
    loop {
        read_line(&mut input, &mut line)?;
        let words: Vec<&str> = line.split_ascii_whitespace().collect();
        match words.as_slice() {
            ["end_header"] => break,
            ["format", f, _] => {
                encoding = Some(match *f {
                    "ascii" => Encoding::Ascii,
                    "binary_little_endian" => Encoding::Little,
                    "binary_big_endian" => Encoding::Big,
                    other => return Err(refuse(format!("unknown format {other}"))),
                })
            }
            ["element", name, count] => {
                let count = count
                    .parse()
                    .map_err(|_| refuse(format!("bad count {count}")))?;
                elements.push(((*name).to_owned(), count));
            }
            ["property", "list", ..] if elements.len() == 1 => {
                return Err(refuse("a list in `vertex`: read whole"));
            }
            ["property", t, name] if elements.len() == 1 => {
                let scalar = Scalar::parse(t).ok_or_else(|| refuse(format!("unknown type {t}")))?;
                let slot = ["x", "y", "z", "nx", "ny", "nz"]
                    .iter()
                    .position(|n| n == name)
                    .unwrap_or(6);
                if slot < 6 && properties.iter().any(|p: &(Scalar, usize)| p.1 == slot) {
                    return Err(refuse(format!("property {name} repeated: read whole")));
                }
                properties.push((scalar, slot));
            }
            _ => {}
        }
    }
    let encoding = encoding.ok_or_else(|| refuse("no `format` line"))?;
    let count = match elements.as_slice() {
        [(v, n), rest @ ..] if v == "vertex" && rest.iter().all(|(_, c)| *c == 0) => *n,
        _ => {
            return Err(refuse(
                "not a point cloud (faces or other elements): read whole",
            ));
        }
    };
    let has = |s: usize| properties.iter().any(|p| p.1 == s);
    if !(0..3).all(has) {
        return Err(refuse("the vertex has no `x y z`: read whole"));
    }
    let header = StreamHeader {
        format: Format::Ply,
        detail: format!("PLY {encoding:?} point cloud, {count} vertices"),
        announced_points: count,
        scans: None,
        normals: (3..6).all(has),
        attributes: Default::default(),
    };
    let record = properties.iter().map(|p| p.0.size()).sum();
    Ok((
        header,
        PlyStream {
            input,
            encoding,
            count,
            properties,
            record,
        },
    ))
}

impl<R: Read> PlyStream<R> {
    /// Every vertex in file order, in chunks of at most `max` points.
    pub(crate) fn for_each_chunk<F: FnMut(PointChunk) -> ControlFlow<()>>(
        mut self,
        header: &StreamHeader,
        max: usize,
        visit: &mut F,
    ) -> Result<StreamEnd, ReadError> {
        let mut end = StreamEnd::default();
        let mut chunk = PointChunk::fresh(header, max);
        let mut bytes = vec![0u8; self.record];
        let mut line = String::new();
        for index in 0..self.count {
            let truncated = || ReadError::Truncated {
                element: "vertex".into(),
                index: index as usize,
                count: self.count as usize,
            };
            let mut v = [0.0f64; 6];
            if self.encoding == Encoding::Ascii {
                line.clear();
                let n = self.input.read_line(&mut line).map_err(io_error)?;
                if n == 0 {
                    return Err(truncated());
                }
                let mut tokens = line.split_ascii_whitespace();
                for &(t, slot) in &self.properties {
                    let token = tokens.next().ok_or_else(truncated)?;
                    let value = t.text(token).ok_or_else(|| ReadError::Header {
                        reason: format!("vertex {index}: `{token}` is not a {t:?}"),
                    })?;
                    if slot < 6 {
                        v[slot] = value;
                    }
                }
            } else {
                self.input.read_exact(&mut bytes).map_err(|e| {
                    if e.kind() == std::io::ErrorKind::UnexpectedEof {
                        truncated()
                    } else {
                        io_error(e)
                    }
                })?;
                let little = self.encoding == Encoding::Little;
                let mut at = 0;
                for &(t, slot) in &self.properties {
                    if slot < 6 {
                        v[slot] = t.binary(&bytes[at..], little);
                    }
                    at += t.size();
                }
            }
            let p = DVec3::new(v[0], v[1], v[2]);
            if !p.is_finite() {
                return Err(ReadError::NonFinite {
                    element: "vertex",
                    index: index as usize,
                    what: "position",
                    line: None,
                });
            }
            chunk.positions.push(p);
            if let Some(n) = chunk.normals.as_mut() {
                n.push(DVec3::new(v[3], v[4], v[5]));
            }
            if emit_if_full(&mut chunk, header, max, &mut end, visit) {
                return Ok(end);
            }
        }
        Ok(emit_rest(chunk, end, visit))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::options::ReadOptions;

    /// Rows x y z nx ny nz from the stream, and whether it had normals.
    fn streamed(bytes: &[u8], max: usize) -> Result<Vec<[f64; 6]>, ReadError> {
        let (header, stream) = open(bytes)?;
        let mut out = Vec::new();
        stream.for_each_chunk(&header, max, &mut |c: PointChunk| {
            for i in 0..c.len() {
                let p = c.positions[i];
                let n = c.normals.as_ref().map_or(DVec3::ZERO, |n| n[i]);
                out.push([p.x, p.y, p.z, n.x, n.y, n.z]);
            }
            ControlFlow::Continue(())
        })?;
        Ok(out)
    }

    /// The same rows from the whole-file reader (before normals are made unit).
    fn whole(bytes: &[u8]) -> Vec<[f64; 6]> {
        let parsed = crate::read_ply::read_ply(bytes).unwrap();
        let n = parsed.normals.unwrap();
        (0..parsed.vertices.len())
            .map(|i| {
                let (p, q) = (parsed.vertices[i], n[i]);
                [p.x, p.y, p.z, q.x, q.y, q.z]
            })
            .collect()
    }

    fn binary(little: bool, rows: &[[f64; 6]]) -> Vec<u8> {
        let order = if little {
            "binary_little_endian"
        } else {
            "binary_big_endian"
        };
        let mut b = format!(
            "ply\nformat {order} 1.0\ncomment x\nelement vertex {}\nproperty float x\n\
             property double y\nproperty uchar extra\nproperty float z\nproperty double nx\n\
             property double ny\nproperty short nz\nelement face 0\nproperty list uchar int \
             vertex_indices\nend_header\n",
            rows.len()
        )
        .into_bytes();
        for r in rows {
            let mut put = |v: &[u8]| b.extend_from_slice(v);
            let f32b = |v: f32| {
                if little {
                    v.to_le_bytes()
                } else {
                    v.to_be_bytes()
                }
            };
            let f64b = |v: f64| {
                if little {
                    v.to_le_bytes()
                } else {
                    v.to_be_bytes()
                }
            };
            put(&f32b(r[0] as f32));
            put(&f64b(r[1]));
            put(&[7]);
            put(&f32b(r[2] as f32));
            put(&f64b(r[3]));
            put(&f64b(r[4]));
            let s = r[5] as i16;
            put(&if little {
                s.to_le_bytes()
            } else {
                s.to_be_bytes()
            });
        }
        b
    }

    fn rows() -> Vec<[f64; 6]> {
        (0..100)
            .map(|i| {
                let t = i as f64 * 0.37;
                [t.sin(), t.cos() * 3.0, 0.1 * t, t.cos(), -t.sin(), 1.0]
            })
            .collect()
    }

    #[test]
    fn binary_and_ascii_point_clouds_stream_what_the_whole_reader_reads() {
        for little in [true, false] {
            let b = binary(little, &rows());
            for max in [1, 7, 1000] {
                assert_eq!(streamed(&b, max).unwrap(), whole(&b));
            }
        }
        let mut ascii = format!(
            "ply\nformat ascii 1.0\nelement vertex {}\nproperty float x\nproperty float y\n\
             property float z\nproperty float nx\nproperty float ny\nproperty float nz\nend_header\n",
            rows().len()
        );
        for r in rows() {
            ascii += &format!("{} {} {} {} {} {}\n", r[0], r[1], r[2], r[3], r[4], r[5]);
        }
        assert_eq!(
            streamed(ascii.as_bytes(), 9).unwrap(),
            whole(ascii.as_bytes())
        );
        let _ = ReadOptions::paper();
    }

    #[test]
    fn meshes_and_truncated_files_are_not_streamed() {
        let mesh = b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
                     property float z\nelement face 1\nproperty list uchar int vertex_indices\n\
                     end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
        assert!(matches!(open(&mesh[..]), Err(ReadError::Header { .. })));
        let mut b = binary(true, &rows());
        b.truncate(b.len() - 5);
        let err = streamed(&b, 10).unwrap_err();
        assert!(
            matches!(
                err,
                ReadError::Truncated {
                    index: 99,
                    count: 100,
                    ..
                }
            ),
            "{err}"
        );
    }

    #[test]
    fn no_damaged_byte_makes_the_stream_panic() {
        let good = binary(true, &rows()[..10]);
        let ascii =
            b"ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n\
                      property float z\nproperty float nx\nproperty float ny\nproperty float nz\n\
                      end_header\n0 0 0 0 0 1\n1 0 0 0 0 1\n";
        for base in [&good[..], &ascii[..]] {
            for i in 0..base.len() {
                for v in [0u8, b' ', b'\n', b'9', 0xff] {
                    let mut b = base.to_vec();
                    b[i] = v;
                    let _ = streamed(&b, 3);
                    b.truncate(i);
                    let _ = streamed(&b, 3);
                }
            }
        }
    }
}
