//! `magfit`'s one pass driver (`magnetometer::pass`) on a file's rows read in passes
//! (`TextSource`) against the same file loaded whole (a held `Recording`, its medians counted
//! by value): the whole JSON of the fit and the loop, or the refusal's sentence, must be
//! equal — on every real magnetometer recording the text reader takes, and on a simulated
//! recording with a temperature column, with the medians counted by value and selected by
//! bits (none counted by value).

use std::path::{Path, PathBuf};
use wiical_analysis::input::columns::Sensor;
use wiical_analysis::input::text_source::TextSource;
use wiical_analysis::magnetometer::{self, pass, Follow, MagModel};
use wiical_analysis::search::select::ALPHA;
use wiical_analysis::source::RowSource;
use wiical_analysis::LoadOptions;
use wiical_sim::magnetometer::{simulate_mag, MagEffectTruth, MagSimConfig};

fn data(rel: &str) -> PathBuf {
    let root = std::env::var("WIICAL_DATA").unwrap_or_else(|_| {
        concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data").to_string()
    });
    let p = Path::new(&root).join(rel);
    assert!(
        p.exists(),
        "test data missing: {} (set WIICAL_DATA)",
        p.display()
    );
    p
}

fn opts(columns: Option<&str>) -> LoadOptions {
    LoadOptions {
        columns: columns.map(|c| {
            let v: Vec<String> = c.split(',').map(String::from).collect();
            [v[0].clone(), v[1].clone(), v[2].clone()]
        }),
        sensor: Some(Sensor::Magnetometer),
        ..Default::default()
    }
}

/// The fit and the loop of `src` with the columns `follow`, counting at most `counted`
/// values by value: the JSON, or the error.
fn run<R: RowSource>(
    src: &R,
    follow: Vec<Follow<R>>,
    model: MagModel,
    counted: usize,
) -> Result<String, String> {
    let prep = pass::fit_source_counting(src, model, counted).map_err(|e| e.to_string())?;
    let an = magnetometer::analyze_source(src, &prep, &follow, model, ALPHA)
        .map_err(|e| e.to_string())?;
    Ok(json(&prep.report, &an))
}

/// The recording held whole, as the CLI holds a small file.
fn held(path: &Path, o: &LoadOptions, follow: &[&str], model: MagModel) -> String {
    let got = || -> Result<String, String> {
        let rec = wiical_analysis::load(path, o).map_err(|e| e.to_string())?;
        let cols = follow.iter().map(|name| {
            let fo = pass::follow_options(name, &rec.axis_columns, &Default::default());
            (name.to_string(), wiical_analysis::load(path, &fo).unwrap())
        });
        run(&rec, cols.collect(), model, pass::MAX_COUNTED)
    };
    got().unwrap_or_else(|e| format!("error: {e}"))
}

/// The file read in passes, counting at most `counted` values by value.
fn streamed(
    path: &Path,
    o: &LoadOptions,
    follow: &[&str],
    model: MagModel,
    counted: usize,
) -> String {
    let Some(src) = TextSource::open(path, o, |_| true).unwrap() else {
        return "read whole".into();
    };
    let cols = follow.iter().map(|name| {
        let fo = pass::follow_options(name, &src.meta.axis_columns, &Default::default());
        let col = TextSource::open(path, &fo, |_| true).unwrap().unwrap();
        (name.to_string(), col)
    });
    run(&src, cols.collect(), model, counted).unwrap_or_else(|e| format!("error: {e}"))
}

fn json(rep: &magnetometer::MagFitReport, an: &magnetometer::MagAnalysis) -> String {
    let mut v = serde_json::to_value(rep).unwrap();
    let a = serde_json::to_value(an).unwrap();
    v.as_object_mut()
        .unwrap()
        .extend(a.as_object().unwrap().clone());
    serde_json::to_string(&v).unwrap()
}

