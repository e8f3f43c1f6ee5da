//! Where the benchmark figures go: printed as they are measured, and kept in the output folder
//! as CSV tables and a `summary.txt` with the setup that produced them.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use spindle_common::scene::SceneDescription;

/// A table of figures: a header and rows of already formatted cells.
#[derive(Debug, Clone, Default)]
pub struct Table {
    pub header: Vec<String>,
    pub rows: Vec<Vec<String>>,
}

impl Table {
    pub fn new(header: &[&str]) -> Table {
        Table {
            header: header.iter().map(|h| h.to_string()).collect(),
            rows: Vec::new(),
        }
    }

    pub fn push(&mut self, row: Vec<String>) {
        debug_assert_eq!(row.len(), self.header.len());
        self.rows.push(row);
    }

    /// The table as CSV (cells never contain commas or quotes; any that do are quoted).
    pub fn csv(&self) -> String {
        let cell = |c: &String| {
            if c.contains([',', '"', '\n']) {
                format!("\"{}\"", c.replace('"', "\"\""))
            } else {
                c.clone()
            }
        };
        let mut out = String::new();
        for row in std::iter::once(&self.header).chain(&self.rows) {
            let cells: Vec<String> = row.iter().map(cell).collect();
            out.push_str(&cells.join(","));
            out.push('\n');
        }
        out
    }

    /// The table aligned in columns, for the terminal.
    pub fn aligned(&self) -> String {
        let widths: Vec<usize> = (0..self.header.len())
            .map(|i| {
                std::iter::once(&self.header)
                    .chain(&self.rows)
                    .map(|r| r.get(i).map_or(0, |c| c.chars().count()))
                    .max()
                    .unwrap_or(0)
            })
            .collect();
        let mut out = String::new();
        for row in std::iter::once(&self.header).chain(&self.rows) {
            let line: Vec<String> = row
                .iter()
                .zip(&widths)
                .map(|(c, w)| format!("{c:>w$}"))
                .collect();
            let _ = writeln!(out, "  {}", line.join("  "));
        }
        out
    }
}

/// The printed and kept record of one benchmark run.
pub struct Report {
    out: PathBuf,
    log: String,
}

impl Report {
    /// A report writing into `out` (created if missing).
    pub fn new(out: &Path) -> Result<Report> {
        std::fs::create_dir_all(out)
            .with_context(|| format!("cannot create the output folder {}", out.display()))?;
        Ok(Report {
            out: out.to_path_buf(),
            log: String::new(),
        })
    }

    pub fn out(&self) -> &Path {
        &self.out
    }

    /// Prints a line and keeps it for `summary.txt`.
    pub fn line(&mut self, text: impl AsRef<str>) {
        let text = text.as_ref();
        println!("{text}");
        self.log.push_str(text);
        self.log.push('\n');
    }

    /// Prints `table` and writes it to `<name>.csv`.
    pub fn table(&mut self, name: &str, table: &Table) -> Result<()> {
        let path = self.out.join(format!("{name}.csv"));
        std::fs::write(&path, table.csv())
            .with_context(|| format!("cannot write {}", path.display()))?;
        let aligned = table.aligned();
        print!("{aligned}");
        self.log.push_str(&aligned);
        self.line(format!("  -> {}", path.display()));
        Ok(())
    }

    /// Writes `summary.txt` with everything printed so far.
    pub fn finish(&self) -> Result<()> {
        let path = self.out.join("summary.txt");
        std::fs::write(&path, &self.log).with_context(|| format!("cannot write {}", path.display()))
    }
}

/// Seconds with three significant digits.
pub fn secs(s: f64) -> String {
    format!("{s:.3e}")
}

/// A ratio or fraction with three significant digits.
pub fn sig(x: f64) -> String {
    if x == 0.0 {
        "0".into()
    } else if (1e-3..1e4).contains(&x.abs()) {
        format!("{x:.4}")
    } else {
        format!("{x:.3e}")
    }
}

/// Writes a scene's JSON into `out/scenes/<name>.json`, so every figure's setup can
/// be rendered again with `spindle render`.
pub fn keep_scene(report: &Report, file: &str, scene: &SceneDescription) -> Result<PathBuf> {
    let dir = report.out().join("scenes");
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let path = dir.join(file);
    let json = serde_json::to_string_pretty(scene).context("scene JSON")?;
    std::fs::write(&path, json).with_context(|| format!("cannot write {}", path.display()))?;
    Ok(path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_quotes_only_cells_that_need_it() {
        let mut t = Table::new(&["name", "value"]);
        t.push(vec!["a,b".into(), "1".into()]);
        t.push(vec!["say \"hi\"".into(), "2".into()]);
        assert_eq!(t.csv(), "name,value\n\"a,b\",1\n\"say \"\"hi\"\"\",2\n");
    }
}
