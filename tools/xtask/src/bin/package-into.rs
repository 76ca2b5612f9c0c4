//! Builds and packages every FMU into a given folder, using the current CARGO_TARGET_DIR (or
//! `target/`). Used by the reproducibility check of `package`.

use std::path::PathBuf;
use std::process::ExitCode;

fn main() -> ExitCode {
    let Some(output) = std::env::args().nth(1).map(PathBuf::from) else {
        eprintln!("usage: package-into <output folder>");
        return ExitCode::FAILURE;
    };
    let target = std::env::var("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|_| antenna_fmus::workspace_root().join("target"));
    let result = xtask::build_libraries(&target)
        .and_then(|()| xtask::package_all(&target, &output));
    match result {
        Ok(paths) => {
            for p in paths {
                println!("{}", p.display());
            }
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("{e}");
            ExitCode::FAILURE
        }
    }
}
