//! The strokes file of `psi edit --strokes`: a JSON list of edits, each checked before any work
//! is done, its errors naming the file, the edit's index and what is wrong.
//!
//! ```json
//! [
//!   {"brush": {"centre": [x, y, z], "radius": r, "displacement": [dx, dy, dz]}},
//!   {"remove": {"centre": [x, y, z], "radius": r}},
//!   {"insert": {"points": [[x, y, z], …], "normals": [[nx, ny, nz], …]}},
//!   {"settle": {"iterations": n}}
//! ]
//! ```
//!
//! A `settle` runs up to n more relaxation iterations of the last stroke when strokes are
//! applied deferred (`--frame-iterations`), as an editor does between frames; nothing otherwise.

use std::path::Path;

use anyhow::{Context, Result, anyhow, bail};
use psi::regen::Edit;
use psi::{DVec3, OrientedPoint};
use serde_json::{Map, Value};

/// A 3-vector from `value` (a JSON array of three numbers; JSON has no infinities or NaN).
fn vector(value: Option<&Value>, what: &str) -> Result<DVec3> {
    let v = value.ok_or_else(|| anyhow!("`{what}` is missing"))?;
    let items = v
        .as_array()
        .filter(|a| a.len() == 3)
        .ok_or_else(|| anyhow!("`{what}` must be an array of three numbers, not {v}"))?;
    let mut out = [0.0; 3];
    for (o, item) in out.iter_mut().zip(items) {
        *o = item
            .as_f64()
            .ok_or_else(|| anyhow!("`{what}` must hold three numbers, not {v}"))?;
    }
    Ok(DVec3::from_array(out))
}

/// A number from `value`.
fn number(value: Option<&Value>, what: &str) -> Result<f64> {
    let v = value.ok_or_else(|| anyhow!("`{what}` is missing"))?;
    v.as_f64()
        .ok_or_else(|| anyhow!("`{what}` must be a number, not {v}"))
}

/// Refuses keys of `fields` that are not among `known`.
fn only(fields: &Map<String, Value>, known: &[&str], kind: &str) -> Result<()> {
    if let Some(k) = fields.keys().find(|k| !known.contains(&k.as_str())) {
        bail!(
            "unknown field `{k}` of a {kind} (it takes {})",
            known.join(", ")
        );
    }
    Ok(())
}

/// One step of a session: an edit, or settling the last stroke for some iterations.
#[derive(Debug)]
pub(crate) enum Step {
    Edit(Edit),
    Settle(usize),
}

/// One edit from its JSON object.
fn edit(value: &Value) -> Result<Edit> {
    let object = value.as_object().filter(|o| o.len() == 1).ok_or_else(|| {
        anyhow!("an edit is an object with one key: brush, remove, insert or settle")
    })?;
    let (kind, fields) = object.iter().next().expect("one key");
    let fields = fields
        .as_object()
        .ok_or_else(|| anyhow!("the {kind}'s fields must be an object"))?;
    match kind.as_str() {
        "brush" => {
            only(fields, &["centre", "radius", "displacement"], "brush")?;
            Ok(Edit::Brush {
                center: vector(fields.get("centre"), "centre")?,
                radius: number(fields.get("radius"), "radius")?,
                displacement: vector(fields.get("displacement"), "displacement")?,
            })
        }
        "remove" => {
            only(fields, &["centre", "radius"], "remove")?;
            Ok(Edit::Remove {
                center: vector(fields.get("centre"), "centre")?,
                radius: number(fields.get("radius"), "radius")?,
            })
        }
        "insert" => {
            only(fields, &["points", "normals"], "insert")?;
            let list = |what: &str| -> Result<Vec<DVec3>> {
                let items = fields
                    .get(what)
                    .ok_or_else(|| anyhow!("`{what}` is missing"))?
                    .as_array()
                    .ok_or_else(|| anyhow!("`{what}` must be an array of [x, y, z]"))?;
                items
                    .iter()
                    .enumerate()
                    .map(|(i, v)| vector(Some(v), &format!("{what}[{i}]")))
                    .collect()
            };
            let (points, normals) = (list("points")?, list("normals")?);
            if points.len() != normals.len() {
                bail!(
                    "an insertion needs one normal per point: {} points, {} normals",
                    points.len(),
                    normals.len()
                );
            }
            let points = points
                .into_iter()
                .zip(normals)
                .enumerate()
                .map(|(i, (p, n))| {
                    OrientedPoint::new_normalized(p, n)
                        .ok_or_else(|| anyhow!("normals[{i}] is zero or too large to normalise"))
                })
                .collect::<Result<_>>()?;
            Ok(Edit::Insert { points })
        }
        other => bail!("unknown edit `{other}` (brush, remove, insert or settle)"),
    }
}

