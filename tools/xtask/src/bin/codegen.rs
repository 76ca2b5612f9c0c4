//! Regenerates the committed model descriptions under `modelDescription/` from the variable
//! tables; `--check` only reports stale files and exits non-zero if there are any.

fn main() {
    let check = std::env::args().any(|a| a == "--check");
    match xtask::codegen(check) {
        Ok(stale) if stale.is_empty() => println!("modelDescription/ is up to date"),
        Ok(stale) if check => {
            eprintln!("stale generated files (run `cargo run -p xtask --bin codegen`):");
            for s in stale {
                eprintln!("  {s}");
            }
            std::process::exit(1);
        }
        Ok(stale) => {
            for s in stale {
                println!("wrote {s}");
            }
        }
        Err(e) => {
            eprintln!("codegen failed: {e}");
            std::process::exit(2);
        }
    }
}
