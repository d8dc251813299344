//! `docs/cli.md` is the help of every `focal` subcommand as clap renders it, so the documented options and
//! defaults cannot drift from the code. This test renders it from the built binary and compares it with
//! the committed file; after changing an option, regenerate the file with
//!
//!     FOCAL_BLESS=1 cargo test -p focal-cli --test cli_docs

use std::path::PathBuf;
use std::process::Command;

/// The committed reference page.
fn cli_md() -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../docs/cli.md"))
}

/// `focal ARGS --help` (clap writes plain text without colour when stdout is not a terminal).
fn help(args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_focal"))
        .args(args)
        .arg("--help")
        .env_remove("COLUMNS")
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "focal {args:?} --help failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

/// The subcommands listed under "Commands:" in the top-level help, without `help`.
fn subcommands(top: &str) -> Vec<String> {
    top.lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| !l.trim().is_empty())
        .filter_map(|l| l.split_whitespace().next())
        .filter(|name| *name != "help")
        .map(str::to_owned)
        .collect()
}

/// The page: a header saying how it is made, then each command's help in a code block.
fn render_page() -> String {
    let top = help(&[]);
    let commands = subcommands(&top);
    assert!(
        commands.iter().any(|c| c == "render"),
        "no subcommands found in:\n{top}"
    );
    let mut page = String::from(
        "# Command-line reference\n\n\
         <!-- Generated from the `focal` binary's help by crates/cli/tests/cli_docs.rs; do not edit by hand.\n     \
         Regenerate after changing an option: FOCAL_BLESS=1 cargo test -p focal-cli --test cli_docs -->\n\n\
         Every option of every `focal` subcommand, as `focal SUBCOMMAND --help` prints it, with its default\n\
         where it has a fixed one (`[default: …]`; options without one take the scene's value or say what\n\
         happens when they are left out). The [README](../README.md) has a worked example; the design notes\n\
         in [design/](design/) explain what the guiding options do.\n\n",
    );
    page.push_str("Subcommands:");
    for c in &commands {
        page.push_str(&format!(" [`{c}`](#focal-{c})"));
    }
    page.push_str("\n\n## focal\n\n```text\n");
    page.push_str(top.trim_end());
    page.push_str("\n```\n");
    for c in &commands {
        page.push_str(&format!("\n## focal {c}\n\n```text\n"));
        page.push_str(help(&[c.as_str()]).trim_end());
        page.push_str("\n```\n");
    }
    page
}

#[test]
fn docs_cli_md_is_the_current_help() {
    let page = render_page();
    let path = cli_md();
    if std::env::var_os("FOCAL_BLESS").is_some() {
        std::fs::write(&path, &page).unwrap();
        return;
    }
    let committed = std::fs::read_to_string(&path).unwrap_or_default();
    if committed != page {
        let first_difference = committed
            .lines()
            .zip(page.lines())
            .position(|(a, b)| a != b)
            .map_or(committed.lines().count().min(page.lines().count()), |i| i);
        panic!(
            "docs/cli.md is not the current help (first difference at line {}); regenerate it with\n  \
             FOCAL_BLESS=1 cargo test -p focal-cli --test cli_docs\n\
             committed: {:?}\ncurrent:   {:?}",
            first_difference + 1,
            committed.lines().nth(first_difference),
            page.lines().nth(first_difference),
        );
    }
}
