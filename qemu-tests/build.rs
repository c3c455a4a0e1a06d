//! 1. Puts memory.x on the linker search path (cortex-m-rt's link.x includes it).
//! 2. Runs the test vectors of `src/cases.rs` on the host (this build script is compiled for
//!    the host, with wiical-core as a build dependency) and writes their results, bit for
//!    bit, to `$OUT_DIR/expected.rs` (and a readable `$OUT_DIR/expected.txt`). The target
//!    binary compares its own results with these: "on-target results equal the desktop's".
//! 3. Reads two real recordings from `$WIICAL_DATA` (default `<workspace>/../shared/data`;
//!    the build fails naming the path when they are missing) and writes them to `OUT_DIR`
//!    only (`real_data.rs`, `xsens_acc.f32le`; never into the repository) for the target's
//!    `real_data` module; the host's run of the cases reads the same values through the
//!    [`real_data`] module below. It also checks that the host results of the real-data
//!    cases equal what the CLI (`wiical fit --json`, `wiical magfit --json`) prints for
//!    the same files.
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::{env, fs};

#[path = "src/cases.rs"]
#[allow(dead_code)]
mod cases;

/// The host side of the target's `real_data` module (`src/lib.rs`): the same functions, backed
/// by the files this build script reads before it runs the cases.
mod real_data {
    use std::sync::OnceLock;

    pub static XSENS_ACC: OnceLock<Vec<u8>> = OnceLock::new();
    pub static XSENS_POSES: OnceLock<Vec<[f32; 3]>> = OnceLock::new();
    pub static MAG_OUT: OnceLock<Vec<[f32; 3]>> = OnceLock::new();

    pub fn xsens_acc_f32le() -> &'static [u8] {
        XSENS_ACC
            .get()
            .expect("the Xsens recording is loaded first")
    }

    pub fn xsens_poses() -> &'static [[f32; 3]] {
        XSENS_POSES
            .get()
            .expect("the Xsens poses are detected first")
    }

    pub fn mag_out_points() -> &'static [[f32; 3]] {
        MAG_OUT.get().expect("mag_out.txt is loaded first")
    }
}

/// The Xsens accelerometer recording (IMU-TK): `t x y z`, raw 16-bit counts, 100 Hz.
const XSENS_FILE: &str = "imu_tk_xsens/xsens_acc.mat";
const XSENS_ROWS: usize = 51_175;
/// Raw magnetometer points (ellipsoid_fit_python): `x y z`.
const MAG_FILE: &str = "mag_ellipsoid_fit_python/mag_out.txt";
const MAG_ROWS: usize = 347;

/// What `wiical fit --json <data>/imu_tk_xsens/xsens_acc.mat` prints (defaults; the CLI's
/// JSON writes each `f32` in its shortest round-trip form, so these literals are its bits).
/// The build script's own run must give the same numbers: it is the same pipeline
/// (`crates/analysis/src/detect/windows.rs`: detector settings from the time column's 100 Hz, `StaticDetector`
/// with capacity 511, `multipos::fit` with the default full model). If the core's detector or
/// solver is changed on purpose, re-run the CLI and update these numbers.
const CLI_FIT_WINDOWS: usize = 38;
const CLI_FIT_BIAS: [f32; 3] = [33123.84, 33275.152, 32364.492];
const CLI_FIT_MATRIX: [[f32; 3]; 3] = [
    [0.00024578712, -8.3790104e-07, -2.2597349e-06],
    [0.0, 0.00024721277, -5.249643e-06],
    [0.0, 0.0, 0.00024566954],
];
const CLI_FIT_RMS_MG: f32 = 0.10052075;

/// What `wiical magfit --json <data>/mag_ellipsoid_fit_python/mag_out.txt` prints (default
/// model `ellipsoid`): centre, matrix W (row-major), radius, fit error %, RMS radius error.
/// The CLI widens the core's `f32` to `f64` for JSON, so each value is exactly an `f32`.
const CLI_MAG: [f64; 15] = [
    -68.10389709472656,
    82.87298583984375,
    -133.42921447753906,
    1.0162689685821533,
    0.0043419720605015755,
    -0.0012326212599873543,
    0.0043419720605015755,
    0.9540590643882751,
    0.054987698793411255,
    -0.0012326212599873543,
    0.054987698793411255,
    1.0345653295516968,
    173.75958251953125,
    2.0601911544799805,
    3.57777738571167,
];

