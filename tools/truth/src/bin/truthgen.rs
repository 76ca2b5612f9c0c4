//! truthgen: writes measured logs from the independent truth simulation.
//!
//! Usage:
//!   truthgen suite --out DIR [--seeds 11,12] [--sizes 0.5,1,2,5,10,20,50] [--clean 10]
//!                  [--kinds coulomb,delay,...] [--duration 60] [--no-pairs] [--presliding RAD] [--internal-rate HZ]
//!                  [--log-rate HZ] [--noise-scale X] [--anti-resonance HZ] [--load-inertia KGM2]
//!                  [--motor-speed | --no-motor-sensor] [--motors 2 [--current-bias A]]
//!   truthgen one --out FILE.csv [--effect KIND --size RATIO]... [--seed N] [--duration 60]
//!   truthgen start --out FILE.params
//!
//! `suite` writes `log_NNN.csv` logs with a hidden `log_NNN.truth` beside each and the starting
//! parameter set `start.params`. `one` writes a single log (and FILE.truth). Sizes are the RMS
//! of what the effect adds to its channel divided by that channel's sensor noise.
//! `--presliding` sets the truth's LuGre bristle deflection at breakaway (axis rad, default
//! 1e-7), for studies of the friction-model-form floor; the suite uses the default.
//! `--internal-rate` sets the RK4 base rate (default 20 kHz; steps are cut into substeps
//! while the bristles relax faster than that).
//! `--log-rate`, `--noise-scale` (current and load-encoder noise times X), `--anti-resonance`
//! (the nominal path stiffness set for this locked-motor anti-resonance, damping ratio kept)
//! and `--load-inertia` make logs unlike the suite's, to check that `validate` is not tuned to
//! the suite (docs/validation.md, "Logs unlike the suite"); the starting set follows the plant.
//! `--motor-speed` logs a motor speed signal (truth::SpeedSensor's default: noise, bias, scale
//! error) instead of the motor encoder, `--no-motor-sensor` neither (the load encoder is the
//! only position), and `--motors 2` the current of two identical motors in
//! columns of their own, as an antenna's azimuth drive logs them, with `--current-bias` amperes
//! added to motor 1's and taken from motor 2's.

use antenna_truth::suite::{self, SuiteConfig};
use antenna_truth::{MotorSensor, SpeedSensor, TruthConfig};
use std::collections::BTreeMap;
use std::path::PathBuf;

fn main() {
    if let Err(message) = run(std::env::args().skip(1).collect()) {
        eprintln!("truthgen: {message}");
        std::process::exit(2);
    }
}

fn value<'a>(args: &'a [String], i: &mut usize, flag: &str) -> Result<&'a str, String> {
    *i += 1;
    args.get(*i).map(String::as_str).ok_or_else(|| format!("{flag} needs a value"))
}

fn positive(text: &str, flag: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(x) if x > 0.0 && x.is_finite() => Ok(x),
        _ => Err(format!("{flag} needs a positive number, not '{text}'")),
    }
}

fn list<T: std::str::FromStr>(text: &str, flag: &str) -> Result<Vec<T>, String> {
    text.split(',')
        .filter(|s| !s.trim().is_empty())
        .map(|s| s.trim().parse::<T>().map_err(|_| format!("{flag}: bad value '{s}'")))
        .collect()
}

