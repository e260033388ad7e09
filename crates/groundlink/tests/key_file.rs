//! Key files: created owner-only without a race, never overwritten, refused when others can
//! read them, and every error names the file and the fix.

use std::fs;
use std::os::unix::fs::PermissionsExt;

use dima_groundlink::key_file::{self, KeyFileError};
use dima_groundlink::v2::{random_session_id, LinkKey};

#[test]
fn create_then_load_gives_the_same_key_with_mode_0600() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("link.key");
    let created = key_file::create(&path).unwrap();
    let mode = fs::metadata(&path).unwrap().permissions().mode();
    assert_eq!(mode & 0o777, 0o600);
    let text = fs::read_to_string(&path).unwrap();
    assert_eq!(text.len(), 33);
    assert!(text.ends_with('\n'));
    assert_eq!(key_file::load(&path).unwrap(), created);
    // Two keys are not the same key.
    let other = key_file::create(&dir.path().join("other.key")).unwrap();
    assert_ne!(other, created);
}

#[test]
fn create_never_overwrites() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("link.key");
    fs::write(&path, "keep me").unwrap();
    let error = key_file::create(&path).unwrap_err();
    assert!(matches!(error, KeyFileError::Exists { .. }), "{error}");
    assert_eq!(fs::read_to_string(&path).unwrap(), "keep me");
}

#[test]
fn group_or_world_access_is_refused_with_the_fix() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("link.key");
    key_file::create(&path).unwrap();
    for mode in [0o640, 0o604, 0o620, 0o644] {
        fs::set_permissions(&path, fs::Permissions::from_mode(mode)).unwrap();
        let message = key_file::load(&path).unwrap_err().to_string();
        assert!(message.contains(&path.display().to_string()), "{message}");
        assert!(
            message.contains(&format!("chmod 600 {}", path.display())),
            "{message}"
        );
    }
    fs::set_permissions(&path, fs::Permissions::from_mode(0o400)).unwrap();
    assert!(key_file::load(&path).is_ok());
}

#[test]
fn missing_and_malformed_files_name_the_file_and_keygen() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("nope.key");
    let message = key_file::load(&missing).unwrap_err().to_string();
    assert!(
        message.contains(&missing.display().to_string()),
        "{message}"
    );
    assert!(message.contains("dima keygen"), "{message}");

    for text in [
        "",
        "0011",
        "zz112233445566778899aabbccddeeff",
        &"0".repeat(1000),
    ] {
        let path = dir.path().join("bad.key");
        let _ = fs::remove_file(&path);
        fs::write(&path, text).unwrap();
        fs::set_permissions(&path, fs::Permissions::from_mode(0o600)).unwrap();
        let error = key_file::load(&path).unwrap_err();
        assert!(matches!(error, KeyFileError::Malformed { .. }), "{error}");
        let message = error.to_string();
        assert!(message.contains(&path.display().to_string()), "{message}");
        assert!(message.contains("dima keygen"), "{message}");
    }
}

#[test]
fn a_hand_written_key_with_whitespace_loads() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("link.key");
    fs::write(&path, "  000102030405060708090A0B0C0D0E0F \r\n").unwrap();
    fs::set_permissions(&path, fs::Permissions::from_mode(0o600)).unwrap();
    assert_eq!(
        key_file::load(&path).unwrap(),
        LinkKey::from_bytes(core::array::from_fn(|i| i as u8))
    );
}

#[test]
fn session_ids_are_nonzero_and_vary() {
    let ids: Vec<u32> = (0..8).map(|_| random_session_id().unwrap()).collect();
    assert!(ids.iter().all(|&id| id != 0));
    assert!(ids.windows(2).any(|w| w[0] != w[1]));
}
