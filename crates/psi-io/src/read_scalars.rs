//! Named scalar columns of a PLY `vertex` element (`x`, `nx`, `depth`, `sigma`, ...), read in
//! file order with nothing dropped, so columns of one file stay aligned with each other.

use ply_rs_bw::parser::Parser;
use ply_rs_bw::ply::{PropertyAccess, PropertyAccessResult, PropertyType};

use crate::error::ReadError;
use crate::read_ply::{open, skip_element};

/// Reads the named scalar properties of the `vertex` element of a PLY file.
///
/// * `bytes`: the whole file (ASCII, binary little- or big-endian PLY).
/// * `names`: property names, e.g. `["x", "y", "z", "depth", "sigma"]`.
///
/// Returns one entry per name, in the order asked: `Some(column)` with one value per vertex
/// record (shape: V, file order, any numeric type widened to f64, units as in the file), or
/// `None` when the `vertex` element has no such property. Unlike [`crate::read_points`],
/// nothing is dropped or normalised, so the columns of one call are aligned index by index.
/// Only the `vertex` element and the elements before it are read; later elements (faces) are
/// not looked at.
///
/// # Errors
///
/// [`ReadError::Empty`] for empty input, [`ReadError::Header`] for a malformed header, a
/// header without a `vertex` element or when a named property is a list;
/// [`ReadError::Record`] when a record cannot be decoded or a requested value is NaN or
/// infinite; [`ReadError::Truncated`] when the data ends early. No byte sequence panics.
///
/// ```
/// use glam::DVec3;
/// use psi_io::{read_point_scalars, write_points_ply};
///
/// let mut bytes = Vec::new();
/// let positions = [DVec3::new(1.0, 2.0, 3.0), DVec3::new(4.0, 5.0, 6.0)];
/// write_points_ply(&mut bytes, &positions, &[DVec3::Z; 2], &[("depth", &[5.0, 7.0])]).unwrap();
/// let columns = read_point_scalars(&bytes, &["y", "depth", "sigma"]).unwrap();
/// assert_eq!(columns[0], Some(vec![2.0, 5.0]));
/// assert_eq!(columns[1], Some(vec![5.0, 7.0]));
/// assert_eq!(columns[2], None);
/// ```
pub fn read_point_scalars(
    bytes: &[u8],
    names: &[&str],
) -> Result<Vec<Option<Vec<f64>>>, ReadError> {
    let (header, mut records) = open(bytes)?;
    let bad = |reason: String| ReadError::Header { reason };
    let vertex = header
        .elements
        .get("vertex")
        .ok_or_else(|| bad("there is no `vertex` element".to_owned()))?;
    // The parser calls one scalar setter per scalar property, in header order; a record is
    // the list of those values, and a name maps to its position among the scalars.
    let mut ordinals = Vec::with_capacity(names.len());
    for name in names {
        let ordinal = match vertex.properties.get_index_of(*name) {
            None => None,
            Some(at) => {
                if matches!(vertex.properties[at].data_type, PropertyType::List(..)) {
                    return Err(bad(format!(
                        "the vertex property `{name}` is a list, not a scalar"
                    )));
                }
                Some(
                    vertex
                        .properties
                        .values()
                        .take(at)
                        .filter(|p| matches!(p.data_type, PropertyType::Scalar(_)))
                        .count(),
                )
            }
        };
        ordinals.push(ordinal);
    }
    let scalars = vertex
        .properties
        .values()
        .filter(|p| matches!(p.data_type, PropertyType::Scalar(_)))
        .count();

    let capacity = records.capacity(vertex.count, vertex);
    let mut columns: Vec<Option<Vec<f64>>> = ordinals
        .iter()
        .map(|o| o.map(|_| Vec::with_capacity(capacity)))
        .collect();
    for (name, def) in &header.elements {
        if name != "vertex" {
            skip_element(&mut records, def)?;
            continue;
        }
        let parser = Parser::<ScalarRecord>::new();
        for index in 0..def.count {
            let record = records.read(&parser, def, index)?;
            if record.0.len() != scalars {
                // Cannot happen with a parser that honours the header; refuse rather than
                // misalign the columns.
                return Err(ReadError::Record {
                    element: "vertex".to_owned(),
                    index,
                    reason: format!(
                        "{} scalar values decoded, the header declares {scalars}",
                        record.0.len()
                    ),
                });
            }
            for ((column, ordinal), name) in columns.iter_mut().zip(&ordinals).zip(names) {
                if let (Some(column), Some(ordinal)) = (column, ordinal) {
                    let value = record.0[*ordinal];
                    if !value.is_finite() {
                        return Err(ReadError::Record {
                            element: "vertex".to_owned(),
                            index,
                            reason: format!("property `{name}` is NaN or infinite"),
                        });
                    }
                    column.push(value);
                }
            }
        }
        break;
    }
    Ok(columns)
}

/// The scalar values of one record in header order, widened to f64; lists are ignored.
struct ScalarRecord(Vec<f64>);

impl ScalarRecord {
    fn push(&mut self, value: f64) -> PropertyAccessResult {
        self.0.push(value);
        PropertyAccessResult::Set
    }
}

impl PropertyAccess for ScalarRecord {
    fn new() -> Self {
        Self(Vec::new())
    }
    fn set_char(&mut self, _: &str, value: i8) -> PropertyAccessResult {
        self.push(f64::from(value))
    }
    fn set_uchar(&mut self, _: &str, value: u8) -> PropertyAccessResult {
        self.push(f64::from(value))
    }
    fn set_short(&mut self, _: &str, value: i16) -> PropertyAccessResult {
        self.push(f64::from(value))
    }
    fn set_ushort(&mut self, _: &str, value: u16) -> PropertyAccessResult {
        self.push(f64::from(value))
    }
    fn set_int(&mut self, _: &str, value: i32) -> PropertyAccessResult {
        self.push(f64::from(value))
    }
    fn set_uint(&mut self, _: &str, value: u32) -> PropertyAccessResult {
        self.push(f64::from(value))
    }
    fn set_float(&mut self, _: &str, value: f32) -> PropertyAccessResult {
        self.push(f64::from(value))
    }
    fn set_double(&mut self, _: &str, value: f64) -> PropertyAccessResult {
        self.push(value)
    }
}
