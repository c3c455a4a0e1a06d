//! Axis columns recognised by pattern: `x`, `ax`, `acc_x_g`, `accel_x`, `AccX`, `ax_mps2`,
//! `mag_x_gauss`, `gyro_x_dps`, `x_g`, … map to an axis triplet of one sensor.
//!
//! A header name (lower-cased by the loader) is split into words at `_`, `-`, `.`, spaces and
//! letter/digit boundaries, after splitting a glued axis letter off a sensor word (`accx`,
//! `accelx`, `magx`, `gyrox`); camel case is already gone with the lower-casing, so `AccX`
//! arrives as `accx`. A name is an axis column when exactly one word is an axis letter (`x`,
//! `y`, `z`) or a short axis form (`ax`, `mx`, `gx`); the other words name the sensor
//! (`acc`, `accel`, `accelerometer`, `a` → accelerometer; `mag`, `magnetometer`, `m`, `compass`
//! → magnetometer; `gyro`, `gyroscope`, `g`, `w`, `omega` → gyroscope) or a unit (`g`, `mg`,
//! `mps2`, `ms2`, `m/s^2`, `gauss`, `ut`, `dps`, `rads`, `raw`, `counts`, …), which also tells the
//! sensor (`dps` is a gyro, `gauss` a magnetometer). A bare `x,y,z` is "any" sensor. Three
//! names that differ only in the axis letter form a triplet.
//!
//! [`find_triplet`] picks, for the sensor the command wants, the first triplet of that sensor
//! (or of an unnamed one); the loader reports which it took.

/// What a column triplet measures.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sensor {
    /// Accelerometer (`fit`, `analyze`).
    Accelerometer,
    /// Magnetometer (`magfit`).
    Magnetometer,
    /// Gyroscope.
    Gyroscope,
    /// Not said (`x,y,z`, `x_raw`).
    Unnamed,
}

impl Sensor {
    /// Name for messages.
    pub fn name(self) -> &'static str {
        match self {
            Sensor::Accelerometer => "accelerometer",
            Sensor::Magnetometer => "magnetometer",
            Sensor::Gyroscope => "gyroscope",
            Sensor::Unnamed => "unnamed sensor",
        }
    }
}

/// Which columns a loader takes (`crate::load`, `crate::input::raw`): explicit header names, else
/// the named sensor's triplet.
#[derive(Debug, Clone, Default)]
pub struct LoadOptions {
    /// Explicit header names for the x, y, z columns (e.g. `["gx","gy","gz"]`).
    pub columns: Option<[String; 3]>,
    /// Which sensor's triplet to take from a header naming several (`None`: the
    /// accelerometer).
    pub sensor: Option<Sensor>,
    /// How the file is read (streaming threshold, standard input's copy, spill): not which
    /// columns, but every loader takes it from here so that it reaches each reader.
    pub read: crate::input::read_options::ReadOptions,
}

/// One axis triplet found in a header.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Triplet {
    /// Column indices of x, y, z.
    pub columns: [usize; 3],
    /// The sensor the names say.
    pub sensor: Sensor,
}

/// Words that name a sensor, and the sensor.
const SENSOR_WORDS: &[(&str, Sensor)] = &[
    ("acc", Sensor::Accelerometer),
    ("accel", Sensor::Accelerometer),
    ("accelerometer", Sensor::Accelerometer),
    ("acceleration", Sensor::Accelerometer),
    ("a", Sensor::Accelerometer),
    ("mag", Sensor::Magnetometer),
    ("magnetometer", Sensor::Magnetometer),
    ("magn", Sensor::Magnetometer),
    ("compass", Sensor::Magnetometer),
    ("m", Sensor::Magnetometer),
    ("gyro", Sensor::Gyroscope),
    ("gyroscope", Sensor::Gyroscope),
    ("gyr", Sensor::Gyroscope),
    ("w", Sensor::Gyroscope),
    ("omega", Sensor::Gyroscope),
];

