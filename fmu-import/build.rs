//! Compiles the C logger shim the importer passes to FMUs (a variadic C function, which stable
//! Rust cannot define).

fn main() {
    println!("cargo:rerun-if-changed=src/logger_shim.c");
    cc::Build::new().file("src/logger_shim.c").warnings(true).compile("fmu_import_logger_shim");
}
