use super::*;

fn names_in(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

#[test]
fn a_new_file_holds_the_bytes_and_no_temporary_file_is_left() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("out.bin");
    write(&path, b"hello").unwrap();
    assert_eq!(std::fs::read(&path).unwrap(), b"hello");
    write(&path, b"replaced").unwrap();
    assert_eq!(std::fs::read(&path).unwrap(), b"replaced");
    assert_eq!(names_in(dir.path()), ["out.bin"]);
}

#[cfg(unix)]
#[test]
fn a_new_file_gets_the_mode_of_an_ordinary_new_file() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let ordinary = dir.path().join("ordinary");
    std::fs::File::create(&ordinary).unwrap();
    let path = dir.path().join("atomic");
    write(&path, b"x").unwrap();
    let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
    assert_eq!(mode(&path), mode(&ordinary));
}

#[test]
fn a_reader_sees_the_old_file_or_the_whole_new_one() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("big.bin");
    const LEN: usize = 1 << 20;
    write(&path, &vec![b'a'; LEN]).unwrap();
    let done = std::sync::atomic::AtomicBool::new(false);
    std::thread::scope(|s| {
        s.spawn(|| {
            for round in 0..20 {
                let byte = if round % 2 == 0 { b'b' } else { b'a' };
                write(&path, &vec![byte; LEN]).unwrap();
            }
            done.store(true, std::sync::atomic::Ordering::SeqCst);
        });
        let mut reads = 0;
        while !done.load(std::sync::atomic::Ordering::SeqCst) || reads == 0 {
            let bytes = std::fs::read(&path).unwrap();
            assert_eq!(bytes.len(), LEN, "a partial file was visible");
            assert!(
                bytes.iter().all(|&b| b == bytes[0]),
                "a mixed file was visible"
            );
            reads += 1;
        }
    });
}

#[test]
fn an_error_names_the_destination_and_leaves_nothing_behind() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("no-such-dir").join("out.exr");
    let err = write(&missing, b"x").unwrap_err();
    assert_eq!(err.path, missing);
    assert_eq!(err.source.kind(), std::io::ErrorKind::NotFound);
    let message = err.to_string();
    assert!(
        message.contains(&missing.display().to_string()),
        "{message}"
    );
    assert!(message.contains("creating a temporary file"), "{message}");

    // A non-empty directory cannot be replaced by a file: the rename fails after the bytes
    // were written, and the temporary file goes.
    let occupied = dir.path().join("occupied");
    std::fs::create_dir(&occupied).unwrap();
    std::fs::write(occupied.join("inside"), b"kept").unwrap();
    let err = write(&occupied, b"x").unwrap_err();
    assert_eq!(err.path, occupied);
    assert!(err.to_string().contains("renaming"), "{err}");
    assert_eq!(names_in(dir.path()), ["occupied"]);
    assert_eq!(std::fs::read(occupied.join("inside")).unwrap(), b"kept");
}
