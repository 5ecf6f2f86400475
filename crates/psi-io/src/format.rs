//! The supported file formats and how to tell them apart.

/// A file format psi reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Format {
    /// Stanford PLY: ASCII, binary little-endian or binary big-endian.
    Ply,
    /// Wavefront OBJ: `v`, `vn` and `f` lines; everything else is ignored.
    Obj,
    /// Plain text, one oriented point `x y z nx ny nz` per line.
    Xyz,
}

impl Format {
    /// The format for a file extension, case-insensitive, with or without a leading dot:
    /// `ply` → [`Format::Ply`], `obj` → [`Format::Obj`], `xyz`/`pts`/`txt` → [`Format::Xyz`];
    /// `None` for anything else.
    ///
    /// ```
    /// use psi_io::Format;
    /// assert_eq!(Format::from_extension("PLY"), Some(Format::Ply));
    /// assert_eq!(Format::from_extension("pts"), Some(Format::Xyz));
    /// assert_eq!(Format::from_extension("stl"), None);
    /// ```
    pub fn from_extension(ext: &str) -> Option<Format> {
        let ext = ext.strip_prefix('.').unwrap_or(ext);
        let is = |name: &str| ext.eq_ignore_ascii_case(name);
        if is("ply") {
            Some(Format::Ply)
        } else if is("obj") {
            Some(Format::Obj)
        } else if is("xyz") || is("pts") || is("txt") {
            Some(Format::Xyz)
        } else {
            None
        }
    }

    /// Guesses the format from the content: [`Format::Ply`] when the bytes start with `ply\n`
    /// or `ply\r\n`; else [`Format::Obj`] when any line starts with `v ` or `f ` (a tab also
    /// counts as the separator); else [`Format::Xyz`]. Never fails; reading then reports
    /// whether the guess parses.
    ///
    /// ```
    /// use psi_io::Format;
    /// assert_eq!(Format::sniff(b"ply\nformat ascii 1.0\n"), Format::Ply);
    /// assert_eq!(Format::sniff(b"# cube\nv 0 0 0\n"), Format::Obj);
    /// assert_eq!(Format::sniff(b"0 0 0 0 0 1\n"), Format::Xyz);
    /// ```
    pub fn sniff(bytes: &[u8]) -> Format {
        if bytes.starts_with(b"ply\n") || bytes.starts_with(b"ply\r\n") {
            return Format::Ply;
        }
        let obj_line = |line: &[u8]| matches!(line, [b'v' | b'f', b' ' | b'\t', ..]);
        if bytes.split(|&b| b == b'\n').any(obj_line) {
            Format::Obj
        } else {
            Format::Xyz
        }
    }
}
