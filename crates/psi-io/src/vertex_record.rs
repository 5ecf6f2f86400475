//! One PLY vertex record as psi reads it ([`VertexRecord`], filled through `ply-rs-bw`'s
//! setters), and the binary vertex blocks whose records all have one size decoded in parallel
//! chunks through the same setters (issue "Throughput": the record-at-a-time reader works on
//! one core; measured in docs/notes/2026-11-26-throughput.md).

use glam::DVec3;
use ply_rs_bw::ply::{ElementDef, PropertyAccess, PropertyAccessResult, PropertyType, ScalarType};
use rayon::prelude::*;

use crate::attributes::{PointAttributes, channel_from_u16, channel_from_unit, intensity_value};

/// The intensity property names read, in order of preference.
pub(crate) const INTENSITY_NAMES: [&str; 2] = ["intensity", "scalar_intensity"];

/// `x y z nx ny nz` of one vertex, any numeric type widened to f64, with its colour (8 bits
/// per channel: `uchar` as is, 16-bit types by their high byte, other integers clamped to
/// 0–255, floats scaled from 0–1) and intensities; other properties ignored.
pub(crate) struct VertexRecord {
    pub(crate) v: [f64; 6],
    pub(crate) rgb: [u8; 3],
    pub(crate) intensity: [f32; 2],
}

/// How a colour channel of some PLY type becomes 8 bits.
enum Channel {
    Byte(u8),
    Wide(u16),
    Int(i64),
    Unit(f64),
}

impl VertexRecord {
    fn set(&mut self, name: &str, value: f64, channel: Channel) -> PropertyAccessResult {
        let slot = match name {
            "x" => 0,
            "y" => 1,
            "z" => 2,
            "nx" => 3,
            "ny" => 4,
            "nz" => 5,
            "red" | "green" | "blue" => {
                let k = usize::from(name != "red") + usize::from(name == "blue");
                self.rgb[k] = match channel {
                    Channel::Byte(v) => v,
                    Channel::Wide(v) => channel_from_u16(v),
                    Channel::Int(v) => v.clamp(0, 255) as u8,
                    Channel::Unit(v) => channel_from_unit(v),
                };
                return PropertyAccessResult::Set;
            }
            _ => match INTENSITY_NAMES.iter().position(|&n| n == name) {
                Some(k) => {
                    self.intensity[k] = intensity_value(value);
                    return PropertyAccessResult::Set;
                }
                None => return PropertyAccessResult::Ignored,
            },
        };
        self.v[slot] = value;
        PropertyAccessResult::Set
    }
}

impl PropertyAccess for VertexRecord {
    fn new() -> Self {
        Self {
            v: [0.0; 6],
            rgb: [0; 3],
            intensity: [0.0; 2],
        }
    }
    fn set_char(&mut self, name: &str, value: i8) -> PropertyAccessResult {
        self.set(name, f64::from(value), Channel::Int(i64::from(value)))
    }
    fn set_uchar(&mut self, name: &str, value: u8) -> PropertyAccessResult {
        self.set(name, f64::from(value), Channel::Byte(value))
    }
    fn set_short(&mut self, name: &str, value: i16) -> PropertyAccessResult {
        let wide = Channel::Wide(value.max(0) as u16);
        self.set(name, f64::from(value), wide)
    }
    fn set_ushort(&mut self, name: &str, value: u16) -> PropertyAccessResult {
        self.set(name, f64::from(value), Channel::Wide(value))
    }
    fn set_int(&mut self, name: &str, value: i32) -> PropertyAccessResult {
        self.set(name, f64::from(value), Channel::Int(i64::from(value)))
    }
    fn set_uint(&mut self, name: &str, value: u32) -> PropertyAccessResult {
        self.set(name, f64::from(value), Channel::Int(i64::from(value)))
    }
    fn set_float(&mut self, name: &str, value: f32) -> PropertyAccessResult {
        self.set(name, f64::from(value), Channel::Unit(f64::from(value)))
    }
    fn set_double(&mut self, name: &str, value: f64) -> PropertyAccessResult {
        self.set(name, value, Channel::Unit(value))
    }
}

/// Records per parallel chunk.
const CHUNK: usize = 1 << 16;

/// Bytes of a scalar of type `s`.
pub(crate) fn scalar_size(s: &ScalarType) -> usize {
    match s {
        ScalarType::Char | ScalarType::UChar => 1,
        ScalarType::Short | ScalarType::UShort => 2,
        ScalarType::Int | ScalarType::UInt | ScalarType::Float => 4,
        ScalarType::Double => 8,
    }
}

/// The size of one record of `def` when every property is a scalar (`None` with a list).
pub(crate) fn fixed_record_size(def: &ElementDef) -> Option<usize> {
    def.properties
        .values()
        .map(|p| match &p.data_type {
            PropertyType::Scalar(s) => Some(scalar_size(s)),
            PropertyType::List(..) => None,
        })
        .sum()
}

