//! The orientation-dependent cross terms of `Effects` against an f64 reference written from
//! the model's definition (module docs of `wiical_core::model`) and the monomial tables'
//! exponents, independently of the core's hand-written `f32` monomials.

use proptest::prelude::*;
use wiical_core::model::{monomials, CROSS2, CROSS3, DEGREE2, DEGREE3};
use wiical_core::{Calibration, Conditions, Effects, PreparedCalibration, Terms};

/// A monomial given by its exponents, in f64.
fn mono(u: &[f64; 3], ex: &[u8; 3]) -> f64 {
    (0..3).map(|j| u[j].powi(i32::from(ex[j]))).product()
}

/// f64 reference of `Calibration::correct`, from the documented definition.
fn reference(cal: &Calibration, m: [f32; 3], cond: &Conditions) -> [f64; 3] {
    let e = &cal.effects;
    let f = f64::from;
    let dtheta = cond.temperature_c.map(|t| f(t) - f(e.temp_ref_c));
    let b: [f64; 3] = std::array::from_fn(|j| {
        f(cal.bias[j])
            + f(e.bias_drift[j]) * f(cond.time_s)
            + dtheta.map_or(0.0, |d| f(e.bias_temp[j]) * d)
    });
    let u: [f64; 3] = std::array::from_fn(|i| {
        let lin: f64 = (0..3).map(|j| f(cal.matrix[i][j]) * (f(m[j]) - b[j])).sum();
        lin * dtheta.map_or(1.0, |d| 1.0 + f(e.scale_temp[i]) * d)
    });
    std::array::from_fn(|i| {
        let x = u[i];
        let mut a = x + f(e.quadratic[i]) * x * x + f(e.cubic[i]) * x * x * x;
        for (c, k) in e.cross_quadratic[i].iter().zip(CROSS2[i]) {
            a += f(*c) * mono(&u, &DEGREE2[k]);
        }
        for (c, k) in e.cross_cubic[i].iter().zip(CROSS3[i]) {
            a += f(*c) * mono(&u, &DEGREE3[k]);
        }
        a
    })
}

/// A Nunchuk-like calibration (10-bit counts, ≈ 200 counts/g).
fn nunchuk() -> Calibration {
    Calibration {
        bias: [510.0, 514.0, 508.0],
        matrix: [
            [1.0 / 204.0, 1e-4, 0.0],
            [-2e-4, 1.0 / 198.0, 0.0],
            [0.0, 3e-4, 1.0 / 201.0],
        ],
        effects: Effects::default(),
    }
}

#[test]
fn the_tables_list_every_monomial_once_and_leave_out_the_own_power() {
    // Degree 2: the six distinct exponent triples summing to 2; degree 3: the ten summing to 3.
    let mut seen2: Vec<_> = DEGREE2.to_vec();
    seen2.sort();
    seen2.dedup();
    assert_eq!(seen2.len(), 6);
    assert!(DEGREE2.iter().all(|e| e.iter().sum::<u8>() == 2));
    let mut seen3: Vec<_> = DEGREE3.to_vec();
    seen3.sort();
    seen3.dedup();
    assert_eq!(seen3.len(), 10);
    assert!(DEGREE3.iter().all(|e| e.iter().sum::<u8>() == 3));
    for i in 0..3 {
        let mut own2 = [0u8; 3];
        own2[i] = 2;
        let mut own3 = [0u8; 3];
        own3[i] = 3;
        let c2: Vec<_> = CROSS2[i].iter().map(|k| DEGREE2[*k]).collect();
        let c3: Vec<_> = CROSS3[i].iter().map(|k| DEGREE3[*k]).collect();
        assert!(!c2.contains(&own2) && !c3.contains(&own3), "axis {i}");
        // Every other monomial is there, in the tables' order.
        assert!(CROSS2[i].windows(2).all(|w| w[0] < w[1]));
        assert!(CROSS3[i].windows(2).all(|w| w[0] < w[1]));
        assert_eq!(c2.len() + 1, DEGREE2.len());
        assert_eq!(c3.len() + 1, DEGREE3.len());
    }
}

