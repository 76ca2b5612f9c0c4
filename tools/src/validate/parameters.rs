//! The plant's parameter set: the names, units and meaning of every parameter in one table, and
//! the `name = value  # unit, comment` text format that the validate tool reads and writes and
//! the plant FMU loads through a string parameter.
//!
//! The plant FMU's variable names are not fixed yet. Every name is a constant in [`names`] and
//! every piece of code refers to the constant, so renaming a parameter is one edit here.

use std::fmt;
use std::path::Path;

/// Parameter names as the plant FMU will know them. Rename here only.
pub mod names {
    pub const GEAR_RATIO: &str = "gear.ratio";
    pub const MOTOR_INERTIA: &str = "motor.inertia";
    pub const TORQUE_CONSTANT: &str = "motor.torque_constant";
    pub const LOAD_INERTIA: &str = "load.inertia";
    pub const STIFFNESS: &str = "path.stiffness";
    pub const DAMPING: &str = "path.damping";
    pub const VISCOUS: &str = "friction.viscous";
    pub const COULOMB: &str = "friction.coulomb";
    pub const STATIC: &str = "friction.static";
    pub const STRIBECK_VELOCITY: &str = "friction.stribeck_velocity";
    pub const ASYMMETRY: &str = "friction.asymmetry";
    pub const TORQUE_OFFSET: &str = "effect.torque_offset";
    pub const UNBALANCE_TORQUE: &str = "effect.unbalance_torque";
    pub const UNBALANCE_PHASE: &str = "effect.unbalance_phase";
    pub const DELAY: &str = "effect.delay";
    pub const TORQUE_CONSTANT_SCALE: &str = "effect.torque_constant_scale";
    pub const COGGING_AMPLITUDE: &str = "effect.cogging_amplitude";
    pub const COGGING_PERIOD: &str = "effect.cogging_period";
    pub const COGGING_PHASE: &str = "effect.cogging_phase";
    pub const BACKLASH_WIDTH: &str = "backlash.width";
}

/// What one parameter means. Torques, stiffness, damping and load inertia are on the axis
/// (load) side of the gearbox; the motor inertia and torque constant are on the motor side, as
/// data sheets give them. Angles and speeds are axis-side.
#[derive(Debug, Clone, Copy)]
pub struct ParameterInfo {
    pub name: &'static str,
    pub unit: &'static str,
    pub description: &'static str,
    /// The value that means "effect absent".
    pub neutral: f64,
}

