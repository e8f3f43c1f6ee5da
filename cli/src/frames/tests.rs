use super::*;

#[test]
fn ranges_and_single_frames_parse() {
    assert_eq!(
        parse_frames("1-48").unwrap(),
        FrameRange { start: 1, end: 48 }
    );
    assert_eq!(
        parse_frames("1001").unwrap(),
        FrameRange {
            start: 1001,
            end: 1001
        }
    );
    assert!(
        parse_frames("48-1")
            .unwrap_err()
            .contains("before the first")
    );
    assert!(parse_frames("a-3").is_err());
    assert!(parse_frames("1-1000000").unwrap_err().contains("999999"));
    assert!(parse_frames("-3").is_err());
}

#[test]
fn hashes_become_the_padded_frame_number() {
    let p = |s: &str, f: u32| frame_path(Path::new(s), f);
    assert_eq!(
        p("out/shot.####.exr", 7),
        PathBuf::from("out/shot.0007.exr")
    );
    assert_eq!(p("shot.#.exr", 1001), PathBuf::from("shot.1001.exr"));
    assert_eq!(p("shot_##.png", 3), PathBuf::from("shot_03.png"));
    // The last run of the file name only: a directory's # is kept.
    assert_eq!(
        p("take#2/a##b###.exr", 5),
        PathBuf::from("take#2/a##b005.exr")
    );
    assert_eq!(p("still.exr", 5), PathBuf::from("still.exr"));
}

#[test]
fn a_sequence_needs_a_frame_number_in_its_name() {
    let range = FrameRange { start: 1, end: 3 };
    let e = check_output("-o", Path::new("shot.exr"), range, "--frames 1-3")
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("-o shot.exr: --frames 1-3 asks for 3 frames"),
        "{e}"
    );
    check_output("-o", Path::new("shot.##.exr"), range, "--frames 1-3").unwrap();
    check_output(
        "-o",
        Path::new("shot.exr"),
        FrameRange { start: 2, end: 2 },
        "--frames 2",
    )
    .unwrap();
}