#[test]
fn each_coefficient_adds_exactly_its_monomial() {
    let m = [612.0, 431.0, 700.0];
    let base = nunchuk();
    let u = base.correct_linear(m);
    let uf = u.map(f64::from);
    let plain = base.correct(m, &Conditions::default());
    for i in 0..3 {
        for j in 0..5 {
            let mut cal = base;
            cal.effects.cross_quadratic[i][j] = 0.25;
            let got = cal.correct(m, &Conditions::default());
            let want = 0.25 * mono(&uf, &DEGREE2[CROSS2[i][j]]);
            for k in 0..3 {
                let delta = f64::from(got[k]) - f64::from(plain[k]);
                let expect = if k == i { want } else { 0.0 };
                assert!(
                    (delta - expect).abs() < 1e-6,
                    "q[{i}][{j}] axis {k}: {delta} vs {expect}"
                );
            }
        }
        for j in 0..9 {
            let mut cal = base;
            cal.effects.cross_cubic[i][j] = -0.125;
            let got = cal.correct(m, &Conditions::default());
            let want = -0.125 * mono(&uf, &DEGREE3[CROSS3[i][j]]);
            for k in 0..3 {
                let delta = f64::from(got[k]) - f64::from(plain[k]);
                let expect = if k == i { want } else { 0.0 };
                assert!(
                    (delta - expect).abs() < 1e-6,
                    "c[{i}][{j}] axis {k}: {delta} vs {expect}"
                );
            }
        }
    }
}

#[test]
fn zero_cross_terms_give_the_per_axis_correction_bit_for_bit() {
    // The per-axis formula as it was before the cross terms, in f32.
    let mut cal = nunchuk();
    cal.effects.quadratic = [0.01, -0.02, 0.005];
    cal.effects.cubic = [-0.003, 0.002, 0.001];
    assert!(!cal.effects.has_cross_terms());
    for m in [
        [0.0, 1023.0, 512.0],
        [300.0, 700.0, 900.0],
        [511.0, 514.0, 712.0],
    ] {
        let u = cal.correct_linear(m);
        let e = &cal.effects;
        let want: [f32; 3] = std::array::from_fn(|i| {
            let x = u[i];
            x + e.quadratic[i] * x * x + e.cubic[i] * x * x * x
        });
        let got = cal.correct(m, &Conditions::default());
        assert_eq!(got.map(f32::to_bits), want.map(f32::to_bits));
    }
}

#[test]
fn cross_terms_count_for_is_none_and_finiteness() {
    let mut cal = nunchuk();
    assert!(cal.effects.is_none());
    // −0 is zero, the smallest subnormal is not.
    cal.effects.cross_quadratic[0][0] = -0.0;
    assert!(cal.effects.is_none() && !cal.effects.has_cross_terms());
    cal.effects.cross_quadratic[1][4] = f32::from_bits(1);
    assert!(cal.effects.has_cross_terms());
    cal.effects.cross_quadratic[1][4] = 0.0;
    cal.effects.cross_cubic[2][8] = 1e-3;
    assert!(!cal.effects.is_none());
    assert!(cal.effects.has_cross_terms());
    assert!(!cal.effects.has_time_or_temperature_terms());
    assert_eq!(cal.validate(), Ok(()));
    cal.effects.cross_quadratic[1][0] = f32::NAN;
    assert_eq!(cal.validate(), Err(wiical_core::Error::NonFinite));
    let mut cal = nunchuk();
    cal.effects.cross_cubic[0][3] = f32::NEG_INFINITY;
    assert_eq!(cal.validate(), Err(wiical_core::Error::NonFinite));
    let mut cal = nunchuk();
    cal.effects.scale_temp[0] = 1e-4;
    assert!(cal.effects.has_time_or_temperature_terms());
}

fn coeff(limit: f32) -> impl Strategy<Value = f32> {
    -limit..limit
}

/// Any f32 bit pattern (NaN, ±∞, ±0, subnormals included) a quarter of the time, else ±0,
/// so that every combination of present and absent term families is drawn.
fn sparse() -> impl Strategy<Value = f32> {
    prop_oneof![
        2 => Just(0.0f32),
        1 => Just(-0.0f32),
        1 => any::<u32>().prop_map(f32::from_bits),
    ]
}

/// A family of `N` coefficients: all (signed) zeros, or some of them arbitrary.
fn family<const N: usize>() -> impl Strategy<Value = [f32; N]> {
    prop_oneof![
        Just([0.0f32; N]),
        Just([-0.0f32; N]),
        prop::collection::vec(sparse(), N).prop_map(|v| std::array::from_fn(|i| v[i])),
    ]
}

/// Every parameter of `cal` as bits (`==` on floats would fail on NaN).
fn bits(cal: &Calibration) -> Vec<u32> {
    let e = &cal.effects;
    cal.bias
        .iter()
        .chain(cal.matrix.as_flattened())
        .chain(&e.quadratic)
        .chain(&e.cubic)
        .chain(&e.bias_drift)
        .chain([&e.temp_ref_c])
        .chain(&e.bias_temp)
        .chain(&e.scale_temp)
        .chain(e.cross_quadratic.as_flattened())
        .chain(e.cross_cubic.as_flattened())
        .map(|x| x.to_bits())
        .collect()
}

