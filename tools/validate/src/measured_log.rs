//! The measured-log format: a CSV file of drive signals with units in the column names.
//!
//! A log is what a real drive (or the truth generator) records: time, the motor current or
//! torque, and the measured motion. The format is documented in `docs/measured-log-format.md`.
//! This module reads it into SI units and rejects anything malformed with an error that names
//! the line (1-based, as an editor shows it) and the column, so that a user can fix the file.
//! It never panics, whatever bytes it is given.

use std::collections::BTreeMap;
use std::path::Path;

/// The physical quantity a column measures; a unit is accepted only for its own dimension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Dimension {
    Time,
    Angle,
    AngularVelocity,
    Current,
    Torque,
    Speed,
}

/// The signals of the vocabulary. Motor signals may carry a motor number (`motor_current_2`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Signal {
    /// Sample time.
    Time,
    /// Motor current, per motor.
    MotorCurrent,
    /// Motor current command (what the current loop was asked for, not what the motor
    /// carried), per motor: turned into the current through the parameter set's current-loop
    /// bandwidth before the analysis ([`MeasuredLog::with_current_from_command`]).
    MotorCurrentCommand,
    /// Motor torque (motor side of the gearbox), per motor.
    MotorTorque,
    /// Position command of the axis.
    RefPos,
    /// Elevation angle (an input for gravity and unbalance on an axis that is not elevation).
    Elevation,
    /// Wind speed.
    WindSpeed,
    /// A measured disturbance torque on the axis (load side); positive accelerates the load.
    DisturbanceTorque,
    /// Axis (load-side) encoder position.
    LoadPos,
    /// Motor encoder position, referred to the axis side through the gear ratio.
    MotorPos,
    /// Motor speed, referred to the axis side through the gear ratio.
    MotorVel,
    /// Axis (load-side) speed.
    LoadVel,
}

impl Signal {
    /// All signals with their column-name stem, the dimension of their unit and whether a motor
    /// number may follow the stem. One table, so the documentation and the parser agree.
    pub const VOCABULARY: [(Signal, &'static str, Dimension, bool); 12] = [
        (Signal::Time, "time", Dimension::Time, false),
        (Signal::MotorCurrent, "motor_current", Dimension::Current, true),
        (Signal::MotorCurrentCommand, "motor_current_command", Dimension::Current, true),
        (Signal::MotorTorque, "motor_torque", Dimension::Torque, true),
        (Signal::RefPos, "ref_pos", Dimension::Angle, false),
        (Signal::Elevation, "elevation", Dimension::Angle, false),
        (Signal::WindSpeed, "wind_speed", Dimension::Speed, false),
        (Signal::DisturbanceTorque, "disturbance_torque", Dimension::Torque, false),
        (Signal::LoadPos, "load_pos", Dimension::Angle, false),
        (Signal::MotorPos, "motor_pos", Dimension::Angle, true),
        (Signal::MotorVel, "motor_vel", Dimension::AngularVelocity, true),
        (Signal::LoadVel, "load_vel", Dimension::AngularVelocity, false),
    ];

    /// The column-name stem, e.g. `motor_vel`.
    pub fn stem(self) -> &'static str {
        Self::VOCABULARY.iter().find(|entry| entry.0 == self).map(|entry| entry.1).unwrap_or("?")
    }

    /// The dimension its unit must have.
    pub fn dimension(self) -> Dimension {
        Self::VOCABULARY.iter().find(|entry| entry.0 == self).map(|entry| entry.2).unwrap_or(Dimension::Time)
    }
}

/// The largest interval between two rows, in median sample intervals, that still counts as
/// one continuous run (a logger's clock jitters by a few percent, never by a factor of ten).
pub const MAX_GAP_INTERVALS: f64 = 10.0;

/// The accepted unit suffixes: name, dimension, factor to SI (value_SI = factor * value).
///
/// A linear axis (a carriage on a screw or a belt) logs its axis-side positions in metres and
/// its axis-side forces in newtons: those are read as the angle and torque of an axis of unit
/// radius, so every equation holds as it is, and [`MeasuredLog::is_linear`] tells the reports
/// to print m, m/s, N, kg and N s/m. Motor-side torques stay in N m.
pub const UNITS: [(&str, Dimension, f64); 22] = [
    ("s", Dimension::Time, 1.0),
    ("ms", Dimension::Time, 1e-3),
    ("us", Dimension::Time, 1e-6),
    ("rad", Dimension::Angle, 1.0),
    ("deg", Dimension::Angle, std::f64::consts::PI / 180.0),
    ("mdeg", Dimension::Angle, std::f64::consts::PI / 180.0e3),
    ("arcsec", Dimension::Angle, std::f64::consts::PI / (180.0 * 3600.0)),
    ("rad_s", Dimension::AngularVelocity, 1.0),
    ("deg_s", Dimension::AngularVelocity, std::f64::consts::PI / 180.0),
    ("rpm", Dimension::AngularVelocity, 2.0 * std::f64::consts::PI / 60.0),
    ("A", Dimension::Current, 1.0),
    ("mA", Dimension::Current, 1e-3),
    ("Nm", Dimension::Torque, 1.0),
    ("kNm", Dimension::Torque, 1e3),
    ("m_s", Dimension::Speed, 1.0),
    ("m", Dimension::Angle, 1.0),
    ("mm", Dimension::Angle, 1e-3),
    ("um", Dimension::Angle, 1e-6),
    ("m_s", Dimension::AngularVelocity, 1.0),
    ("mm_s", Dimension::AngularVelocity, 1e-3),
    ("N", Dimension::Torque, 1.0),
    ("kN", Dimension::Torque, 1e3),
];

/// The unit suffixes of a linear axis's positions and speeds.
pub const LINEAR_UNITS: [&str; 5] = ["m", "mm", "um", "m_s", "mm_s"];

/// A parse or validation error, naming where it is so the file can be fixed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{}{kind}", location(.line, .column))]
pub struct LogError {
    /// 1-based line number in the file, when the error belongs to one line.
    pub line: Option<usize>,
    /// The column name as written in the header, when the error belongs to one column.
    pub column: Option<String>,
    pub kind: LogErrorKind,
}

/// `line N, column 'C': ` (or the parts known), the prefix of an error message.
fn location(line: &Option<usize>, column: &Option<String>) -> String {
    match (line, column) {
        (Some(line), Some(column)) => format!("line {line}, column '{column}': "),
        (Some(line), None) => format!("line {line}: "),
        (None, Some(column)) => format!("column '{column}': "),
        (None, None) => String::new(),
    }
}

