//! Fuzzes psi-io's PCD reader: any byte sequence, read whole and streamed in small chunks,
//! must give points or an error, never a panic, a hang or an unbounded allocation; accepted
//! points are finite with their attribute columns aligned.
#![no_main]

use std::io::Cursor;
use std::ops::ControlFlow;

use libfuzzer_sys::fuzz_target;
use psi_io::{Format, NormalSource, PointStream, ReadOptions, read_points};

fuzz_target!(|data: &[u8]| {
    if let Ok(file) = read_points(data, Format::Pcd, &ReadOptions::paper()) {
        assert!(file.attributes.fits(file.points.len()));
        for p in &file.points {
            assert!(p.p.is_finite());
            if file.normals != NormalSource::Missing {
                assert!((p.n.length() - 1.0).abs() < 1e-9);
            }
        }
    }
    if let Ok(stream) = PointStream::open(Cursor::new(data.to_vec()), Format::Pcd) {
        let _ = stream.for_each_chunk(7, |chunk| {
            assert!((1..=7).contains(&chunk.len()));
            assert!(chunk.attributes.fits(chunk.len()));
            ControlFlow::Continue(())
        });
    }
});