/// Unit words, and the sensor a unit implies (`None`: says nothing about the sensor).
const UNIT_WORDS: &[(&str, Option<Sensor>)] = &[
    ("g", Some(Sensor::Accelerometer)),
    ("mg", Some(Sensor::Accelerometer)),
    ("mps2", Some(Sensor::Accelerometer)),
    ("ms2", Some(Sensor::Accelerometer)),
    ("m/s^2", Some(Sensor::Accelerometer)),
    ("m/s2", Some(Sensor::Accelerometer)),
    ("gauss", Some(Sensor::Magnetometer)),
    ("ut", Some(Sensor::Magnetometer)),
    ("nt", Some(Sensor::Magnetometer)),
    ("mgauss", Some(Sensor::Magnetometer)),
    ("dps", Some(Sensor::Gyroscope)),
    ("degs", Some(Sensor::Gyroscope)),
    ("rads", Some(Sensor::Gyroscope)),
    ("rad/s", Some(Sensor::Gyroscope)),
    ("raw", None),
    ("counts", None),
    ("adc", None),
];

/// Short axis forms with the sensor letter glued on (`ax`, `mx`, `gx`).
const SHORT_FORMS: &[(&str, Sensor)] = &[
    ("a", Sensor::Accelerometer),
    ("m", Sensor::Magnetometer),
    ("g", Sensor::Gyroscope),
];

/// A header name understood as one axis of a sensor: `(axis 0..3, sensor, the name with the
/// axis replaced by `*` — the key three names of a triplet share)`. `None`: not an axis.
pub fn classify(name: &str) -> Option<(usize, Sensor, String)> {
    let words = split_words(name);
    let mut axis: Option<(usize, usize, Option<Sensor>)> = None; // (word, axis, short-form sensor)
    for (i, w) in words.iter().enumerate() {
        let found = axis_of(w);
        if let Some((a, s)) = found {
            if axis.is_some() {
                return None; // two axis words: not one axis column
            }
            axis = Some((i, a, s));
        }
    }
    let (wi, a, short) = axis?;
    let mut sensor = short;
    for (i, w) in words.iter().enumerate() {
        if i == wi {
            continue;
        }
        let named = SENSOR_WORDS
            .iter()
            .find(|(k, _)| k == w)
            .map(|(_, s)| Some(*s))
            .or_else(|| UNIT_WORDS.iter().find(|(k, _)| k == w).map(|(_, s)| *s));
        match named {
            // A unit like `g` after the axis says g, not gyro: units come after the axis.
            Some(Some(s)) if sensor.is_none() || (i > wi && is_unit(w)) => {
                sensor = sensor.or(Some(s));
            }
            Some(_) => {}
            None => return None, // an unknown word: not an axis column we understand
        }
    }
    let key: Vec<String> = words
        .iter()
        .enumerate()
        .map(|(i, w)| if i == wi { "*".into() } else { w.clone() })
        .collect();
    Some((a, sensor.unwrap_or(Sensor::Unnamed), key.join("_")))
}

fn is_unit(w: &str) -> bool {
    UNIT_WORDS.iter().any(|(k, _)| *k == w)
}

/// `x`/`y`/`z` → (axis, None); `ax`/`mx`/`gx` → (axis, its sensor).
fn axis_of(w: &str) -> Option<(usize, Option<Sensor>)> {
    let letter = |c: char| "xyz".find(c);
    let mut chars = w.chars();
    match (chars.next(), chars.next(), chars.next()) {
        (Some(c), None, None) => letter(c).map(|a| (a, None)),
        (Some(s), Some(c), None) => {
            let sensor = SHORT_FORMS
                .iter()
                .find(|(k, _)| k.starts_with(s))
                .map(|(_, v)| *v)?;
            letter(c).map(|a| (a, Some(sensor)))
        }
        _ => None,
    }
}

