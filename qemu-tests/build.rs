//! 1. Puts memory.x on the linker search path (cortex-m-rt's link.x includes it).
//! 2. Runs the test vectors of `src/cases.rs` on the host (this build script is compiled for
//!    the host, with wiical-core as a build dependency) and writes their results, bit for
//!    bit, to `$OUT_DIR/expected.rs` (and a readable `$OUT_DIR/expected.txt`). The target
//!    binary compares its own results with these: "on-target results equal the desktop's".
use std::fmt::Write as _;
use std::{env, fs, path::PathBuf};

#[path = "src/cases.rs"]
#[allow(dead_code)]
mod cases;

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("OUT_DIR"));
    fs::write(out.join("memory.x"), include_bytes!("memory.x")).expect("write memory.x");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=memory.x");
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-changed=src/cases.rs");

    let mut rs = String::from(
        "/// Results of every case of `cases.rs` computed on the host by the build script, as\n\
         /// `f32` bit patterns (generated: see build.rs).\n\
         pub const EXPECTED: &[(&str, &[u32])] = &[\n",
    );
    let mut txt = String::new();
    for case in cases::CASES {
        let mut o = cases::Out::new();
        if let Err(e) = (case.run)(&mut o) {
            panic!("test vector `{}` fails on the host: {e}", case.name);
        }
        let _ = writeln!(rs, "    ({:?}, &[", case.name);
        let _ = writeln!(txt, "{}", case.name);
        for v in o.as_slice() {
            let _ = writeln!(rs, "        {:#010x}, // {v:e}", v.to_bits());
            let _ = writeln!(txt, "  {v:e}");
        }
        rs.push_str("    ]),\n");
    }
    rs.push_str("];\n");
    fs::write(out.join("expected.rs"), rs).expect("write expected.rs");
    fs::write(out.join("expected.txt"), txt).expect("write expected.txt");
}