fn run(args: Vec<String>) -> Result<(), String> {
    let Some(command) = args.first() else {
        return Err("expected a command: suite, one or start (see the source header for usage)".into());
    };
    let mut out: Option<PathBuf> = None;
    let mut suite_config = SuiteConfig::default();
    let mut base = TruthConfig::default();
    let mut effects: Vec<(String, f64)> = Vec::new();
    let mut seed = 1u64;
    let mut i = 1;
    while i < args.len() {
        let flag = args[i].as_str();
        match flag {
            "--out" => out = Some(PathBuf::from(value(&args, &mut i, flag)?)),
            "--seeds" => suite_config.seeds = list(value(&args, &mut i, flag)?, flag)?,
            "--sizes" => suite_config.sizes = list(value(&args, &mut i, flag)?, flag)?,
            "--kinds" => suite_config.kinds = list(value(&args, &mut i, flag)?, flag)?,
            "--clean" => {
                let n: u64 = value(&args, &mut i, flag)?.parse().map_err(|_| "--clean needs a count")?;
                suite_config.clean_seeds = (101..101 + n).collect();
            }
            "--no-pairs" => suite_config.pairs.clear(),
            "--presliding" => {
                base.plant.presliding_displacement =
                    value(&args, &mut i, flag)?.parse().map_err(|_| "--presliding needs a displacement in rad")?;
                if !(base.plant.presliding_displacement > 0.0) {
                    return Err("--presliding needs a positive displacement in rad".into());
                }
            }
            "--internal-rate" => {
                base.internal_rate =
                    value(&args, &mut i, flag)?.parse().map_err(|_| "--internal-rate needs a rate in Hz")?;
                if !(base.internal_rate >= base.controller_rate) {
                    return Err("--internal-rate must be at least the controller rate".into());
                }
            }
            "--log-rate" => {
                base.log_rate = positive(value(&args, &mut i, flag)?, flag)?;
                if base.log_rate > base.controller_rate {
                    return Err("--log-rate must not exceed the controller rate".into());
                }
            }
            "--noise-scale" => {
                let scale = positive(value(&args, &mut i, flag)?, flag)?;
                base.noise.current_sigma *= scale;
                base.noise.load_encoder_sigma *= scale;
            }
            "--anti-resonance" => {
                let hz = positive(value(&args, &mut i, flag)?, flag)?;
                base.plant.set_anti_resonance(hz);
            }
            "--load-inertia" => {
                let inertia = positive(value(&args, &mut i, flag)?, flag)?;
                let hz = base.plant.anti_resonance();
                base.plant.load_inertia = inertia;
                base.plant.set_anti_resonance(hz);
            }
            "--motor-speed" => base.noise.motor_sensor = MotorSensor::Speed(SpeedSensor::default()),
            "--no-motor-sensor" => base.noise.motor_sensor = MotorSensor::None,
            "--motors" => {
                base.noise.motors = value(&args, &mut i, flag)?.parse().map_err(|_| "--motors needs 1 or 2")?;
                if !(1..=2).contains(&base.noise.motors) {
                    return Err("--motors needs 1 or 2".into());
                }
            }
            "--current-bias" => {
                base.noise.current_bias =
                    value(&args, &mut i, flag)?.parse().map_err(|_| "--current-bias needs amperes")?
            }
            "--duration" => {
                base.duration = value(&args, &mut i, flag)?.parse().map_err(|_| "--duration needs seconds")?
            }
            "--seed" => seed = value(&args, &mut i, flag)?.parse().map_err(|_| "--seed needs an integer")?,
            "--effect" => {
                let kind = value(&args, &mut i, flag)?.to_string();
                effects.push((kind, 10.0));
            }
            "--size" => {
                let size: f64 = value(&args, &mut i, flag)?.parse().map_err(|_| "--size needs a number")?;
                effects.last_mut().ok_or("--size must follow --effect")?.1 = size;
            }
            other => return Err(format!("unknown option '{other}'")),
        }
        i += 1;
    }
    let out = out.ok_or("--out is required")?;
    match command.as_str() {
        "suite" => {
            suite_config.base = base;
            let truths = suite::write_suite(&out, &suite_config, &mut |line| println!("{line}"))?;
            println!("wrote {} logs to {}", truths.len(), out.display());
        }
        "one" => {
            let name = out.file_name().map(|n| n.to_string_lossy().to_string()).unwrap_or_default();
            let (text, truth) = suite::generate_case(&base, seed, &effects, &name, &mut BTreeMap::new())?;
            std::fs::write(&out, text).map_err(|e| format!("cannot write {}: {e}", out.display()))?;
            std::fs::write(out.with_extension("truth"), suite::truth_text(&truth)).map_err(|e| e.to_string())?;
            println!("{}: {}", out.display(), suite::describe(&truth));
        }
        "start" => {
            base.plant
                .starting_parameters()
                .write(&out, "Starting parameter set: the truth generator's nominal plant.")?;
        }
        other => return Err(format!("unknown command '{other}'")),
    }
    Ok(())
}
