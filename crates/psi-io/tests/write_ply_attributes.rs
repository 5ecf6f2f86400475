//! `write_points_ply_with_attributes`: particles with `red green blue` (uchar), `intensity`
//! (float) and `classification` (uchar) after the scalar columns, read back exactly by
//! psi-io's PLY readers; without attributes the bytes of `write_points_ply`; bad columns and
//! clashing names refused before anything is written.

use glam::DVec3;
use psi_io::{
    Format, PointAttributes, ReadOptions, WriteError, read_point_scalars, read_points,
    write_points_ply, write_points_ply_with_attributes,
};

fn particles(n: usize) -> (Vec<DVec3>, Vec<DVec3>, Vec<f64>, Vec<f64>, PointAttributes) {
    let positions: Vec<DVec3> = (0..n)
        .map(|i| {
            let t = i as f64;
            DVec3::new(t.sin(), t.cos(), 0.001 * t - 1.0 / 3.0)
        })
        .collect();
    let normals: Vec<DVec3> = positions
        .iter()
        .map(|p| (*p + DVec3::Z).normalize())
        .collect();
    let depth = (0..n).map(|i| (i % 9) as f64).collect();
    let sigma = (0..n).map(|i| 0.01 + i as f64 * 1e-7).collect();
    let attributes = PointAttributes {
        colors: Some(
            (0..n)
                .map(|i| [(i % 256) as u8, (i * 3 % 256) as u8, (255 - i % 256) as u8])
                .collect(),
        ),
        intensity: Some(
            (0..n)
                .map(|i| i as f32 * 0.37 - 20.0 + f32::EPSILON)
                .collect(),
        ),
        classification: Some((0..n).map(|i| (i * 11 % 256) as u8).collect()),
    };
    (positions, normals, depth, sigma, attributes)
}

#[test]
fn attributes_read_back_exactly() {
    let n = 700;
    let (positions, normals, depth, sigma, attributes) = particles(n);
    let mut bytes = Vec::new();
    write_points_ply_with_attributes(
        &mut bytes,
        &positions,
        &normals,
        &[("depth", &depth), ("sigma", &sigma)],
        &attributes,
    )
    .unwrap();
    let header_end = bytes
        .windows(11)
        .position(|w| w == b"end_header\n")
        .unwrap();
    let header = std::str::from_utf8(&bytes[..header_end]).unwrap();
    assert!(header.contains(
        "property double sigma\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n\
         property float intensity\nproperty uchar classification\n"
    ));

    let file = read_points(&bytes, Format::Ply, &ReadOptions::paper()).unwrap();
    assert_eq!(file.points.len(), n);
    for (got, (p, nv)) in file.points.iter().zip(positions.iter().zip(&normals)) {
        assert_eq!(got.p, *p);
        assert!((got.n - *nv).length() < 1e-15);
    }
    assert_eq!(file.attributes.colors, attributes.colors);
    assert_eq!(file.attributes.intensity, attributes.intensity);

    let names = [
        "depth",
        "sigma",
        "red",
        "green",
        "blue",
        "intensity",
        "classification",
    ];
    let columns = read_point_scalars(&bytes, &names).unwrap();
    assert_eq!(columns[0].as_ref(), Some(&depth));
    assert_eq!(columns[1].as_ref(), Some(&sigma));
    let colors = attributes.colors.as_ref().unwrap();
    for k in 0..3 {
        let want: Vec<f64> = colors.iter().map(|c| f64::from(c[k])).collect();
        assert_eq!(columns[2 + k].as_ref(), Some(&want));
    }
    let intensity: Vec<f64> = attributes
        .intensity
        .as_ref()
        .unwrap()
        .iter()
        .map(|&v| f64::from(v))
        .collect();
    assert_eq!(columns[5].as_ref(), Some(&intensity));
    let classes: Vec<f64> = attributes
        .classification
        .as_ref()
        .unwrap()
        .iter()
        .map(|&c| f64::from(c))
        .collect();
    assert_eq!(columns[6].as_ref(), Some(&classes));
}

#[test]
fn present_columns_only() {
    let (positions, normals, _, _, all) = particles(50);
    let only_intensity = PointAttributes {
        intensity: all.intensity.clone(),
        ..PointAttributes::default()
    };
    let mut bytes = Vec::new();
    write_points_ply_with_attributes(&mut bytes, &positions, &normals, &[], &only_intensity)
        .unwrap();
    let file = read_points(&bytes, Format::Ply, &ReadOptions::paper()).unwrap();
    assert_eq!(file.attributes.colors, None);
    assert_eq!(file.attributes.intensity, all.intensity);
    let columns = read_point_scalars(&bytes, &["red", "classification"]).unwrap();
    assert_eq!(columns, vec![None, None]);
    // 6 doubles and one float a record after the header.
    let header_end = bytes
        .windows(11)
        .position(|w| w == b"end_header\n")
        .unwrap()
        + 11;
    assert_eq!(bytes.len() - header_end, 50 * (6 * 8 + 4));
}

#[test]
fn without_attributes_the_bytes_are_those_of_write_points_ply() {
    let (positions, normals, depth, sigma, _) = particles(100);
    let scalars: [(&str, &[f64]); 2] = [("depth", &depth), ("sigma", &sigma)];
    let mut plain = Vec::new();
    write_points_ply(&mut plain, &positions, &normals, &scalars).unwrap();
    let mut with = Vec::new();
    write_points_ply_with_attributes(
        &mut with,
        &positions,
        &normals,
        &scalars,
        &PointAttributes::default(),
    )
    .unwrap();
    assert_eq!(plain, with);
}

#[test]
fn bad_columns_and_clashing_names_are_refused() {
    let (positions, normals, _, _, all) = particles(10);
    let short = PointAttributes {
        colors: Some(vec![[0; 3]; 9]),
        ..PointAttributes::default()
    };
    let mut out = Vec::new();
    let err =
        write_points_ply_with_attributes(&mut out, &positions, &normals, &[], &short).unwrap_err();
    assert!(
        matches!(&err, WriteError::LengthMismatch { what, expected: 10, got: 9 } if what == "colors"),
        "{err:?}"
    );
    let values = [0.0; 10];
    let err = write_points_ply_with_attributes(
        &mut out,
        &positions,
        &normals,
        &[("classification", &values)],
        &all,
    )
    .unwrap_err();
    assert!(matches!(&err, WriteError::InvalidName { name, .. } if name == "classification"));
    assert!(out.is_empty());
    // The name is free when the column is absent.
    write_points_ply_with_attributes(
        &mut out,
        &positions,
        &normals,
        &[("classification", &values)],
        &PointAttributes::default(),
    )
    .unwrap();
}