/// [`edit`], its numbers checked ([`Edit::validate`]).
fn checked_edit(value: &Value) -> Result<Edit> {
    let edit = edit(value)?;
    edit.validate()?;
    Ok(edit)
}

/// One step from its JSON object: `{"settle": {"iterations": n}}` or a checked edit.
fn step(value: &Value) -> Result<Step> {
    let Some(fields) = value.get("settle") else {
        return checked_edit(value).map(Step::Edit);
    };
    let fields = fields
        .as_object()
        .filter(|_| value.as_object().is_some_and(|o| o.len() == 1))
        .ok_or_else(|| anyhow!("a settle is `{{\"settle\": {{\"iterations\": n}}}}`"))?;
    only(fields, &["iterations"], "settle")?;
    let n = fields
        .get("iterations")
        .ok_or_else(|| anyhow!("`iterations` is missing"))?;
    let n = n
        .as_u64()
        .ok_or_else(|| anyhow!("`iterations` must be a whole number ≥ 0, not {n}"))?;
    Ok(Step::Settle(usize::try_from(n).unwrap_or(usize::MAX)))
}

/// The steps of the strokes file at `path`, in order; every error names the file and, for an
/// edit, its index.
pub(crate) fn read_strokes(path: &Path) -> Result<Vec<Step>> {
    let name = path.display();
    let text = std::fs::read(path).with_context(|| format!("{name}: cannot read"))?;
    let value: Value =
        serde_json::from_slice(&text).with_context(|| format!("{name}: not valid JSON"))?;
    let list = value
        .as_array()
        .ok_or_else(|| anyhow!("{name}: a strokes file is a JSON array of edits"))?;
    if list.is_empty() {
        bail!("{name}: no edits");
    }
    list.iter()
        .enumerate()
        .map(|(i, v)| step(v).map_err(|e| anyhow!("{name}: edit {i}: {e}")))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_kind_is_read_and_every_fault_named() {
        let ok = serde_json::json!([
            {"brush": {"centre": [0, 0, 1], "radius": 0.5, "displacement": [0, 0, 0.1]}},
            {"remove": {"centre": [1, 0, 0], "radius": 0}},
            {"insert": {"points": [[0, 0, 2]], "normals": [[0, 0, 3]]}}
        ]);
        let edits: Vec<Edit> = ok
            .as_array()
            .unwrap()
            .iter()
            .map(|e| edit(e).unwrap())
            .collect();
        assert_eq!(edits.len(), 3);
        match &edits[2] {
            Edit::Insert { points } => assert_eq!(points[0].n, DVec3::Z),
            e => panic!("{e:?}"),
        }
        let faults = [
            (
                serde_json::json!({"brush": {"centre": [0, 0], "radius": 1, "displacement": [0, 0, 0]}}),
                "three numbers",
            ),
            (
                serde_json::json!({"brush": {"centre": [0, 0, 0], "radius": -1, "displacement": [0, 0, 0]}}),
                "positive",
            ),
            (
                serde_json::json!({"remove": {"centre": [0, 0, 0], "radius": -1}}),
                "negative",
            ),
            (serde_json::json!({"smudge": {}}), "unknown edit"),
            (
                serde_json::json!({"brush": {"centre": [0, 0, 0], "radius": 1, "displacement": [0, 0, 0], "speed": 2}}),
                "unknown field",
            ),
            (
                serde_json::json!({"insert": {"points": [[0, 0, 0]], "normals": []}}),
                "one normal per point",
            ),
            (
                serde_json::json!({"insert": {"points": [[0, 0, 0]], "normals": [[0, 0, 0]]}}),
                "is zero",
            ),
            (
                serde_json::json!({"remove": {"centre": [0, 0, 0]}}),
                "missing",
            ),
        ];
        for (value, expected) in faults {
            let err = checked_edit(&value).unwrap_err().to_string();
            assert!(err.contains(expected), "{value}: {err}");
        }
        assert!(matches!(
            step(&serde_json::json!({"settle": {"iterations": 3}})).unwrap(),
            Step::Settle(3)
        ));
        for (value, expected) in [
            (
                serde_json::json!({"settle": {"iterations": -1}}),
                "whole number",
            ),
            (serde_json::json!({"settle": {}}), "missing"),
            (serde_json::json!({"settle": 3}), "a settle is"),
            (
                serde_json::json!({"settle": {"iterations": 1, "ms": 2}}),
                "unknown field",
            ),
        ] {
            let err = step(&value).unwrap_err().to_string();
            assert!(err.contains(expected), "{value}: {err}");
        }
    }
}
