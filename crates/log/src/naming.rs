//! The names of a run's files, written and parsed in one place.
//!
//! A run starts in `NAME.mcap` (on the robot `dima-YYYYMMDDTHHMMSSZ.mcap`, the UTC time it
//! started; the ground station's session recordings `dima-ground-YYYYMMDDTHHMMSSZ.mcap`, so
//! the two sort and read alike) and goes on, after a split by duration or a resume after a disk fault, in
//! `NAME-1.mcap`, `NAME-2.mcap`, ... beside it: one numbering for the run.

use std::path::{Path, PathBuf};
use std::time::{SystemTime, UNIX_EPOCH};

/// `dima-YYYYMMDDTHHMMSSZ.mcap` for `now`: the name of a run's first file.
pub fn log_file_name(now: SystemTime) -> String {
    format!("dima-{}.mcap", utc_stamp(now))
}

/// `dima-ground-YYYYMMDDTHHMMSSZ.mcap` for `now`: the name of a ground station's session
/// recording, in the robot's style.
pub fn ground_session_name(now: SystemTime) -> String {
    format!("dima-ground-{}.mcap", utc_stamp(now))
}

/// `YYYYMMDDTHHMMSSZ`: `now` in UTC, to the second.
fn utc_stamp(now: SystemTime) -> String {
    let secs = now.duration_since(UNIX_EPOCH).map_or(0, |d| d.as_secs()) as i64;
    let (days, rem) = (secs.div_euclid(86_400), secs.rem_euclid(86_400));
    // Civil date from days since 1970-01-01 (Howard Hinnant's algorithm).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1_460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!(
        "{year:04}{month:02}{day:02}T{:02}{:02}{:02}Z",
        rem / 3_600,
        rem % 3_600 / 60,
        rem % 60
    )
}

/// Whether `stem` is the stem of a robot's first file: `dima-YYYYMMDDTHHMMSSZ`.
pub fn is_timestamped(stem: &str) -> bool {
    let Some(t) = stem.strip_prefix("dima-") else {
        return false;
    };
    let b = t.as_bytes();
    b.len() == 16
        && b[8] == b'T'
        && b[15] == b'Z'
        && b[..8].iter().chain(&b[9..15]).all(u8::is_ascii_digit)
}

/// `dir/NAME-n.mcap` for the run whose first file is `dir/NAME.mcap` (`n` from 1).
pub fn numbered_name(first: &Path, n: u32) -> PathBuf {
    let stem = first
        .file_stem()
        .map_or_else(|| "dima".to_owned(), |s| s.to_string_lossy().into_owned());
    first.with_file_name(format!("{stem}-{n}.mcap"))
}

/// A file's place in its run, as its name tells it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RunPlace {
    /// The run's first file, `NAME.mcap`.
    pub first: PathBuf,
    /// 0 for the first file, `n` for `NAME-n.mcap`.
    pub number: u32,
}

/// The place of `path` in its run: `NAME-n.mcap` is file `n` of the run starting at
/// `NAME.mcap` when `NAME.mcap` exists or `NAME` is a robot's time stamp (whose names never
/// end in `-n` themselves); any other file is the first (and maybe only) file of its run.
pub fn run_place(path: &Path) -> RunPlace {
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let numbered = stem
        .rsplit_once('-')
        .filter(|(_, n)| !n.is_empty() && n.bytes().all(|b| b.is_ascii_digit()))
        .and_then(|(base, n)| Some((base.to_owned(), n.parse::<u32>().ok()?)));
    if let Some((base, number)) = numbered {
        let first = path.with_file_name(format!("{base}.mcap"));
        if number > 0 && (is_timestamped(&base) || first.is_file()) {
            return RunPlace { first, number };
        }
    }
    RunPlace {
        first: path.to_path_buf(),
        number: 0,
    }
}

/// Every file of the run `path` belongs to, first to last: the files up to `path` by its name
/// (each must exist: a missing one is an error naming it), then the following numbers as long
/// as they exist.
///
/// # Errors
/// `path`, or a file of the run before it, is missing.
pub fn run_files(path: &Path) -> anyhow::Result<Vec<PathBuf>> {
    let place = run_place(path);
    let mut files = vec![place.first.clone()];
    files.extend((1..=place.number).map(|n| numbered_name(&place.first, n)));
    if !path.is_file() {
        anyhow::bail!("{}: no such log file", path.display());
    }
    if let Some(missing) = files.iter().find(|f| !f.is_file()) {
        anyhow::bail!(
            "{}: file of the run of {} is missing",
            missing.display(),
            path.display()
        );
    }
    while numbered_name(&place.first, files.len() as u32).is_file() {
        files.push(numbered_name(&place.first, files.len() as u32));
    }
    Ok(files)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn file_names_are_utc_timestamps() {
        let t = UNIX_EPOCH + Duration::from_secs(1_795_000_000);
        // `date -u -d @1795000000`: 2026-11-18 11:06:40 UTC.
        assert_eq!(log_file_name(t), "dima-20261118T110640Z.mcap");
        assert_eq!(log_file_name(UNIX_EPOCH), "dima-19700101T000000Z.mcap");
        let leap = UNIX_EPOCH + Duration::from_secs(951_825_600); // 2000-02-29 12:00:00
        assert_eq!(log_file_name(leap), "dima-20000229T120000Z.mcap");
        assert_eq!(ground_session_name(t), "dima-ground-20261118T110640Z.mcap");
        assert!(is_timestamped("dima-20000229T120000Z"));
        assert!(!is_timestamped("dima-ground-20000229T120000Z"));
        assert!(!is_timestamped("dima-20000229T120000Z-1"));
        assert!(!is_timestamped("dst-seed"));
    }

    #[test]
    fn numbered_names_parse_back_to_their_place() {
        let first = Path::new("/logs/dima-20261126T170000Z.mcap");
        let third = numbered_name(first, 2);
        assert_eq!(third, Path::new("/logs/dima-20261126T170000Z-2.mcap"));
        assert_eq!(
            run_place(&third),
            RunPlace {
                first: first.to_path_buf(),
                number: 2
            }
        );
        assert_eq!(run_place(first).number, 0);
        // Not a robot's name, and no `dst-seed.mcap` beside it: a file of its own.
        let seed = Path::new("/nonexistent/dst-seed-7.mcap");
        assert_eq!(run_place(seed).first, seed);
    }

    #[test]
    fn a_missing_file_of_the_run_is_an_error_naming_it() {
        let e = run_files(Path::new("/nonexistent/dima-20261126T170000Z-1.mcap")).unwrap_err();
        assert_eq!(
            format!("{e:#}"),
            "/nonexistent/dima-20261126T170000Z-1.mcap: no such log file"
        );
        let dir = std::env::temp_dir().join(format!("dima-log-gap-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let second = dir.join("dima-20261126T170000Z-1.mcap");
        std::fs::write(&second, b"").unwrap();
        let e = run_files(&second).unwrap_err();
        assert!(
            format!("{e:#}").contains("dima-20261126T170000Z.mcap: file of the run of"),
            "{e:#}"
        );
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn any_file_of_a_run_finds_all_of_it() {
        let dir = std::env::temp_dir().join(format!("dima-log-naming-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let first = dir.join("run.mcap");
        let all = [
            first.clone(),
            numbered_name(&first, 1),
            numbered_name(&first, 2),
        ];
        for f in &all {
            std::fs::write(f, b"").unwrap();
        }
        for f in &all {
            assert_eq!(run_files(f).unwrap(), all, "given {}", f.display());
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