/// What is wrong with a log.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LogErrorKind {
    #[error("cannot read {path}: {reason}")]
    Read { path: String, reason: String },
    #[error("the file is empty")]
    Empty,
    #[error("the file is not valid UTF-8 text")]
    NotUtf8,
    #[error("metadata line has an empty key (expected '# key = value')")]
    EmptyMetadataKey,
    #[error("the file has no header line (only comments)")]
    NoHeader,
    #[error("header cell {0} is empty")]
    EmptyHeaderCell(usize),
    #[error("column appears twice in the header")]
    ColumnTwice,
    #[error("a second column for the same signal")]
    SecondColumnForSignal,
    #[error("required column missing: {0}")]
    MissingColumn(String),
    #[error("signal '{stem}' has no unit suffix (write e.g. '{stem}_{si}')")]
    NoUnit { stem: &'static str, si: &'static str },
    #[error("signal '{0}' does not take a motor number")]
    NotNumbered(&'static str),
    #[error("unit '{unit}' is not a unit of {dimension:?} (signal '{stem}')")]
    WrongDimension { unit: String, dimension: Dimension, stem: &'static str },
    /// A unit the reader cannot convert to SI: refused rather than read as NaN or as SI.
    #[error("unknown unit suffix '{unit}' for signal '{stem}' (units of {dimension:?}: {known})")]
    UnknownUnit { unit: String, stem: &'static str, dimension: Dimension, known: String },
    #[error("row has {cells} cells but the header has {columns} columns")]
    RaggedRow { cells: usize, columns: usize },
    #[error("not a number: '{0}'")]
    NotANumber(String),
    #[error("value is not finite: '{0}'")]
    NotFinite(String),
    #[error("value {0} is beyond {MAX_ABS_VALUE:e} in SI units: no sensor of a drive reads that; the file is damaged or a unit is wrong")]
    Implausible(String),
    #[error("the median sample interval is {0:e} s, outside {MIN_SAMPLE_INTERVAL_S:e} to {MAX_SAMPLE_INTERVAL_S} s: the time column is not in seconds, or damaged")]
    ImplausibleSampleInterval(f64),
    #[error("the file has a header but no data rows")]
    NoRows,
    #[error("a log needs at least two samples")]
    TooFewSamples,
    #[error("time does not increase ({time} s after {previous} s on the previous row)")]
    TimeNotIncreasing { time: f64, previous: f64 },
    #[error("a gap of {gap} s after {after} s is more than {MAX_GAP_INTERVALS} times the usual sample interval {interval} s: split the log into continuous runs at this row")]
    Gap { gap: f64, after: f64, interval: f64 },
    #[error("malformed CSV: {0}")]
    Csv(String),
}

impl LogError {
    fn at(line: Option<usize>, column: Option<&str>, kind: LogErrorKind) -> Self {
        LogError { line, column: column.map(str::to_string), kind }
    }
}

/// One recognised column, converted to SI.
#[derive(Debug, Clone, PartialEq)]
pub struct Channel {
    pub signal: Signal,
    /// Motor number for per-motor signals (`motor_current_2` has 2); `None` when not numbered.
    pub motor: Option<u32>,
    /// The column name as written in the file.
    pub column: String,
    /// The unit suffix as written in the file.
    pub unit: String,
    /// Values in SI units (s, rad, rad/s, A, N m, m/s).
    pub values: Vec<f64>,
}

/// The unit recorded for a motor position integrated from a motor speed.
pub const INTEGRATED_UNIT: &str = "rad, integrated from the motor speed";

/// The unit recorded for a motor position integrated from a motor speed whose bias drift was
/// estimated and taken out ([`crate::sensor_errors::TachoDrift`]): its twist is then as
/// trustworthy as an encoder's, one constant offset.
pub const DRIFT_REMOVED_UNIT: &str = "rad, integrated from the motor speed, drift removed";

/// A measured log in SI units.
#[derive(Debug, Clone, PartialEq)]
pub struct MeasuredLog {
    /// `# key = value` lines before the header, e.g. `gear_ratio`, `axis`.
    pub metadata: BTreeMap<String, String>,
    /// Sample times in seconds, strictly increasing.
    pub time: Vec<f64>,
    /// Every recognised column except time, in file order.
    pub channels: Vec<Channel>,
    /// Things worth telling the user that are not errors (ignored columns, uneven sampling).
    pub notes: Vec<String>,
}

/// The largest magnitude of a logged value in SI units (rad, rad/s, N m, A, m, N): a billion is
/// beyond any drive's sensor, and a value of 1e300 is a damaged file that would make the fits
/// run for minutes on numbers without meaning.
pub const MAX_ABS_VALUE: f64 = 1e9;

/// The plausible range of a log's median sample interval, s: 1 MHz to one sample in 10 s.
pub const MIN_SAMPLE_INTERVAL_S: f64 = 1e-6;
pub const MAX_SAMPLE_INTERVAL_S: f64 = 10.0;

/// The largest log read, bytes (512 MiB: an hour at 2 kHz with a dozen columns is about 1 GB
/// of numbers at full precision, a minute some 20 MB).
pub const MAX_LOG_BYTES: u64 = 512 << 20;

impl MeasuredLog {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.time.len()
    }

    /// True when the log has no samples (never true for a parsed log).
    pub fn is_empty(&self) -> bool {
        self.time.is_empty()
    }

    /// The first channel of a signal, whatever its motor number.
    pub fn signal(&self, signal: Signal) -> Option<&[f64]> {
        self.channels.iter().find(|c| c.signal == signal).map(|c| c.values.as_slice())
    }

    /// All channels of a signal (one per motor for per-motor signals).
    pub fn signals(&self, signal: Signal) -> Vec<&Channel> {
        self.channels.iter().filter(|c| c.signal == signal).collect()
    }

    /// Median sample interval in seconds.
    pub fn sample_interval(&self) -> f64 {
        let mut steps: Vec<f64> = self.time.windows(2).map(|w| w[1] - w[0]).collect();
        if steps.is_empty() {
            return f64::NAN;
        }
        steps.sort_by(|a, b| a.total_cmp(b));
        steps[steps.len() / 2]
    }

    /// Total motor-side torque in N m: the sum of the per-motor torque columns when the log has
    /// them, otherwise the sum of the per-motor currents times `torque_constant` (N m/A).
    pub fn total_motor_torque(&self, torque_constant: f64) -> Vec<f64> {
        let torques = self.signals(Signal::MotorTorque);
        let (columns, scale) =
            if torques.is_empty() { (self.signals(Signal::MotorCurrent), torque_constant) } else { (torques, 1.0) };
        let mut total = vec![0.0; self.len()];
        for column in columns {
            for (sum, value) in total.iter_mut().zip(&column.values) {
                *sum += scale * value;
            }
        }
        total
    }

    /// A log whose drive has a motor speed sensor (a tachometer, a resolver's speed) but no
    /// motor encoder, with the motor position integrated from that speed, so the twist and the
    /// compliant-drive analysis stay available. None when the log has a motor position, no
    /// motor speed or no load position to anchor the integral to.
    ///
    /// Each motor speed column is integrated by the trapezoid rule. An integrated speed starts
    /// at an unknown angle and drifts with the sensor's bias; a twist cannot grow without bound,
    /// so the straight line fitted to (integral - load position) is removed: the result sits on
    /// the load position with zero mean twist (the twist offset is a nuisance parameter of the
    /// analysis anyway) and no drift. The unit is marked "integrated" so that readers know.
    pub fn with_motor_position_from_speed(&self) -> Option<MeasuredLog> {
        if self.signal(Signal::MotorPos).is_some() {
            return None;
        }
        let load = self.signal(Signal::LoadPos)?;
        let speeds = self.signals(Signal::MotorVel);
        if speeds.is_empty() || self.len() < 2 {
            return None;
        }
        let t0 = self.time[0];
        let mut log = self.clone();
        for speed in speeds {
            let mut integral = Vec::with_capacity(self.len());
            let mut angle = 0.0;
            integral.push(angle);
            for k in 1..self.len() {
                angle += 0.5 * (speed.values[k] + speed.values[k - 1]) * (self.time[k] - self.time[k - 1]);
                integral.push(angle);
            }
            // (integral - load) = c + b t + e load + (1 + e) twist, with c the unknown start, b
            // the sensor's bias and e its scale error: least squares on [1, t, load] finds them
            // (time and load centred, so the constant stays well conditioned beside them), and
            // the motor position is (integral - c - b t) / (1 + e). A load that stands still or
            // moves at one speed cannot tell a scale error from a bias: no position then.
            let n = self.len() as f64;
            let time: Vec<f64> = self.time.iter().map(|t| t - t0).collect();
            let (time_mean, load_mean) = (time.iter().sum::<f64>() / n, load.iter().sum::<f64>() / n);
            let centred = |x: &[f64], m: f64| x.iter().map(|v| v - m).collect::<Vec<f64>>();
            let columns = [vec![1.0; self.len()], centred(&time, time_mean), centred(load, load_mean)];
            let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, z)| x * z).sum::<f64>();
            let (tt, ll, tl) =
                (dot(&columns[1], &columns[1]), dot(&columns[2], &columns[2]), dot(&columns[1], &columns[2]));
            // Written so that NaN counts as ill-posed too.
            let well_posed = tt * ll - tl * tl > 1e-9 * tt * ll;
            if !well_posed {
                return None;
            }
            let target: Vec<f64> = integral.iter().zip(load).map(|(q, l)| q - l).collect();
            let (beta, _) = antenna_dsp::weighted_least_squares(&columns, &target, &vec![1.0; self.len()]);
            let (bias, scale_error) = (beta[1], beta[2]);
            let start = beta[0] - bias * time_mean - scale_error * load_mean;
            let values: Vec<f64> = integral
                .iter()
                .enumerate()
                .map(|(k, q)| (q - start - bias * (self.time[k] - t0)) / (1.0 + scale_error))
                .collect();
            log.notes.push(format!(
                "no motor encoder: the motor position is integrated from '{}' and put on the load encoder (its mean twist, a bias of {bias:.3e} rad/s and a scale error of {:.3} % of the speed sensor removed)",
                speed.column,
                100.0 * scale_error
            ));
            log.channels.push(Channel {
                signal: Signal::MotorPos,
                motor: speed.motor,
                column: format!("motor_pos (integrated from {})", speed.column),
                unit: INTEGRATED_UNIT.into(),
                values,
            });
        }
        Some(log)
    }

    /// True when the motor position was integrated from a motor speed
    /// ([`MeasuredLog::with_motor_position_from_speed`]).
    pub fn motor_position_is_integrated(&self) -> bool {
        self.signals(Signal::MotorPos).iter().any(|c| c.unit == INTEGRATED_UNIT)
    }

    /// True when the torque comes from current columns (so a torque constant is needed).
    pub fn torque_from_current(&self) -> bool {
        self.signals(Signal::MotorTorque).is_empty()
    }

    /// True when the log's axis is linear: its positions are in metres (see [`UNITS`]).
    pub fn is_linear(&self) -> bool {
        self.channels
            .iter()
            .any(|c| matches!(c.signal, Signal::LoadPos | Signal::MotorPos) && LINEAR_UNITS.contains(&c.unit.as_str()))
    }

    /// True when the log holds the current command rather than the measured current.
    pub fn current_is_commanded(&self) -> bool {
        !self.signals(Signal::MotorCurrentCommand).is_empty() && self.signals(Signal::MotorCurrent).is_empty()
    }

    /// A log whose current command columns are replaced by the current the motors carried: the
    /// command through the drive's current loop, a first-order lag of `bandwidth_hz`, exact for
    /// a command that is linear between samples (the command as it is when the bandwidth is not
    /// a positive number, with a note). `None` when the log has no command column or
    /// also logs the measured current (which is then used as it is).
    ///
    /// A logged command lags the current by the loop's time constant; left as it is, that lag
    /// shows as a delay, a torque-constant change or an inertia error in every equation.
    pub fn with_current_from_command(&self, bandwidth_hz: f64) -> Option<MeasuredLog> {
        if !self.current_is_commanded() {
            return None;
        }
        let known = bandwidth_hz > 0.0 && bandwidth_hz.is_finite();
        let tau = if known { 1.0 / (2.0 * std::f64::consts::PI * bandwidth_hz) } else { 0.0 };
        let mut log = self.clone();
        for channel in log.channels.iter_mut().filter(|c| c.signal == Signal::MotorCurrentCommand) {
            if known {
                channel.values = first_order_lag(&self.time, &channel.values, tau);
            }
            channel.signal = Signal::MotorCurrent;
        }
        log.notes.push(if known {
            format!(
                "the log holds the current command: the current the motors carried is taken as the command through the current loop ({bandwidth_hz} Hz from the parameter set, time constant {:.3} ms); the torque's sensor noise is that of the command's rounding",
                tau * 1e3
            )
        } else {
            "the log holds the current command, but the parameter set gives no motor.current_loop_bandwidth: the command is taken as the current, and the loop's lag will show as a delay".to_string()
        });
        Some(log)
    }

    /// Reads and parses a log file (a regular file of at most [`MAX_LOG_BYTES`]).
    pub fn read(path: &Path) -> Result<MeasuredLog, LogError> {
        let text = fmu_runtime::files::read_regular_file(path, MAX_LOG_BYTES, "log").map_err(|reason| {
            LogError::at(
                None,
                None,
                LogErrorKind::Read { path: path.display().to_string(), reason: reason.to_string() },
            )
        })?;
        parse_bytes(text.as_bytes())
    }

    /// Writes the log in the measured-log format, in the units given per signal (SI when the
    /// signal is not listed). Used by the truth generator; `units` maps a signal to a suffix.
    pub fn to_csv(&self, units: &[(Signal, &str)]) -> String {
        let unit_of = |signal: Signal| -> (&str, f64) {
            let suffix =
                units.iter().find(|u| u.0 == signal).map(|u| u.1).unwrap_or_else(|| si_unit(signal.dimension()));
            let factor = UNITS.iter().find(|u| u.0 == suffix).map(|u| u.2).unwrap_or(1.0);
            (suffix, factor)
        };
        let mut out = String::new();
        for (key, value) in &self.metadata {
            out.push_str(&format!("# {key} = {value}\n"));
        }
        let (time_unit, time_factor) = unit_of(Signal::Time);
        let mut header = vec![format!("time_{time_unit}")];
        let mut factors = vec![time_factor];
        for channel in &self.channels {
            let (suffix, factor) = unit_of(channel.signal);
            let name = match channel.motor {
                Some(m) => format!("{}_{m}_{suffix}", channel.signal.stem()),
                None => format!("{}_{suffix}", channel.signal.stem()),
            };
            header.push(name);
            factors.push(factor);
        }
        // Names and numbers never need quoting, so the writer's output is the plain
        // comma-separated text of the format.
        let mut writer = csv::WriterBuilder::new().terminator(csv::Terminator::Any(b'\n')).from_writer(Vec::new());
        let written: Result<(), csv::Error> = (|| {
            writer.write_record(&header)?;
            for i in 0..self.len() {
                let mut cells = vec![format_number(self.time[i] / factors[0])];
                for (channel, factor) in self.channels.iter().zip(&factors[1..]) {
                    cells.push(format_number(channel.values[i] / factor));
                }
                writer.write_record(&cells)?;
            }
            writer.flush()?;
            Ok(())
        })();
        // Writing into memory cannot fail.
        written.expect("writing CSV into memory");
        let bytes = writer.into_inner().expect("CSV writer into memory");
        out.push_str(&String::from_utf8(bytes).expect("the CSV text is UTF-8"));
        out
    }
}

