//! One PLY vertex record as psi reads it ([`VertexRecord`], filled through `ply-rs-bw`'s
//! setters), and the binary vertex blocks whose records all have one size decoded in parallel,
//! array by array, through the same conversions (issue "Throughput": the record-at-a-time
//! reader works on one core; measured in docs/notes/2026-11-26-throughput.md).

use glam::DVec3;
use ply_rs_bw::ply::{ElementDef, PropertyAccess, PropertyAccessResult, PropertyType, ScalarType};
use psi_octree::OrientedPoint;
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

/// Where a property's value goes in a [`VertexRecord`], resolved from its name once.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Slot {
    /// `v[k]`: `x y z nx ny nz`.
    Coordinate(usize),
    /// `rgb[k]`: `red green blue`.
    Color(usize),
    /// `intensity[k]`: [`INTENSITY_NAMES`]`[k]`.
    Intensity(usize),
}

impl Slot {
    /// The slot of property `name` (`None`: psi ignores it).
    fn of(name: &str) -> Option<Slot> {
        Some(match name {
            "x" => Slot::Coordinate(0),
            "y" => Slot::Coordinate(1),
            "z" => Slot::Coordinate(2),
            "nx" => Slot::Coordinate(3),
            "ny" => Slot::Coordinate(4),
            "nz" => Slot::Coordinate(5),
            "red" => Slot::Color(0),
            "green" => Slot::Color(1),
            "blue" => Slot::Color(2),
            _ => Slot::Intensity(INTENSITY_NAMES.iter().position(|&n| n == name)?),
        })
    }
}

impl VertexRecord {
    /// `x y z` (world units).
    pub(crate) fn position(&self) -> DVec3 {
        DVec3::new(self.v[0], self.v[1], self.v[2])
    }

    /// `nx ny nz` as read (any length).
    pub(crate) fn normal(&self) -> DVec3 {
        DVec3::new(self.v[3], self.v[4], self.v[5])
    }

    fn set(&mut self, name: &str, (value, channel): (f64, Channel)) -> PropertyAccessResult {
        match Slot::of(name) {
            Some(slot) => {
                self.put(slot, value, channel);
                PropertyAccessResult::Set
            }
            None => PropertyAccessResult::Ignored,
        }
    }

    /// Stores a property's `value` (and its colour reading `channel`) in `slot`.
    #[inline]
    fn put(&mut self, slot: Slot, value: f64, channel: Channel) {
        match slot {
            Slot::Coordinate(k) => self.v[k] = value,
            Slot::Color(k) => {
                self.rgb[k] = match channel {
                    Channel::Byte(v) => v,
                    Channel::Wide(v) => channel_from_u16(v),
                    Channel::Int(v) => v.clamp(0, 255) as u8,
                    Channel::Unit(v) => channel_from_unit(v),
                }
            }
            Slot::Intensity(k) => self.intensity[k] = intensity_value(value),
        }
    }
}

/// A property value of each PLY type as a number and as a colour channel: what the setters
/// store and what the block decoder stores, the one through the other.
fn of_i8(v: i8) -> (f64, Channel) {
    (f64::from(v), Channel::Int(i64::from(v)))
}
fn of_u8(v: u8) -> (f64, Channel) {
    (f64::from(v), Channel::Byte(v))
}
fn of_i16(v: i16) -> (f64, Channel) {
    (f64::from(v), Channel::Wide(v.max(0) as u16))
}
fn of_u16(v: u16) -> (f64, Channel) {
    (f64::from(v), Channel::Wide(v))
}
fn of_i32(v: i32) -> (f64, Channel) {
    (f64::from(v), Channel::Int(i64::from(v)))
}
fn of_u32(v: u32) -> (f64, Channel) {
    (f64::from(v), Channel::Int(i64::from(v)))
}
fn of_f32(v: f32) -> (f64, Channel) {
    (f64::from(v), Channel::Unit(f64::from(v)))
}
fn of_f64(v: f64) -> (f64, Channel) {
    (v, Channel::Unit(v))
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
        self.set(name, of_i8(value))
    }
    fn set_uchar(&mut self, name: &str, value: u8) -> PropertyAccessResult {
        self.set(name, of_u8(value))
    }
    fn set_short(&mut self, name: &str, value: i16) -> PropertyAccessResult {
        self.set(name, of_i16(value))
    }
    fn set_ushort(&mut self, name: &str, value: u16) -> PropertyAccessResult {
        self.set(name, of_u16(value))
    }
    fn set_int(&mut self, name: &str, value: i32) -> PropertyAccessResult {
        self.set(name, of_i32(value))
    }
    fn set_uint(&mut self, name: &str, value: u32) -> PropertyAccessResult {
        self.set(name, of_u32(value))
    }
    fn set_float(&mut self, name: &str, value: f32) -> PropertyAccessResult {
        self.set(name, of_f32(value))
    }
    fn set_double(&mut self, name: &str, value: f64) -> PropertyAccessResult {
        self.set(name, of_f64(value))
    }
}

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