/// Every real magnetometer recording: the same JSON (or refusal) in passes as held, with the
/// medians counted by value (the default) and selected by bits (nothing counted).
#[test]
fn real_recordings_stream_as_held() {
    let files = [
        ("qmc5883l_mag_tomisuarez/noisy_raw_data.csv", None),
        ("qmc5883l_mag_tomisuarez/filtered_raw_data.csv", None),
        ("mag_ellipsoid_fit_python/mag_out.txt", None),
        ("acc_mag_ck_explorer/acc_mag_log.csv", Some("mx,my,mz")),
        (
            "mpu6050_hmc5883l_sunsided_set2/full-sphere_hmc5883l.csv",
            None,
        ),
        (
            "mpu6050_hmc5883l_sunsided_set2/roll-and-tilt-at-45-90_hmc5883l.csv",
            None,
        ),
        (
            "mpu6050_hmc5883l_sunsided_set2/unmoved-with-x-pointing-forward_hmc5883l.csv",
            None,
        ),
    ];
    let (mut refused, mut streamed_files) = (0, 0);
    for (rel, cols) in files {
        let path = data(rel);
        let o = opts(cols);
        let want = held(&path, &o, &[], MagModel::Ellipsoid);
        refused += usize::from(want.starts_with("error:"));
        for counted in [pass::MAX_COUNTED, 0] {
            let got = streamed(&path, &o, &[], MagModel::Ellipsoid, counted);
            if got != "read whole" {
                assert_eq!(got, want, "{rel}, counting {counted} by value");
                streamed_files += usize::from(counted == 0);
            }
        }
    }
    // The unmoved log is refused on both paths, the rest fitted.
    assert_eq!(refused, 1);
    assert!(streamed_files >= 5, "{streamed_files} streamed");
}

/// A simulated magnetometer recording with `effect` (seed `seed`) written in `dir` as
/// `mag.csv`: `t,mx,my,mz,temp,current`.
fn simulated_csv(dir: &Path, effect: MagEffectTruth, seed: u64) -> PathBuf {
    let sim = simulate_mag(&MagSimConfig {
        effect,
        seed,
        ..Default::default()
    });
    let path = dir.join("mag.csv");
    let mut text = String::from("t,mx,my,mz,temp,current\n");
    for i in 0..sim.xyz.len() {
        let [x, y, z] = sim.xyz[i];
        text += &format!(
            "{},{x},{y},{z},{},{}\n",
            sim.t[i], sim.temp[i], sim.current[i]
        );
    }
    std::fs::write(&path, text).unwrap();
    path
}

/// A simulated recording with a centre drift and a temperature column, written as text:
/// every model's JSON in passes is the held one, the medians selected by bits.
#[test]
fn simulation_streams_as_held() {
    let dir = tempfile::tempdir().unwrap();
    let path = simulated_csv(dir.path(), MagEffectTruth::Drift([0.2, -0.1, 0.15]), 7);
    let o = opts(None);
    for model in MagModel::ALL {
        let want = held(&path, &o, &[], model);
        assert!(want.contains("centre-drift"), "{model}: {want}");
        assert_eq!(streamed(&path, &o, &[], model, 0), want, "{model}");
    }
    // A followed column (the loader once refused it as "one column twice"): read on both
    // paths, its candidate tested, the same report.
    let want = held(&path, &o, &["current"], MagModel::Ellipsoid);
    assert!(
        !want.starts_with("error") && want.contains("current"),
        "{want}"
    );
    let got = streamed(&path, &o, &["current"], MagModel::Ellipsoid, 0);
    assert_eq!(got, want);
}

/// Large interference (the centre moving by 10 % of the field with the current): the loop's
/// second pass about its first estimate (base refitted without the shift, the loop again)
/// reads the file three more times; the report is the held one, bit for bit, and names the
/// effect.
#[test]
fn relinearised_interference_streams_as_held() {
    let dir = tempfile::tempdir().unwrap();
    let path = simulated_csv(
        dir.path(),
        MagEffectTruth::Interference([5.0, 2.0, -3.0]),
        11,
    );
    let o = opts(None);
    let want = held(&path, &o, &["current"], MagModel::Ellipsoid);
    assert!(want.contains("\"name\":\"interference:current\""), "{want}");
    assert_eq!(
        streamed(&path, &o, &["current"], MagModel::Ellipsoid, 0),
        want
    );
}