/// Every parameter the model knows, in the order the files list them.
pub const PARAMETERS: [ParameterInfo; 20] = [
    ParameterInfo { name: names::GEAR_RATIO, unit: "-", description: "gear ratio, motor turns per axis turn", neutral: 1.0 },
    ParameterInfo { name: names::MOTOR_INERTIA, unit: "kg m^2", description: "motor rotor inertia (motor side, all motors together)", neutral: 0.0 },
    ParameterInfo { name: names::TORQUE_CONSTANT, unit: "N m/A", description: "motor torque constant (per motor)", neutral: 1.0 },
    ParameterInfo { name: names::LOAD_INERTIA, unit: "kg m^2", description: "load inertia about the axis", neutral: 0.0 },
    ParameterInfo { name: names::STIFFNESS, unit: "N m/rad", description: "drive path stiffness, axis side", neutral: 0.0 },
    ParameterInfo { name: names::DAMPING, unit: "N m s/rad", description: "drive path damping, axis side", neutral: 0.0 },
    ParameterInfo { name: names::VISCOUS, unit: "N m s/rad", description: "viscous friction at the motor, referred to the axis", neutral: 0.0 },
    ParameterInfo { name: names::COULOMB, unit: "N m", description: "Coulomb friction at the motor, referred to the axis", neutral: 0.0 },
    ParameterInfo { name: names::STATIC, unit: "N m", description: "breakaway (static) friction level; equal to Coulomb means no Stribeck hump", neutral: 0.0 },
    ParameterInfo { name: names::STRIBECK_VELOCITY, unit: "rad/s", description: "Stribeck velocity of exp(-(w/ws)^2), axis side", neutral: 0.01 },
    ParameterInfo { name: names::ASYMMETRY, unit: "N m", description: "friction asymmetry a: friction is Fc + a moving forward and -(Fc - a) moving backward", neutral: 0.0 },
    ParameterInfo { name: names::TORQUE_OFFSET, unit: "N m", description: "constant torque offset (friction asymmetry, cable drag, sensor offset), axis side", neutral: 0.0 },
    ParameterInfo { name: names::UNBALANCE_TORQUE, unit: "N m", description: "unbalance torque amplitude m g r: T = A cos(angle + phase)", neutral: 0.0 },
    ParameterInfo { name: names::UNBALANCE_PHASE, unit: "rad", description: "unbalance phase; the angle is the elevation input if logged, else the axis angle", neutral: 0.0 },
    ParameterInfo { name: names::DELAY, unit: "s", description: "delay of the applied torque behind the logged current/torque", neutral: 0.0 },
    ParameterInfo { name: names::TORQUE_CONSTANT_SCALE, unit: "-", description: "true torque constant / nominal torque constant", neutral: 1.0 },
    ParameterInfo { name: names::COGGING_AMPLITUDE, unit: "N m", description: "position-periodic torque amplitude: T = A sin(2 pi angle/period + phase), angle = motor angle referred to the axis", neutral: 0.0 },
    ParameterInfo { name: names::COGGING_PERIOD, unit: "rad", description: "period of the position-periodic torque in axis-referred motor angle", neutral: 0.0 },
    ParameterInfo { name: names::COGGING_PHASE, unit: "rad", description: "phase of the position-periodic torque", neutral: 0.0 },
    ParameterInfo { name: names::BACKLASH_WIDTH, unit: "rad", description: "total lost motion (dead zone width) of the drive path, axis side", neutral: 0.0 },
];

/// Looks up the description of a known parameter.
pub fn info(name: &str) -> Option<&'static ParameterInfo> {
    PARAMETERS.iter().find(|p| p.name == name)
}

/// An error reading a parameter file, with its 1-based line.
#[derive(Debug, Clone, PartialEq)]
pub struct ParameterError {
    pub line: usize,
    pub message: String,
}

impl fmt::Display for ParameterError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "line {}: {}", self.line, self.message)
    }
}

impl std::error::Error for ParameterError {}

/// An ordered set of named parameters with a comment each (unit first, by convention).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ParameterSet {
    entries: Vec<(String, f64, String)>,
}

impl ParameterSet {
    pub fn new() -> Self {
        Self::default()
    }

    /// The value of a parameter, if set.
    pub fn get(&self, name: &str) -> Option<f64> {
        self.entries.iter().find(|e| e.0 == name).map(|e| e.1)
    }

    /// The value of a parameter, or its neutral value (effect absent) when it is not set.
    pub fn value(&self, name: &str) -> f64 {
        self.get(name).unwrap_or_else(|| info(name).map(|i| i.neutral).unwrap_or(0.0))
    }

    /// Sets a parameter, keeping its place (and its comment) if it exists already. New known
    /// parameters get their unit and description as the comment.
    pub fn set(&mut self, name: &str, value: f64) {
        if let Some(entry) = self.entries.iter_mut().find(|e| e.0 == name) {
            entry.1 = value;
        } else {
            let comment = info(name).map(|i| format!("{}, {}", i.unit, i.description)).unwrap_or_default();
            self.entries.push((name.to_string(), value, comment));
        }
    }

    /// Sets a parameter with an explicit comment.
    pub fn set_with_comment(&mut self, name: &str, value: f64, comment: &str) {
        self.set(name, value);
        if let Some(entry) = self.entries.iter_mut().find(|e| e.0 == name) {
            entry.2 = comment.to_string();
        }
    }

    /// Names in file order.
    pub fn names(&self) -> impl Iterator<Item = &str> {
        self.entries.iter().map(|e| e.0.as_str())
    }

