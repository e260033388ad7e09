//! A whole run read as one: given any of its files, every file of the run in order (see
//! [`naming`](crate::naming)), their records one after the other and their metadata merged.

use std::path::Path;

use anyhow::Context;

use crate::naming::run_files;
use crate::reader::LoggedRun;

/// Reads every file of the run `path` belongs to, in order, as one [`LoggedRun`]: the
/// messages of each file after those of the one before, the configuration, version and
/// realtime setup of the first file that has them, the summary, ground link counts and
/// histogram of the last file that has them (the run's exit), and every metadata record and
/// attachment name. [`LoggedRun::files`] lists the files read.
///
/// A file of the run that cannot be read at all is a warning when another file could be read.
///
/// # Errors
/// A file of the run before `path` is missing, or no file of the run could be read.
pub fn read_run(path: &Path) -> anyhow::Result<LoggedRun> {
    let files = run_files(path)?;
    let mut run = LoggedRun::default();
    let mut first_error = None;
    for file in &files {
        match LoggedRun::read(file) {
            Ok(part) => append(&mut run, part, file),
            Err(e) => {
                run.warnings.push(format!("{e:#}"));
                first_error.get_or_insert(e);
            }
        }
    }
    if run.files.is_empty() {
        if let Some(e) = first_error {
            return Err(e).with_context(|| format!("no file of the run of {}", path.display()));
        }
    }
    Ok(run)
}

/// Adds `part` (the file `file`) after what `run` holds.
fn append(run: &mut LoggedRun, part: LoggedRun, file: &Path) {
    run.cycles.extend(part.cycles);
    run.states.extend(part.states);
    run.infos.extend(part.infos);
    run.raw.extend(part.raw);
    run.config = run.config.take().or(part.config);
    run.version = run.version.take().or(part.version);
    run.navigation = run.navigation.take().or(part.navigation);
    run.rt_setup = run.rt_setup.take().or(part.rt_setup);
    run.summary = part.summary.or(run.summary.take());
    run.ground_link = part.ground_link.or(run.ground_link.take());
    run.histogram = part.histogram.or(run.histogram.take());
    run.metadata.extend(part.metadata);
    run.attachments.extend(part.attachments);
    run.files.extend(part.files);
    let name = file.display();
    run.warnings
        .extend(part.warnings.into_iter().map(|w| format!("{name}: {w}")));
}

/// `N (first, second, ...)`: how many files a run read, by name.
pub fn files_line(run: &LoggedRun) -> String {
    let names: Vec<String> = run
        .files
        .iter()
        .map(|f| {
            f.file_name()
                .map_or_else(|| f.display().to_string(), |n| n.to_string_lossy().into())
        })
        .collect();
    format!("{} ({})", names.len(), names.join(", "))
}
