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
#[path = "vertex_record_tests.rs"]
mod tests;
