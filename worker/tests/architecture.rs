//! Architecture invariant: the renderer (`worker/src/render/`) opens no socket, starts no
//! runtime and reads no file. Checked by reading its sources.

use std::path::{Path, PathBuf};

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

#[test]
fn renderer_uses_no_network_runtime_or_files() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("src/render");
    let mut files = Vec::new();
    rust_files(&root, &mut files);
    assert!(
        files.len() > 10,
        "expected the renderer's modules under {}",
        root.display()
    );
    let forbidden = [
        "tokio",
        "reqwest",
        "std::net",
        "std::fs",
        "File::open",
        // `hyper::`, not `hyper`: the pruning docs speak of a hyperbola.
        "hyper::",
        "axum",
    ];
    for file in files {
        let text = std::fs::read_to_string(&file).unwrap();
        for word in forbidden {
            assert!(
                !text.contains(word),
                "{} mentions `{word}`: the renderer must stay a pure library",
                file.display()
            );
        }
    }
}
