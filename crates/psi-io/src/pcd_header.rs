//! The header of a PCD file (PCL's "The PCD (Point Cloud Data) file format", v0.7): `VERSION`,
//! `FIELDS`, `SIZE`, `TYPE`, `COUNT`, `WIDTH`, `HEIGHT`, `VIEWPOINT`, `POINTS`, then `DATA`
//! (`ascii`, `binary` or `binary_compressed`) as the last header line; `#` lines are comments.
//! Parsed, checked for agreement (one `SIZE`, `TYPE`, `COUNT` per field; `POINTS` equal to
//! `WIDTH × HEIGHT`; sizes that exist for the type) and turned into the layout psi reads:
//! `x y z`, optional `normal_x normal_y normal_z`, `rgb` or `rgba` (a packed 32-bit colour,
//! `0x00RRGGBB` / `0xAARRGGBB`, usually typed `F`), `intensity`.

use std::io::BufRead;

use crate::error::ReadError;

/// The longest header psi reads, in bytes.
const MAX_HEADER: u64 = 64 << 10;
/// The largest point record accepted, in bytes, and the most values per record.
const MAX_RECORD: usize = 1 << 20;

/// A field's value type: `I` signed, `U` unsigned integer, `F` IEEE float; `size` bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Kind {
    I,
    U,
    F,
}

/// Where one value of a field is in a record: its byte offset in a binary record, its token
/// index in an ASCII line, and its type.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Slot {
    pub(crate) offset: usize,
    pub(crate) token: usize,
    pub(crate) kind: Kind,
    pub(crate) size: usize,
}

/// How the point data is stored.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Encoding {
    Ascii,
    Binary,
    Compressed,
}

/// The header, checked, with the slots of the fields psi reads.
#[derive(Clone, Debug)]
pub(crate) struct PcdHeader {
    pub(crate) version: String,
    pub(crate) width: u64,
    pub(crate) height: u64,
    pub(crate) points: u64,
    pub(crate) encoding: Encoding,
    /// Bytes per binary record.
    pub(crate) record: usize,
    /// Values per ASCII line.
    pub(crate) tokens: usize,
    /// Bytes of each field (size × count), in file order (binary_compressed stores the
    /// fields as columns in this order).
    pub(crate) field_bytes: Vec<usize>,
    pub(crate) position: [Slot; 3],
    pub(crate) normal: Option<[Slot; 3]>,
    pub(crate) rgb: Option<Slot>,
    pub(crate) intensity: Option<Slot>,
    /// Header lines read (the data's first line is `lines + 1`).
    pub(crate) lines: usize,
    /// Header bytes read.
    pub(crate) bytes: u64,
}

fn header_error(line: usize, reason: impl Into<String>) -> ReadError {
    ReadError::PcdHeader {
        line,
        reason: reason.into(),
    }
}

/// Reads the header lines up to and including `DATA`.
pub(crate) fn read_header<R: BufRead>(input: &mut R) -> Result<PcdHeader, ReadError> {
    let mut entries: Vec<(String, Vec<String>, usize)> = Vec::new();
    let (mut lines, mut bytes) = (0usize, 0u64);
    let mut raw = Vec::new();
    loop {
        raw.clear();
        let n = std::io::Read::take(&mut *input, MAX_HEADER + 1 - bytes.min(MAX_HEADER))
            .read_until(b'\n', &mut raw)
            .map_err(crate::point_chunk::io_error)?;
        lines += 1;
        bytes += n as u64;
        if n == 0 {
            return Err(header_error(lines, "the file ends before the DATA line"));
        }
        if bytes > MAX_HEADER {
            return Err(header_error(lines, "no DATA line in the first 64 KiB"));
        }
        let text = std::str::from_utf8(&raw)
            .map_err(|_| header_error(lines, "the line is not valid UTF-8 text"))?;
        let text = text.trim();
        if text.is_empty() || text.starts_with('#') {
            continue;
        }
        let mut tokens = text.split_ascii_whitespace().map(str::to_owned);
        let key = tokens.next().unwrap_or_default().to_ascii_uppercase();
        if entries.iter().any(|(k, _, _)| *k == key) {
            return Err(header_error(lines, format!("{key} is given twice")));
        }
        let is_data = key == "DATA";
        entries.push((key, tokens.collect(), lines));
        if is_data {
            break;
        }
    }
    parse(&entries, lines, bytes)
}

