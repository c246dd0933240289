//! Where a field path sits in RON text: the byte offset of the value at a serde field path
//! (`bodies[1].mass`) and its line:column, so that an error found after parsing points at the
//! offending value like a syntax error does. A small structural scanner, not a parser.

/// 1-based line and column (in characters) of byte offset `off`.
pub fn line_col(text: &str, off: usize) -> (usize, usize) {
    // Round down to a character boundary so that no offset can make the slice panic.
    let mut off = off.min(text.len());
    while !text.is_char_boundary(off) {
        off -= 1;
    }
    let before = &text[..off];
    let line = before.bytes().filter(|&b| b == b'\n').count() + 1;
    let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, col)
}

/// Byte offset of the value at `path` in RON `text`, or `None` when the path cannot be followed.
///
/// A small structural scanner, not a parser: it knows strings, comments, brackets and `name:`
/// pairs, which is all a path walk needs. Paths are serde_path_to_error's: `.field` and `[index]`.
pub fn locate(text: &str, path: &str) -> Option<usize> {
    let b = text.as_bytes();
    let mut pos = skip_attributes(b, 0);
    for seg in parse_path(path) {
        let inner = enter_group(b, pos)?;
        let inner = through_newtype(b, pos, inner, &seg);
        pos = match seg {
            Seg::Field(name) => find_field(b, inner, name)?,
            Seg::Index(i) => find_index(b, inner, i)?,
        };
    }
    Some(ws(b, pos))
}

/// Like [`locate`], but when the path cannot be followed to the end, the offset of the deepest
/// value on it that was found (the top-level value at least, if the text has one).
pub(super) fn locate_nearest(text: &str, path: &str) -> Option<usize> {
    let b = text.as_bytes();
    let mut pos = skip_attributes(b, 0);
    if pos >= b.len() {
        return None;
    }
    for seg in parse_path(path) {
        let Some(inner) = enter_group(b, pos) else { break };
        let inner = through_newtype(b, pos, inner, &seg);
        let next = match seg {
            Seg::Field(name) => find_field(b, inner, name),
            Seg::Index(i) => find_index(b, inner, i),
        };
        match next {
            Some(p) => pos = p,
            None => break,
        }
    }
    Some(ws(b, pos))
}

enum Seg<'a> {
    Field(&'a str),
    Index(usize),
}

fn parse_path(path: &str) -> Vec<Seg<'_>> {
    let mut out = Vec::new();
    for part in path.split('.').filter(|p| !p.is_empty()) {
        let (name, rest) = part.split_once('[').map_or((part, ""), |(n, r)| (n, r));
        if !name.is_empty() {
            out.push(Seg::Field(name));
        }
        for idx in rest.split('[') {
            if let Ok(i) = idx.trim_end_matches(']').parse() {
                out.push(Seg::Index(i));
            }
        }
    }
    out
}

/// Skips whitespace and comments (`//…` and `/* … */`, nested as RON allows).
pub(super) fn ws(b: &[u8], mut i: usize) -> usize {
    loop {
        while i < b.len() && b[i].is_ascii_whitespace() {
            i += 1;
        }
        if b[i..].starts_with(b"//") {
            while i < b.len() && b[i] != b'\n' {
                i += 1;
            }
        } else if b[i..].starts_with(b"/*") {
            let mut depth = 0usize;
            while i < b.len() {
                if b[i..].starts_with(b"/*") {
                    depth += 1;
                    i += 2;
                } else if b[i..].starts_with(b"*/") {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    i += 1;
                }
            }
        } else {
            return i;
        }
    }
}

/// Skips `#![enable(...)]` attributes at the top of a file.
pub(super) fn skip_attributes(b: &[u8], mut i: usize) -> usize {
    loop {
        i = ws(b, i);
        if b[i..].starts_with(b"#!") {
            i = skip_value(b, i + 2);
        } else {
            return i;
        }
    }
}

pub(super) fn is_word(c: u8) -> bool {
    c.is_ascii_alphanumeric() || matches!(c, b'_' | b'.' | b'+' | b'-')
}

fn skip_string(b: &[u8], mut i: usize) -> usize {
    // b[i] is the opening quote (" or ').
    let q = b[i];
    i += 1;
    while i < b.len() && b[i] != q {
        i += if b[i] == b'\\' { 2 } else { 1 };
    }
    (i + 1).min(b.len())
}

fn skip_raw_string(b: &[u8], mut i: usize) -> usize {
    // b[i] == 'r', then hashes, then a quote.
    i += 1;
    let hashes = b[i..].iter().take_while(|&&c| c == b'#').count();
    i += hashes + 1;
    while i < b.len() {
        if b[i] == b'"' && b[i + 1..].iter().take(hashes).filter(|&&c| c == b'#').count() == hashes {
            return i + 1 + hashes;
        }
        i += 1;
    }
    b.len()
}

