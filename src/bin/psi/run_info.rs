//! `psi info`.

use crate::input::load;
use crate::{Failure, InputArgs};

pub(crate) fn run(args: &InputArgs, json: bool) -> Result<(), Failure> {
    let loaded = load(args)?;
    let j = loaded.json();
    if json {
        println!("{}", serde_json::to_string_pretty(&j)?);
    } else {
        println!("input          {}", loaded.name);
        println!("vertices       {}", loaded.file.vertices);
        println!("faces          {}", loaded.file.faces);
        println!("points         {} oriented", loaded.file.points.len());
        if loaded.file.degenerate_faces > 0 {
            println!(
                "skipped        {} degenerate faces",
                loaded.file.degenerate_faces
            );
        }
        println!("bbox min       {}", j["bbox_min"]);
        println!("bbox max       {}", j["bbox_max"]);
        println!("bbox diagonal  {}", j["bbox_diagonal"]);
        println!(
            "normals        {:.2} % of neighbouring pairs opposed",
            100.0 * loaded.normals.opposed_fraction()
        );
        if loaded.flipped > 0 {
            println!("reoriented     {} normals flipped", loaded.flipped);
        }
    }
    Ok(())
}
