//! `windfit`: analyse a measured wind-speed record against the Davenport spectrum (Eq. 2).
//! A thin front to `antenna_windfit`; run with `--help` for the options.
//!
//! Exit codes: 0 the report was written; 2 bad usage or bad input (clap's errors, an unreadable
//! or malformed record, an invalid setting, a record the analysis cannot use, an output that
//! cannot be written). The tool checks nothing that could fail, so it never exits 1.

use antenna_windfit::WindfitArgs;
use clap::Parser;
use std::process::ExitCode;

fn main() -> ExitCode {
    let args = WindfitArgs::parse();
    match run(&args) {
        Ok(report) => {
            print!("{report}");
            ExitCode::SUCCESS
        }
        Err(error) => {
            eprintln!("windfit: error: {error:#}");
            ExitCode::from(2)
        }
    }
}

fn run(args: &WindfitArgs) -> anyhow::Result<String> {
    Ok(antenna_windfit::run(args)?)
}
