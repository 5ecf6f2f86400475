//! PLY reader (ASCII, binary little- and big-endian) on top of `ply-rs-bw`.
//!
//! The header is parsed by `ply-rs-bw` and then validated here (duplicate names, the `vertex`
//! and `face` layout, index list types) before any record is read. Records are read one at a
//! time so errors name the element and record index, and so elements psi does not need are
//! skipped without being stored. Every loop consumes input, so hostile counts end in
//! [`ReadError::Truncated`] rather than in unbounded work.

use std::collections::HashSet;
use std::io::ErrorKind;

use ply_rs_bw::parser::{ParseError, Parser, Reader};
use ply_rs_bw::ply::{
    BeginList, ElementDef, Encoding, Header, PropertyAccess, PropertyAccessResult, PropertyType,
    ScalarType,
};

use crate::attributes::PointAttributes;
use crate::error::ReadError;
use crate::model::Parsed;
use crate::text::is_blank;
use crate::vertex_record::{
    INTENSITY_NAMES, VertexRecord, decode_oriented_block, decode_vertex_block, fixed_record_size,
    scalar_size,
};

/// The two names PLY writers use for a face's vertex index list.
const INDEX_LISTS: [&str; 2] = ["vertex_indices", "vertex_index"];

fn is_index_list(name: &str) -> bool {
    INDEX_LISTS.contains(&name)
}

/// Parses a PLY file: the `vertex` element (`x y z`, optional `nx ny nz`, and the attributes
/// `red green blue` and `intensity` or `scalar_intensity` when present) and, when present,
/// the `face` element's index lists, triangulated as fans. Other elements and properties are
/// skipped.
pub(crate) fn read_ply(bytes: &[u8]) -> Result<Parsed, ReadError> {
    read_ply_as(bytes, false)
}

/// [`read_ply`] for the file's points only (not its mesh): a binary file without faces whose
/// vertices have normals comes back as oriented points (`Parsed::oriented`), decoded straight
/// into one array.
pub(crate) fn read_ply_for_points(bytes: &[u8]) -> Result<Parsed, ReadError> {
    read_ply_as(bytes, true)
}

fn read_ply_as(bytes: &[u8], for_points: bool) -> Result<Parsed, ReadError> {
    let (header, mut records) = open(bytes)?;
    let layout = Layout::of(&header)?;
    let mut parsed = Parsed::default();
    let mut pending = 1 + usize::from(layout.faces);
    for (name, def) in &header.elements {
        if pending == 0 {
            break;
        }
        if name == "vertex" {
            let oriented = for_points && !layout.faces && layout.normals;
            read_vertices(&mut records, def, &layout, &mut parsed, oriented)?;
            pending -= 1;
        } else if layout.faces && name == "face" {
            parsed.faces = read_faces(&mut records, def, layout.vertex_count)?;
            pending -= 1;
        } else {
            skip_element(&mut records, def)?;
        }
    }
    Ok(parsed)
}

/// Parses and checks the header (no repeated names); returns it with the payload cursor.
pub(crate) fn open(bytes: &[u8]) -> Result<(Header, Records<'_>), ReadError> {
    if is_blank(bytes) {
        return Err(ReadError::Empty);
    }
    let mut reader = Reader::new(bytes);
    let header = Parser::<Skip>::new()
        .read_header(&mut reader)
        .map_err(|e| ReadError::Header {
            reason: one_line(&e.to_string()),
        })?;
    let data = reader.into_inner();
    let header_bytes = &bytes[..bytes.len() - data.len()];
    check_unique_names(header_bytes)?;
    let records = Records {
        data,
        encoding: header.encoding,
        line: header_bytes.iter().filter(|&&b| b == b'\n').count() + 1,
    };
    Ok((header, records))
}

/// What the header promises, after validation.
struct Layout {
    vertex_count: usize,
    normals: bool,
    faces: bool,
    /// `red green blue` are all scalar properties of `vertex`.
    colors: bool,
    /// Which intensity property is read: 0 `intensity`, 1 `scalar_intensity` (CloudCompare).
    intensity: Option<usize>,
}