/// The properties of `def` a record uses, with their slots, types and byte offsets (the
/// others are skipped), and the record size in bytes (at least 1).
fn record_fields(def: &ElementDef) -> (Vec<(Slot, ScalarType, usize)>, usize) {
    let size = fixed_record_size(def).unwrap_or(0).max(1);
    let mut fields = Vec::new();
    let mut offset = 0;
    for (name, p) in &def.properties {
        if let PropertyType::Scalar(s) = &p.data_type {
            if let Some(slot) = Slot::of(name) {
                fields.push((slot, s.clone(), offset));
            }
            offset += scalar_size(s);
        }
    }
    (fields, size)
}

/// The record `r` (one record's bytes; big-endian when `big_endian`) through `fields`, with the
/// setters' conversions.
fn read_record(r: &[u8], fields: &[(Slot, ScalarType, usize)], big_endian: bool) -> VertexRecord {
    let mut rec = VertexRecord::new();
    for &(slot, ref ty, at) in fields {
        let b = &r[at..at + scalar_size(ty)];
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
        let (value, channel) = match ty {
            ScalarType::Char => of_i8(b[0] as i8),
            ScalarType::UChar => of_u8(b[0]),
            ScalarType::Short => of_i16(num!(i16)),
            ScalarType::UShort => of_u16(num!(u16)),
            ScalarType::Int => of_i32(num!(i32)),
            ScalarType::UInt => of_u32(num!(u32)),
            ScalarType::Float => of_f32(num!(f32)),
            ScalarType::Double => of_f64(num!(f64)),
        };
        rec.put(slot, value, channel);
    }
    rec
}

/// Decodes the `def.count` fixed-size binary records of `data` (exactly that many bytes; big-
/// endian when `big_endian`) as the record-at-a-time reader does through [`VertexRecord`]'s
/// setters (the same conversions, each property's slot resolved once instead of by name per
/// record); `normals`, `colors` and `intensity` (which intensity name) as its layout says.
/// Each array is collected in parallel straight into its allocation.
/// `Err(index)`: the first record whose position is not finite.
pub(crate) fn decode_vertex_block(
    data: &[u8],
    def: &ElementDef,
    big_endian: bool,
    (normals, colors, intensity): (bool, bool, Option<usize>),
) -> Result<VertexBlock, usize> {
    let records = Records::of(data, def, big_endian);
    let (positions, normals) = if normals {
        let (mut positions, mut normals) = (Vec::new(), Vec::new());
        records
            .par_iter()
            .map(|rec| (rec.position(), rec.normal()))
            .unzip_into_vecs(&mut positions, &mut normals);
        (positions, Some(normals))
    } else {
        (records.column(|rec| rec.position()), None)
    };
    if let Some(bad) = positions.par_iter().position_first(|p| !p.is_finite()) {
        return Err(bad);
    }
    Ok(VertexBlock {
        positions,
        normals,
        attributes: records.attributes(colors, intensity),
    })
}

/// The records of [`decode_vertex_block`] as oriented points (position, and normal as read:
/// `nx ny nz`, any length), collected in parallel straight into one array, with the attributes
/// `colors` and `intensity` ask for. `Err(index)`: the first record whose position is not
/// finite.
pub(crate) fn decode_oriented_block(
    data: &[u8],
    def: &ElementDef,
    big_endian: bool,
    (colors, intensity): (bool, Option<usize>),
) -> Result<(Vec<OrientedPoint>, PointAttributes), usize> {
    let records = Records::of(data, def, big_endian);
    let points = records.column(|rec| OrientedPoint {
        p: rec.position(),
        n: rec.normal(),
    });
    if let Some(bad) = points.par_iter().position_first(|q| !q.p.is_finite()) {
        return Err(bad);
    }
    Ok((points, records.attributes(colors, intensity)))
}