/// What a vertex block holds, by record: positions (world units), normals when `normals`, and
/// the attributes the layout asks for.
pub(crate) struct VertexBlock {
    pub(crate) positions: Vec<DVec3>,
    pub(crate) normals: Option<Vec<DVec3>>,
    pub(crate) attributes: PointAttributes,
}

/// Decodes the `def.count` fixed-size binary records of `data` (exactly that many bytes; big-
/// endian when `big_endian`), each through [`VertexRecord`]'s setters, as the record-at-a-time
/// reader does; `normals`, `colors` and `intensity` (which intensity name) as its layout says.
/// `Err(index)`: the first record whose position is not finite.
pub(crate) fn decode_vertex_block(
    data: &[u8],
    def: &ElementDef,
    big_endian: bool,
    (normals, colors, intensity): (bool, bool, Option<usize>),
) -> Result<VertexBlock, usize> {
    let size = fixed_record_size(def).unwrap_or(0).max(1);
    // The properties the record uses, with their offsets (the others are skipped).
    let mut fields: Vec<(&str, ScalarType, usize)> = Vec::new();
    let mut offset = 0;
    for (name, p) in &def.properties {
        if let PropertyType::Scalar(s) = &p.data_type {
            let used = VertexRecord::new().set_double(name, 0.0) == PropertyAccessResult::Set;
            if used {
                fields.push((name.as_str(), s.clone(), offset));
            }
            offset += scalar_size(s);
        }
    }
    let read = |r: &[u8]| -> VertexRecord {
        let mut rec = VertexRecord::new();
        for (name, ty, at) in &fields {
            let b = &r[*at..*at + scalar_size(ty)];
            macro_rules! num {
                ($t:ty) => {{
                    let bytes = b.try_into().unwrap_or_default();
                    if big_endian {
                        <$t>::from_be_bytes(bytes)
                    } else {
                        <$t>::from_le_bytes(bytes)
                    }
                }};
            }
            match ty {
                ScalarType::Char => rec.set_char(name, b[0] as i8),
                ScalarType::UChar => rec.set_uchar(name, b[0]),
                ScalarType::Short => rec.set_short(name, num!(i16)),
                ScalarType::UShort => rec.set_ushort(name, num!(u16)),
                ScalarType::Int => rec.set_int(name, num!(i32)),
                ScalarType::UInt => rec.set_uint(name, num!(u32)),
                ScalarType::Float => rec.set_float(name, num!(f32)),
                ScalarType::Double => rec.set_double(name, num!(f64)),
            };
        }
        rec
    };
    type Chunk = (
        Vec<DVec3>,
        Vec<DVec3>,
        Vec<[u8; 3]>,
        Vec<f32>,
        Option<usize>,
    );
    let chunks: Vec<Chunk> = data
        .par_chunks(CHUNK * size)
        .enumerate()
        .map(|(c, bytes)| {
            let n = bytes.len() / size;
            let mut out: Chunk = (
                Vec::with_capacity(n),
                Vec::with_capacity(if normals { n } else { 0 }),
                Vec::with_capacity(if colors { n } else { 0 }),
                Vec::with_capacity(if intensity.is_some() { n } else { 0 }),
                None,
            );
            for (k, r) in bytes.chunks_exact(size).enumerate() {
                let rec = read(r);
                let p = DVec3::new(rec.v[0], rec.v[1], rec.v[2]);
                if !p.is_finite() && out.4.is_none() {
                    out.4 = Some(c * CHUNK + k);
                }
                out.0.push(p);
                if normals {
                    out.1.push(DVec3::new(rec.v[3], rec.v[4], rec.v[5]));
                }
                if colors {
                    out.2.push(rec.rgb);
                }
                if let Some(which) = intensity {
                    out.3.push(rec.intensity[which]);
                }
            }
            out
        })
        .collect();
    if let Some(bad) = chunks.iter().find_map(|c| c.4) {
        return Err(bad);
    }
    let count = data.len() / size;
    let mut block = VertexBlock {
        positions: Vec::with_capacity(count),
        normals: normals.then(|| Vec::with_capacity(count)),
        attributes: PointAttributes {
            colors: colors.then(|| Vec::with_capacity(count)),
            intensity: intensity.map(|_| Vec::with_capacity(count)),
            classification: None,
        },
    };
    for (p, n, c, i, _) in chunks {
        block.positions.extend(p);
        if let Some(v) = &mut block.normals {
            v.extend(n);
        }
        if let Some(v) = &mut block.attributes.colors {
            v.extend(c);
        }
        if let Some(v) = &mut block.attributes.intensity {
            v.extend(i);
        }
    }
    Ok(block)
}

#[cfg(test)]
mod tests {
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64Mcg;

