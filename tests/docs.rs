//! docs/architecture.md names every module of the two `std` crates (issue 18): a new module
//! that is not described there fails this test.

use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
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
    let doc = std::fs::read_to_string(root().join("docs/architecture.md")).unwrap();
    let missing: Vec<String> = ["crates/analysis/src", "host/src"]
        .iter()
        .flat_map(|src| modules(src))
        .filter(|m| !doc.contains(&format!("`{m}`")))
        .collect();
    assert!(
        missing.is_empty(),
        "docs/architecture.md does not describe: {missing:?}"
    );
}
