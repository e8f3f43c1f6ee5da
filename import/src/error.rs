//! The importer's one error: the glTF element at fault (`nodes[3].mesh`,
//! `meshes[0].primitives[1]`, `buffers[0]`, as the glTF JSON indexes it) and what is wrong.

/// A glTF file that cannot become a spindle scene. Displays as `<element>: <problem>`.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{element}: {problem}")]
pub struct ImportError {
    /// The JSON path of the element in the glTF file (or the file itself when it cannot be read).
    pub element: String,
    pub problem: String,
}

impl ImportError {
    pub fn new(element: impl Into<String>, problem: impl ToString) -> ImportError {
        ImportError {
            element: element.into(),
            problem: problem.to_string(),
        }
    }
}