fn si_unit(dimension: Dimension) -> &'static str {
    match dimension {
        Dimension::Time => "s",
        Dimension::Angle => "rad",
        Dimension::AngularVelocity => "rad_s",
        Dimension::Current => "A",
        Dimension::Torque => "Nm",
        Dimension::Speed => "m_s",
    }
}

/// Enough significant digits that writing and reading back loses nothing a sensor resolves.
fn format_number(value: f64) -> String {
    format!("{value:.10e}")
}

/// What a header cell turned out to be.
enum ColumnKind {
    Known { signal: Signal, motor: Option<u32>, unit: String, factor: f64 },
    Unknown,
}

/// FMU output and input variables that an fmpy result file (`fmpy.util.write_csv`: a header of
/// quoted variable names starting with `"time"`, values in the units of the FMU's model
/// description) may hold, and the signal each one is: (variable, signal, motor number, unit
/// suffix of the FMU's unit). The names are those of `AzimuthPlant` and `ElevationPlant`;
/// docs/measured-log-format.md has this table for users.
pub const FMU_VARIABLES: [(&str, Signal, Option<u32>, &str); 10] = [
    ("motor1.current", Signal::MotorCurrent, Some(1), "A"),
    ("motor2.current", Signal::MotorCurrent, Some(2), "A"),
    ("motor.current", Signal::MotorCurrent, None, "A"),
    ("motor1.torque", Signal::MotorTorque, Some(1), "Nm"),
    ("motor2.torque", Signal::MotorTorque, Some(2), "Nm"),
    ("motor.torque", Signal::MotorTorque, None, "Nm"),
    ("axis.encoder_position", Signal::LoadPos, None, "deg"),
    ("axis.speed", Signal::LoadVel, None, "deg_s"),
    ("load.disturbance_torque", Signal::DisturbanceTorque, None, "Nm"),
    ("elevation", Signal::Elevation, None, "deg"),
];