/// Words of a lower-cased name (see the module docs).
fn split_words(name: &str) -> Vec<String> {
    let mut words = Vec::new();
    for part in name.split(['_', '-', '.', ' ', '(', ')', '[', ']']) {
        if part.is_empty() {
            continue;
        }
        // A unit with a slash stays whole (`m/s^2`).
        if UNIT_WORDS.iter().any(|(k, _)| *k == part) {
            words.push(part.to_string());
            continue;
        }
        // `accx`, `accelx`, `magx`, `gyrox`: a sensor word with the axis letter glued on.
        let glued = SENSOR_WORDS.iter().find_map(|(k, _)| {
            let rest = part.strip_prefix(k)?;
            (k.len() > 1 && rest.len() == 1 && "xyz".contains(rest)).then_some((*k, rest))
        });
        if let Some((k, rest)) = glued {
            words.push(k.to_string());
            words.push(rest.to_string());
            continue;
        }
        words.push(part.replace('/', ""));
    }
    // Units written in two words (`rad_s`, `deg_s`, `m_s2`) are one unit word.
    let mut merged: Vec<String> = Vec::with_capacity(words.len());
    for w in words {
        let joined = match (merged.last().map(String::as_str), w.as_str()) {
            (Some("rad"), "s") => Some("rads"),
            (Some("deg"), "s") => Some("degs"),
            (Some("m"), "s2") => Some("ms2"),
            _ => None,
        };
        match joined {
            Some(j) => *merged.last_mut().expect("checked above") = j.to_string(),
            None => merged.push(w),
        }
    }
    merged
}

/// The unit a column's name states (`gyro_x_dps` → `deg/s`, `acc_x_g` → `g`, `gyro_x_rad_s`
/// → `rad/s`, `acc_x_ms2` → `m/s^2`); `None` when the name states none (`gx`, `x_raw`).
pub fn unit_of(name: &str) -> Option<&'static str> {
    let words = split_words(&name.to_ascii_lowercase());
    Some(match words.last()?.as_str() {
        "dps" | "degs" => "deg/s",
        "rads" | "rad/s" => "rad/s",
        "g" => "g",
        "mg" => "mg",
        "mps2" | "ms2" | "m/s^2" | "m/s2" => "m/s^2",
        "gauss" => "gauss",
        "mgauss" => "mgauss",
        "ut" => "uT",
        "nt" => "nT",
        _ => return None,
    })
}

/// The sensor a header name is an axis of (any case); `None`: not an axis column.
pub fn column_sensor(name: &str) -> Option<Sensor> {
    classify(&name.to_ascii_lowercase()).map(|(_, s, _)| s)
}

/// True when every name is an axis of `sensor` by its name (`gx`, `gyro_x_dps` for the
/// gyroscope): a triplet the loader took by name, not as its fallback.
pub fn all_named(names: &[String], sensor: Sensor) -> bool {
    names.iter().all(|n| column_sensor(n) == Some(sensor))
}

/// The unit of a triplet: the one all three names state, else `None`.
pub fn triplet_unit(names: &[String; 3]) -> Option<&'static str> {
    let u = unit_of(&names[0])?;
    (unit_of(&names[1]) == Some(u) && unit_of(&names[2]) == Some(u)).then_some(u)
}

/// Every axis triplet in `fields` (lower-cased header names), in header order of their x
/// column.
pub fn triplets(fields: &[String]) -> Vec<Triplet> {
    let classes: Vec<Option<(usize, Sensor, String)>> =
        fields.iter().map(|f| classify(f)).collect();
    let mut out = Vec::new();
    for (i, c) in classes.iter().enumerate() {
        let Some((0, sensor, key)) = c else { continue };
        let find = |axis: usize| {
            classes.iter().position(|o| {
                o.as_ref()
                    .is_some_and(|(a, s, k)| *a == axis && s == sensor && k == key)
            })
        };
        if let (Some(y), Some(z)) = (find(1), find(2)) {
            out.push(Triplet {
                columns: [i, y, z],
                sensor: *sensor,
            });
        }
    }
    out
}