/// An `f32` of any bit pattern.
fn any_f32() -> impl Strategy<Value = f32> {
    prop_oneof![any::<u32>().prop_map(f32::from_bits), -2000.0f32..2000.0]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    /// The f32 correction with every term agrees with the f64 reference to f32 rounding.
    #[test]
    fn f32_correction_matches_the_f64_reference(
        m in prop::array::uniform3(0.0f32..1023.0),
        quad in prop::array::uniform3(coeff(0.05)),
        cubic in prop::array::uniform3(coeff(0.02)),
        cq in prop::array::uniform3(prop::array::uniform5(coeff(0.05))),
        cc in prop::array::uniform3(prop::array::uniform9(coeff(0.02))),
        drift in prop::array::uniform3(coeff(0.01)),
        btemp in prop::array::uniform3(coeff(1.0)),
        stemp in prop::array::uniform3(coeff(1e-3)),
        time_s in 0.0f32..3600.0,
        temp in prop::option::of(0.0f32..50.0),
    ) {
        let mut cal = nunchuk();
        cal.effects = Effects {
            quadratic: quad,
            cubic,
            bias_drift: drift,
            temp_ref_c: 25.0,
            bias_temp: btemp,
            scale_temp: stemp,
            cross_quadratic: cq,
            cross_cubic: cc,
        };
        let cond = Conditions { time_s, temperature_c: temp };
        let got = cal.correct(m, &cond);
        // The per-sample path gives the same bits, hence the same agreement with the reference.
        let prepared = cal.prepare().correct(m, &cond);
        prop_assert_eq!(prepared.map(f32::to_bits), got.map(f32::to_bits));
        let want = reference(&cal, m, &cond);
        // Scale of the terms summed: f32 rounding is relative to the largest of them.
        let u = reference(&Calibration { effects: Effects::default(), ..cal }, m, &cond);
        let umax = u.iter().fold(1.0f64, |a, x| a.max(x.abs()));
        let scale = umax * (1.0 + umax * umax);
        for i in 0..3 {
            let err = (f64::from(got[i]) - want[i]).abs();
            prop_assert!(err <= 2e-5 * scale, "axis {i}: {} vs {} (err {err:e})", got[i], want[i]);
        }
    }

    /// `PreparedCalibration::correct` is `Calibration::correct` bit for bit, whatever the
    /// terms present and whatever the bits (NaN payloads, ±∞, ±0 and subnormals included), and
    /// its flags are the `Effects` predicates.
    #[test]
    fn prepared_correction_is_the_convenience_path_bit_for_bit(
        m in prop::array::uniform3(any_f32()),
        bias in prop::array::uniform3(any_f32()),
        row in prop::array::uniform3(any_f32()),
        quad in family::<3>(),
        cubic in family::<3>(),
        drift in family::<3>(),
        btemp in family::<3>(),
        stemp in family::<3>(),
        temp_ref in any_f32(),
        cq in prop::array::uniform3(family::<5>()),
        cc in prop::array::uniform3(family::<9>()),
        time_s in any_f32(),
        temp in prop::option::of(any_f32()),
    ) {
        let mut cal = nunchuk();
        cal.bias = bias;
        cal.matrix[1] = row;
        cal.effects = Effects {
            quadratic: quad,
            cubic,
            bias_drift: drift,
            temp_ref_c: temp_ref,
            bias_temp: btemp,
            scale_temp: stemp,
            cross_quadratic: cq,
            cross_cubic: cc,
        };
        let cond = Conditions { time_s, temperature_c: temp };
        let p = PreparedCalibration::new(cal);
        prop_assert_eq!(bits(p.calibration()), bits(&cal));
        let e = &cal.effects;
        prop_assert_eq!(p.terms(), Terms {
            linear_only: e.is_none(),
            cross: e.has_cross_terms(),
            time_or_temperature: e.has_time_or_temperature_terms(),
        });
        prop_assert_eq!(
            p.correct(m, &cond).map(f32::to_bits),
            cal.correct(m, &cond).map(f32::to_bits)
        );
        prop_assert_eq!(
            p.correct_linear(m).map(f32::to_bits),
            cal.correct_linear(m).map(f32::to_bits)
        );
    }

    /// The core's f32 monomials are the tables' exponents evaluated in f32.
    #[test]
    fn monomials_follow_the_tables(u in prop::array::uniform3(-3.0f32..3.0)) {
        let (m2, m3) = monomials(&u);
        let uf = u.map(f64::from);
        for (got, ex) in m2.iter().zip(DEGREE2.iter()) {
            prop_assert!((f64::from(*got) - mono(&uf, ex)).abs() <= 1e-6 * 9.0);
        }
        for (got, ex) in m3.iter().zip(DEGREE3.iter()) {
            prop_assert!((f64::from(*got) - mono(&uf, ex)).abs() <= 1e-6 * 27.0);
        }
    }
}