fn parse(
    entries: &[(String, Vec<String>, usize)],
    lines: usize,
    bytes: u64,
) -> Result<PcdHeader, ReadError> {
    const KEYS: [&str; 10] = [
        "VERSION",
        "FIELDS",
        "SIZE",
        "TYPE",
        "COUNT",
        "WIDTH",
        "HEIGHT",
        "VIEWPOINT",
        "POINTS",
        "DATA",
    ];
    if let Some((key, _, line)) = entries.iter().find(|(k, _, _)| !KEYS.contains(&k.as_str())) {
        return Err(header_error(*line, format!("unknown header entry {key:?}")));
    }
    let get = |key: &str| entries.iter().find(|(k, _, _)| k == key);
    let need = |key: &str| get(key).ok_or_else(|| header_error(lines, format!("no {key} line")));
    let (_, names, fields_line) = need("FIELDS")?;
    if names.is_empty() {
        return Err(header_error(*fields_line, "FIELDS names no field"));
    }
    let per_field = |key: &str, default: Option<&str>| -> Result<Vec<String>, ReadError> {
        match (get(key), default) {
            (Some((_, v, line)), _) if v.len() != names.len() => Err(header_error(
                *line,
                format!("{key} gives {} values for {} FIELDS", v.len(), names.len()),
            )),
            (Some((_, v, _)), _) => Ok(v.clone()),
            (None, Some(d)) => Ok(vec![d.to_owned(); names.len()]),
            (None, None) => Err(header_error(lines, format!("no {key} line"))),
        }
    };
    let sizes = per_field("SIZE", None)?;
    let types = per_field("TYPE", None)?;
    let counts = per_field("COUNT", Some("1"))?;
    let line_of = |key: &str| get(key).map_or(lines, |e| e.2);
    let number = |key: &str, text: &str| -> Result<u64, ReadError> {
        text.parse::<u64>().map_err(|_| {
            header_error(
                line_of(key),
                format!("{key} value {text:?} is not a whole number"),
            )
        })
    };
    let (mut offset, mut token) = (0usize, 0usize);
    let mut slots: Vec<(&str, Slot, usize)> = Vec::with_capacity(names.len());
    let mut field_bytes = Vec::with_capacity(names.len());
    for (i, name) in names.iter().enumerate() {
        let size = number("SIZE", &sizes[i])? as usize;
        let count = number("COUNT", &counts[i])? as usize;
        let kind = match (types[i].as_str(), size) {
            ("F", 4 | 8) => Kind::F,
            ("I", 1 | 2 | 4 | 8) => Kind::I,
            ("U", 1 | 2 | 4 | 8) => Kind::U,
            (t, s) => {
                return Err(header_error(
                    line_of("TYPE"),
                    format!("field {name}: TYPE {t:?} with SIZE {s} is not a PCD value type"),
                ));
            }
        };
        if count == 0 || count > MAX_RECORD {
            return Err(header_error(
                line_of("COUNT"),
                format!("field {name}: COUNT {count}"),
            ));
        }
        if name != "_" && slots.iter().any(|(n, _, _)| n == name) {
            return Err(header_error(
                *fields_line,
                format!("field {name} is named twice"),
            ));
        }
        let slot = Slot {
            offset,
            token,
            kind,
            size,
        };
        slots.push((name, slot, count));
        field_bytes.push(size * count);
        offset += size * count;
        token += count;
        if offset > MAX_RECORD {
            return Err(header_error(*fields_line, "a point record exceeds 1 MiB"));
        }
    }
    let find = |name: &str| -> Result<Option<Slot>, ReadError> {
        match slots.iter().find(|(n, _, _)| *n == name) {
            Some((_, _, count)) if *count != 1 => Err(header_error(
                line_of("COUNT"),
                format!("field {name} must have COUNT 1"),
            )),
            Some((_, slot, _)) => Ok(Some(*slot)),
            None => Ok(None),
        }
    };
    let triple = |names: [&str; 3]| -> Result<Option<[Slot; 3]>, ReadError> {
        match [find(names[0])?, find(names[1])?, find(names[2])?] {
            [Some(a), Some(b), Some(c)] => Ok(Some([a, b, c])),
            [None, None, None] => Ok(None),
            _ => Err(header_error(
                *fields_line,
                format!("give all of {} {} {} or none", names[0], names[1], names[2]),
            )),
        }
    };
    let position = match [find("x")?, find("y")?, find("z")?] {
        [Some(x), Some(y), Some(z)] => [x, y, z],
        _ => return Err(header_error(*fields_line, "FIELDS has no x y z")),
    };
    let normal = triple(["normal_x", "normal_y", "normal_z"])?;
    let rgb = match (find("rgb")?, find("rgba")?) {
        (Some(_), Some(_)) => {
            return Err(header_error(*fields_line, "give rgb or rgba, not both"));
        }
        (a, b) => a.or(b),
    };
    if let Some(slot) = rgb.filter(|s| s.size != 4) {
        return Err(header_error(
            line_of("SIZE"),
            format!("a packed colour needs SIZE 4, not {}", slot.size),
        ));
    }
    let intensity = find("intensity")?;
    let width = number("WIDTH", &single(need("WIDTH")?)?)?;
    let height = match get("HEIGHT") {
        Some(e) => number("HEIGHT", &single(e)?)?,
        None => 1,
    };
    let grid = width.checked_mul(height);
    let points = match get("POINTS") {
        Some(e) => number("POINTS", &single(e)?)?,
        None => grid.unwrap_or(u64::MAX),
    };
    if grid != Some(points) {
        return Err(header_error(
            line_of("POINTS"),
            format!("POINTS {points} but WIDTH × HEIGHT = {width} × {height}"),
        ));
    }
    if let Some((_, v, line)) = get("VIEWPOINT")
        && (v.len() != 7 || v.iter().any(|t| t.parse::<f64>().is_err()))
    {
        return Err(header_error(
            *line,
            "VIEWPOINT needs 7 numbers (tx ty tz qw qx qy qz)",
        ));
    }
    let (_, data, data_line) = need("DATA")?;
    let encoding = match data.first().map(String::as_str) {
        Some("ascii") => Encoding::Ascii,
        Some("binary") => Encoding::Binary,
        Some("binary_compressed") => Encoding::Compressed,
        other => {
            return Err(header_error(
                *data_line,
                format!("DATA {other:?}: expected ascii, binary or binary_compressed"),
            ));
        }
    };
    let version = get("VERSION")
        .and_then(|(_, v, _)| v.first().cloned())
        .unwrap_or_else(|| "0.7".to_owned());
    Ok(PcdHeader {
        version,
        width,
        height,
        points,
        encoding,
        record: offset,
        tokens: token,
        field_bytes,
        position,
        normal,
        rgb,
        intensity,
        lines,
        bytes,
    })
}

/// The one value of a header entry.
fn single((key, values, line): &(String, Vec<String>, usize)) -> Result<String, ReadError> {
    match values.as_slice() {
        [v] => Ok(v.clone()),
        _ => Err(header_error(*line, format!("{key} needs one value"))),
    }
}
