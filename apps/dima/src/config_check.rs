//! `dima config --check FILE`: read and validate a configuration, then print it with every
//! default filled in.

use std::path::Path;

use anyhow::Context;
use dima_robot::config;

/// The configuration in `path`, validated, as the complete TOML `dima config --check` prints.
pub fn check(path: &Path) -> anyhow::Result<String> {
    let config = config::load(path)?;
    toml::to_string(&config).context("serialising the configuration")
}

#[cfg(test)]
mod tests {
    //! Every ```toml snippet of README.md and docs/*.md goes through the very check
    //! `dima config --check` runs. A snippet that is deliberately not a configuration (a
    //! controller the reader is about to write, a mistake shown on purpose) is preceded by the
    //! line `<!-- config-check: skip -->` (an HTML comment, invisible once rendered), optionally
    //! followed by the reason.

    use super::*;
    use std::path::PathBuf;

    /// The marker line that exempts the next ```toml block.
    const SKIP_MARKER: &str = "<!-- config-check: skip";

    /// A ```toml block of a Markdown file: where it starts and its text.
    #[derive(Debug)]
    struct Snippet {
        line: usize,
        text: String,
    }

    /// The ```toml blocks of `markdown` that are not marked to be skipped.
    fn toml_snippets(markdown: &str) -> Vec<Snippet> {
        let mut snippets = Vec::new();
        let mut open: Option<Snippet> = None;
        let mut skip_next = false;
        for (i, line) in markdown.lines().enumerate() {
            let trimmed = line.trim_start();
            if let Some(snippet) = open.as_mut() {
                if trimmed.starts_with("```") {
                    snippets.extend(open.take());
                } else {
                    snippet.text.push_str(line);
                    snippet.text.push('\n');
                }
            } else if let Some(info) = trimmed.strip_prefix("```") {
                if info.trim() == "toml" && !skip_next {
                    open = Some(Snippet {
                        line: i + 1,
                        text: String::new(),
                    });
                }
                skip_next = false;
            } else if trimmed.starts_with(SKIP_MARKER) {
                skip_next = true;
            } else if !trimmed.is_empty() {
                skip_next = false;
            }
        }
        snippets
    }

    /// README.md and docs/*.md of the workspace.
    fn documents() -> Vec<PathBuf> {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
        let mut files = vec![root.join("README.md")];
        let mut docs: Vec<PathBuf> = std::fs::read_dir(root.join("docs"))
            .expect("the workspace's docs/")
            .map(|e| e.expect("a docs/ entry").path())
            .filter(|p| p.extension().is_some_and(|x| x == "md"))
            .collect();
        docs.sort();
        files.extend(docs);
        files
    }

    #[test]
    fn every_toml_snippet_of_the_documentation_passes_config_check() {
        let dir = std::env::temp_dir().join(format!("dima-snippets-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let mut checked = 0;
        let mut failures = Vec::new();
        for doc in documents() {
            let markdown = std::fs::read_to_string(&doc).unwrap();
            for snippet in toml_snippets(&markdown) {
                let path = dir.join(format!("snippet-{checked}.toml"));
                std::fs::write(&path, &snippet.text).unwrap();
                if let Err(e) = check(&path) {
                    failures.push(format!("{}:{}: {e:#}", doc.display(), snippet.line));
                }
                checked += 1;
            }
        }
        std::fs::remove_dir_all(&dir).ok();
        assert!(checked >= 4, "found only {checked} snippets");
        assert!(failures.is_empty(), "{}", failures.join("\n"));
    }

    #[test]
    fn snippets_are_found_and_the_marker_skips_exactly_the_next_one() {
        let md = "text\n```toml\na = 1\n```\n<!-- config-check: skip (a new kind) -->\n\
                  ```toml\nb = 2\n```\n```sh\nc\n```\n```toml\nd = 4\n```\n";
        let found: Vec<_> = toml_snippets(md)
            .into_iter()
            .map(|s| (s.line, s.text))
            .collect();
        assert_eq!(
            found,
            [(2, "a = 1\n".to_owned()), (12, "d = 4\n".to_owned())]
        );
    }
}
