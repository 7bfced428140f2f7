//! The arrows of `arc` and `synch` rows: `[-…][(][weight][)][-…]>`, so `->`, `----->`,
//! `>`, `-()->`, `-7->`, `--2-->`, `(9)>` and `9)>` are all arrows; the weight defaults to 1.

/// The arrow's weight, or what is wrong with it (for a message that also says how to fix
/// it).
pub(crate) fn parse_arrow(text: &str) -> Result<u32, String> {
    let bad = || {
        let hint = if text.starts_with('<') {
            " (arrows point from left to right: swap the two names)"
        } else {
            ""
        };
        Err(format!(
            "`{text}` is not an arrow{hint}: write `->` for weight 1 or `-N->` for weight N"
        ))
    };
    let b = text.as_bytes();
    let mut i = 0;
    while b.get(i) == Some(&b'-') {
        i += 1;
    }
    if b.get(i) == Some(&b'(') {
        i += 1;
    }
    let digits = i;
    while b.get(i).is_some_and(u8::is_ascii_digit) {
        i += 1;
    }
    let weight = &text[digits..i];
    if b.get(i) == Some(&b')') {
        i += 1;
    }
    while b.get(i) == Some(&b'-') {
        i += 1;
    }
    if b.get(i) != Some(&b'>') || i + 1 != b.len() {
        return bad();
    }
    if weight.is_empty() {
        return Ok(1);
    }
    weight
        .parse()
        .map_err(|_| format!("the weight of `{text}` is too large (at most {})", u32::MAX))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(input: &str, expect: Result<u32, &str>) {
        assert_eq!(
            parse_arrow(input),
            expect.map_err(str::to_string),
            "arrow `{input}`"
        );
    }

    #[test]
    fn reference_examples() {
        for a in ["->", "----->", ">", "-()->", "()>", "(>", ")>"] {
            check(a, Ok(1));
        }
        check("-7->", Ok(7));
        check("8>", Ok(8));
        for a in ["(9)>", "(9>", "9)>"] {
            check(a, Ok(9));
        }
        check("--2-->", Ok(2));
        check("-(12)->", Ok(12));
        check("--0-->", Ok(0));
    }

    #[test]
    fn not_arrows() {
        let plain = |a: &str| {
            format!("`{a}` is not an arrow: write `->` for weight 1 or `-N->` for weight N")
        };
        for a in ["", "-", "=>", "->>", "-x->", "((1)>", "-1-2->", "- >", "→"] {
            check(a, Err(&plain(a)));
        }
        check(
            "<-",
            Err(
                "`<-` is not an arrow (arrows point from left to right: swap the two names): \
                 write `->` for weight 1 or `-N->` for weight N",
            ),
        );
        check(
            "-99999999999->",
            Err("the weight of `-99999999999->` is too large (at most 4294967295)"),
        );
    }
}