/// Largest accepted distance between the build script's result and the CLI's (the iterative
/// solvers' policy of `cases.rs`; both run the same code on the same machine, so 0 is
/// expected).
const CLI_MAX_ULPS: u32 = 4;

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("OUT_DIR"));
    fs::write(out.join("memory.x"), include_bytes!("memory.x")).expect("write memory.x");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=memory.x");
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-changed=src/cases.rs");

    let data = data_dir();
    let xsens_path = data.join(XSENS_FILE);
    let mag_path = data.join(MAG_FILE);
    println!("cargo:rerun-if-env-changed=WIICAL_DATA");
    println!("cargo:rerun-if-changed={}", xsens_path.display());
    println!("cargo:rerun-if-changed={}", mag_path.display());
    let poses = load_real_data(&out, &xsens_path, &mag_path);

    let mut rs = String::from(
        "/// Results of every case of `cases.rs` computed on the host by the build script, as\n\
         /// `f32` bit patterns (generated: see build.rs).\n\
         pub const EXPECTED: &[(&str, &[u32])] = &[\n",
    );
    let mut txt = String::new();
    let mut real_fit = None;
    let mut real_mag = None;
    for case in cases::CASES {
        let mut o = cases::Out::new();
        if let Err(e) = (case.run)(&mut o) {
            panic!("test vector `{}` fails on the host: {e}", case.name);
        }
        match case.name {
            "xsens_multipos_fit" => real_fit = Some(o.as_slice().to_vec()),
            "mag_out_ellipsoid_fit" => real_mag = Some(o.as_slice().to_vec()),
            _ => {}
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

    let fit = real_fit.expect("the case xsens_multipos_fit exists");
    let mag = real_mag.expect("the case mag_out_ellipsoid_fit exists");
    let _ = writeln!(
        txt,
        "equal to the CLI: wiical fit ({} windows) within {} ulp, wiical magfit within {} ulp",
        poses.len(),
        check_fit_against_cli(&poses, &fit),
        check_mag_against_cli(&mag)
    );
    fs::write(out.join("expected.txt"), txt).expect("write expected.txt");
}

/// The shared recordings: `$WIICAL_DATA`, else `<workspace>/../shared/data`.
fn data_dir() -> PathBuf {
    env::var_os("WIICAL_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            let manifest =
                PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").expect("CARGO_MANIFEST_DIR"));
            manifest.join("../../shared/data")
        })
}

/// Reads a whitespace-separated numeric text file of `cols` columns; fails the build with a
/// message naming the file and `WIICAL_DATA` when it cannot be read.
fn read_table(path: &Path, cols: usize, rows: usize) -> Vec<Vec<f64>> {
    let text = fs::read_to_string(path).unwrap_or_else(|e| {
        panic!(
            "cannot read the real recording {} ({e}): set WIICAL_DATA to the shared data \
             directory (default <workspace>/../shared/data); the data is read in place, never \
             copied into the repository",
            path.display()
        )
    });
    let table: Vec<Vec<f64>> = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty())
        .map(|(i, l)| {
            let row: Vec<f64> = l
                .split_ascii_whitespace()
                .map(|f| {
                    f.parse::<f64>()
                        .ok()
                        .filter(|v| v.is_finite())
                        .unwrap_or_else(|| {
                            panic!("{} line {}: '{f}' is not a number", path.display(), i + 1)
                        })
                })
                .collect();
            assert_eq!(
                row.len(),
                cols,
                "{} line {}: expected {cols} columns",
                path.display(),
                i + 1
            );
            row
        })
        .collect();
    assert_eq!(
        table.len(),
        rows,
        "{}: expected {rows} rows (is WIICAL_DATA the right directory?)",
        path.display()
    );
    table
}

/// `f64` file values to the core's `f32`, as the CLI converts them (`v as f32`).
fn to_f32(v: &[f64]) -> [f32; 3] {
    [v[0] as f32, v[1] as f32, v[2] as f32]
}