/// The FMU's true (unquantised) axis angle: the load position of an fmpy result file that has
/// no `axis.encoder_position`.
pub const FMU_TRUE_POSITION: &str = "axis.position";

/// The column kind of an FMU variable of an fmpy result file, if it is one of [`FMU_VARIABLES`].
fn classify_fmu_variable(name: &str, header: &[String]) -> Option<ColumnKind> {
    let known = |signal, motor, unit: &str| {
        let factor = UNITS.iter().find(|u| u.0 == unit).map_or(1.0, |u| u.2);
        Some(ColumnKind::Known { signal, motor, unit: unit.to_string(), factor })
    };
    if name == "time" {
        return known(Signal::Time, None, "s");
    }
    if name == FMU_TRUE_POSITION && !header.iter().any(|h| h == "axis.encoder_position") {
        return known(Signal::LoadPos, None, "deg");
    }
    let &(_, signal, motor, unit) = FMU_VARIABLES.iter().find(|v| v.0 == name)?;
    known(signal, motor, unit)
}

/// Splits a header name into signal, optional motor number and unit.
///
/// Stems are tried longest first so that `motor_vel_deg_s` is not read as a `motor_...` with a
/// strange unit. A name whose stem is known but whose unit is not is an error, not an unknown
/// column: a known signal with a wrong unit would otherwise be silently dropped.
fn classify_column(name: &str, line: usize) -> Result<ColumnKind, LogError> {
    let mut vocabulary = Signal::VOCABULARY.to_vec();
    vocabulary.sort_by_key(|entry| std::cmp::Reverse(entry.1.len()));
    for (signal, stem, dimension, numbered) in vocabulary {
        let error = |kind| Err(LogError::at(Some(line), Some(name), kind));
        if name == stem {
            return error(LogErrorKind::NoUnit { stem, si: si_unit(dimension) });
        }
        let Some(rest) = name.strip_prefix(stem).and_then(|r| r.strip_prefix('_')) else { continue };
        let (motor, unit) = match rest.split_once('_') {
            Some((digits, unit)) if numbered && !digits.is_empty() && digits.bytes().all(|b| b.is_ascii_digit()) => {
                (digits.parse::<u32>().ok(), unit)
            }
            _ => (None, rest),
        };
        if !numbered
            && rest.split_once('_').is_some_and(|(d, _)| !d.is_empty() && d.bytes().all(|b| b.is_ascii_digit()))
        {
            return error(LogErrorKind::NotNumbered(stem));
        }
        let same_dimension = UNITS.iter().find(|u| u.0 == unit && u.1 == dimension);
        return match same_dimension.or_else(|| UNITS.iter().find(|u| u.0 == unit)) {
            Some(&(_, unit_dimension, factor)) if unit_dimension == dimension => {
                Ok(ColumnKind::Known { signal, motor, unit: unit.to_string(), factor })
            }
            Some(_) => error(LogErrorKind::WrongDimension { unit: unit.to_string(), dimension, stem }),
            None => {
                let known: Vec<&str> = UNITS.iter().filter(|u| u.1 == dimension).map(|u| u.0).collect();
                error(LogErrorKind::UnknownUnit { unit: unit.to_string(), stem, dimension, known: known.join(", ") })
            }
        };
    }
    Ok(ColumnKind::Unknown)
}

/// Parses a log from raw bytes (the file need not be valid UTF-8 to get a clear error).
pub fn parse_bytes(bytes: &[u8]) -> Result<MeasuredLog, LogError> {
    let text = std::str::from_utf8(bytes).map_err(|e| {
        let line = bytes[..e.valid_up_to()].iter().filter(|&&b| b == b'\n').count() + 1;
        LogError::at(Some(line), None, LogErrorKind::NotUtf8)
    })?;
    parse_str(text)
}

/// The `# key = value` lines before the header. Later comment lines are skipped by the CSV
/// reader and carry no metadata.
fn read_metadata(text: &str) -> Result<BTreeMap<String, String>, LogError> {
    let mut metadata = BTreeMap::new();
    for (index, raw) in text.lines().enumerate() {
        let line = raw.trim();
        if line.is_empty() {
            continue;
        }
        let Some(comment) = line.strip_prefix('#') else { break };
        if let Some((key, value)) = comment.split_once('=') {
            let key = key.trim();
            if key.is_empty() {
                return Err(LogError::at(Some(index + 1), None, LogErrorKind::EmptyMetadataKey));
            }
            metadata.insert(key.to_string(), value.trim().to_string());
        }
    }
    Ok(metadata)
}

/// The recognised columns of a header, with the notes on the ignored ones.
struct Header {
    names: Vec<String>,
    kinds: Vec<ColumnKind>,
    notes: Vec<String>,
}

impl Header {
    /// Classifies the header cells. A header with a bare `time` column is an fmpy result file:
    /// its columns are FMU variable names (see [`FMU_VARIABLES`]).
    fn read(record: &csv::StringRecord, line: usize) -> Result<Header, LogError> {
        let names: Vec<String> = record.iter().map(|c| c.trim_matches('"').to_string()).collect();
        let fmpy = names.iter().any(|n| n == "time");
        let mut kinds = Vec::new();
        let mut notes = Vec::new();
        for (i, name) in names.iter().enumerate() {
            if name.is_empty() {
                return Err(LogError::at(Some(line), None, LogErrorKind::EmptyHeaderCell(i + 1)));
            }
            if names[..i].contains(name) {
                return Err(LogError::at(Some(line), Some(name), LogErrorKind::ColumnTwice));
            }
            let kind = match fmpy.then(|| classify_fmu_variable(name, &names)).flatten() {
                Some(kind) => kind,
                None => classify_column(name, line)?,
            };
            if matches!(kind, ColumnKind::Unknown) {
                notes.push(if fmpy {
                    format!("column '{name}' is not an FMU variable with a signal in the log format and is ignored")
                } else {
                    format!("column '{name}' is not in the vocabulary and is ignored")
                });
            }
            kinds.push(kind);
        }
        check_required(&kinds, &names, line)?;
        // Two columns of the same signal and motor number would be ambiguous.
        for (i, a) in kinds.iter().enumerate() {
            for b in &kinds[..i] {
                if let (
                    ColumnKind::Known { signal: sa, motor: ma, .. },
                    ColumnKind::Known { signal: sb, motor: mb, .. },
                ) = (a, b)
                {
                    if sa == sb && ma == mb {
                        return Err(LogError::at(Some(line), Some(&names[i]), LogErrorKind::SecondColumnForSignal));
                    }
                }
            }
        }
        Ok(Header { names, kinds, notes })
    }
}

