//! The documentation of every code, kept beside the code that emits it (each front end has a
//! table of [`Entry`]s) and rendered into one page, docs/diagnostics.md, by [`page`].

/// What a code means, shown by an example, and how to fix it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Entry {
    pub code: &'static str,
    /// One line: the problem in a few words.
    pub title: &'static str,
    /// What the check is about and why it is an error, when the title does not say it all;
    /// may be empty.
    pub explanation: &'static str,
    /// A small input that gets the code, in the language of [`Group::example_lang`].
    pub example: &'static str,
    /// How to fix it.
    pub fix: &'static str,
}

/// The codes of one front end.
#[derive(Clone, Copy, Debug)]
pub struct Group {
    /// The section's heading: `IEC 61131-3 sources (E, W)`.
    pub heading: &'static str,
    /// A paragraph before the codes: what reads these inputs, where else they are described.
    pub intro: &'static str,
    /// The fence of the examples (`st`, `xml`, `conf`-like text is `text`).
    pub example_lang: &'static str,
    pub entries: &'static [Entry],
}

/// The Markdown page documenting every group's codes, in the groups' order and each group's
/// order (deterministic: the page is compared with the file in the repository).
pub fn page(title: &str, intro: &str, groups: &[Group]) -> String {
    let mut out = format!("# {title}\n\n{intro}\n");
    out.push_str(
        "\n<!-- Generated from the code tables; do not edit: see the intro for the command. -->\n",
    );
    for g in groups {
        out.push_str(&format!("\n## {}\n\n{}\n", g.heading, g.intro));
        for e in g.entries {
            out.push_str(&format!("\n### {}: {}\n", e.code, e.title));
            if !e.explanation.is_empty() {
                out.push_str(&format!("\n{}\n", e.explanation));
            }
            if !e.example.is_empty() {
                out.push_str(&format!(
                    "\nFor example:\n\n```{}\n{}\n```\n",
                    g.example_lang,
                    e.example.trim_end()
                ));
            }
            if !e.fix.is_empty() {
                out.push_str(&format!("\nTo fix it: {}\n", e.fix));
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn renders_groups_and_entries_in_order() {
        const E: &[Entry] = &[
            Entry {
                code: "X001",
                title: "a thing twice",
                explanation: "",
                example: "a\na\n",
                fix: "remove one.",
            },
            Entry {
                code: "X002",
                title: "no thing",
                explanation: "Things are needed.",
                example: "",
                fix: "",
            },
        ];
        let p = page(
            "Codes",
            "All of them.",
            &[Group {
                heading: "Things (X)",
                intro: "Read by the thing reader.",
                example_lang: "text",
                entries: E,
            }],
        );
        assert_eq!(
            p,
            "# Codes\n\nAll of them.\n\n\
             <!-- Generated from the code tables; do not edit: see the intro for the command. -->\n\
             \n## Things (X)\n\nRead by the thing reader.\n\
             \n### X001: a thing twice\n\nFor example:\n\n```text\na\na\n```\n\nTo fix it: remove one.\n\
             \n### X002: no thing\n\nThings are needed.\n"
        );
    }
}