    use crate::read_ply::read_ply;

    /// One property of the test files: its PLY type and name.
    const LAYOUTS: [&[(&str, &str)]; 4] = [
        &[("float", "x"), ("float", "y"), ("float", "z")],
        &[
            ("double", "x"),
            ("double", "y"),
            ("double", "z"),
            ("float", "nx"),
            ("float", "ny"),
            ("float", "nz"),
            ("uchar", "red"),
            ("uchar", "green"),
            ("uchar", "blue"),
            ("float", "intensity"),
        ],
        &[
            ("int", "x"),
            ("short", "y"),
            ("uint", "z"),
            ("ushort", "red"),
            ("ushort", "green"),
            ("ushort", "blue"),
            ("char", "flag"),
            ("double", "scalar_intensity"),
        ],
        &[
            ("uchar", "quality"),
            ("float", "z"),
            ("float", "y"),
            ("float", "x"),
            ("float", "red"),
            ("float", "green"),
            ("float", "blue"),
            ("double", "nz"),
            ("double", "nx"),
            ("double", "ny"),
        ],
    ];

    /// A value of PLY type `ty` from `r` (a pseudo-random integer), as text and as bytes.
    fn value(ty: &str, r: u64, big: bool) -> (String, Vec<u8>) {
        let f = (r % 20_001) as f64 / 7.0 - 1400.0;
        macro_rules! out {
            ($v:expr) => {{
                let v = $v;
                let b = if big {
                    v.to_be_bytes().to_vec()
                } else {
                    v.to_le_bytes().to_vec()
                };
                (format!("{v}"), b)
            }};
        }
        match ty {
            "char" => out!((r % 256) as u8 as i8),
            "uchar" => out!((r % 256) as u8),
            "short" => out!((r % 65_536) as u16 as i16),
            "ushort" => out!((r % 65_536) as u16),
            "int" => out!((r % 2_000_001) as i32 - 1_000_000),
            "uint" => out!((r % 2_000_001) as u32),
            "float" => out!(f as f32),
            _ => out!(f),
        }
    }

    /// The same records as ASCII, binary little- and big-endian PLY read through the PLY
    /// reader: the binary files take the parallel block decoder, the ASCII one the record-at-a-
    /// time parser of `ply-rs-bw`; all three give the same points and attributes.
    #[test]
    fn binary_blocks_decode_as_the_record_parser_reads_text() {
        let mut rng = Pcg64Mcg::seed_from_u64(99);
        let mut rnd = move || rng.random::<u64>();
        for layout in LAYOUTS {
            for count in [1usize, 7, 70_000] {
                let rows: Vec<Vec<u64>> = (0..count)
                    .map(|_| layout.iter().map(|_| rnd()).collect())
                    .collect();
                let file = |encoding: &str| -> Vec<u8> {
                    let mut out = format!("ply\nformat {encoding} 1.0\nelement vertex {count}\n");
                    for (ty, name) in layout {
                        out += &format!("property {ty} {name}\n");
                    }
                    out += "end_header\n";
                    let mut bytes = out.into_bytes();
                    for row in &rows {
                        let mut line = Vec::new();
                        for ((ty, _), &r) in layout.iter().zip(row) {
                            let (text, b) = value(ty, r, encoding == "binary_big_endian");
                            if encoding == "ascii" {
                                line.push(text);
                            } else {
                                bytes.extend(b);
                            }
                        }
                        if encoding == "ascii" {
                            bytes.extend(line.join(" ").into_bytes());
                            bytes.push(b'\n');
                        }
                    }
                    bytes
                };
                let text = read_ply(&file("ascii")).unwrap();
                for encoding in ["binary_little_endian", "binary_big_endian"] {
                    let bin = read_ply(&file(encoding)).unwrap();
                    assert_eq!(bin.vertices, text.vertices, "{encoding} {layout:?}");
                    assert_eq!(bin.normals, text.normals, "{encoding} {layout:?}");
                    assert_eq!(bin.attributes, text.attributes, "{encoding} {layout:?}");
                }
            }
        }
    }

    /// A non-finite position is refused with the index of the first one, whatever chunk it is in.
    #[test]
    fn the_first_non_finite_position_is_named() {
        let count = 200_000;
        let mut bytes = format!(
            "ply\nformat binary_little_endian 1.0\nelement vertex {count}\nproperty float x\nproperty float y\nproperty float z\nend_header\n"
        )
        .into_bytes();
        for i in 0..count {
            let x = if i == 150_001 || i == 190_000 {
                f32::NAN
            } else {
                i as f32
            };
            for v in [x, 0.0, 1.0] {
                bytes.extend(v.to_le_bytes());
            }
        }
        let err = read_ply(&bytes).unwrap_err();
        assert!(err.to_string().contains("150001"), "{err}");
    }
}