/// The CSV reader of the log format: comma-separated, `#` comment lines, cells trimmed, rows
/// of any length (a ragged row is reported with its line by the caller).
fn csv_reader(text: &str) -> csv::Reader<&[u8]> {
    csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .comment(Some(b'#'))
        .trim(csv::Trim::All)
        .from_reader(text.as_bytes())
}

/// A record that is a blank line or a comment line indented by white space.
fn is_blank_or_comment(record: &csv::StringRecord) -> bool {
    (record.len() == 1 && record[0].is_empty()) || record.get(0).is_some_and(|c| c.starts_with('#'))
}

/// The data rows converted to SI, one vector per column (empty for unknown columns), with the
/// file line of each row.
fn read_rows(
    records: &mut csv::StringRecordsIter<&[u8]>,
    header: &Header,
) -> Result<(Vec<Vec<f64>>, Vec<usize>), LogError> {
    let mut columns: Vec<Vec<f64>> = vec![Vec::new(); header.names.len()];
    let mut row_lines = Vec::new();
    for record in records {
        let record = record.map_err(|e| LogError::at(None, None, LogErrorKind::Csv(e.to_string())))?;
        if is_blank_or_comment(&record) {
            continue;
        }
        let line = record.position().map_or(0, |p| p.line() as usize);
        if record.len() != header.names.len() {
            let kind = LogErrorKind::RaggedRow { cells: record.len(), columns: header.names.len() };
            return Err(LogError::at(Some(line), None, kind));
        }
        for (j, cell) in record.iter().enumerate() {
            let ColumnKind::Known { factor, signal, .. } = &header.kinds[j] else { continue };
            let error = |kind| LogError::at(Some(line), Some(&header.names[j]), kind);
            let value: f64 = cell.parse().map_err(|_| error(LogErrorKind::NotANumber(truncate(cell, 40))))?;
            if !value.is_finite() {
                return Err(error(LogErrorKind::NotFinite(truncate(cell, 40))));
            }
            // Times may be clock readings (a Unix time is 1.7e9 s): their sample interval is checked.
            if *signal != Signal::Time && (value * factor).abs() > MAX_ABS_VALUE {
                return Err(error(LogErrorKind::Implausible(truncate(cell, 40))));
            }
            columns[j].push(value * factor);
        }
        row_lines.push(line);
    }
    Ok((columns, row_lines))
}

/// Parses a log from text.
pub fn parse_str(text: &str) -> Result<MeasuredLog, LogError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    if text.trim().is_empty() {
        return Err(LogError::at(None, None, LogErrorKind::Empty));
    }
    let metadata = read_metadata(text)?;
    let mut reader = csv_reader(text);
    let mut records = reader.records();
    let header = loop {
        match records.next() {
            None => return Err(LogError::at(None, None, LogErrorKind::NoHeader)),
            Some(Err(e)) => return Err(LogError::at(None, None, LogErrorKind::Csv(e.to_string()))),
            Some(Ok(record)) if is_blank_or_comment(&record) => continue,
            Some(Ok(record)) => {
                let line = record.position().map_or(0, |p| p.line() as usize);
                break Header::read(&record, line)?;
            }
        }
    };
    let (columns, row_lines) = read_rows(&mut records, &header)?;
    if row_lines.is_empty() {
        return Err(LogError::at(None, None, LogErrorKind::NoRows));
    }
    if row_lines.len() < 2 {
        return Err(LogError::at(Some(row_lines[0]), None, LogErrorKind::TooFewSamples));
    }
    assemble(metadata, header, columns, &row_lines)
}

/// The log from its columns: time checked to increase without gaps, the other known columns as
/// channels in file order.
fn assemble(
    metadata: BTreeMap<String, String>,
    header: Header,
    mut columns: Vec<Vec<f64>>,
    row_lines: &[usize],
) -> Result<MeasuredLog, LogError> {
    let Header { names, kinds, notes } = header;
    let time_index =
        kinds.iter().position(|k| matches!(k, ColumnKind::Known { signal: Signal::Time, .. })).unwrap_or(0);
    let time = std::mem::take(&mut columns[time_index]);
    let time_error = |row: usize, kind| LogError::at(Some(row_lines[row]), Some(&names[time_index]), kind);
    for i in 1..time.len() {
        if time[i] <= time[i - 1] {
            return Err(time_error(i, LogErrorKind::TimeNotIncreasing { time: time[i], previous: time[i - 1] }));
        }
    }
    let mut channels = Vec::new();
    for (j, kind) in kinds.into_iter().enumerate() {
        if let ColumnKind::Known { signal, motor, unit, .. } = kind {
            if signal == Signal::Time {
                continue;
            }
            channels.push(Channel {
                signal,
                motor,
                column: names[j].clone(),
                unit,
                values: std::mem::take(&mut columns[j]),
            });
        }
    }
    let mut log = MeasuredLog { metadata, time, channels, notes };
    let dt = log.sample_interval();
    if !(MIN_SAMPLE_INTERVAL_S..=MAX_SAMPLE_INTERVAL_S).contains(&dt) {
        return Err(LogError::at(None, Some(&names[time_index]), LogErrorKind::ImplausibleSampleInterval(dt)));
    }
    // A gap many times the usual interval is a record stitched from separate runs (or a
    // logger that stalled): the analyses assume one continuous run, and resampling across the
    // gap would invent data (and, for a long gap, exhaust memory). Say where to split it.
    if let Some(i) = (1..log.time.len()).find(|&i| log.time[i] - log.time[i - 1] > MAX_GAP_INTERVALS * dt) {
        let kind = LogErrorKind::Gap { gap: log.time[i] - log.time[i - 1], after: log.time[i - 1], interval: dt };
        return Err(time_error(i, kind));
    }
    let worst = log.time.windows(2).map(|w| ((w[1] - w[0]) / dt - 1.0).abs()).fold(0.0, f64::max);
    if worst > 0.01 {
        log.notes.push(format!(
            "sampling is uneven: an interval differs from the median {dt:.6} s by {:.0} %",
            worst * 100.0
        ));
    }
    Ok(log)
}

/// The response of a first-order lag of time constant `tau` (starting in steady state) to an
/// input that is linear between its samples: exact at the sample times.
pub fn first_order_lag(time: &[f64], input: &[f64], tau: f64) -> Vec<f64> {
    let mut output = Vec::with_capacity(input.len());
    let Some(&first) = input.first() else { return output };
    let mut y = first;
    output.push(y);
    for k in 1..input.len() {
        let h = time[k] - time[k - 1];
        let decay = (-h / tau).exp();
        let slope = (input[k] - input[k - 1]) / h;
        // y' = (u - y)/tau with u = u0 + slope t: y(h) = u(h) - slope tau + (y0 - u0 + slope tau) e^(-h/tau).
        y = input[k] - slope * tau + (y - input[k - 1] + slope * tau) * decay;
        output.push(y);
    }
    output
}

