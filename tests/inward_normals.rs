//! The inward-normals judgement on the paper's models (`../shared/models`, skipped without):
//! their own outward normals are never judged inward, and negated they are.

use std::path::Path;

use psi::preprocess::inward_votes;

fn model(name: &str) -> Option<Vec<psi::OrientedPoint>> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/models")
        .join(name);
    if !path.is_file() {
        eprintln!(
            "skipped: {} is absent (the paper's models live in ../shared/models)",
            path.display()
        );
        return None;
    }
    Some(
        psi::load_points(&path, &psi::ReadOptions::paper())
            .unwrap()
            .points,
    )
}

#[test]
fn the_papers_models_are_outward_and_negated_closed_ones_inward() {
    // (The bunny's and igea's holes are small: seen from their hulls they are closed too.)
    for name in [
        "horse.ply",
        "armadillo.ply",
        "bunny.ply",
        "igea.ply",
        "cow_original_5804.ply",
    ] {
        let Some(mut points) = model(name) else {
            continue;
        };
        let out = inward_votes(&points);
        assert!(!out.inward(), "{name}: {out:?}");
        for p in &mut points {
            p.n = -p.n;
        }
        let inw = inward_votes(&points);
        eprintln!("{name}: outward {out:?}, negated {inw:?}");
        assert!(inw.inward(), "{name} negated: {inw:?}");
    }
}