impl Layout {
    fn of(header: &Header) -> Result<Self, ReadError> {
        let bad = |reason: String| ReadError::Header { reason };
        let vertex = header
            .elements
            .get("vertex")
            .ok_or_else(|| bad("there is no `vertex` element".to_owned()))?;
        if vertex.count > u32::MAX as usize + 1 {
            return Err(bad(format!(
                "{} vertices exceed the u32 index range",
                vertex.count
            )));
        }
        let scalar = |name: &str| {
            matches!(
                vertex.properties.get(name).map(|p| &p.data_type),
                Some(PropertyType::Scalar(_))
            )
        };
        for name in ["x", "y", "z"] {
            if !scalar(name) {
                return Err(bad(format!(
                    "the `vertex` element has no scalar property `{name}`"
                )));
            }
        }
        let normal_names = ["nx", "ny", "nz"];
        let normals = normal_names.iter().filter(|n| scalar(n)).count();
        let listed = normal_names
            .iter()
            .filter(|n| vertex.properties.contains_key(**n))
            .count();
        if listed != normals || (normals != 0 && normals != 3) {
            return Err(bad(
                "the `vertex` element must have all of `nx ny nz` as scalars, or none".to_owned(),
            ));
        }
        let faces = match header.elements.get("face") {
            Some(face) if face.count > 0 => {
                let lists: Vec<_> = face
                    .properties
                    .values()
                    .filter(|p| is_index_list(&p.name))
                    .collect();
                match lists.as_slice() {
                    [] => {
                        return Err(bad(
                            "the `face` element has no `vertex_indices` list".to_owned()
                        ));
                    }
                    [list] => match &list.data_type {
                        PropertyType::List(_, ScalarType::Float | ScalarType::Double)
                        | PropertyType::Scalar(_) => {
                            return Err(bad(format!(
                                "the face property `{}` must be a list of integers",
                                list.name
                            )));
                        }
                        PropertyType::List(..) => true,
                    },
                    _ => {
                        return Err(bad(
                            "the `face` element has both `vertex_indices` and `vertex_index`"
                                .to_owned(),
                        ));
                    }
                }
            }
            _ => false,
        };
        let colors = ["red", "green", "blue"].iter().all(|n| scalar(n));
        let intensity = INTENSITY_NAMES.iter().position(|n| scalar(n));
        Ok(Self {
            vertex_count: vertex.count,
            normals: normals == 3,
            faces,
            colors,
            intensity,
        })
    }
}

/// Rejects repeated element names, and repeated property names within an element: the header
/// model keys them by name, so a repeat would silently desynchronise the payload.
fn check_unique_names(header: &[u8]) -> Result<(), ReadError> {
    let text = String::from_utf8_lossy(header);
    let mut elements = HashSet::new();
    let mut properties = HashSet::new();
    for line in text.lines() {
        let mut tokens = line.split_ascii_whitespace();
        match tokens.next() {
            Some("element") => {
                let name = tokens.next().unwrap_or_default();
                if !elements.insert(name.to_owned()) {
                    return Err(ReadError::Header {
                        reason: format!("element `{name}` is declared twice"),
                    });
                }
                properties.clear();
            }
            Some("property") => {
                let name = tokens.last().unwrap_or_default();
                if !properties.insert(name.to_owned()) {
                    return Err(ReadError::Header {
                        reason: format!("property `{name}` is declared twice in one element"),
                    });
                }
            }
            _ => {}
        }
    }
    Ok(())
}

/// The payload cursor: reads one record at a time in the header's encoding.
pub(crate) struct Records<'a> {
    data: &'a [u8],
    encoding: Encoding,
    /// 1-based line number of the next record (meaningful for ASCII only).
    line: usize,
}

