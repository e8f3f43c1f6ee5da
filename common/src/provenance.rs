//! What a rendered image was made from beyond the scene's own settings: the renderer's version,
//! the built scene's size, its warnings and the single-scattering plan.
//!
//! Only a process that builds the scene can know these (the coordinator never links the
//! renderer), so `spindle render --workers 0` builds a [`Provenance`] from its scene and a farm
//! worker builds the same one from the same scene and sends it with its tiles; both write it into
//! the EXR header through [`Provenance::header_attributes`], so the two headers cannot drift.
//!
//! A provenance from a worker is untrusted: [`Provenance::check`] bounds its size and refuses
//! control characters, and [`Provenance::new`] applies the same bounds to what an honest renderer
//! reports, so an honest record always passes.

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

/// At most this many warning lines and this many plan lines are kept.
pub const MAX_LINES: usize = 64;
/// At most this many bytes per line (renderer, warning or plan line).
pub const MAX_LINE_BYTES: usize = 512;

/// The provenance of a render: recorded in the EXR header and shown in `JobInfo`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct Provenance {
    /// The renderer's package and version, e.g. `spindle-render 0.1.0`.
    pub renderer: String,
    /// Objects in the built scene.
    pub objects: u64,
    /// Triangles in the built scene (every object's mesh).
    pub triangles: u64,
    /// Lights in the built scene.
    pub lights: u64,
    /// The scene's build warnings (at most [`MAX_LINES`]).
    pub warnings: Vec<String>,
    /// Per object, which single-scattering model runs and why (at most [`MAX_LINES`]).
    pub plan: Vec<String>,
}

impl Provenance {
    /// A provenance within the bounds [`Provenance::check`] enforces: lines past
    /// [`MAX_LINES`] are summarised in a last line, long lines are cut at [`MAX_LINE_BYTES`]
    /// (on a character boundary) and control characters become spaces.
    pub fn new(
        renderer: &str,
        objects: u64,
        triangles: u64,
        lights: u64,
        warnings: &[String],
        plan: &[String],
    ) -> Provenance {
        Provenance {
            renderer: clean_line(renderer),
            objects,
            triangles,
            lights,
            warnings: clean_lines(warnings),
            plan: clean_lines(plan),
        }
    }

    /// Checks a provenance received from elsewhere; the error names the field and the problem.
    pub fn check(&self) -> Result<(), String> {
        check_line("provenance.renderer", &self.renderer)?;
        for (field, lines) in [("warnings", &self.warnings), ("plan", &self.plan)] {
            if lines.len() > MAX_LINES {
                return Err(format!(
                    "provenance.{field}: at most {MAX_LINES} lines, got {}",
                    lines.len()
                ));
            }
            for (i, line) in lines.iter().enumerate() {
                check_line(&format!("provenance.{field}[{i}]"), line)?;
            }
        }
        Ok(())
    }

    /// The EXR header attributes: `spindle.renderer`, `spindle.objects`, `spindle.triangles`,
    /// `spindle.lights`, `spindle.single_scatter.plan` (lines joined with `; `) and, when there
    /// are any, `spindle.warnings` (joined the same way).
    pub fn header_attributes(&self) -> Vec<(String, String)> {
        let mut a = vec![
            ("spindle.renderer".to_string(), self.renderer.clone()),
            ("spindle.objects".to_string(), self.objects.to_string()),
            ("spindle.triangles".to_string(), self.triangles.to_string()),
            ("spindle.lights".to_string(), self.lights.to_string()),
            (
                "spindle.single_scatter.plan".to_string(),
                self.plan.join("; "),
            ),
        ];
        if !self.warnings.is_empty() {
            a.push(("spindle.warnings".to_string(), self.warnings.join("; ")));
        }
        a
    }
}

fn check_line(field: &str, line: &str) -> Result<(), String> {
    if line.len() > MAX_LINE_BYTES {
        return Err(format!(
            "{field}: at most {MAX_LINE_BYTES} bytes, got {}",
            line.len()
        ));
    }
    if line.chars().any(char::is_control) {
        return Err(format!("{field}: must not contain control characters"));
    }
    Ok(())
}

fn clean_line(line: &str) -> String {
    let mut end = line.len().min(MAX_LINE_BYTES);
    while !line.is_char_boundary(end) {
        end -= 1;
    }
    line[..end]
        .chars()
        .map(|c| if c.is_control() { ' ' } else { c })
        .collect()
}

fn clean_lines(lines: &[String]) -> Vec<String> {
    let mut out: Vec<String> = lines
        .iter()
        .take(MAX_LINES)
        .map(|l| clean_line(l))
        .collect();
    if lines.len() > MAX_LINES {
        out.pop();
        out.push(format!("… and {} more", lines.len() - (MAX_LINES - 1)));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn new_stays_within_the_bounds_check_enforces() {
        let long = "é".repeat(MAX_LINE_BYTES); // 2 bytes each: cut on a character boundary
        let many: Vec<String> = (0..200).map(|i| format!("line {i}\twith a tab")).collect();
        let p = Provenance::new(&long, 1, 2, 3, &many, &many);
        assert_eq!(p.check(), Ok(()));
        assert_eq!(p.renderer.len(), MAX_LINE_BYTES);
        assert_eq!(p.plan.len(), MAX_LINES);
        assert_eq!(p.plan[0], "line 0 with a tab");
        assert_eq!(p.plan[MAX_LINES - 1], "… and 137 more");
    }

    #[test]
    fn check_names_the_field_of_an_oversized_or_hostile_record() {
        let ok = Provenance::new(
            "spindle-render 1",
            1,
            12,
            1,
            &[],
            &["object 0: interval".into()],
        );
        assert_eq!(ok.check(), Ok(()));
        let mut p = ok.clone();
        p.plan = vec!["x".into(); MAX_LINES + 1];
        assert!(
            p.check()
                .unwrap_err()
                .starts_with("provenance.plan: at most")
        );
        let mut p = ok.clone();
        p.warnings = vec!["fine".into(), "a".repeat(MAX_LINE_BYTES + 1)];
        assert!(
            p.check()
                .unwrap_err()
                .starts_with("provenance.warnings[1]: at most")
        );
        let mut p = ok;
        p.renderer = "evil\u{1b}[31m".into();
        assert_eq!(
            p.check().unwrap_err(),
            "provenance.renderer: must not contain control characters"
        );
    }

    #[test]
    fn header_attributes_name_every_value() {
        let p = Provenance::new(
            "r 1",
            2,
            24,
            1,
            &["w1".into(), "w2".into()],
            &["a".into(), "b".into()],
        );
        let a: std::collections::BTreeMap<_, _> = p.header_attributes().into_iter().collect();
        assert_eq!(a["spindle.renderer"], "r 1");
        assert_eq!(a["spindle.objects"], "2");
        assert_eq!(a["spindle.triangles"], "24");
        assert_eq!(a["spindle.lights"], "1");
        assert_eq!(a["spindle.single_scatter.plan"], "a; b");
        assert_eq!(a["spindle.warnings"], "w1; w2");
    }
}
