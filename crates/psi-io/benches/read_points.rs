//! Reading a million oriented points from memory: binary PLY with normals (decoded straight
//! into points), binary PLY of positions only (the vertex block; doubles and floats), and XYZ
//! text with normals (blocks of lines parsed in parallel). The inputs are the built-in model
//! sampled with a fixed seed and written by psi-io itself.

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::DVec3;
use psi_io::{Format, ReadOptions, read_points, write_points_ply};

const POINTS: usize = 1_000_000;

/// A binary little-endian PLY of `positions` alone, as `float` when `single`, else `double`.
fn positions_ply(positions: &[DVec3], single: bool) -> Vec<u8> {
    let ty = if single { "float" } else { "double" };
    let mut out = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\n\
         property {ty} x\nproperty {ty} y\nproperty {ty} z\nend_header\n",
        positions.len()
    )
    .into_bytes();
    for v in positions.iter().flat_map(|p| p.to_array()) {
        if single {
            out.extend((v as f32).to_le_bytes());
        } else {
            out.extend(v.to_le_bytes());
        }
    }
    out
}

fn read(c: &mut Criterion) {
    let points = psi_shapes::sample_builtin(POINTS, 0x5051_2007);
    let positions: Vec<DVec3> = points.iter().map(|p| p.p).collect();
    let normals: Vec<DVec3> = points.iter().map(|p| p.n).collect();
    let mut with_normals = Vec::new();
    write_points_ply(&mut with_normals, &positions, &normals, &[]).unwrap();
    // Positions only: the same file without its normal columns (written by hand: psi-io's
    // writer always writes normals), in double and, as scanners and samplers write them, in
    // single precision.
    let positions_only = positions_ply(&positions, false);
    let float_positions = positions_ply(&positions, true);
    let mut xyz = String::new();
    for p in &points {
        xyz += &format!(
            "{} {} {} {} {} {}\n",
            p.p.x, p.p.y, p.p.z, p.n.x, p.n.y, p.n.z
        );
    }
    let options = ReadOptions::paper();
    let mut group = c.benchmark_group("read_points_1M");
    group.sample_size(10);
    group.throughput(Throughput::Elements(POINTS as u64));
    for (name, bytes, format) in [
        ("ply_normals", &with_normals[..], Format::Ply),
        ("ply_positions", &positions_only[..], Format::Ply),
        ("ply_float_positions", &float_positions[..], Format::Ply),
        ("xyz_normals", xyz.as_bytes(), Format::Xyz),
    ] {
        group.bench_function(name, |b| {
            b.iter(|| black_box(read_points(bytes, format, &options).unwrap().points.len()))
        });
    }
    group.finish();
}

criterion_group!(benches, read);
criterion_main!(benches);
