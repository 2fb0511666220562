//! `docs/cli.md`, the command-line reference, is the long help (`--help`) of `haze` and of
//! every subcommand, generated here: this test fails when the checked-in file differs, and
//! `HAZE_BLESS=1 cargo test --test cli_reference` rewrites it.

use assert_cmd::Command;
use std::path::Path;

/// Help is wrapped at this width, whatever the terminal.
const COLUMNS: &str = "100";

/// The long help of `haze ARGS…`.
fn long_help(args: &[&str]) -> String {
    let out = Command::cargo_bin("haze")
        .unwrap()
        .args(args)
        .arg("--help")
        .env("COLUMNS", COLUMNS)
        .env_remove("RUST_LOG")
        .output()
        .unwrap();
    assert!(out.status.success(), "{args:?} --help failed");
    String::from_utf8(out.stdout).unwrap()
}

/// The subcommands a help text lists under "Commands:" (without `help`).
fn subcommands(help: &str) -> Vec<String> {
    help.lines()
        .skip_while(|l| l.trim_end() != "Commands:")
        .skip(1)
        .take_while(|l| !l.trim().is_empty())
        .filter(|l| l.starts_with("  ") && !l.starts_with("   "))
        .filter_map(|l| l.split_whitespace().next())
        .filter(|name| *name != "help")
        .map(str::to_string)
        .collect()
}

/// The reference of `haze ARGS…` and of its subcommands, depth first.
fn section(args: &[&str], out: &mut String) {
    let help = long_help(args);
    let title = ["haze"].iter().chain(args).copied().collect::<Vec<_>>();
    let level = "#".repeat(args.len() + 2);
    out.push_str(&format!(
        "{level} `{}`\n\n```text\n{}\n```\n\n",
        title.join(" "),
        help.trim_end()
    ));
    for sub in subcommands(&help) {
        let mut next = args.to_vec();
        next.push(&sub);
        section(&next, out);
    }
}

fn reference() -> String {
    let mut out = String::from(
        "# Command-line reference\n\n\
         The long help of `haze` and of each subcommand (`haze COMMAND --help`), generated \
         by `tests/cli_reference.rs` (`HAZE_BLESS=1 cargo test --test cli_reference` \
         rewrites this file).\n\n",
    );
    section(&[], &mut out);
    format!("{}\n", out.trim_end())
}

#[test]
fn docs_cli_md_is_the_help_of_every_command() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/cli.md");
    let text = reference();
    if std::env::var_os("HAZE_BLESS").is_some_and(|v| v == "1") {
        std::fs::write(&path, &text).unwrap();
        return;
    }
    let checked_in = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        checked_in == text,
        "{} differs from the commands' --help: run `HAZE_BLESS=1 cargo test --test cli_reference` and commit it",
        path.display()
    );
}