fn check_required(kinds: &[ColumnKind], names: &[String], line: usize) -> Result<(), LogError> {
    let has = |wanted: &[Signal]| {
        kinds.iter().any(|k| matches!(k, ColumnKind::Known { signal, .. } if wanted.contains(signal)))
    };
    if !has(&[Signal::Time]) {
        return Err(LogError::at(
            Some(line),
            Some("time"),
            LogErrorKind::MissingColumn(format!(
                "time (e.g. 'time_s', or 'time' in an fmpy result file); header is: {}",
                names.join(",")
            )),
        ));
    }
    if !has(&[Signal::MotorCurrent, Signal::MotorCurrentCommand, Signal::MotorTorque]) {
        return Err(LogError::at(
            Some(line),
            Some("motor_current / motor_torque"),
            LogErrorKind::MissingColumn(
                "at least one motor_current_<unit>, motor_current_command_<unit> or motor_torque_<unit>".into(),
            ),
        ));
    }
    if !has(&[Signal::LoadPos, Signal::MotorPos]) {
        return Err(LogError::at(
            Some(line),
            Some("load_pos / motor_pos"),
            LogErrorKind::MissingColumn("at least one position output, load_pos_<unit> or motor_pos_<unit>".into()),
        ));
    }
    Ok(())
}