/// The fields of a record that holds only coordinates in floating point (`x y z`, maybe
/// `nx ny nz`, each `float` or `double`; other properties skipped), the common layout of
/// scans: `(k, offset, double)` for `v[k]`. `None` when some field is a colour, an intensity or
/// an integer.
fn float_coordinates(fields: &[(Slot, ScalarType, usize)]) -> Option<Vec<(usize, usize, bool)>> {
    fields
        .iter()
        .map(|(slot, ty, at)| match (slot, ty) {
            (Slot::Coordinate(k), ScalarType::Float) => Some((*k, *at, false)),
            (Slot::Coordinate(k), ScalarType::Double) => Some((*k, *at, true)),
            _ => None,
        })
        .collect()
}

/// The record `r` through `coordinates` ([`float_coordinates`]): [`read_record`]'s values
/// (a `float` widened to f64, a `double` as is) without its per-field dispatch on type, slot
/// and colour channel.
#[inline]
fn read_coordinates(
    r: &[u8],
    coordinates: &[(usize, usize, bool)],
    big_endian: bool,
) -> VertexRecord {
    let mut rec = VertexRecord::new();
    for &(k, at, double) in coordinates {
        rec.v[k] = if double {
            let b: [u8; 8] = r[at..at + 8].try_into().unwrap_or_default();
            if big_endian {
                f64::from_be_bytes(b)
            } else {
                f64::from_le_bytes(b)
            }
        } else {
            let b: [u8; 4] = r[at..at + 4].try_into().unwrap_or_default();
            f64::from(if big_endian {
                f32::from_be_bytes(b)
            } else {
                f32::from_le_bytes(b)
            })
        };
    }
    rec
}

/// A block of fixed-size binary records with the fields a [`VertexRecord`] reads of them.
struct Records<'a> {
    /// Whole records only (a trailing partial record is left out).
    bytes: &'a [u8],
    fields: Vec<(Slot, ScalarType, usize)>,
    /// [`float_coordinates`] of `fields`.
    coordinates: Option<Vec<(usize, usize, bool)>>,
    size: usize,
    big_endian: bool,
}

impl<'a> Records<'a> {
    fn of(data: &'a [u8], def: &ElementDef, big_endian: bool) -> Self {
        let (fields, size) = record_fields(def);
        Self {
            bytes: &data[..(data.len() / size) * size],
            coordinates: float_coordinates(&fields),
            fields,
            size,
            big_endian,
        }
    }

