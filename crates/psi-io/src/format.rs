//! The supported file formats and how to tell them apart (extension, signature, text or binary).

/// A file format psi reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Format {
    /// Stanford PLY: ASCII, binary little-endian or binary big-endian.
    Ply,
    /// Wavefront OBJ: `v`, `vn` and `f` lines; everything else is ignored.
    Obj,
    /// Plain text, one oriented point `x y z nx ny nz` per line.
    Xyz,
    /// ASPRS LAS 1.0–1.4 (LAS 1.4 R15), uncompressed or LAZ: the reader tells from the header.
    Las,
    /// LAZ (LASzip-compressed LAS); read by the same reader as [`Format::Las`].
    Laz,
    /// ASTM E2807 E57: one or more scans with their poses.
    E57,
    /// PCL's PCD v0.7 (ASCII, binary, binary_compressed).
    Pcd,
}

impl Format {
    /// Every format, in the order of their names in help texts.
    pub const ALL: [Format; 7] = [
        Format::Ply,
        Format::Obj,
        Format::Xyz,
        Format::Las,
        Format::Laz,
        Format::E57,
        Format::Pcd,
    ];

    /// The format's short name, as on the command line's `--format`: `ply`, `obj`, `xyz`,
    /// `las`, `laz`, `e57`, `pcd`.
    ///
    /// ```
    /// use psi_io::Format;
    /// assert!(Format::ALL.iter().all(|f| Format::from_extension(f.name()) == Some(*f)));
    /// ```
    pub fn name(self) -> &'static str {
        match self {
            Format::Ply => "ply",
            Format::Obj => "obj",
            Format::Xyz => "xyz",
            Format::Las => "las",
            Format::Laz => "laz",
            Format::E57 => "e57",
            Format::Pcd => "pcd",
        }
    }

    /// Whether the format holds points only and is read in bounded chunks
    /// ([`crate::PointStream`]): LAS, LAZ, E57 and PCD.
    pub fn is_streamed(self) -> bool {
        matches!(self, Format::Las | Format::Laz | Format::E57 | Format::Pcd)
    }

    /// The format for a file extension, case-insensitive, with or without a leading dot:
    /// `ply` → [`Format::Ply`], `obj` → [`Format::Obj`], `xyz`/`pts`/`txt` → [`Format::Xyz`],
    /// `las`, `laz`, `e57`, `pcd`; `None` for anything else.
    ///
    /// ```
    /// use psi_io::Format;
    /// assert_eq!(Format::from_extension("PLY"), Some(Format::Ply));
    /// assert_eq!(Format::from_extension("pts"), Some(Format::Xyz));
    /// assert_eq!(Format::from_extension(".laz"), Some(Format::Laz));
    /// assert_eq!(Format::from_extension("stl"), None);
    /// ```
    pub fn from_extension(ext: &str) -> Option<Format> {
        let ext = ext.strip_prefix('.').unwrap_or(ext);
        let is = |name: &str| ext.eq_ignore_ascii_case(name);
        if is("xyz") || is("pts") || is("txt") {
            return Some(Format::Xyz);
        }
        Format::ALL.into_iter().find(|f| is(f.name()))
    }

    /// The format whose signature starts the content, or `None`: PLY (`ply` line), LAS/LAZ
    /// (`LASF`, LAS 1.4 R15 §2.4), E57 (`ASTM-E57`, ASTM E2807 §9.3) and PCD (a first line
    /// `# .PCD`, or `VERSION` with a `FIELDS` line in the first 4 KiB: PCD v0.7). OBJ and XYZ
    /// have none.
    ///
    /// ```
    /// use psi_io::Format;
    /// assert_eq!(Format::detect(b"LASF\x00\x00"), Some(Format::Las));
    /// assert_eq!(Format::detect(b"# .PCD v0.7\nVERSION 0.7\n"), Some(Format::Pcd));
    /// assert_eq!(Format::detect(b"0 0 0\n"), None);
    /// ```
    pub fn detect(bytes: &[u8]) -> Option<Format> {
        if bytes.starts_with(b"ply\n") || bytes.starts_with(b"ply\r\n") {
            Some(Format::Ply)
        } else if bytes.starts_with(b"LASF") {
            Some(Format::Las)
        } else if bytes.starts_with(b"ASTM-E57") {
            Some(Format::E57)
        } else if bytes.starts_with(b"# .PCD") || is_pcd_version_line(bytes) {
            Some(Format::Pcd)
        } else {
            None
        }
    }

    /// Whether the content (its first 8 KiB) looks binary rather than text: a NUL byte, or
    /// bytes that are not UTF-8.
    ///
    /// ```
    /// assert!(psi_io::Format::looks_binary(b"\x00\x01\x02"));
    /// assert!(!psi_io::Format::looks_binary("0 0 0 # été\n".as_bytes()));
    /// ```
    pub fn looks_binary(bytes: &[u8]) -> bool {
        let head = &bytes[..bytes.len().min(8192)];
        if head.contains(&0) {
            return true;
        }
        match std::str::from_utf8(head) {
            Ok(_) => false,
            // A character cut by the 8 KiB window is not evidence of binary content.
            Err(e) => e.error_len().is_some(),
        }
    }

    /// Guesses the format from the content: the format of its signature ([`Format::detect`]:
    /// PLY, LAS, E57, PCD); else [`Format::Obj`] when any line starts with `v ` or `f ` (a tab
    /// also counts as the separator); else [`Format::Xyz`]. Never fails; reading then reports
    /// whether the guess parses.
    ///
    /// ```
    /// use psi_io::Format;
    /// assert_eq!(Format::sniff(b"ply\nformat ascii 1.0\n"), Format::Ply);
    /// assert_eq!(Format::sniff(b"# cube\nv 0 0 0\n"), Format::Obj);
    /// assert_eq!(Format::sniff(b"0 0 0 0 0 1\n"), Format::Xyz);
    /// ```
    pub fn sniff(bytes: &[u8]) -> Format {
        if let Some(format) = Format::detect(bytes) {
            return format;
        }
        let obj_line = |line: &[u8]| matches!(line, [b'v' | b'f', b' ' | b'\t', ..]);
        if bytes.split(|&b| b == b'\n').any(obj_line) {
            Format::Obj
        } else {
            Format::Xyz
        }
    }
}

/// A PCD header that starts with its `VERSION` line (no comment first) and declares fields.
fn is_pcd_version_line(bytes: &[u8]) -> bool {
    let head = &bytes[..bytes.len().min(4096)];
    head.starts_with(b"VERSION ") && head.windows(8).any(|w| w == b"\nFIELDS ")
}