impl Records<'_> {
    pub(crate) fn read<E: PropertyAccess>(
        &mut self,
        parser: &Parser<E>,
        def: &ElementDef,
        index: usize,
    ) -> Result<E, ReadError> {
        let truncated = || ReadError::Truncated {
            element: def.name.clone(),
            index,
            count: def.count,
        };
        let record_error = |e: ParseError| {
            if e.kind() == ErrorKind::UnexpectedEof {
                truncated()
            } else {
                ReadError::Record {
                    element: def.name.clone(),
                    index,
                    reason: one_line(&e.to_string()),
                }
            }
        };
        match self.encoding {
            Encoding::Ascii => {
                if self.data.is_empty() {
                    return Err(truncated());
                }
                let end = self
                    .data
                    .iter()
                    .position(|&b| b == b'\n')
                    .unwrap_or(self.data.len());
                let at_end = end == self.data.len();
                let line = &self.data[..end];
                self.data = &self.data[(end + 1).min(self.data.len())..];
                self.line += 1;
                let text = std::str::from_utf8(line).map_err(|_| ReadError::Record {
                    element: def.name.clone(),
                    index,
                    reason: "the line is not valid UTF-8 text".to_owned(),
                })?;
                parser.read_ascii_element(text, def).map_err(|e| {
                    // A last, unterminated line of well-formed numbers that is too short is
                    // a file cut off mid-record.
                    let numbers = text
                        .split_ascii_whitespace()
                        .all(|t| t.parse::<f64>().is_ok());
                    if at_end && numbers {
                        truncated()
                    } else {
                        record_error(e)
                    }
                })
            }
            Encoding::BinaryLittleEndian => parser
                .read_little_endian_element(&mut self.data, def)
                .map_err(record_error),
            Encoding::BinaryBigEndian => parser
                .read_big_endian_element(&mut self.data, def)
                .map_err(record_error),
        }
    }

    /// The next `def.count` records as one block of bytes, and whether they are big-endian,
    /// when they are binary, of one size (no list property) and all there; the cursor moves
    /// past them. `None` otherwise (the cursor stays).
    pub(crate) fn fixed_block(&mut self, def: &ElementDef) -> Option<(&[u8], bool)> {
        let big_endian = match self.encoding {
            Encoding::Ascii => return None,
            Encoding::BinaryLittleEndian => false,
            Encoding::BinaryBigEndian => true,
        };
        let bytes = fixed_record_size(def)?.checked_mul(def.count)?;
        if bytes > self.data.len() || def.count == 0 {
            return None;
        }
        let (block, rest) = self.data.split_at(bytes);
        self.data = rest;
        Some((block, big_endian))
    }

    /// The line of the record just read, for ASCII files.
    pub(crate) fn last_line(&self) -> Option<usize> {
        (self.encoding == Encoding::Ascii).then(|| self.line - 1)
    }

    /// A capacity for `count` records that the remaining bytes could actually hold.
    pub(crate) fn capacity(&self, count: usize, def: &ElementDef) -> usize {
        let min_bytes = match self.encoding {
            // At least one digit and one separator per property.
            Encoding::Ascii => 2 * def.properties.len(),
            _ => def
                .properties
                .values()
                .map(|p| match &p.data_type {
                    PropertyType::Scalar(s) | PropertyType::List(s, _) => scalar_size(s),
                })
                .sum(),
        };
        count.min(self.data.len() / min_bytes.max(1))
    }
}

fn read_vertices(
    records: &mut Records<'_>,
    def: &ElementDef,
    layout: &Layout,
    parsed: &mut Parsed,
    oriented: bool,
) -> Result<(), ReadError> {
    let normals = layout.normals;
    let non_finite = |index| ReadError::NonFinite {
        element: "vertex",
        index,
        what: "position",
        line: None,
    };
    // Binary records of one size: decoded in parallel through the same setters.
    if let Some((block, big_endian)) = records.fixed_block(def) {
        if oriented {
            let (points, attributes) =
                decode_oriented_block(block, def, big_endian, (layout.colors, layout.intensity))
                    .map_err(non_finite)?;
            parsed.oriented = Some(points);
            parsed.attributes = attributes;
            return Ok(());
        }
        let wanted = (normals, layout.colors, layout.intensity);
        let block = decode_vertex_block(block, def, big_endian, wanted).map_err(non_finite)?;
        parsed.vertices = block.positions;
        parsed.normals = block.normals;
        parsed.attributes = block.attributes;
        return Ok(());
    }
    let parser = Parser::<VertexRecord>::new();
    let capacity = records.capacity(def.count, def);
    let mut positions = Vec::with_capacity(capacity);
    let mut vertex_normals = Vec::with_capacity(if normals { capacity } else { 0 });
    let mut attributes = PointAttributes {
        colors: layout.colors.then(|| Vec::with_capacity(capacity)),
        intensity: layout.intensity.map(|_| Vec::with_capacity(capacity)),
        classification: None,
    };
    for index in 0..def.count {
        let record = records.read(&parser, def, index)?;
        let p = record.position();
        if !p.is_finite() {
            return Err(ReadError::NonFinite {
                element: "vertex",
                index,
                what: "position",
                line: records.last_line(),
            });
        }
        positions.push(p);
        if normals {
            vertex_normals.push(record.normal());
        }
        if let Some(colors) = &mut attributes.colors {
            colors.push(record.rgb);
        }
        if let (Some(values), Some(which)) = (&mut attributes.intensity, layout.intensity) {
            values.push(record.intensity[which]);
        }
    }
    parsed.vertices = positions;
    parsed.normals = normals.then_some(vertex_normals);
    parsed.attributes = attributes;
    Ok(())
}

