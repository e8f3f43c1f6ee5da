//! The real scanned meshes beside the project (`../shared/meshes`, or `$SPINDLE_MESHES`).
//! Each test skips with a printed reason when the files are absent.

use std::path::PathBuf;

use spindle_worker::render::obj::parse_obj;

fn mesh_file(name: &str) -> Option<Vec<u8>> {
    let dir = std::env::var_os("SPINDLE_MESHES")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/meshes"));
    let path = dir.join(name);
    match std::fs::read(&path) {
        Ok(bytes) => Some(bytes),
        Err(e) => {
            println!("skipped: {} is absent ({e})", path.display());
            None
        }
    }
}

#[test]
fn open_bunny_reports_its_holes() {
    let Some(bytes) = mesh_file("bunny-70k-open.obj") else {
        return;
    };
    let mesh = parse_obj(&bytes).unwrap();
    let report = mesh.report();
    println!("bunny-70k-open: {report:?}");
    assert_eq!(report.triangles, 69_451);
    assert!(!report.closed);
    assert_eq!(report.boundary_edges, 223);
}

#[test]
fn closed_bunny_is_closed() {
    let Some(bytes) = mesh_file("bunny-4k.obj") else {
        return;
    };
    let report = parse_obj(&bytes).unwrap().report();
    println!("bunny-4k: {report:?}");
    assert_eq!(report.triangles, 4_000);
    assert!(report.closed && report.boundary_edges == 0);
}