/// Skips a balanced group starting at an opening bracket.
fn skip_group(b: &[u8], mut i: usize) -> usize {
    let mut depth = 0usize;
    while i < b.len() {
        match b[i] {
            b'(' | b'[' | b'{' => {
                depth += 1;
                i += 1;
            }
            b')' | b']' | b'}' => {
                depth = depth.saturating_sub(1);
                i += 1;
                if depth == 0 {
                    return i;
                }
            }
            b'"' | b'\'' => i = skip_string(b, i),
            b'/' if b[i..].starts_with(b"//") || b[i..].starts_with(b"/*") => i = ws(b, i),
            _ => i += 1,
        }
    }
    i
}

/// Skips one value (a string, a group, a word, or a word followed by a group such as
/// `Some(…)`/`Body(…)`).
fn skip_value(b: &[u8], i: usize) -> usize {
    let mut i = ws(b, i);
    if i >= b.len() {
        return i;
    }
    match b[i] {
        b'"' | b'\'' => return skip_string(b, i),
        b'(' | b'[' | b'{' => return skip_group(b, i),
        b'r' if matches!(b.get(i + 1), Some(b'#') | Some(b'"')) => return skip_raw_string(b, i),
        _ => {}
    }
    while i < b.len() && is_word(b[i]) {
        i += 1;
    }
    let j = ws(b, i);
    if j < b.len() && matches!(b[j], b'(' | b'[' | b'{') { skip_group(b, j) } else { i }
}

/// Positions just inside the group of the value at `i` (after an optional type name).
/// An index into a list that a named newtype variant wraps (`pressure: Table([…])`, whose serde
/// path is `pressure[71]`): the group entered at `value` is the variant's `(`, so step into its
/// `[` too. `inner` is the position after the `(`.
fn through_newtype(b: &[u8], value: usize, inner: usize, seg: &Seg) -> usize {
    let named = b.get(ws(b, value)).is_some_and(|&c| is_word(c));
    let list = ws(b, inner);
    if matches!(seg, Seg::Index(_)) && named && b[inner - 1] == b'(' && b.get(list) == Some(&b'[') {
        list + 1
    } else {
        inner
    }
}

fn enter_group(b: &[u8], i: usize) -> Option<usize> {
    let mut i = ws(b, i);
    while i < b.len() && is_word(b[i]) {
        i += 1;
    }
    i = ws(b, i);
    matches!(b.get(i), Some(b'(' | b'[' | b'{')).then_some(i + 1)
}

fn at_close(b: &[u8], i: usize) -> bool {
    i >= b.len() || matches!(b[i], b')' | b']' | b'}')
}

fn find_field(b: &[u8], mut i: usize, name: &str) -> Option<usize> {
    loop {
        i = ws(b, i);
        if at_close(b, i) {
            return None;
        }
        let start = i;
        let key_end = if b[i] == b'"' { skip_string(b, i) } else { skip_value(b, i) };
        let after = ws(b, key_end);
        if b.get(after) == Some(&b':') {
            let key = std::str::from_utf8(&b[start..key_end]).ok()?.trim_matches('"');
            let value = ws(b, after + 1);
            if key == name {
                return Some(value);
            }
            i = skip_value(b, value);
        } else {
            i = key_end;
        }
        i = ws(b, i);
        if b.get(i) == Some(&b',') {
            i += 1;
        } else if !at_close(b, i) {
            // Not well formed here: give up rather than guess.
            return None;
        }
    }
}

fn find_index(b: &[u8], mut i: usize, index: usize) -> Option<usize> {
    for k in 0.. {
        i = ws(b, i);
        if at_close(b, i) {
            return None;
        }
        if k == index {
            return Some(i);
        }
        i = ws(b, skip_value(b, i));
        if b.get(i) == Some(&b',') {
            i += 1;
        } else {
            return None;
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    const TEXT: &str = r#"#![enable(implicit_some)]
// a comment with "quotes" and (brackets
Mechanism(
    name: "m", /* block ( */
    bodies: [
        Body(name: "a", mass: 1.0),
        Body(
            name: "b",
            mass: 2.0,
        ),
    ],
)
"#;

    #[test]
    fn locates_fields_and_indices() {
        assert_eq!(locate(TEXT, "name").map(|o| line_col(TEXT, o)), Some((4, 11)));
        assert_eq!(locate(TEXT, "bodies[0].mass").map(|o| line_col(TEXT, o)), Some((6, 31)));
        assert_eq!(locate(TEXT, "bodies[1].mass").map(|o| line_col(TEXT, o)), Some((9, 19)));
        assert_eq!(locate(TEXT, "bodies[2]"), None);
        assert_eq!(locate(TEXT, "nothing"), None);
    }
}
