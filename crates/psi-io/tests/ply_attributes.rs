//! PLY vertex colours (`red green blue`, any type) and intensities (`intensity` or
//! `scalar_intensity`) in every encoding: read as 8-bit colours and f32 intensities, carried
//! with the points that are kept (zero normals dropped), averaged onto a mesh's face
//! centroids; files without them give no attribute column and the same points as before.

mod common;

use common::{ALL_ENCODINGS, Enc, XYZ_FLOAT, ply};
use psi_io::{Format, MeshSampling, ReadOptions, read_points};

fn props<'a>(extra: &[(&'a str, &'a str)]) -> Vec<(&'a str, &'a str)> {
    let mut p = vec![
        ("float", "x"),
        ("float", "y"),
        ("float", "z"),
        ("float", "nx"),
        ("float", "ny"),
        ("float", "nz"),
    ];
    p.extend_from_slice(extra);
    p
}

#[test]
fn colours_and_intensities_follow_the_kept_points() {
    let rows = vec![
        vec![0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 255.0, 0.0, 10.0, 1.5],
        vec![1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 2.0, 3.0, 2.5], // zero normal: dropped
        vec![0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 7.0, 128.0, 255.0, -4.0],
    ];
    for enc in ALL_ENCODINGS {
        let extra = [
            ("uchar", "red"),
            ("uchar", "green"),
            ("uchar", "blue"),
            ("float", "intensity"),
        ];
        let bytes = ply(enc, &props(&extra), &rows, None, &[]);
        let file = read_points(&bytes, Format::Ply, &ReadOptions::paper()).unwrap();
        assert_eq!((file.points.len(), file.dropped_points), (2, 1), "{enc:?}");
        assert_eq!(
            file.attributes.colors,
            Some(vec![[255, 0, 10], [7, 128, 255]])
        );
        assert_eq!(file.attributes.intensity, Some(vec![1.5, -4.0]));
        assert_eq!(file.attributes.classification, None);
    }
}

#[test]
fn colour_types_scale_to_eight_bits() {
    let rows = vec![vec![
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        1.0,
        65535.0,
        256.0 * 200.0,
        300.0,
        0.25,
    ]];
    let extra = [
        ("ushort", "red"),
        ("ushort", "green"),
        ("int", "blue"),
        ("double", "scalar_intensity"),
    ];
    let bytes = ply(Enc::Le, &props(&extra), &rows, None, &[]);
    let file = read_points(&bytes, Format::Ply, &ReadOptions::paper()).unwrap();
    // 16 bits: the high byte; other integers clamped to 0-255.
    assert_eq!(file.attributes.colors, Some(vec![[255, 200, 255]]));
    assert_eq!(file.attributes.intensity, Some(vec![0.25]));
    let unit = [("float", "red"), ("float", "green"), ("float", "blue")];
    let rows = vec![vec![0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 0.5, -1.0]];
    let file = read_points(
        &ply(Enc::Be, &props(&unit), &rows, None, &[]),
        Format::Ply,
        &ReadOptions::paper(),
    )
    .unwrap();
    assert_eq!(file.attributes.colors, Some(vec![[255, 128, 0]]));
}

#[test]
fn mesh_centroids_average_their_vertices_attributes() {
    let mut p = XYZ_FLOAT.to_vec();
    p.extend([
        ("uchar", "red"),
        ("uchar", "green"),
        ("uchar", "blue"),
        ("float", "intensity"),
    ]);
    let rows = vec![
        vec![0.0, 0.0, 0.0, 0.0, 0.0, 255.0, 3.0],
        vec![1.0, 0.0, 0.0, 3.0, 0.0, 255.0, 6.0],
        vec![0.0, 1.0, 0.0, 3.0, 3.0, 254.0, 0.0],
        vec![1.0, 1.0, 0.0, 9.0, 9.0, 9.0, 9.0],
    ];
    let faces = vec![vec![0, 1, 2], vec![1, 3, 2], vec![0, 0, 1]];
    let bytes = ply(
        Enc::Ascii,
        &p,
        &rows,
        Some(("uchar", "int", "vertex_indices")),
        &faces,
    );
    let file = read_points(&bytes, Format::Ply, &ReadOptions::paper()).unwrap();
    assert_eq!((file.points.len(), file.degenerate_faces), (2, 1));
    assert_eq!(file.attributes.colors, Some(vec![[2, 1, 255], [5, 4, 173]]));
    assert_eq!(file.attributes.intensity, Some(vec![3.0, 5.0]));
    let opts = ReadOptions {
        sampling: MeshSampling::VertexNormals,
    };
    let file = read_points(&bytes, Format::Ply, &opts).unwrap();
    assert_eq!(file.attributes.colors.unwrap().len(), 4);
}

#[test]
fn files_without_attributes_have_no_columns() {
    let rows = vec![vec![0.0, 0.0, 0.0, 0.0, 0.0, 1.0]];
    let bytes = ply(
        Enc::Le,
        &props(&[("uchar", "red"), ("uchar", "green")][..0]),
        &rows,
        None,
        &[],
    );
    let file = read_points(&bytes, Format::Ply, &ReadOptions::paper()).unwrap();
    assert!(file.attributes.is_empty());
    assert_eq!(file.source.format, Some(Format::Ply));
    // Only two of red green blue: no colour column.
    let rows = vec![vec![0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 2.0]];
    let bytes = ply(
        Enc::Le,
        &props(&[("uchar", "red"), ("uchar", "green")]),
        &rows,
        None,
        &[],
    );
    let file = read_points(&bytes, Format::Ply, &ReadOptions::paper()).unwrap();
    assert!(file.attributes.is_empty());
}
