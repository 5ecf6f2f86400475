//! Reads every real test model in `shared/models` and checks its vertex and face counts
//! against MANIFEST.md (one oriented point per non-degenerate triangle). Skipped, with a
//! message, when the folder is absent.

use std::path::Path;
use std::time::Instant;

use psi_io::{Format, ReadOptions, read_points};

/// (file, vertices, faces, zero-area faces) from `shared/models/MANIFEST.md`.
const MODELS: [(&str, usize, usize, usize); 10] = [
    ("bunny.ply", 35947, 69451, 0),
    ("cow.ply", 46433, 92864, 0),
    ("horse.ply", 48485, 96966, 0),
    ("igea.ply", 134345, 268686, 0),
    ("armadillo.ply", 172966, 345928, 0),
    ("dragon_standin_stanford_480076.ply", 239930, 480076, 0),
    ("david_standin_stanford_dragon.ply", 435545, 871306, 0),
    ("cow_original_5804.ply", 2903, 5804, 0),
    ("armadillo_base_libigl_86482.ply", 43243, 86482, 0),
    ("stanford_dragon_vrip_raw.ply", 437645, 871414, 108),
];

#[test]
fn real_models_have_the_manifest_counts() {
    let dir = Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../../shared/models"
    ));
    if !dir.is_dir() {
        println!(
            "skipped: ../shared/models not found (looked in {})",
            dir.display()
        );
        return;
    }
    for (name, vertices, faces, degenerate) in MODELS {
        let path = dir.join(name);
        let bytes = std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert_eq!(Format::sniff(&bytes), Format::Ply, "{name}");
        let start = Instant::now();
        let file = read_points(&bytes, Format::Ply, &ReadOptions::paper())
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        let elapsed = start.elapsed();
        println!(
            "{name}: {} v, {} f, {} points, {} degenerate, read in {:.0} ms",
            file.vertices,
            file.faces,
            file.points.len(),
            file.degenerate_faces,
            elapsed.as_secs_f64() * 1e3
        );
        assert_eq!(file.vertices, vertices, "{name}");
        assert_eq!(file.faces, faces, "{name}");
        assert_eq!(file.degenerate_faces, degenerate, "{name}");
        assert_eq!(file.points.len(), faces - degenerate, "{name}");
        assert_eq!(file.dropped_points, 0, "{name}");
        let mesh = file.mesh.as_ref().expect("the models are meshes");
        assert_eq!(
            (mesh.vertices.len(), mesh.faces.len()),
            (vertices, faces),
            "{name}"
        );
    }
}