    /// Parses `name = value  # comment` lines; blank lines and `#` lines are ignored.
    pub fn parse(text: &str) -> Result<ParameterSet, ParameterError> {
        let mut set = ParameterSet::new();
        for (index, raw) in text.lines().enumerate() {
            let line = index + 1;
            let (content, comment) = match raw.split_once('#') {
                Some((c, k)) => (c.trim(), k.trim()),
                None => (raw.trim(), ""),
            };
            if content.is_empty() {
                continue;
            }
            let Some((name, value)) = content.split_once('=') else {
                return Err(ParameterError { line, message: format!("expected 'name = value', found '{content}'") });
            };
            let name = name.trim();
            if name.is_empty() || name.contains(char::is_whitespace) {
                return Err(ParameterError { line, message: format!("bad parameter name '{name}'") });
            }
            let value: f64 = value
                .trim()
                .parse()
                .map_err(|_| ParameterError { line, message: format!("'{}' is not a number (parameter {name})", value.trim()) })?;
            if !value.is_finite() {
                return Err(ParameterError { line, message: format!("parameter {name} is not finite") });
            }
            if set.get(name).is_some() {
                return Err(ParameterError { line, message: format!("parameter {name} is set twice") });
            }
            set.entries.push((name.to_string(), value, comment.to_string()));
        }
        Ok(set)
    }

    pub fn read(path: &Path) -> Result<ParameterSet, String> {
        let text = std::fs::read_to_string(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
        ParameterSet::parse(&text).map_err(|e| format!("{}: {e}", path.display()))
    }

    /// The file text: one `name = value  # comment` line per parameter, values in full precision.
    pub fn to_text(&self) -> String {
        let width = self.entries.iter().map(|e| e.0.len()).max().unwrap_or(0);
        let mut out = String::new();
        for (name, value, comment) in &self.entries {
            if comment.is_empty() {
                out.push_str(&format!("{name:width$} = {value:e}\n"));
            } else {
                out.push_str(&format!("{name:width$} = {value:e}  # {comment}\n"));
            }
        }
        out
    }

    pub fn write(&self, path: &Path, header: &str) -> Result<(), String> {
        let mut text = String::new();
        for line in header.lines() {
            text.push_str(&format!("# {line}\n"));
        }
        text.push_str(&self.to_text());
        std::fs::write(path, text).map_err(|e| format!("cannot write {}: {e}", path.display()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parameter_names_are_unique() {
        for (i, a) in PARAMETERS.iter().enumerate() {
            assert!(PARAMETERS[..i].iter().all(|b| b.name != a.name), "{} twice", a.name);
        }
    }

    #[test]
    fn text_round_trip_keeps_order_values_and_comments() {
        let text = "# start\ngear.ratio = 256.9  # -, KUKA axis 1\nmotor.inertia=0.00923\n\nfriction.coulomb = 1.5e2 # N m\n";
        let set = ParameterSet::parse(text).unwrap();
        assert_eq!(set.names().collect::<Vec<_>>(), vec!["gear.ratio", "motor.inertia", "friction.coulomb"]);
        let back = ParameterSet::parse(&set.to_text()).unwrap();
        assert_eq!(back, set);
        assert_eq!(back.get("friction.coulomb"), Some(150.0));
    }

    #[test]
    fn missing_parameters_read_as_their_neutral_value() {
        let set = ParameterSet::parse("gear.ratio = 10").unwrap();
        assert_eq!(set.value(names::TORQUE_CONSTANT_SCALE), 1.0);
        assert_eq!(set.value(names::COULOMB), 0.0);
    }

    #[test]
    fn malformed_lines_are_reported_with_their_line() {
        assert_eq!(ParameterSet::parse("a = 1\nb 2\n").unwrap_err().line, 2);
        assert_eq!(ParameterSet::parse("a = x\n").unwrap_err().line, 1);
        assert_eq!(ParameterSet::parse("a = 1\na = 2\n").unwrap_err().line, 2);
        assert_eq!(ParameterSet::parse("a = nan\n").unwrap_err().line, 1);
    }
}
