//! Packaging: the committed model descriptions are what the variable tables generate now, the
//! packaged FMUs carry those same descriptions, and packaging one build twice gives
//! byte-identical `.fmu` files.

use std::io::Read;

#[test]
fn committed_model_descriptions_are_not_stale() {
    let stale = xtask::codegen(true).expect("codegen --check");
    assert!(stale.is_empty(), "stale generated files (run `cargo xtask codegen`): {stale:?}");
}

#[test]
fn packaged_fmus_carry_the_generated_model_descriptions() {
    // A stale .fmu (sources changed, not re-packaged) would test yesterday's FMU.
    for spec in antenna_fmus::all_fmus() {
        let path = antenna_tests::fmu_path(spec.model_identifier);
        let mut archive = zip::ZipArchive::new(std::fs::File::open(&path).unwrap()).unwrap();
        let mut packaged = String::new();
        archive.by_name("modelDescription.xml").unwrap().read_to_string(&mut packaged).unwrap();
        assert!(
            packaged == (spec.model_description)(),
            "{} has an out-of-date modelDescription.xml: package again (cargo xtask package)",
            path.display()
        );
    }
}

#[test]
fn packaging_the_same_build_twice_gives_byte_identical_fmus() {
    let target = antenna_fmus::workspace_root().join("target");
    let root = std::env::temp_dir().join(format!("antenna-packaging-{}", std::process::id()));
    let (first, second) = (root.join("first"), root.join("second"));
    let hint = "build the libraries first (cargo xtask package)";
    let a = xtask::package_all(&target, &first).unwrap_or_else(|e| panic!("{e}; {hint}"));
    let b = xtask::package_all(&target, &second).unwrap_or_else(|e| panic!("{e}; {hint}"));
    assert_eq!(a.len(), antenna_fmus::all_fmus().len());
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(x.file_name(), y.file_name());
        let (bytes_x, bytes_y) = (std::fs::read(x).unwrap(), std::fs::read(y).unwrap());
        assert!(!bytes_x.is_empty());
        assert!(
            bytes_x == bytes_y,
            "{} differs between two packagings of the same build",
            x.file_name().unwrap().to_string_lossy()
        );
    }
    let _ = std::fs::remove_dir_all(&root);
}
