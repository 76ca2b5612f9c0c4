//! An fmpy result file (what an FMI user has after simulating the plant FMU with fmpy) is
//! validated like the same log in the measured-log format: the same effect found, the same
//! residuals. The file is written in fmpy's exact format (`fmpy.util.write_csv`: quoted
//! variable names, `time` first, Python's `str` of each value), with the `AzimuthPlant`
//! variables in their model description's units.

use antenna_truth::suite::generate_case;
use antenna_truth::{MotorSensor, TruthConfig};
use antenna_validate::measured_log::{parse_str, MeasuredLog, Signal};
use antenna_validate::{validate, ValidateOptions};
use std::collections::BTreeMap;

/// Python's `str(float)`: the shortest representation, positional from 1e-4 to 1e16,
/// otherwise with a two-digit signed exponent.
fn python_str(x: f64) -> String {
    if x == 0.0 {
        return if x.is_sign_negative() { "-0.0" } else { "0.0" }.to_string();
    }
    let scientific = format!("{x:e}");
    let (mantissa, exponent) = scientific.split_once('e').expect("an exponent");
    let exponent: i32 = exponent.parse().expect("an integer exponent");
    if (-4..16).contains(&exponent) {
        let positional = format!("{x}");
        if positional.contains('.') {
            positional
        } else {
            positional + ".0"
        }
    } else {
        format!("{mantissa}e{}{:02}", if exponent < 0 { '-' } else { '+' }, exponent.abs())
    }
}

#[test]
fn python_str_matches_pythons_float_formatting() {
    for (x, python) in [
        (0.0, "0.0"),
        (1.0, "1.0"),
        (0.002, "0.002"),
        (1e-5, "1e-05"),
        (-1.5e-7, "-1.5e-07"),
        (12345.678, "12345.678"),
        (1e16, "1e+16"),
        (0.1 + 0.2, "0.30000000000000004"),
    ] {
        assert_eq!(python_str(x), python, "{x:e}");
    }
}

/// The log as fmpy writes the `AzimuthPlant` variables `axis.encoder_position` (deg),
/// `axis.speed` (deg/s) and the two motor currents (A), selected with `columns=`.
fn fmpy_text(log: &MeasuredLog, load_speed: &[f64]) -> String {
    let load = log.signal(Signal::LoadPos).unwrap();
    let currents = log.signals(Signal::MotorCurrent);
    let mut text =
        String::from("\"time\",\"axis.encoder_position\",\"axis.speed\",\"motor1.current\",\"motor2.current\"\n");
    for k in 0..log.len() {
        let cells = [
            log.time[k],
            load[k].to_degrees(),
            load_speed[k].to_degrees(),
            currents[0].values[k],
            currents[1].values[k],
        ];
        text.push_str(&cells.iter().map(|v| python_str(*v)).collect::<Vec<_>>().join(","));
        text.push('\n');
    }
    text
}

#[test]
fn an_fmpy_result_file_validates_like_the_same_log_in_the_log_format() {
    // The azimuth drive's sensors: two motors' currents and the axis encoder.
    let mut base = TruthConfig { duration: 30.0, ..TruthConfig::default() };
    base.noise.motor_sensor = MotorSensor::None;
    base.noise.motors = 2;
    let kinds = vec![("coulomb".to_string(), 20.0)];
    let (text, _) = generate_case(&base, 41, &kinds, "case.csv", &mut BTreeMap::new()).unwrap();
    let native = parse_str(&text).unwrap();
    let speed: Vec<f64> = native.time.iter().map(|t| 1e-3 * t.cos()).collect();
    let fmpy = parse_str(&fmpy_text(&native, &speed)).unwrap();
    assert_eq!(fmpy.signals(Signal::MotorCurrent).len(), 2);
    assert!(fmpy.signal(Signal::LoadVel).is_some());

    let start = base.plant.starting_parameters();
    let options = ValidateOptions::default();
    let (a, b) = (validate(&native, &start, &options).unwrap(), validate(&fmpy, &start, &options).unwrap());
    let names = |v: &antenna_validate::Validation| {
        v.selection.found.iter().map(|f| f.kind.name().to_string()).collect::<Vec<_>>()
    };
    assert_eq!(names(&a), vec!["coulomb".to_string()]);
    assert_eq!(names(&b), names(&a));
    let close = |x: f64, y: f64| (x - y).abs() <= 1e-6 * y.abs();
    for (x, y) in a.before.iter().zip(&b.before).chain(a.after.iter().zip(&b.after)) {
        assert!(close(x.rms, y.rms), "{}: RMS {} (log format) against {} (fmpy)", x.name, x.rms, y.rms);
    }
    let coulomb = |v: &antenna_validate::Validation| v.selection.corrected.value("friction.coulomb");
    assert!(close(coulomb(&b), coulomb(&a)), "{} against {}", coulomb(&b), coulomb(&a));
}