fn truncate(text: &str, max_chars: usize) -> String {
    let mut out: String = text.chars().take(max_chars).collect();
    if text.chars().count() > max_chars {
        out.push_str("...");
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};

    const GOOD: &str = "# gear_ratio = 256.9\n# axis = azimuth\ntime_s,ref_pos_deg,motor_pos_deg,load_pos_deg,motor_vel_deg_s,load_vel_deg_s,motor_torque_Nm\n\
0.000,0.0,0.1,0.0,1.0,1.0,2.0\n0.004,0.0,0.2,0.1,1.0,1.0,2.5\n0.008,0.0,0.3,0.2,1.0,1.0,3.0\n";

    fn error_of(text: &str) -> LogError {
        parse_str(text).expect_err("the log should be rejected")
    }

    #[test]
    fn reads_metadata_units_and_signals_in_si() {
        let log = parse_str(GOOD).unwrap();
        assert_eq!(log.metadata.get("gear_ratio").map(String::as_str), Some("256.9"));
        assert_eq!(log.metadata.get("axis").map(String::as_str), Some("azimuth"));
        assert_eq!(log.len(), 3);
        let motor_pos = log.signal(Signal::MotorPos).unwrap();
        assert!((motor_pos[1] - 0.2_f64.to_radians()).abs() < 1e-15);
        assert!((log.sample_interval() - 0.004).abs() < 1e-12);
        assert_eq!(log.total_motor_torque(99.0), vec![2.0, 2.5, 3.0]);
        assert!(log.notes.is_empty());
    }

    #[test]
    fn kuka_files_are_valid_logs_as_they_are() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/measured/kuka-robot-drive");
        for axis in 1..=3 {
            let log = MeasuredLog::read(&dir.join(format!("axis{axis}.csv"))).unwrap();
            assert_eq!(log.len(), 2501);
            for signal in [
                Signal::RefPos,
                Signal::MotorPos,
                Signal::LoadPos,
                Signal::MotorVel,
                Signal::LoadVel,
                Signal::MotorTorque,
            ] {
                assert!(log.signal(signal).is_some(), "axis {axis} lacks {signal:?}");
            }
            assert!(log.notes.is_empty(), "{:?}", log.notes);
        }
    }

    #[test]
    fn converts_every_unit_suffix() {
        let text = "time_ms,motor_current_1_mA,motor_current_2_A,load_pos_arcsec,motor_pos_mdeg,motor_vel_rpm,load_vel_rad_s,wind_speed_m_s,disturbance_torque_kNm,elevation_rad\n\
0,1000,1,3600,1000,60,1,5,1,0.5\n1,2000,2,7200,2000,120,1,5,1,0.5\n";
        let log = parse_str(text).unwrap();
        assert!((log.time[1] - 1e-3).abs() < 1e-15);
        let currents = log.signals(Signal::MotorCurrent);
        assert_eq!(currents.len(), 2);
        assert_eq!((currents[0].motor, currents[1].motor), (Some(1), Some(2)));
        assert!((currents[0].values[0] - 1.0).abs() < 1e-12);
        assert!((log.signal(Signal::LoadPos).unwrap()[0] - 1f64.to_radians()).abs() < 1e-12);
        assert!((log.signal(Signal::MotorPos).unwrap()[0] - 1f64.to_radians()).abs() < 1e-12);
        assert!((log.signal(Signal::MotorVel).unwrap()[0] - 2.0 * std::f64::consts::PI).abs() < 1e-12);
        assert!((log.signal(Signal::DisturbanceTorque).unwrap()[0] - 1000.0).abs() < 1e-9);
        // Two current columns add up, each times the torque constant.
        assert!((log.total_motor_torque(2.0)[0] - 4.0).abs() < 1e-12);
        assert!(log.torque_from_current());
    }

    #[test]
    fn a_linear_axis_reads_metres_and_newtons_and_says_it_is_linear() {
        let text =
            "time_s,motor_current_A,load_pos_mm,motor_pos_m,load_vel_mm_s,disturbance_torque_kN,wind_speed_m_s\n\
0,1,1000,1,10,2,5\n0.01,1,1001,1.001,10,2,5\n";
        let log = parse_str(text).unwrap();
        assert!(log.is_linear());
        assert!((log.signal(Signal::LoadPos).unwrap()[1] - 1.001).abs() < 1e-12);
        assert!((log.signal(Signal::MotorPos).unwrap()[1] - 1.001).abs() < 1e-12);
        assert!((log.signal(Signal::LoadVel).unwrap()[0] - 0.01).abs() < 1e-15);
        assert_eq!(log.signal(Signal::DisturbanceTorque).unwrap()[0], 2000.0);
        // m_s is still the wind's unit, and an angle log is not linear.
        assert_eq!(log.signal(Signal::WindSpeed).unwrap()[0], 5.0);
        assert!(!parse_str(GOOD).unwrap().is_linear());
        // A length is no unit of a current.
        assert!(error_of("time_s,motor_current_m,load_pos_m\n0,1,0\n1,1,0\n")
            .to_string()
            .contains("not a unit of Current"));
    }

    #[test]
    fn a_logged_current_command_becomes_the_current_through_the_loop() {
        let text = "time_s,motor_current_command_A,load_pos_rad\n0,0,0\n0.001,1,0\n0.002,1,0\n0.003,1,0\n";
        let log = parse_str(text).unwrap();
        assert!(log.current_is_commanded() && log.signal(Signal::MotorCurrent).is_none());
        let bandwidth = 100.0;
        let current = log.with_current_from_command(bandwidth).unwrap();
        assert!(!current.current_is_commanded());
        let values = current.signal(Signal::MotorCurrent).unwrap();
        // The lag's response to a ramp over the first millisecond, then to the held value:
        // t/T - (tau/T)(1 - exp(-t/tau)), then 1 + (y(T) - 1) exp(-(t - T)/tau).
        let tau = 1.0 / (2.0 * std::f64::consts::PI * bandwidth);
        let ramp_end = 1.0 - tau / 0.001 * (1.0 - (-0.001 / tau).exp());
        let expected: Vec<f64> = (0..4)
            .map(|k| match k {
                0 => 0.0,
                _ => 1.0 + (ramp_end - 1.0) * (-((k - 1) as f64) * 0.001 / tau).exp(),
            })
            .collect();
        for (a, b) in values.iter().zip(&expected) {
            assert!((a - b).abs() < 1e-12, "{values:?} against {expected:?}");
        }
        // Without a bandwidth the command is taken as it is, with a note saying so.
        let as_is = log.with_current_from_command(0.0).unwrap();
        assert_eq!(as_is.signal(Signal::MotorCurrent).unwrap(), log.signal(Signal::MotorCurrentCommand).unwrap());
        assert!(as_is.notes.iter().any(|n| n.contains("no motor.current_loop_bandwidth")));
        // A log of the measured current is left alone.
        assert!(parse_str(GOOD).unwrap().with_current_from_command(bandwidth).is_none());
    }

    #[test]
    fn unknown_columns_are_ignored_with_a_note() {
        let text = "time_s,motor_torque_Nm,load_pos_rad,temperature_C,comment\n0,1,0,20,x\n1,1,0,21,y\n";
        let log = parse_str(text).unwrap();
        assert_eq!(log.channels.len(), 2);
        assert_eq!(log.notes.len(), 2);
        assert!(log.notes[0].contains("temperature_C"));
    }

    #[test]
    fn missing_time_column_is_named() {
        let e = error_of("motor_torque_Nm,load_pos_rad\n1,0\n2,0\n");
        assert_eq!(e.line, Some(1));
        assert!(e.to_string().contains("time"), "{e}");
    }

    #[test]
    fn missing_torque_or_current_column_is_named() {
        let e = error_of("time_s,load_pos_rad\n0,0\n1,0\n");
        assert!(e.to_string().contains("motor_current"), "{e}");
    }

    #[test]
    fn missing_position_output_is_named() {
        let e = error_of("time_s,motor_torque_Nm,ref_pos_rad\n0,1,0\n1,1,0\n");
        assert!(e.to_string().contains("load_pos"), "{e}");
    }

    #[test]
    fn non_numeric_cell_names_line_and_column() {
        let e = error_of("# axis = el\ntime_s,motor_torque_Nm,load_pos_rad\n0,1,0\n0.1,abc,0\n");
        assert_eq!(e.line, Some(4));
        assert_eq!(e.column.as_deref(), Some("motor_torque_Nm"));
        assert!(e.to_string().contains("abc"));
    }

    #[test]
    fn empty_cell_is_rejected_not_read_as_zero() {
        let e = error_of("time_s,motor_torque_Nm,load_pos_rad\n0,1,0\n0.1,,0\n");
        assert_eq!((e.line, e.column.as_deref()), (Some(3), Some("motor_torque_Nm")));
    }

    #[test]
    fn nan_and_infinity_are_rejected() {
        for bad in ["NaN", "nan", "inf", "-inf", "1e999"] {
            let e = error_of(&format!("time_s,motor_torque_Nm,load_pos_rad\n0,1,0\n0.1,1,{bad}\n"));
            assert_eq!((e.line, e.column.as_deref()), (Some(3), Some("load_pos_rad")), "{bad}");
        }
    }

    #[test]
    fn non_increasing_time_names_the_row() {
        let e = error_of("time_s,motor_torque_Nm,load_pos_rad\n0,1,0\n0.1,1,0\n0.1,1,0\n");
        assert_eq!((e.line, e.column.as_deref()), (Some(4), Some("time_s")));
        let e = error_of("time_s,motor_torque_Nm,load_pos_rad\n0,1,0\n0.1,1,0\n0.05,1,0\n");
        assert_eq!(e.line, Some(4));
    }

    #[test]
    fn a_gap_in_the_sampling_names_the_row_instead_of_being_resampled() {
        let mut text = String::from("time_s,motor_torque_Nm,load_pos_rad\n");
        for k in 0..2000 {
            text.push_str(&format!("{},1,0\n", k as f64 * 2e-3));
        }
        text.push_str("1e7,1,0\n");
        let e = error_of(&text);
        assert_eq!((e.line, e.column.as_deref()), (Some(2002), Some("time_s")));
        assert!(e.to_string().contains("split the log"), "{e}");
        // Ordinary jitter of the logger's clock is not a gap.
        let jittered: String = std::iter::once("time_s,motor_torque_Nm,load_pos_rad\n".to_string())
            .chain((0..200).map(|k| format!("{},1,0\n", k as f64 * 2e-3 + if k % 2 == 0 { 3e-4 } else { 0.0 })))
            .collect();
        assert!(parse_str(&jittered).is_ok());
    }

    #[test]
    fn ragged_rows_are_rejected() {
        let e = error_of("time_s,motor_torque_Nm,load_pos_rad\n0,1,0\n0.1,1\n");
        assert_eq!(e.line, Some(3));
        let e = error_of("time_s,motor_torque_Nm,load_pos_rad\n0,1,0\n0.1,1,0,7\n");
        assert_eq!(e.line, Some(3));
    }

    #[test]
    fn empty_file_and_header_only_are_rejected() {
        assert!(error_of("").to_string().contains("empty"));
        assert!(error_of("\n \n").to_string().contains("empty"));
        assert!(error_of("# a = b\n").to_string().contains("no header"));
        assert!(error_of("time_s,motor_torque_Nm,load_pos_rad\n").to_string().contains("no data rows"));
    }

    #[test]
    fn unknown_unit_on_a_known_signal_is_an_error() {
        let e = error_of("time_s,motor_torque_lbft,load_pos_rad\n0,1,0\n1,1,0\n");
        assert_eq!(e.column.as_deref(), Some("motor_torque_lbft"));
        assert!(matches!(&e.kind, LogErrorKind::UnknownUnit { unit, .. } if unit == "lbft"), "{e}");
        assert!(e.to_string().contains("unknown unit suffix 'lbft'"), "{e}");
        // A real unit of the wrong dimension is an error too.
        let e = error_of("time_s,motor_torque_Nm,load_pos_rad_s\n0,1,0\n1,1,0\n");
        assert_eq!(e.column.as_deref(), Some("load_pos_rad_s"));
        // And a known signal without any unit.
        let e = error_of("time_s,motor_torque,load_pos_rad\n0,1,0\n1,1,0\n");
        assert_eq!(e.column.as_deref(), Some("motor_torque"));
    }

    #[test]
    fn duplicate_signal_columns_are_rejected() {
        let e = error_of("time_s,motor_torque_Nm,load_pos_rad,load_pos_deg\n0,1,0,0\n1,1,0,0\n");
        assert_eq!(e.column.as_deref(), Some("load_pos_deg"));
    }

    #[test]
    fn invalid_utf8_is_an_error_with_a_line() {
        let mut bytes = b"time_s,motor_torque_Nm,load_pos_rad\n0,1,0\n".to_vec();
        bytes.extend_from_slice(&[0xff, 0xfe, b'\n']);
        assert_eq!(parse_bytes(&bytes).unwrap_err().line, Some(3));
    }

    #[test]
    fn motor_position_is_integrated_from_a_motor_speed_without_a_motor_encoder() {
        // A drive swinging back and forth and twisting at a higher frequency; the log has the
        // motor speed (with the bias and scale error of an analogue speed output) and the load
        // encoder, but no motor encoder.
        let dt = 0.002;
        let (twist_amplitude, bias, scale_error) = (2e-6, 3e-7, 5e-3);
        let load_pos = |t: f64| 0.01 * t + 0.02 * (0.5 * t).sin();
        let load_vel = |t: f64| 0.01 + 0.01 * (0.5 * t).cos();
        let motor_pos = |t: f64| load_pos(t) + twist_amplitude * (7.0 * t).sin();
        let mut text = String::from("time_s,motor_current_A,load_pos_rad,motor_vel_rad_s\n");
        for k in 0..10_000 {
            let t = k as f64 * dt;
            let speed = (1.0 + scale_error) * (load_vel(t) + 7.0 * twist_amplitude * (7.0 * t).cos()) + bias;
            text.push_str(&format!("{t:.4},1.0,{:.12e},{speed:.12e}\n", load_pos(t)));
        }
        let log = parse_str(&text).unwrap();
        assert!(!log.motor_position_is_integrated());
        let integrated = log.with_motor_position_from_speed().expect("a motor position from the speed");
        assert!(integrated.motor_position_is_integrated());
        assert!(
            integrated.notes.iter().any(|n| n.contains("integrated from 'motor_vel_rad_s'")),
            "{:?}",
            integrated.notes
        );
        // The result is the motor position less its mean twist, the bias's drift and the scale
        // error: what is left is the twist's own variation, to the trapezoid rule's accuracy.
        let load = integrated.signal(Signal::LoadPos).unwrap();
        let twist: Vec<f64> =
            integrated.signal(Signal::MotorPos).unwrap().iter().zip(load).map(|(m, l)| m - l).collect();
        let true_twist: Vec<f64> = integrated.time.iter().zip(load).map(|(t, l)| motor_pos(*t) - l).collect();
        let mean = |x: &[f64]| x.iter().sum::<f64>() / x.len() as f64;
        let (m_twist, m_true) = (mean(&twist), mean(&true_twist));
        let worst =
            twist.iter().zip(&true_twist).map(|(a, b)| ((a - m_twist) - (b - m_true)).abs()).fold(0.0, f64::max);
        assert!(worst < 0.05 * twist_amplitude, "twist error {worst:e} against an amplitude {twist_amplitude:e}");
        // Without the scale correction the twist would be off by the scale error times the
        // swing (1e-4 rad here), fifty times the twist itself.
        // A log with a motor encoder, or without a load encoder to anchor to, is left alone.
        assert!(parse_str(GOOD).unwrap().with_motor_position_from_speed().is_none());
        let no_load =
            parse_str("time_s,motor_current_A,motor_vel_rad_s,motor_pos_rad\n0,1,1,0\n0.1,1,1,0.1\n").unwrap();
        assert!(no_load.with_motor_position_from_speed().is_none());
    }

    #[test]
    fn written_logs_read_back_identically() {
        let log = parse_str(GOOD).unwrap();
        let text = log.to_csv(&[(Signal::MotorPos, "deg"), (Signal::LoadPos, "arcsec")]);
        let back = parse_str(&text).unwrap();
        assert_eq!(back.metadata, log.metadata);
        for (a, b) in back.channels.iter().zip(&log.channels) {
            assert_eq!(a.signal, b.signal);
            for (x, y) in a.values.iter().zip(&b.values) {
                assert!((x - y).abs() <= 1e-9 * y.abs().max(1e-12), "{x} vs {y}");
            }
        }
    }

    /// The start of an `AzimuthPlant` result as fmpy's `write_csv` writes it: every output, in
    /// the model description's order, quoted names, Python's `str` of each value.
    const FMPY_AZIMUTH: &str = "\"time\",\"axis.encoder_position\",\"axis.position\",\"axis.speed\",\"motor1.speed\",\"motor2.speed\",\"motor1.current\",\"motor2.current\",\"motor1.torque\",\"motor2.torque\",\"pinion1.torque\",\"pinion2.torque\",\"pinion1.flank\",\"pinion2.flank\",\"load.inertia\",\"drive.anti_resonance_frequency\"
