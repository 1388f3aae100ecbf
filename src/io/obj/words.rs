//! An OBJ line's words, found byte by byte where the line is ASCII (as
//! nearly every OBJ line is), with `str::split_whitespace`'s result: the
//! same words for any line (a line with other characters takes
//! `split_whitespace` itself). Reading the ogre's 496k-triangle OBJ spent a
//! fifth of its time decoding characters to split lines.

/// Whitespace as `char::is_whitespace` sees it, for an ASCII byte (the
/// vertical tab included, which `u8::is_ascii_whitespace` leaves out).
#[inline]
fn space(b: u8) -> bool {
    matches!(b, b' ' | b'\t' | b'\n' | 0x0B | 0x0C | b'\r')
}

/// The words of a line; see the module documentation.
pub(super) enum Words<'a> {
    Ascii(&'a str),
    Other(std::str::SplitWhitespace<'a>),
}

/// The words of `s`, as `s.split_whitespace()` gives them.
pub(super) fn words(s: &str) -> Words<'_> {
    if s.is_ascii() {
        Words::Ascii(s)
    } else {
        Words::Other(s.split_whitespace())
    }
}

impl<'a> Iterator for Words<'a> {
    type Item = &'a str;

    #[inline]
    fn next(&mut self) -> Option<&'a str> {
        match self {
            Words::Other(w) => w.next(),
            Words::Ascii(s) => {
                let b = s.as_bytes();
                let Some(start) = b.iter().position(|&c| !space(c)) else {
                    *s = "";
                    return None;
                };
                let end = b[start..]
                    .iter()
                    .position(|&c| space(c))
                    .map_or(b.len(), |e| start + e);
                let word = &s[start..end];
                *s = &s[end..];
                Some(word)
            }
        }
    }
}

/// The first word of `s` and the rest, trimmed at the start, as
/// `trim_start` and `find(char::is_whitespace)` give them.
pub(super) fn split_keyword(s: &str) -> (&str, &str) {
    if !s.is_ascii() {
        let s = s.trim_start();
        return match s.find(char::is_whitespace) {
            Some(i) => (&s[..i], s[i..].trim_start()),
            None => (s, ""),
        };
    }
    let b = s.as_bytes();
    let start = b.iter().position(|&c| !space(c)).unwrap_or(b.len());
    let end = b[start..]
        .iter()
        .position(|&c| space(c))
        .map_or(b.len(), |e| start + e);
    let rest = b[end..]
        .iter()
        .position(|&c| !space(c))
        .map_or(b.len(), |e| end + e);
    (&s[start..end], &s[rest..])
}

/// `s` up to its first `#`.
#[inline]
pub(super) fn strip_comment(s: &str) -> &str {
    match s.as_bytes().iter().position(|&b| b == b'#') {
        Some(i) => &s[..i],
        None => s,
    }
}

/// A face corner `v`, `v/vt`, `v//vn` or `v/vt/vn` split at its slashes
/// into three (empty where absent); `None` with more than two slashes.
#[inline]
pub(super) fn corner_parts(tok: &str) -> Option<[&str; 3]> {
    let mut cuts = [tok.len(); 2];
    let mut k = 0;
    for (i, &c) in tok.as_bytes().iter().enumerate() {
        if c == b'/' {
            if k == 2 {
                return None;
            }
            cuts[k] = i;
            k += 1;
        }
    }
    Some(match k {
        0 => [tok, "", ""],
        1 => [&tok[..cuts[0]], &tok[cuts[0] + 1..], ""],
        _ => [&tok[..cuts[0]], &tok[cuts[0] + 1..cuts[1]], &tok[cuts[1] + 1..]],
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Lines of every kind of whitespace, ASCII and not: the same words as
    /// `split_whitespace`, the same keyword split as before, the same
    /// corner parts as `split('/')`.
    #[test]
    fn the_same_words_as_the_standard_library() {
        let lines = [
            "",
            "   ",
            "v 1 2 3",
            "  v\t1.5  -2e3\x0b3\x0c \r",
            "f 1/2/3 4//6 7/8 9",
            "f 1/2/3/4 5",
            "vt 0.5 0.5 # comment # more",
            "v\u{a0}1 2\u{2003}3",
            "usemtl  caf\u{e9} au lait ",
            "\u{3000}g name",
            "#",
            "x",
            "x ",
        ];
        for line in lines {
            let ours: Vec<&str> = words(line).collect();
            let std: Vec<&str> = line.split_whitespace().collect();
            assert_eq!(ours, std, "{line:?}");
            let old = {
                let s = line.trim_start();
                match s.find(char::is_whitespace) {
                    Some(i) => (&s[..i], s[i..].trim_start()),
                    None => (s, ""),
                }
            };
            assert_eq!(split_keyword(line), old, "{line:?}");
            assert_eq!(strip_comment(line), line.split('#').next().unwrap());
            for tok in line.split_whitespace() {
                let mut parts = tok.split('/');
                let want = [0; 3].map(|_| parts.next().unwrap_or(""));
                let want = if parts.next().is_some() { None } else { Some(want) };
                assert_eq!(corner_parts(tok), want, "{tok:?}");
            }
        }
    }
}
