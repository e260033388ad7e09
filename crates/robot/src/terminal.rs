//! What the programs write to the terminal on stderr: a fatal error in one style for every
//! command (`error: ` and the cause chain, no timestamp), colour only on a terminal and never
//! with `NO_COLOR` set, and a live status line that log lines never land on.
//!
//! The status line (`dima sim`'s) is redrawn in place, without a newline; a log line written
//! after it would continue it. Both therefore go through here: [`draw_status`] remembers the
//! line on screen, and [`StderrBelowStatus`] (the log's writer) clears it, writes the log line
//! and draws it again under the line, all under one lock.

use std::io::{IsTerminal, Write};
use std::sync::Mutex;

/// Erases the terminal's current line and returns to its start.
const CLEAR_LINE: &[u8] = b"\r\x1b[2K";

/// The status line drawn on stderr, if one is.
static STATUS_LINE: Mutex<Option<String>> = Mutex::new(None);

fn status_line() -> std::sync::MutexGuard<'static, Option<String>> {
    STATUS_LINE.lock().unwrap_or_else(|e| e.into_inner())
}

/// Draws `line` in place of the status line on stderr (a terminal) and remembers it, so log
/// lines can clear and redraw it.
pub fn draw_status(line: &str) {
    let mut on_screen = status_line();
    let mut err = std::io::stderr().lock();
    let _ = err.write_all(CLEAR_LINE);
    let _ = err.write_all(line.as_bytes());
    let _ = err.flush();
    *on_screen = Some(line.to_owned());
}

/// Ends the status line: it stays on screen, and what follows starts on a new line.
pub fn finish_status() {
    let mut on_screen = status_line();
    if on_screen.take().is_some() {
        eprintln!();
    }
}

/// `log` written to a terminal that shows `status` on its last line: the status line
/// cleared, the log line, the status line drawn again below it.
pub fn below_status(out: &mut impl Write, status: Option<&str>, log: &[u8]) -> std::io::Result<()> {
    if status.is_some() {
        out.write_all(CLEAR_LINE)?;
    }
    out.write_all(log)?;
    if let Some(line) = status {
        if !log.ends_with(b"\n") {
            out.write_all(b"\n")?;
        }
        out.write_all(line.as_bytes())?;
    }
    out.flush()
}

/// A writer for log lines on stderr that never lands on the status line: it collects one log
/// event and writes it when dropped, through [`below_status`]. Give `StderrBelowStatus::default`
/// to the log subscriber as its writer.
#[derive(Debug, Default)]
pub struct StderrBelowStatus {
    buffer: Vec<u8>,
}

impl Write for StderrBelowStatus {
    fn write(&mut self, bytes: &[u8]) -> std::io::Result<usize> {
        self.buffer.extend_from_slice(bytes);
        Ok(bytes.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl Drop for StderrBelowStatus {
    fn drop(&mut self) {
        if self.buffer.is_empty() {
            return;
        }
        let on_screen = status_line();
        let _ = below_status(
            &mut std::io::stderr().lock(),
            on_screen.as_deref(),
            &self.buffer,
        );
    }
}

/// Whether stderr may carry colour: it is a terminal and `NO_COLOR` is unset or empty
/// (<https://no-color.org>).
pub fn stderr_colour() -> bool {
    colour_allowed(
        std::io::stderr().is_terminal(),
        std::env::var_os("NO_COLOR").as_deref(),
    )
}

/// Colour for a stream that is (or not) a terminal, given the value of `NO_COLOR`.
pub fn colour_allowed(terminal: bool, no_color: Option<&std::ffi::OsStr>) -> bool {
    terminal && no_color.is_none_or(|v| v.is_empty())
}

/// A fatal error as one line: `error: ` and the error with its causes, `: `-separated; the
/// word `error` in bold red when `colour`.
pub fn fatal_line(error: &anyhow::Error, colour: bool) -> String {
    let label = if colour {
        "\x1b[1;31merror\x1b[0m"
    } else {
        "error"
    };
    format!("{label}: {error:#}")
}

/// Prints `error` to stderr as [`fatal_line`] does, coloured only where [`stderr_colour`]
/// allows.
pub fn report_fatal(error: &anyhow::Error) {
    eprintln!("{}", fatal_line(error, stderr_colour()));
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::ffi::OsStr;

    #[test]
    fn a_fatal_error_is_one_line_with_its_causes() {
        let error = anyhow::anyhow!("no such file").context("reading the log x.mcap");
        assert_eq!(
            fatal_line(&error, false),
            "error: reading the log x.mcap: no such file"
        );
        let coloured = fatal_line(&error, true);
        assert!(
            coloured.starts_with("\x1b[1;31merror\x1b[0m: reading"),
            "{coloured:?}"
        );
    }

    #[test]
    fn a_log_line_clears_the_status_line_and_redraws_it_below() {
        let mut out = Vec::new();
        below_status(
            &mut out,
            Some("12.0/20s AUTO"),
            b"WARN dima: sensor board lost\n",
        )
        .unwrap();
        assert_eq!(
            out,
            b"\r\x1b[2KWARN dima: sensor board lost\n12.0/20s AUTO".to_vec()
        );
        let mut out = Vec::new();
        below_status(&mut out, None, b"WARN x\n").unwrap();
        assert_eq!(
            out,
            b"WARN x\n".to_vec(),
            "no status line: the log line alone"
        );
    }

    #[test]
    fn colour_only_on_a_terminal_without_no_color() {
        assert!(colour_allowed(true, None));
        assert!(colour_allowed(true, Some(OsStr::new(""))));
        assert!(!colour_allowed(true, Some(OsStr::new("1"))));
        assert!(!colour_allowed(false, None));
    }
}
