//! Changing one field of a scene from the command line (`--set objects[0].material.eta=1.33`),
//! without editing its JSON — Mitsuba's `-D`, for any field.
//!
//! An override names a field by the path the validation messages use (`film.width`,
//! `objects[0].shape.waves.amplitude`, `lights[1].position[2]`) and gives its value as JSON
//! (`1.33`, `[0, 1, 0]`, `{"type": "isotropic"}`); a value that is not JSON is taken as a string
//! (`objects[0].shape.path=bunny.obj`). The overridden scene goes through the same parsing and
//! validation as a scene file, so a bad value is refused with its path, as in a file.

use std::str::FromStr;

use serde_json::Value;

use crate::scene::SceneDescription;
use crate::validate::SceneError;

/// One `PATH=VALUE`.
#[derive(Debug, Clone, PartialEq)]
pub struct Override {
    /// The path as written (`objects[0].material.eta`).
    pub path: String,
    steps: Vec<Step>,
    pub value: Value,
}

/// A field name or an array index along a path.
#[derive(Debug, Clone, PartialEq)]
enum Step {
    Field(String),
    Index(usize),
}

impl FromStr for Override {
    type Err = String;

    fn from_str(text: &str) -> Result<Override, String> {
        let (path, value) = text
            .split_once('=')
            .ok_or_else(|| format!("{text:?}: expected PATH=VALUE, e.g. film.spp=16"))?;
        let path = path.trim();
        let steps = parse_path(path).map_err(|e| format!("{path:?}: {e}"))?;
        let value = value.trim();
        let value = serde_json::from_str(value).unwrap_or_else(|_| Value::String(value.into()));
        Ok(Override {
            path: path.to_string(),
            steps,
            value,
        })
    }
}

/// `a.b[2].c` → fields and indices; every field name non-empty.
fn parse_path(path: &str) -> Result<Vec<Step>, String> {
    let mut steps = Vec::new();
    for part in path.split('.') {
        let (name, mut rest) = part.split_at(part.find('[').unwrap_or(part.len()));
        if name.is_empty() {
            return Err("a field name is missing (write film.spp or objects[0].material)".into());
        }
        steps.push(Step::Field(name.to_string()));
        while !rest.is_empty() {
            let inner = rest
                .strip_prefix('[')
                .and_then(|r| r.split_once(']'))
                .ok_or_else(|| format!("{part:?}: an index is written [0]"))?;
            let index = inner
                .0
                .parse::<usize>()
                .map_err(|_| format!("{part:?}: {:?} is not an index", inner.0))?;
            steps.push(Step::Index(index));
            rest = inner.1;
        }
    }
    Ok(steps)
}

/// The scene with every override applied in order, parsed and validated again: an error names
/// the overridden path (a field that does not exist, an index past the end) or, as for a scene
/// file, the first bad value.
pub fn apply_overrides(
    scene: &SceneDescription,
    overrides: &[Override],
) -> Result<SceneDescription, SceneError> {
    if overrides.is_empty() {
        return Ok(scene.clone());
    }
    let mut json = serde_json::to_value(scene).map_err(|e| SceneError::new(".", e))?;
    for o in overrides {
        set(&mut json, o)?;
    }
    SceneDescription::from_json(&json.to_string())
}

fn set(json: &mut Value, o: &Override) -> Result<(), SceneError> {
    let (last, parents) = o.steps.split_last().expect("a path has at least one step");
    let mut here = json;
    for step in parents {
        here = match (step, here) {
            (Step::Field(name), Value::Object(fields)) => {
                // A section left out of the file (all its defaults) can be set field by field.
                fields
                    .entry(name.clone())
                    .or_insert_with(|| Value::Object(Default::default()))
            }
            (Step::Index(i), Value::Array(items)) => {
                let len = items.len();
                items.get_mut(*i).ok_or_else(|| {
                    SceneError::new(&o.path, format!("index {i} is past the end (length {len})"))
                })?
            }
            (step, value) => return Err(mismatch(o, step, value)),
        };
    }
    match (last, here) {
        (Step::Field(name), Value::Object(fields)) => {
            fields.insert(name.clone(), o.value.clone());
        }
        (Step::Index(i), Value::Array(items)) => {
            let len = items.len();
            *items.get_mut(*i).ok_or_else(|| {
                SceneError::new(&o.path, format!("index {i} is past the end (length {len})"))
            })? = o.value.clone();
        }
        (step, value) => return Err(mismatch(o, step, value)),
    }
    Ok(())
}

fn mismatch(o: &Override, step: &Step, value: &Value) -> SceneError {
    let found = match value {
        Value::Object(_) => "an object (use .field)",
        Value::Array(_) => "a list (use [index])",
        _ => "a single value",
    };
    let wanted = match step {
        Step::Field(name) => format!("field {name:?}"),
        Step::Index(i) => format!("index [{i}]"),
    };
    SceneError::new(
        &o.path,
        format!("cannot take {wanted}: that part of the scene is {found}"),
    )
}

#[cfg(test)]
mod tests;