/// The triplet for `want`: the first of that sensor, else the first unnamed one (`x,y,z`),
/// else the first triplet at all (a file holding only another sensor's axes is taken as it
/// is, as before names were read by pattern). `None` when the header has no triplet.
pub fn find_triplet(fields: &[String], want: Sensor) -> Option<Triplet> {
    let all = triplets(fields);
    all.iter()
        .find(|t| t.sensor == want)
        .or_else(|| all.iter().find(|t| t.sensor == Sensor::Unnamed))
        .or_else(|| all.first())
        .cloned()
}

/// One sentence saying which triplet was taken for `want` when the header offers a choice
/// (several triplets) or none of the wanted sensor; `None` when there was nothing to choose.
/// `fields`: the header names, `chosen`: what [`find_triplet`] returned.
pub fn choice_note(fields: &[String], chosen: &Triplet, want: Sensor) -> Option<String> {
    let all = triplets(fields);
    let names = |t: &Triplet| t.columns.map(|i| fields[i].as_str()).join(",");
    let described = |t: &Triplet| format!("{} ({})", t.sensor.name(), names(t));
    if chosen.sensor != want && chosen.sensor != Sensor::Unnamed {
        return Some(format!(
            "no {} columns named in the header; took the {} for it",
            want.name(),
            described(chosen)
        ));
    }
    if all.len() < 2 {
        return None;
    }
    let others: Vec<String> = all.iter().filter(|t| *t != chosen).map(described).collect();
    Some(format!(
        "took {} as the {}; also in the header: {}",
        names(chosen),
        want.name(),
        others.join(", ")
    ))
}

#[cfg(test)]
mod tests {

    #[test]
    fn units_are_read_from_the_names() {
        assert_eq!(unit_of("gyro_x_dps"), Some("deg/s"));
        assert_eq!(unit_of("gyro_x_rad_s"), Some("rad/s"));
        assert_eq!(unit_of("gyro_x_rads"), Some("rad/s"));
        assert_eq!(unit_of("acc_x_g"), Some("g"));
        assert_eq!(unit_of("acc_x_ms2"), Some("m/s^2"));
        assert_eq!(unit_of("acc_x_mps2"), Some("m/s^2"));
        assert_eq!(unit_of("mag_x_uT"), Some("uT"));
        assert_eq!(unit_of("gx"), None);
        assert_eq!(unit_of("x_raw"), None);
        let names = ["gyro_x_dps", "gyro_y_dps", "gyro_z_dps"].map(String::from);
        assert_eq!(triplet_unit(&names), Some("deg/s"));
        let mixed = ["gyro_x_dps", "gyro_y_rads", "gyro_z_dps"].map(String::from);
        assert_eq!(triplet_unit(&mixed), None);
        // A two-word unit keeps the column an axis of its sensor.
        let (axis, sensor, _) = classify("gyro_y_rad_s").unwrap();
        assert_eq!((axis, sensor), (1, Sensor::Gyroscope));
    }

    use super::*;

    fn fields(s: &str) -> Vec<String> {
        s.split(',').map(|f| f.to_ascii_lowercase()).collect()
    }

    #[test]
    fn names_from_the_issue_map_to_the_right_sensor_and_axis() {
        for (name, axis, sensor) in [
            ("acc_x_g", 0, Sensor::Accelerometer),
            ("accel_y", 1, Sensor::Accelerometer),
            ("accz", 2, Sensor::Accelerometer),
            ("ax_mps2", 0, Sensor::Accelerometer),
            ("mag_x_gauss", 0, Sensor::Magnetometer),
            ("gyro_z_dps", 2, Sensor::Gyroscope),
            ("x_g", 0, Sensor::Accelerometer),
            ("gx", 0, Sensor::Gyroscope),
            ("my", 1, Sensor::Magnetometer),
            ("x", 0, Sensor::Unnamed),
            ("z_raw", 2, Sensor::Unnamed),
        ] {
            let (a, s, _) = classify(&name.to_ascii_lowercase())
                .unwrap_or_else(|| panic!("{name} not recognised"));
            assert_eq!((a, s), (axis, sensor), "{name}");
        }
        // `AccX` arrives lower-cased from the loader.
        assert_eq!(
            classify("accx").map(|c| (c.0, c.1)),
            Some((0, Sensor::Accelerometer))
        );
        for name in ["t_s", "temp", "time", "pose", "xy", "max", "index", "x_y"] {
            assert!(classify(name).is_none(), "{name}");
        }
    }

