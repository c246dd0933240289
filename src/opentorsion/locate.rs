//! Locating a field path in JSON text, for messages that give line:column.

/// Byte offset of the value at `path` (`a[1].b`) in JSON `text`, or of the nearest enclosing
/// value that can be found (0 for the whole text). A structural scanner, not a parser: the text
/// has already been parsed when this is asked.
pub(super) fn locate_json(text: &str, path: &str) -> usize {
    let b = text.as_bytes();
    let mut pos = ws(b, 0);
    for seg in path_segments(path) {
        let found = match seg {
            Seg::Key(key) => find_key(b, pos, key),
            Seg::Index(i) => find_index(b, pos, i),
        };
        match found {
            Some(p) => pos = p,
            None => break,
        }
    }
    pos
}

enum Seg<'a> {
    Key(&'a str),
    Index(usize),
}

fn path_segments(path: &str) -> Vec<Seg<'_>> {
    let mut out = Vec::new();
    for part in path.split('.').filter(|p| !p.is_empty()) {
        let (key, mut rest) = part.split_once('[').map_or((part, ""), |(k, r)| (k, r));
        if !key.is_empty() {
            out.push(Seg::Key(key));
        }
        while let Some((i, r)) = rest.split_once(']') {
            if let Ok(i) = i.parse() {
                out.push(Seg::Index(i));
            }
            rest = r.trim_start_matches('[');
        }
    }
    out
}

fn ws(b: &[u8], mut i: usize) -> usize {
    while i < b.len() && b[i].is_ascii_whitespace() {
        i += 1;
    }
    i
}

/// The end of the string starting at `i` (`b[i] == b'"'`), just past its closing quote.
fn string_end(b: &[u8], mut i: usize) -> usize {
    i += 1;
    while i < b.len() {
        match b[i] {
            b'\\' => i += 2,
            b'"' => return i + 1,
            _ => i += 1,
        }
    }
    b.len()
}

/// The end of the value starting at `i`.
fn value_end(b: &[u8], i: usize) -> usize {
    match b.get(i) {
        Some(b'"') => string_end(b, i),
        Some(b'{' | b'[') => {
            let mut depth = 0usize;
            let mut j = i;
            while j < b.len() {
                match b[j] {
                    b'"' => {
                        j = string_end(b, j);
                        continue;
                    }
                    b'{' | b'[' => depth += 1,
                    b'}' | b']' => {
                        depth -= 1;
                        if depth == 0 {
                            return j + 1;
                        }
                    }
                    _ => {}
                }
                j += 1;
            }
            b.len()
        }
        _ => {
            let mut j = i;
            while j < b.len() && !matches!(b[j], b',' | b'}' | b']') && !b[j].is_ascii_whitespace() {
                j += 1;
            }
            j
        }
    }
}

fn find_key(b: &[u8], pos: usize, key: &str) -> Option<usize> {
    if b.get(pos) != Some(&b'{') {
        return None;
    }
    let mut i = ws(b, pos + 1);
    while b.get(i) == Some(&b'"') {
        let end = string_end(b, i);
        let name = &b[i + 1..end.saturating_sub(1).max(i + 1)];
        i = ws(b, end);
        if b.get(i) != Some(&b':') {
            return None;
        }
        let value = ws(b, i + 1);
        if name == key.as_bytes() {
            return Some(value);
        }
        i = ws(b, value_end(b, value));
        if b.get(i) == Some(&b',') {
            i = ws(b, i + 1);
        }
    }
    None
}

fn find_index(b: &[u8], pos: usize, index: usize) -> Option<usize> {
    if b.get(pos) != Some(&b'[') {
        return None;
    }
    let mut i = ws(b, pos + 1);
    for _ in 0..index {
        if matches!(b.get(i), None | Some(b']')) {
            return None;
        }
        i = ws(b, value_end(b, i));
        if b.get(i) != Some(&b',') {
            return None;
        }
        i = ws(b, i + 1);
    }
    (!matches!(b.get(i), None | Some(b']'))).then_some(i)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::line_col;

    #[test]
    fn locates_json_paths() {
        let text = "{\n  \"a\": [1, {\"b\": \"x\\\"]\", \"c\": 2}],\n  \"d\": {}\n}";
        let at = |p: &str| line_col(text, locate_json(text, p));
        assert_eq!(at("a[1].c"), (2, 31));
        assert_eq!(at("d"), (3, 8));
        // Not found: the nearest enclosing value.
        assert_eq!(at("a[5]"), (2, 8));
    }
}
