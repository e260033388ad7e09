//! What the programs write to the terminal on stderr: a fatal error in one style for every
//! command (`error: ` and the cause chain, no timestamp), colour only on a terminal and never
//! with `NO_COLOR` set.

use std::io::IsTerminal;

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
    fn colour_only_on_a_terminal_without_no_color() {
        assert!(colour_allowed(true, None));
        assert!(colour_allowed(true, Some(OsStr::new(""))));
        assert!(!colour_allowed(true, Some(OsStr::new("1"))));
        assert!(!colour_allowed(false, None));
    }
}