    #[test]
    fn the_command_picks_its_sensor_from_a_mixed_header() {
        let f = fields("t_s,acc_x_g,acc_y_g,acc_z_g,gyro_x_dps,gyro_y_dps,gyro_z_dps");
        let acc = find_triplet(&f, Sensor::Accelerometer).unwrap();
        assert_eq!(acc.columns, [1, 2, 3]);
        let gyro = find_triplet(&f, Sensor::Gyroscope).unwrap();
        assert_eq!(gyro.columns, [4, 5, 6]);
        // No magnetometer: the first triplet, as the loader always did.
        assert_eq!(
            find_triplet(&f, Sensor::Magnetometer).unwrap().sensor,
            Sensor::Accelerometer
        );
        let f = fields("t_s,mag_x_gauss,mag_y_gauss,mag_z_gauss");
        assert_eq!(
            find_triplet(&f, Sensor::Magnetometer).unwrap().columns,
            [1, 2, 3]
        );
        assert_eq!(
            find_triplet(&f, Sensor::Accelerometer).unwrap().sensor,
            Sensor::Magnetometer
        );
        let f = fields("AccX,AccY,AccZ,MagX,MagY,MagZ");
        assert_eq!(
            find_triplet(&f, Sensor::Magnetometer).unwrap().columns,
            [3, 4, 5]
        );
        assert_eq!(
            find_triplet(&f, Sensor::Accelerometer).unwrap().columns,
            [0, 1, 2]
        );
        // Plain x,y,z serve any command.
        let f = fields("t,x,y,z,temp");
        assert_eq!(
            find_triplet(&f, Sensor::Magnetometer).unwrap().columns,
            [1, 2, 3]
        );
        // Axes of different units do not form a triplet.
        let f = fields("acc_x_g,acc_y_g,acc_z_mg");
        assert!(triplets(&f).is_empty());
    }

    #[test]
    fn the_choice_is_said_when_there_was_one() {
        let f = fields("t_s,acc_x_g,acc_y_g,acc_z_g,gyro_x_dps,gyro_y_dps,gyro_z_dps");
        let acc = find_triplet(&f, Sensor::Accelerometer).unwrap();
        let note = choice_note(&f, &acc, Sensor::Accelerometer).unwrap();
        assert_eq!(
            note,
            "took acc_x_g,acc_y_g,acc_z_g as the accelerometer; also in the header: gyroscope (gyro_x_dps,gyro_y_dps,gyro_z_dps)"
        );
        // Only a magnetometer in the file, the accelerometer wanted: said plainly.
        let f = fields("t_s,mag_x_gauss,mag_y_gauss,mag_z_gauss");
        let mag = find_triplet(&f, Sensor::Accelerometer).unwrap();
        let note = choice_note(&f, &mag, Sensor::Accelerometer).unwrap();
        assert!(note.starts_with("no accelerometer columns named"), "{note}");
        // One plain triplet: nothing to say.
        let f = fields("t,x,y,z");
        let xyz = find_triplet(&f, Sensor::Accelerometer).unwrap();
        assert_eq!(choice_note(&f, &xyz, Sensor::Accelerometer), None);
        // Short forms pair only with their own sensor: `gx` is not the x of `y,z`.
        let f = fields("t,x,y,z,gx,gy,gz");
        let found: Vec<_> = triplets(&f).iter().map(|t| (t.columns, t.sensor)).collect();
        assert_eq!(
            found,
            [([1, 2, 3], Sensor::Unnamed), ([4, 5, 6], Sensor::Gyroscope)]
        );
    }
}
