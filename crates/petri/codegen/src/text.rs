//! Small text helpers shared by the backends: comment-safe text and XML escaping.

/// `s` made safe inside an IEC `(* … *)` comment (which does not nest) or a C `/* … */`
/// comment: the closing and opening sequences are broken with a space.
pub fn comment(s: &str) -> String {
    s.replace("*)", "* )")
        .replace("(*", "( *")
        .replace("*/", "* /")
        .replace("/*", "/ *")
        .replace(['\n', '\r'], " ")
}

/// `s` escaped for XML text and attribute values.
pub fn xml(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            _ => out.push(c),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn comments_cannot_be_closed_early() {
        assert_eq!(
            comment("a *) b (* c */ d /* e"),
            "a * ) b ( * c * / d / * e"
        );
    }

    #[test]
    fn xml_special_characters_are_escaped() {
        assert_eq!(
            xml("a<b & \"c\" > 'd'"),
            "a&lt;b &amp; &quot;c&quot; &gt; &apos;d&apos;"
        );
    }
}
