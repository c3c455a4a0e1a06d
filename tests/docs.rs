//! docs/architecture.md and README.md checked against the code: the doc names every module of
//! the engine, the simulator and the CLI, its list of which wiical crate uses which is `cargo
//! metadata`'s, and the command lists (README's tour, the doc's `host/src/cmd/` row) are
//! clap's subcommands.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::process::Command;

use clap::CommandFactory;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn read(path: &str) -> String {
    std::fs::read_to_string(root().join(path)).unwrap_or_else(|e| panic!("{path}: {e}"))
}

/// `crates/analysis/src/x.rs` for a file module, `crates/analysis/src/dir/` for a directory.
fn modules(src: &str) -> Vec<String> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(root().join(src)).unwrap() {
        let e = e.unwrap();
        let name = e.file_name().to_string_lossy().into_owned();
        if e.file_type().unwrap().is_dir() {
            out.push(format!("{src}/{name}/"));
        } else if name.ends_with(".rs") && name != "lib.rs" {
            out.push(format!("{src}/{name}"));
        }
    }
    out.sort();
    out
}

#[test]
fn architecture_doc_names_every_module() {
    let doc = read("docs/architecture.md");
    let missing: Vec<String> = [
        "crates/analysis/src",
        "crates/sim/src",
        "host/src",
        "host/src/live",
    ]
    .iter()
    .flat_map(|src| modules(src))
    .filter(|m| !doc.contains(&format!("`{m}`")))
    .collect();
    assert!(
        missing.is_empty(),
        "docs/architecture.md does not describe: {missing:?}"
    );
}

/// Package → the `wiical*` packages it depends on (normal dependencies), per `cargo metadata`
/// of the workspace at `manifest` (`--no-deps`: the manifests only, no registry).
fn wiical_dependencies(manifest: &str) -> BTreeMap<String, BTreeSet<String>> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = Command::new(cargo)
        .args([
            "metadata",
            "--format-version",
            "1",
            "--no-deps",
            "--offline",
        ])
        .arg("--manifest-path")
        .arg(root().join(manifest))
        .output()
        .expect("run cargo metadata");
    assert!(
        out.status.success(),
        "cargo metadata {manifest}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let meta: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let mut map = BTreeMap::new();
    for p in meta["packages"].as_array().unwrap() {
        let deps = p["dependencies"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|d| d["kind"].is_null() && d["name"].as_str().unwrap().starts_with("wiical"))
            .map(|d| d["name"].as_str().unwrap().to_string())
            .collect();
        map.insert(p["name"].as_str().unwrap().to_string(), deps);
    }
    map
}

/// The doc's list under "Which crate uses which": lines `` - `package`: `a`, `b` `` (or
/// "no wiical crate").
fn documented_dependencies(doc: &str) -> BTreeMap<String, BTreeSet<String>> {
    let start = doc
        .find("Which crate uses which")
        .expect("docs/architecture.md has a 'Which crate uses which' list");
    let mut map = BTreeMap::new();
    for line in doc[start..].lines().skip(1) {
        let Some(rest) = line.strip_prefix("- `") else {
            if map.is_empty() {
                continue;
            }
            break;
        };
        let (name, uses) = rest.split_once("`: ").expect("- `package`: uses");
        let deps = uses
            .split('`')
            .skip(1)
            .step_by(2)
            .map(str::to_string)
            .collect();
        map.insert(name.to_string(), deps);
    }
    map
}

#[test]
fn architecture_doc_states_the_crate_dependencies_cargo_has() {
    let mut actual = wiical_dependencies("Cargo.toml");
    for other in ["firmware/Cargo.toml", "python/Cargo.toml"] {
        actual.extend(wiical_dependencies(other));
    }
    // Test and build-task packages are not part of the map.
    actual.retain(|name, _| name.starts_with("wiical") && name != "wiical-integration-tests");
    let documented = documented_dependencies(&read("docs/architecture.md"));
    assert_eq!(
        documented, actual,
        "docs/architecture.md's 'Which crate uses which' (left) is not Cargo's (right)"
    );
}

/// clap's subcommand names of the `wiical` CLI.
fn subcommands() -> BTreeSet<String> {
    wiical::cli::Cli::command()
        .get_subcommands()
        .map(|c| c.get_name().to_string())
        .filter(|n| n != "help")
        .collect()
}

/// The subcommands a doc's command table lists: rows starting with "| `wiical NAME".
fn tour_rows(doc: &str) -> BTreeSet<String> {
    doc.lines()
        .filter_map(|l| l.strip_prefix("| `wiical "))
        .map(|l| l.split([' ', '`']).next().unwrap().to_string())
        .collect()
}

#[test]
fn readme_tour_lists_every_subcommand() {
    assert_eq!(
        tour_rows(&read("README.md")),
        subcommands(),
        "README's tour (left) vs clap (right)"
    );
}

#[test]
fn cli_doc_lists_every_subcommand() {
    assert_eq!(
        tour_rows(&read("docs/cli.md")),
        subcommands(),
        "docs/cli.md's table (left) vs clap (right)"
    );
}

/// The checker itself: a table missing a command, or naming one clap lacks, differs.
#[test]
fn tour_rows_sees_a_missing_and_an_extra_row() {
    let doc = "| `wiical fit FILE` | a |\n| `wiical nosuch X` | b |\n";
    let rows = tour_rows(doc);
    assert!(rows.contains("fit") && rows.contains("nosuch"));
    assert_ne!(rows, subcommands());
}

#[test]
fn readme_stays_short() {
    let n = read("README.md").lines().count();
    assert!(
        n <= 150,
        "README.md has {n} lines; the aim is at most 150 (details go to docs/)"
    );
}

#[test]
fn architecture_doc_lists_every_subcommand_module() {
    let doc = read("docs/architecture.md");
    let row = doc
        .lines()
        .find(|l| l.starts_with("| `host/src/cmd/` |"))
        .expect("a host/src/cmd/ row");
    let listed: BTreeSet<String> = row
        .split(':')
        .nth(1)
        .unwrap()
        .split('`')
        .skip(1)
        .step_by(2)
        .map(|m| m.replace('_', "-"))
        .collect();
    assert_eq!(
        listed,
        subcommands(),
        "the doc's cmd row (left) vs clap (right)"
    );
}
