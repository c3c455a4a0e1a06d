//! Raw Axivity `.cwa` / GENEActiv `.bin` files through the CLI (docs/raw-formats.md): ordinary
//! inputs, corrupt blocks a counted warning, too few still epochs one sentence.

mod common;

use common::{data_dir, temp_file, wiical};

fn testfile(name: &str) -> String {
    data_dir()
        .join("ggirread_testfiles")
        .join(name)
        .display()
        .to_string()
}

/// `fit`/`analyze` on a minutes-long raw file: one sentence with the epochs found and needed.
#[test]
fn short_raw_files_say_how_many_still_epochs() {
    for name in [
        "ax3_testfile.cwa",
        "ax6_testfile.cwa",
        "GENEActiv_testfile.bin",
    ] {
        for cmd in ["fit", "analyze"] {
            let f = testfile(name);
            let (ok, _, err) = wiical(&[cmd, &f]);
            assert!(!ok, "{cmd} {name}");
            let last = err.lines().last().unwrap();
            assert!(last.starts_with(&format!("error: in {f}: found ")), "{err}");
            assert!(last.contains("still 10-s epochs"), "{err}");
            assert!(last.contains("needs at least 10"), "{err}");
        }
    }
}

/// The corrupt-blocks file: the six corrupt blocks are skipped, counted and named.
#[test]
fn corrupt_blocks_are_a_counted_warning() {
    let f = testfile("ax3_testfile_corrupt_blocks_0_13_14_142_143_144.cwa");
    let (_, _, err) = wiical(&["six-position", &f]);
    let want = format!("warning: in {f}: skipped 6 corrupt data block(s) of 145 (checksum failed): #0, #13, #14, #142, #143, #144");
    assert!(err.lines().any(|l| l == want), "{err}");
    assert!(!err.contains("panicked"), "{err}");
}

/// Channels the file does not record, and a `.cwa` name on something else, are one sentence.
#[test]
fn missing_channels_and_false_extensions() {
    let (ok, _, err) = wiical(&["magfit", &testfile("ax6_testfile.cwa")]);
    assert!(!ok);
    assert!(
        err.contains("the file records gx,gy,gz,ax,ay,az; the magnetometer was asked for"),
        "{err}"
    );
    let fake = temp_file("raw", "fake.cwa", "t,x,y,z\n0,1,2,3\n");
    let (ok, _, err) = wiical(&["fit", fake.to_str().unwrap()]);
    assert!(!ok);
    assert!(err.contains("not a readable Axivity .cwa file"), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
}