fn read_faces(
    records: &mut Records<'_>,
    def: &ElementDef,
    vertex_count: usize,
) -> Result<Vec<[u32; 3]>, ReadError> {
    let parser = Parser::<FaceRecord>::new();
    let mut faces = Vec::with_capacity(records.capacity(def.count, def));
    let mut polygon: Vec<i64> = Vec::new();
    for index in 0..def.count {
        let record = records.read(&parser, def, index)?;
        polygon.clear();
        polygon.extend(record.i32s.iter().map(|&i| i64::from(i)));
        polygon.extend(record.u32s.iter().map(|&i| i64::from(i)));
        polygon.extend_from_slice(&record.wide);
        if polygon.len() < 3 {
            return Err(ReadError::Record {
                element: def.name.clone(),
                index,
                reason: format!(
                    "a face needs at least 3 vertex indices, found {}",
                    polygon.len()
                ),
            });
        }
        if let Some(&bad) = polygon
            .iter()
            .find(|&&i| i < 0 || i as u64 >= vertex_count as u64)
        {
            return Err(ReadError::IndexOutOfRange {
                face: index,
                vertex: bad,
                vertices: vertex_count,
            });
        }
        // In range, so each index is below vertex_count <= u32::MAX + 1.
        for k in 1..polygon.len() - 1 {
            faces.push([polygon[0] as u32, polygon[k] as u32, polygon[k + 1] as u32]);
        }
    }
    Ok(faces)
}

pub(crate) fn skip_element(records: &mut Records<'_>, def: &ElementDef) -> Result<(), ReadError> {
    if def.properties.is_empty() && records.encoding != Encoding::Ascii {
        // A binary record without properties occupies no bytes.
        return Ok(());
    }
    let parser = Parser::<Skip>::new();
    for index in 0..def.count {
        records.read(&parser, def, index)?;
    }
    Ok(())
}

/// A ply-rs-bw error or header line, flattened to one short line for an error message.
fn one_line(message: &str) -> String {
    const MAX: usize = 200;
    let flat = message.split_whitespace().collect::<Vec<_>>().join(" ");
    if flat.chars().count() <= MAX {
        flat
    } else {
        let mut short: String = flat.chars().take(MAX).collect();
        short.push_str("...");
        short
    }
}

/// A record of an element psi does not use: every property is ignored.
struct Skip;

impl PropertyAccess for Skip {
    fn new() -> Self {
        Skip
    }
}

/// The vertex index list of one face; exactly one of the vectors is filled, by list type.
#[derive(Default)]
struct FaceRecord {
    i32s: Vec<i32>,
    u32s: Vec<u32>,
    wide: Vec<i64>,
}

impl FaceRecord {
    fn set_small<T: Into<i64>>(&mut self, name: &str, values: Vec<T>) -> PropertyAccessResult {
        if !is_index_list(name) {
            return PropertyAccessResult::Ignored;
        }
        self.wide = values.into_iter().map(Into::into).collect();
        PropertyAccessResult::Set
    }
}

impl PropertyAccess for FaceRecord {
    fn new() -> Self {
        Self::default()
    }
    fn begin_list_int(&mut self, name: &str, _len: usize) -> BeginList<'_, i32> {
        if is_index_list(name) {
            BeginList::Fill(&mut self.i32s)
        } else {
            BeginList::UseSetter
        }
    }
    fn begin_list_uint(&mut self, name: &str, _len: usize) -> BeginList<'_, u32> {
        if is_index_list(name) {
            BeginList::Fill(&mut self.u32s)
        } else {
            BeginList::UseSetter
        }
    }
    fn set_list_char(&mut self, name: &str, values: Vec<i8>) -> PropertyAccessResult {
        self.set_small(name, values)
    }
    fn set_list_uchar(&mut self, name: &str, values: Vec<u8>) -> PropertyAccessResult {
        self.set_small(name, values)
    }
    fn set_list_short(&mut self, name: &str, values: Vec<i16>) -> PropertyAccessResult {
        self.set_small(name, values)
    }
    fn set_list_ushort(&mut self, name: &str, values: Vec<u16>) -> PropertyAccessResult {
        self.set_small(name, values)
    }
    fn set_list_float(&mut self, name: &str, _values: Vec<f32>) -> PropertyAccessResult {
        if is_index_list(name) {
            PropertyAccessResult::UnsupportedType
        } else {
            PropertyAccessResult::Ignored
        }
    }
    fn set_list_double(&mut self, name: &str, _values: Vec<f64>) -> PropertyAccessResult {
        if is_index_list(name) {
            PropertyAccessResult::UnsupportedType
        } else {
            PropertyAccessResult::Ignored
        }
    }
}