/// Reads both recordings, runs the detector on the Xsens one (the poses), fills
/// [`real_data`] and writes `real_data.rs` / `xsens_acc.f32le` to `out`. Returns the poses.
fn load_real_data(out: &Path, xsens_path: &Path, mag_path: &Path) -> Vec<[f32; 3]> {
    let xsens = read_table(xsens_path, 4, XSENS_ROWS);
    // `wiical fit` takes the rate from the median time step (`Recording::estimated_rate_hz`)
    // and builds the detector settings from it in f32: check that this gives the 100 Hz the
    // cases assume.
    let mut dts: Vec<f64> = xsens.windows(2).map(|w| w[1][0] - w[0][0]).collect();
    dts.sort_by(f64::total_cmp);
    let rate = (1.0 / dts[dts.len() / 2]) as f32;
    assert_eq!(
        rate,
        100.0,
        "{}: the CLI would use {rate} Hz, the cases assume 100 Hz",
        xsens_path.display()
    );
    let bytes: Vec<u8> = xsens
        .iter()
        .flat_map(|r| to_f32(&r[1..]))
        .flat_map(f32::to_le_bytes)
        .collect();
    fs::write(out.join("xsens_acc.f32le"), &bytes).expect("write xsens_acc.f32le");
    real_data::XSENS_ACC.set(bytes).expect("set once");

    let mut poses = Vec::new();
    cases::xsens_detect(|iv| {
        poses.push(iv.mean);
        Ok(())
    })
    .unwrap_or_else(|e| panic!("static detection on {}: {e}", xsens_path.display()));
    real_data::XSENS_POSES.set(poses.clone()).expect("set once");

    let mag: Vec<[f32; 3]> = read_table(mag_path, 3, MAG_ROWS)
        .iter()
        .map(|r| to_f32(r))
        .collect();
    real_data::MAG_OUT.set(mag.clone()).expect("set once");

    let mut rs = String::from(
        "// Generated by build.rs from the real recordings (see there); not in the repository.\n\n\
         /// `imu_tk_xsens/xsens_acc.mat`: raw counts as little-endian `f32` triplets.\n\
         static XSENS_ACC_F32LE: &[u8] = include_bytes!(concat!(env!(\"OUT_DIR\"), \"/xsens_acc.f32le\"));\n\n",
    );
    write_points(
        &mut rs,
        "Static-window means of the Xsens recording (host detector, `wiical fit` defaults).",
        "XSENS_POSES",
        &poses,
    );
    write_points(
        &mut rs,
        "`mag_ellipsoid_fit_python/mag_out.txt`, file order.",
        "MAG_OUT_POINTS",
        &mag,
    );
    fs::write(out.join("real_data.rs"), rs).expect("write real_data.rs");
    poses
}

/// Writes `const NAME: [[f32; 3]; N]` with the exact bits (the decimal value as a comment).
fn write_points(rs: &mut String, doc: &str, name: &str, pts: &[[f32; 3]]) {
    let _ = writeln!(rs, "/// {doc}\nconst {name}: [[f32; 3]; {}] = [", pts.len());
    for p in pts {
        let b = p.map(f32::to_bits);
        let _ = writeln!(
            rs,
            "    [f32::from_bits({:#010x}), f32::from_bits({:#010x}), f32::from_bits({:#010x})], // {p:?}",
            b[0], b[1], b[2]
        );
    }
    rs.push_str("];\n\n");
}

/// Largest ulp distance between `got` and `want`; fails the build naming `what` beyond
/// [`CLI_MAX_ULPS`].
fn compare(what: &str, got: &[f32], want: &[f32]) -> u32 {
    assert_eq!(got.len(), want.len(), "{what}: value count");
    let mut worst = 0;
    for (i, (g, w)) in got.iter().zip(want).enumerate() {
        let d = cases::ulp_distance(*g, *w);
        assert!(
            d <= CLI_MAX_ULPS,
            "{what}: value {i} is {g:e} here but the CLI prints {w:e} ({d} ulp): the build \
             script no longer reproduces the CLI's pipeline, or the core changed (then re-run \
             the CLI and update the CLI_* constants in build.rs)"
        );
        worst = worst.max(d);
    }
    worst
}

/// The host result of `xsens_multipos_fit` (bias, K row-major, rms, …) against `wiical fit
/// --json`: window count, bias, matrix and `rms_mg` (the CLI reports `1000 · rms` in f32).
fn check_fit_against_cli(poses: &[[f32; 3]], fit: &[f32]) -> u32 {
    assert_eq!(
        poses.len(),
        CLI_FIT_WINDOWS,
        "static windows in the Xsens recording: {} here, {CLI_FIT_WINDOWS} in `wiical fit`",
        poses.len()
    );
    let mut got: Vec<f32> = fit[..12].to_vec();
    got.push(1000.0 * fit[12]);
    let mut want: Vec<f32> = CLI_FIT_BIAS.to_vec();
    want.extend(CLI_FIT_MATRIX.iter().flatten());
    want.push(CLI_FIT_RMS_MG);
    compare("xsens_multipos_fit vs `wiical fit --json`", &got, &want)
}

/// The host result of `mag_out_ellipsoid_fit` (centre, W, radius, fit error %, RMS radius
/// error, semi-axes) against `wiical magfit --json` (all but the semi-axes).
fn check_mag_against_cli(mag: &[f32]) -> u32 {
    let want: Vec<f32> = CLI_MAG.iter().map(|v| *v as f32).collect();
    compare(
        "mag_out_ellipsoid_fit vs `wiical magfit --json`",
        &mag[..CLI_MAG.len()],
        &want,
    )
}
