//! The README's suite tables are the generated ones: the block between its validation-summary
//! markers (written by `validate suite --generate`) must stand, unchanged, in
//! docs/validation-results.md, which the same run writes.

use std::path::Path;

#[test]
fn readme_suite_tables_match_the_generated_results() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let readme = std::fs::read_to_string(root.join("README.md")).expect("README.md");
    let results =
        std::fs::read_to_string(root.join("docs").join("validation-results.md")).expect("docs/validation-results.md");
    let begin = readme.find("<!-- validation-summary:").expect("the README's validation-summary marker");
    let body_start = begin + readme[begin..].find('\n').expect("a line after the marker") + 1;
    let end = readme.find("<!-- end of validation-summary -->").expect("the README's end marker");
    let block = &readme[body_start..end];
    assert!(
        block.contains("| size / noise |") && block.contains("| effect | cases |"),
        "the block holds no suite tables"
    );
    assert!(
        results.contains(block),
        "README.md's suite tables differ from docs/validation-results.md: run `validate suite --generate`"
    );
}