0.0,10.0,10.0,0.0,0.0,0.0,0.0,0.0,0.0,0.0,0.0,0.0,0,0,60000.0,4.0
0.002,10.000010728836059,10.000012345678901,0.012,1.2566370614359172,1.2566370614359172,1.5,-0.5,3.0,-1.0,1800.0,-600.0,1,-1,60000.0,4.0
0.004,10.000042915344238,10.00004938271605,0.024,2.5132741228718345,2.5132741228718345,2.0,1e-05,4.0,2e-05,2400.0,0.024,1,1,60000.0,4.0
";

    #[test]
    fn an_fmpy_result_file_maps_the_fmu_variables_to_signals() {
        let log = parse_str(FMPY_AZIMUTH).unwrap();
        assert_eq!(log.time, vec![0.0, 0.002, 0.004]);
        // The encoder reading (not the true angle) is the load position, in deg in the file.
        let load = log.signals(Signal::LoadPos);
        assert_eq!((load.len(), load[0].column.as_str()), (1, "axis.encoder_position"));
        assert!((load[0].values[1] - "10.000010728836059".parse::<f64>().unwrap().to_radians()).abs() < 1e-15);
        assert!((log.signal(Signal::LoadVel).unwrap()[1] - 0.012f64.to_radians()).abs() < 1e-15);
        // Two motors, numbered as in the FMU; torques in N m win over currents.
        let currents = log.signals(Signal::MotorCurrent);
        assert_eq!((currents[0].motor, currents[1].motor), (Some(1), Some(2)));
        assert_eq!(currents[1].values[2], 1e-5);
        assert!(!log.torque_from_current());
        assert_eq!(log.total_motor_torque(99.0), vec![0.0, 2.0, 4.00002]);
        // Shaft speeds (not referred to the axis), pinion torques and the rest are ignored,
        // each with a note.
        assert!(log.signal(Signal::MotorVel).is_none() && log.signal(Signal::MotorPos).is_none());
        for ignored in ["axis.position", "motor1.speed", "pinion2.flank", "drive.anti_resonance_frequency"] {
            assert!(log.notes.iter().any(|n| n.contains(&format!("'{ignored}'"))), "{ignored}: {:?}", log.notes);
        }
    }

    #[test]
    fn an_fmpy_result_file_without_the_encoder_uses_the_true_angle() {
        let text = "\"time\",\"axis.position\",\"motor.current\"\n0.0,1.0,0.5\n0.01,2.0,0.5\n";
        let log = parse_str(text).unwrap();
        assert_eq!(log.signals(Signal::LoadPos)[0].column, "axis.position");
        assert!((log.signal(Signal::LoadPos).unwrap()[1] - 2f64.to_radians()).abs() < 1e-15);
        // An fmpy file without any current, torque or position is refused by name.
        let e = error_of("\"time\",\"axis.speed\"\n0.0,1.0\n0.01,2.0\n");
        assert_eq!(e.column.as_deref(), Some("motor_current / motor_torque"));
    }

    #[test]
    fn random_bytes_and_mutations_never_panic() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let alphabet = b"0123456789.,-+eE#=_ \n\r\tabcdefghijklmnopqrstuvwxyz\"NnaIif\xff\x00";
        for _ in 0..3000 {
            let len = rng.random_range(0..200);
            let bytes: Vec<u8> = (0..len).map(|_| alphabet[rng.random_range(0..alphabet.len())]).collect();
            let _ = parse_bytes(&bytes);
        }
        // Mutations of a valid log reach the deeper code paths that random bytes rarely do.
        let good = GOOD.as_bytes();
        for _ in 0..3000 {
            let mut bytes = good.to_vec();
            for _ in 0..rng.random_range(1..4) {
                let at = rng.random_range(0..bytes.len());
                match rng.random_range(0..3) {
                    0 => bytes[at] = alphabet[rng.random_range(0..alphabet.len())],
                    1 => {
                        bytes.remove(at);
                    }
                    _ => bytes.insert(at, alphabet[rng.random_range(0..alphabet.len())]),
                }
                if bytes.is_empty() {
                    break;
                }
            }
            let _ = parse_bytes(&bytes);
        }
    }
}