    /// The records decoded, in order, in parallel.
    fn par_iter(&self) -> impl IndexedParallelIterator<Item = VertexRecord> + '_ {
        self.bytes
            .par_chunks_exact(self.size)
            .map(|r| match &self.coordinates {
                Some(coordinates) => read_coordinates(r, coordinates, self.big_endian),
                None => read_record(r, &self.fields, self.big_endian),
            })
    }

    /// One value per record (shape: the record count), collected in parallel.
    fn column<T: Send>(&self, f: impl Fn(VertexRecord) -> T + Sync + Send) -> Vec<T> {
        let mut out = Vec::new();
        self.par_iter().map(f).collect_into_vec(&mut out);
        out
    }

    /// The colours when `colors`, the intensity named `intensity` when given.
    fn attributes(&self, colors: bool, intensity: Option<usize>) -> PointAttributes {
        PointAttributes {
            colors: colors.then(|| self.column(|rec| rec.rgb)),
            intensity: intensity.map(|which| self.column(|rec| rec.intensity[which])),
            classification: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64Mcg;

    use crate::read_ply::read_ply;

    /// One property of the test files: its PLY type and name.
    const LAYOUTS: [&[(&str, &str)]; 5] = [
        &[("float", "x"), ("float", "y"), ("float", "z")],
        &[
            ("double", "x"),
            ("uchar", "quality"),
            ("double", "y"),
            ("double", "z"),
            ("float", "nx"),
            ("float", "ny"),
            ("float", "nz"),
        ],
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

    /// The coordinates-only decoder gives the general one's records (its brute-force twin), in
    /// both byte orders; a layout with a colour or an integer coordinate takes the general one.
    #[test]
    fn coordinates_only_records_decode_as_the_general_decoder() {
        use super::*;
        let f = |slot, ty, at| (slot, ty, at);
        let fields = vec![
            f(Slot::Coordinate(0), ScalarType::Double, 0),
            f(Slot::Coordinate(1), ScalarType::Double, 9),
            f(Slot::Coordinate(2), ScalarType::Double, 17),
            f(Slot::Coordinate(5), ScalarType::Float, 25),
            f(Slot::Coordinate(3), ScalarType::Float, 29),
        ];
        let coordinates = float_coordinates(&fields).expect("coordinates only");
        let mut rng = Pcg64Mcg::seed_from_u64(5);
        for big_endian in [false, true] {
            for _ in 0..1000 {
                let r: Vec<u8> = (0..33).map(|_| rng.random::<u8>()).collect();
                let general = read_record(&r, &fields, big_endian);
                let fast = read_coordinates(&r, &coordinates, big_endian);
                let bits = |v: [f64; 6]| v.map(f64::to_bits);
                assert_eq!(bits(fast.v), bits(general.v));
                assert_eq!((fast.rgb, fast.intensity), (general.rgb, general.intensity));
            }
        }
        let mut coloured = fields.clone();
        coloured.push(f(Slot::Color(0), ScalarType::UChar, 8));
        assert!(float_coordinates(&coloured).is_none());
        let integer = vec![f(Slot::Coordinate(0), ScalarType::Int, 0)];
        assert!(float_coordinates(&integer).is_none());
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

    /// A binary PLY without faces read for its points (decoded straight into oriented points)
    /// gives the points, attributes and counts that the mesh reader's vertices and normals give
    /// (zero normals left out with their attributes, the first non-finite normal named).
    #[test]
    fn points_decoded_for_themselves_are_the_vertex_readers() {
        use crate::mesh_to_points::to_point_cloud;
        use crate::options::ReadOptions;
        use crate::read_ply::read_ply_for_points;
        let mut rng = Pcg64Mcg::seed_from_u64(7);
        for (count, zeros, nan) in [
            (10usize, vec![3usize], None),
            (70_000, vec![], None),
            (200_000, vec![0, 70_000, 199_999], None),
            (200_000, vec![5], Some(150_001usize)),
        ] {
            let mut bytes = format!(
                "ply\nformat binary_little_endian 1.0\nelement vertex {count}\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\nproperty uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n"
            )
            .into_bytes();
            for i in 0..count {
                let mut v: Vec<f32> = (0..6).map(|_| rng.random_range(-2.0..2.0)).collect();
                if zeros.contains(&i) {
                    v[3..].fill(0.0);
                }
                if nan == Some(i) {
                    v[4] = f32::NAN;
                }
                for x in v {
                    bytes.extend(x.to_le_bytes());
                }
                bytes.extend([(i % 251) as u8, (i % 7) as u8, 9]);
            }
            let opts = ReadOptions::paper();
            let direct = read_ply_for_points(&bytes).unwrap();
            assert!(direct.oriented.is_some() && direct.vertices.is_empty());
            let got = to_point_cloud(direct, &opts);
            let want = to_point_cloud(read_ply(&bytes).unwrap(), &opts);
            match (got, want) {
                (Ok(a), Ok(b)) => {
                    assert_eq!(a, b, "{count} points");
                    assert_eq!(a.dropped_points, zeros.len());
                    assert_eq!(
                        a.attributes.colors.as_ref().map(Vec::len),
                        Some(a.points.len())
                    );
                }
                (Err(a), Err(b)) => {
                    assert_eq!(a.to_string(), b.to_string());
                    assert!(
                        nan.is_some_and(|k| a.to_string().contains(&k.to_string())),
                        "{a}"
                    );
                }
                (a, b) => panic!("{count} points: {a:?} against {b:?}"),
            }
        }
    }
}
