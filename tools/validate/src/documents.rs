//! Markdown documents written in parts: a header and named `## name: description` sections,
//! of which a run rewrites only the ones it produced. The holdout documents are such: a
//! `validate holdout --only NAMES` run replaces the sections of the suites it ran, and a full
//! run that is stopped half-way must leave the sections it did not reach as they were, not
//! drop them.

/// The name of a section that starts with `line` (`## name: description` or `## name`), or
/// None when the line starts no section (`### ` and deeper headings belong to the section
/// above them).
pub fn section_name(line: &str) -> Option<&str> {
    let rest = line.strip_prefix("## ")?;
    let name = rest.split(':').next().unwrap_or(rest).trim();
    (!name.is_empty()).then_some(name)
}

/// The text before the first section, and each section's name and whole text (its heading
/// line to the line before the next section's heading), in the document's order.
pub fn split_sections(text: &str) -> (String, Vec<(String, String)>) {
    let mut preamble = String::new();
    let mut sections: Vec<(String, String)> = Vec::new();
    for line in text.split_inclusive('\n') {
        if let Some(name) = section_name(line) {
            sections.push((name.to_string(), String::new()));
        }
        match sections.last_mut() {
            Some((_, body)) => body.push_str(line),
            None => preamble.push_str(line),
        }
    }
    (preamble, sections)
}

/// `existing` with the sections in `replacements` put in place of the ones of the same name
/// (added when it has none), behind `header` (which replaces the existing text before the
/// first section). Sections are in `order`; a section whose name is not in `order` keeps its
/// place after them. After the header one line names the sections the document holds and the
/// ones of `order` it does not, so that the summary stays true of whatever mix of runs wrote
/// the document.
pub fn merge_sections(existing: &str, header: &str, replacements: &[(String, String)], order: &[&str]) -> String {
    let (_, mut sections) = split_sections(existing);
    for (name, text) in replacements {
        match sections.iter_mut().find(|(n, _)| n == name) {
            Some(slot) => slot.1 = text.clone(),
            None => sections.push((name.clone(), text.clone())),
        }
    }
    let rank = |name: &str| order.iter().position(|o| *o == name).unwrap_or(order.len());
    // A stable sort: sections not in `order` stay in the order they had.
    sections.sort_by_key(|(name, _)| rank(name));
    let present: Vec<&str> = sections.iter().map(|(n, _)| n.as_str()).collect();
    let missing: Vec<&str> = order.iter().copied().filter(|o| !present.contains(o)).collect();
    let mut out = header.trim_end().to_string();
    out.push_str("\n\n");
    if present.is_empty() {
        out.push_str("Sections in this document: none yet.\n");
    } else {
        out.push_str(&format!("Sections in this document: {}", present.join(", ")));
        if !missing.is_empty() {
            out.push_str(&format!("; not in it: {}", missing.join(", ")));
        }
        out.push_str(
            ". Each section is from the run that last produced it (its first line gives the date and the run time).\n",
        );
    }
    for (_, text) in &sections {
        out.push('\n');
        out.push_str(text.trim_end());
        out.push('\n');
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn section(name: &str, body: &str) -> (String, String) {
        (
            name.to_string(),
            format!("## {name}: the {name} suite\n\n{body}\n\n### All cases\n\n| a |\n|---|\n| {body} |\n"),
        )
    }

    fn document(sections: &[(String, String)]) -> String {
        merge_sections("", "# Title\n\nIntro.", sections, &["one", "two", "three"])
    }

    #[test]
    fn a_run_of_some_sections_replaces_them_and_keeps_the_others_in_order() {
        let old = document(&[section("one", "old 1"), section("two", "old 2"), section("three", "old 3")]);
        let merged = merge_sections(&old, "# Title\n\nIntro.", &[section("two", "new 2")], &["one", "two", "three"]);
        let (_, sections) = split_sections(&merged);
        let names: Vec<&str> = sections.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(names, ["one", "two", "three"]);
        assert!(sections[0].1.contains("old 1") && sections[2].1.contains("old 3"));
        assert!(sections[1].1.contains("new 2") && !merged.contains("old 2"));
        // The "### All cases" heading stays inside its section.
        assert_eq!(merged.matches("### All cases").count(), 3);
        assert!(merged.contains("Sections in this document: one, two, three."));
    }

    #[test]
    fn a_section_missing_so_far_is_added_in_its_place_and_the_summary_names_what_is_missing() {
        let old = document(&[section("three", "old 3")]);
        let merged = merge_sections(&old, "# New title", &[section("one", "new 1")], &["one", "two", "three"]);
        let (preamble, sections) = split_sections(&merged);
        let names: Vec<&str> = sections.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(names, ["one", "three"]);
        assert!(preamble.starts_with("# New title\n") && !preamble.contains("Intro."));
        assert!(preamble.contains("Sections in this document: one, three; not in it: two."));
        // The summary line is written once however often the document is merged.
        let again = merge_sections(&merged, "# New title", &[section("two", "new 2")], &["one", "two", "three"]);
        assert_eq!(again.matches("Sections in this document").count(), 1);
        assert!(again.contains("Sections in this document: one, two, three."));
    }

    #[test]
    fn a_section_of_no_known_name_is_kept_after_the_known_ones() {
        let old = document(&[section("one", "old 1")]) + "\n## retired: an old suite\n\ntext\n";
        let merged = merge_sections(&old, "# Title", &[section("two", "new 2")], &["one", "two", "three"]);
        let (_, sections) = split_sections(&merged);
        let names: Vec<&str> = sections.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(names, ["one", "two", "retired"]);
    }

    #[test]
    fn merging_a_section_with_itself_changes_nothing() {
        let old = document(&[section("one", "1"), section("three", "3")]);
        assert_eq!(merge_sections(&old, "# Title\n\nIntro.", &[section("one", "1")], &["one", "two", "three"]), old);
    }
}
