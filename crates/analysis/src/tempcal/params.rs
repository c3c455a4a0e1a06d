//! The autopilots' parameter files of a [`super::TempcalReport`] (accelerometer 1 / instance 0).
//!
//! **ArduPilot** (`AP_InertialSensor_tempcal.cpp`, `Tools/scripts/tempcal_IMU.py`):
//! `INS_TCAL1_ENABLE 1`, `INS_TCAL1_TMIN`, `INS_TCAL1_TMAX` (°C) and
//! `INS_TCAL1_ACCk_X/Y/Z` (k = 1, 2, 3: linear, quadratic, cubic) about the fixed reference
//! 35 °C, in m/s² per °C^k **scaled by 10⁶** (the firmware's `SCALE_FACTOR`: it multiplies by
//! 1e-6 when evaluating). The firmware clamps the temperature to [TMIN, TMAX] and subtracts
//! the polynomial from the reading (adding it back at the accelerometer calibration's
//! temperature), so the coefficients are the bias's, as here. One `NAME VALUE` per line, as
//! `tempcal_IMU.py` writes `tcal.parm`; `#` lines are comments.
//!
//! **PX4** (`TemperatureCompensation.cpp`, `temp_comp_params_accel.c`,
//! `Tools/process_sensor_caldata.py`): `TC_A_ENABLE`, `TC_A0_TREF`, `TC_A0_TMIN`,
//! `TC_A0_TMAX` (°C) and `TC_A0_Xk_i` (k = 0..3 the power of `T − TREF`, i = 0, 1, 2 the axis),
//! m/s² per °C^k, unscaled; the offset `X0 + X1·ΔT + X2·ΔT² + X3·ΔT³` (temperature clamped to
//! [TMIN, TMAX]) is subtracted from the reading. `X0` is written 0: the constant is left to the
//! ordinary accelerometer calibration done after the thermal one (PX4's own procedure).
//! QGroundControl's `.params` layout, as `process_sensor_caldata.py` writes it: tab-separated
//! `vehicle-id component-id name value type` (type 6 = int32, 9 = float). `TC_A0_ID` (the
//! sensor's device id) is not known from a CSV and is not written.

use super::TempcalReport;

/// Standard gravity, m/s² per g.
pub const G: f64 = 9.80665;
/// ArduPilot's parameter scaling of TCAL coefficients.
pub const ARDUPILOT_SCALE: f64 = 1.0e6;

/// Coefficients of `Σ c_k (T − from)^k` (k ≥ 1) re-expanded about `to` (k ≥ 1; the constant,
/// a pose-constant matter, is dropped), padded to the cube.
pub fn about(coef: &[f64], from_c: f64, to_c: f64) -> [f64; 3] {
    // (T − from) = (T − to) + s, s = to − from; (x + s)^k = Σ_j C(k,j) x^j s^(k−j).
    let s = to_c - from_c;
    let mut out = [0.0; 3];
    for (k1, c) in coef.iter().enumerate() {
        let k = k1 + 1;
        for (j1, o) in out.iter_mut().enumerate().take(k) {
            let j = j1 + 1;
            *o += c * binomial(k, j) * s.powi((k - j) as i32);
        }
    }
    out
}

fn binomial(n: usize, k: usize) -> f64 {
    (0..k).fold(1.0, |acc, i| acc * (n - i) as f64 / (i + 1) as f64)
}

/// ArduPilot `.parm` text. `to_ms2` converts the file's units to m/s².
pub fn ardupilot(rep: &TempcalReport, to_ms2: f64) -> String {
    let mut o = String::new();
    o.push_str(
        "# wiical tempcal: accelerometer bias against temperature (ArduPilot TCAL, IMU 1)\n",
    );
    o.push_str(&format!(
        "# coefficients: 1e-6 m/s^2 per degC^k about 35 degC; orders chosen {}\n",
        orders(rep)
    ));
    o.push_str("INS_TCAL1_ENABLE 1\n");
    o.push_str(&format!("INS_TCAL1_TMIN {:.1}\n", rep.t_min_c));
    o.push_str(&format!("INS_TCAL1_TMAX {:.1}\n", rep.t_max_c));
    let c: Vec<[f64; 3]> = rep
        .axes
        .iter()
        .map(|a| about(&a.coefficients, rep.t_ref_c, super::TEMP_REF_C))
        .collect();
    for k in 0..3 {
        for (ck, name) in c.iter().zip(["X", "Y", "Z"]) {
            let v = ck[k] * to_ms2 * ARDUPILOT_SCALE;
            o.push_str(&format!("INS_TCAL1_ACC{}_{name} {v:.9}\n", k + 1));
        }
    }
    o
}

/// PX4 `.params` text (QGroundControl layout). `to_ms2` converts the file's units to m/s².
pub fn px4(rep: &TempcalReport, to_ms2: f64) -> String {
    let mut o = String::new();
    o.push_str("# Sensor thermal compensation parameters (wiical tempcal, accelerometer 0)\n");
    o.push_str(&format!(
        "# orders chosen {}; set TC_A0_ID to the accelerometer's device id (CAL_ACC0_ID)\n",
        orders(rep)
    ));
    o.push_str("# Vehicle-Id Component-Id Name Value Type\n");
    let mut line = |name: &str, value: String, ty: u8| {
        o.push_str(&format!("1\t1\t{name}\t{value}\t{ty}\n"));
    };
    line("TC_A_ENABLE", "1".into(), 6);
    line("TC_A0_TREF", format!("{}", rep.t_ref_c), 9);
    line("TC_A0_TMIN", format!("{:.3}", rep.t_min_c), 9);
    line("TC_A0_TMAX", format!("{:.3}", rep.t_max_c), 9);
    for (i, a) in rep.axes.iter().enumerate() {
        line(&format!("TC_A0_X0_{i}"), "0".into(), 9);
        for k in 0..3 {
            let v = a.coefficients.get(k).copied().unwrap_or(0.0) * to_ms2;
            line(&format!("TC_A0_X{}_{i}", k + 1), format!("{v:e}"), 9);
        }
    }
    o
}

fn orders(rep: &TempcalReport) -> String {
    rep.axes
        .iter()
        .map(|a| a.order.to_string())
        .collect::<Vec<_>>()
        .join(",")
}

/// Reads either file back as `(name, value)` pairs: `#` lines skipped; a line is
/// `NAME VALUE`, `NAME,VALUE` (ArduPilot) or five tab-separated fields (PX4/QGroundControl).
/// `None` when a line fits none of these.
pub fn parse(text: &str) -> Option<Vec<(String, f64)>> {
    let mut out = Vec::new();
    for line in text.lines() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let tabs: Vec<&str> = line.split('\t').collect();
        let (name, value) = match tabs.as_slice() {
            [_, _, name, value, _] => (*name, *value),
            _ => {
                let mut f = line.split([' ', ',']).filter(|s| !s.is_empty());
                let pair = (f.next()?, f.next()?);
                if f.next().is_some() {
                    return None;
                }
                pair
            }
        };
        out.push((name.to_string(), value.parse().ok()?));
    }
    Some(out)
}
