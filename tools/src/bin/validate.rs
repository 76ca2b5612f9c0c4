//! validate: traces a measured log's residual to effects the model lacks.
//!
//! Usage:
//!   validate run LOG.csv --params START.params [--out DIR] [--alpha 1e-3] [--verbose]
//!       Validates one log: writes DIR/<log>_report.md, DIR/<log>_corrected.params and PNG
//!       figures, and prints the summary. Exit code 0 on success, 2 on an input error.
//!   validate suite DIR [--out DIR2]
//!       Validates every log of a truthgen suite against DIR/start.params and scores the
//!       results against the hidden truth: writes results.md (table and detection curve),
//!       detection.csv and detection.png.

use antenna_tools::measured_log::MeasuredLog;
use antenna_tools::validate::{self, parameters::ParameterSet, report, scoring, ValidateOptions};
use std::path::{Path, PathBuf};

fn main() {
    if let Err(message) = run(std::env::args().skip(1).collect()) {
        eprintln!("validate: {message}");
        std::process::exit(2);
    }
}

fn run(args: Vec<String>) -> Result<(), String> {
    let command = args.first().ok_or("expected a command: run or suite (see the source header)")?;
    let target = args.get(1).ok_or("expected a log file or a suite folder")?;
    let mut params_path: Option<PathBuf> = None;
    let mut out: Option<PathBuf> = None;
    let mut options = ValidateOptions::default();
    let mut verbose = false;
    let mut i = 2;
    while i < args.len() {
        let flag = args[i].as_str();
        let mut value = || -> Result<String, String> {
            i += 1;
            args.get(i).cloned().ok_or_else(|| format!("{flag} needs a value"))
        };
        match flag {
            "--params" => params_path = Some(PathBuf::from(value()?)),
            "--out" => out = Some(PathBuf::from(value()?)),
            "--alpha" => options.selection.alpha = value()?.parse().map_err(|_| "--alpha needs a number")?,
            "--min-effect-to-noise" => options.selection.min_effect_to_noise = value()?.parse().map_err(|_| "--min-effect-to-noise needs a number")?,
            "--verbose" => verbose = true,
            other => return Err(format!("unknown option '{other}'")),
        }
        i += 1;
    }
    match command.as_str() {
        "run" => {
            let log_path = Path::new(target);
            let log = MeasuredLog::read(log_path).map_err(|e| format!("{}: {e}", log_path.display()))?;
            let params_path = params_path.ok_or("--params is required")?;
            let start = ParameterSet::read(&params_path)?;
            let validation = validate::validate(&log, &start, &options)?;
            let stem = log_path.file_stem().map(|s| s.to_string_lossy().to_string()).unwrap_or_else(|| "log".into());
            let text = report::markdown(&validation, &log_path.display().to_string());
            if let Some(dir) = &out {
                std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
                std::fs::write(dir.join(format!("{stem}_report.md")), &text).map_err(|e| e.to_string())?;
                validation.selection.corrected.write(
                    &dir.join(format!("{stem}_corrected.params")),
                    &format!("Corrected by validate from {} on {}.", params_path.display(), log_path.display()),
                )?;
                for figure in report::figures(&validation, dir, &stem)? {
                    println!("wrote {figure}");
                }
            }
            if verbose {
                println!("{text}");
            } else {
                print_summary(&validation);
            }
        }
        "suite" => {
            let dir = Path::new(target);
            let out = out.unwrap_or_else(|| dir.to_path_buf());
            std::fs::create_dir_all(&out).map_err(|e| e.to_string())?;
            let results = scoring::run_suite(dir, &options, &mut |r| {
                let truth = antenna_tools::truth::suite::describe(&r.truth);
                let found = r.error.clone().unwrap_or_else(|| if r.found.is_empty() { "none".into() } else { r.found.join(", ") });
                println!("{}: {truth} -> {found}", r.truth.log_file);
            })?;
            let mut text = String::from("## Results on the generated suite\n\n");
            text.push_str(&scoring::summary_markdown(&results));
            text.push_str("\n### All cases\n\n");
            text.push_str(&scoring::table_markdown(&results));
            std::fs::write(out.join("results.md"), &text).map_err(|e| e.to_string())?;
            std::fs::write(out.join("detection.csv"), scoring::detection_csv(&results)).map_err(|e| e.to_string())?;
            scoring::detection_figure(&results, &out.join("detection.png"))?;
            println!("{}", scoring::summary_markdown(&results));
            println!("wrote {}", out.join("results.md").display());
        }
        other => return Err(format!("unknown command '{other}'")),
    }
    Ok(())
}

fn print_summary(v: &validate::Validation) {
    if v.selection.found.is_empty() {
        println!("no significant missing effect");
    }
    for found in &v.selection.found {
        println!("found {} ({})", found.kind.name(), found.kind.description());
        for (name, value, sd, unit) in &found.parameters {
            println!("    {name} = {value:.6e} +- {sd:.2e} {unit}");
        }
    }
    for (b, a) in v.before.iter().zip(&v.after) {
        println!("{}: RMS {:.4} -> {:.4} N m (axis side), fit {:.1} -> {:.1} %, whiteness p {:.1e} -> {:.1e}", b.name, b.rms, a.rms, b.fit_percent, a.fit_percent, b.whiteness_p, a.whiteness_p);
    }
}
