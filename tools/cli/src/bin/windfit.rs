//! `windfit`: analyse a measured wind-speed record against the Davenport spectrum (Eq. 2).
//! A thin front to `antenna_windfit`; run with `--help` for the options.

use antenna_windfit::{parse_cli_args, run_cli, USAGE};
use std::process::ExitCode;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let options = match parse_cli_args(&args) {
        Ok(Some(options)) => options,
        Ok(None) => {
            print!("{USAGE}");
            return ExitCode::SUCCESS;
        }
        Err(error) => {
            eprintln!("windfit: {error}\n\n{USAGE}");
            return ExitCode::from(2);
        }
    };
    match run_cli(&options) {
        Ok(report) => {
            print!("{report}");
            ExitCode::SUCCESS
        }
        Err(error) => {
            eprintln!("windfit: {error}");
            ExitCode::FAILURE
        }
    }
}
