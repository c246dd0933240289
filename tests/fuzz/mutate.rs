//! Mutators of the fuzz harness (`tests/fuzz.rs`): a small RON tokenizer and the mutations of
//! issue 11, each a function of the input bytes, an RNG and the corpus (for splices and token
//! swaps). Deterministic given the RNG state.

use rand::Rng;
use rand::rngs::StdRng;

/// No mutation may grow an input beyond this (bytes); a mutation that would is skipped. 1 MiB is
/// five times the largest single mutation of a corpus file (100 000 bracket pairs, 200 kB);
/// larger inputs only cost tokenizing time (24 bytes per token) without new shapes.
pub const MAX_INPUT: usize = 1 << 20;

/// What a token is; whitespace, comments, colons and anything else are not tokens (they stay in
/// place when tokens are deleted or duplicated).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Tok {
    Ident,
    Number,
    Str,
    Open,
    Close,
    Comma,
}

/// A token: its kind and byte range.
#[derive(Debug, Clone, Copy)]
pub struct Token {
    pub kind: Tok,
    pub start: usize,
    pub end: usize,
}

/// Splits RON text into tokens. Not a parser: unterminated strings run to the end, unknown
/// bytes are skipped, so it works on any (mutated) input.
pub fn tokenize(b: &[u8]) -> Vec<Token> {
    let mut out = Vec::new();
    let mut i = 0;
    let n = b.len();
    while i < n {
        let c = b[i];
        let start = i;
        let kind = match c {
            b'/' if b.get(i + 1) == Some(&b'/') => {
                while i < n && b[i] != b'\n' {
                    i += 1;
                }
                continue;
            }
            b'"' => {
                i += 1;
                while i < n && b[i] != b'"' {
                    i += if b[i] == b'\\' { 2 } else { 1 };
                }
                i = (i + 1).min(n);
                Tok::Str
            }
            b'(' | b'[' | b'{' => {
                i += 1;
                Tok::Open
            }
            b')' | b']' | b'}' => {
                i += 1;
                Tok::Close
            }
            b',' => {
                i += 1;
                Tok::Comma
            }
            b'0'..=b'9' | b'-' | b'+' | b'.' => {
                i += 1;
                while i < n && (b[i].is_ascii_alphanumeric() || matches!(b[i], b'.' | b'_' | b'+' | b'-')) {
                    // A sign only right after an exponent.
                    if matches!(b[i], b'+' | b'-') && !matches!(b[i - 1], b'e' | b'E') {
                        break;
                    }
                    i += 1;
                }
                Tok::Number
            }
            c if c.is_ascii_alphabetic() || c == b'_' => {
                while i < n && (b[i].is_ascii_alphanumeric() || b[i] == b'_') {
                    i += 1;
                }
                Tok::Ident
            }
            _ => {
                i += 1;
                continue;
            }
        };
        out.push(Token { kind, start, end: i });
    }
    out
}

/// The bracket matching the opening token `open` (index into `toks`), if any.
fn matching(toks: &[Token], open: usize) -> Option<usize> {
    let mut depth = 0usize;
    for (k, t) in toks.iter().enumerate().skip(open) {
        match t.kind {
            Tok::Open => depth += 1,
            Tok::Close => {
                depth -= 1;
                if depth == 0 {
                    return Some(k);
                }
            }
            _ => {}
        }
    }
    None
}

/// Numbers that break naive arithmetic: zeros, the f64 extremes and a subnormal, 1e19 (beyond
/// i64), u64::MAX, the non-finite spellings, counts just off the usual limits.
const NUMBERS: &[&str] = &[
    "0",
    "-0.0",
    "1e308",
    "-1e308",
    "1e-320",
    "1e19",
    "-1e19",
    "18446744073709551615",
    "18446744073709551616",
    "-9223372036854775808",
    "4294967296",
    "NaN",
    "inf",
    "-inf",
    "1e999",
    "-1",
    "1",
    "2",
    "1e6",
    "1e9",
    "0.5",
    "0x7fffffff",
];

/// Strings aimed at names and paths: empty, directory tricks, absolute paths, devices.
const STRINGS: &[&str] = &[
    "",
    "..",
    ".",
    "/",
    "/etc/passwd",
    "/dev/zero",
    "../../x",
    "a/b",
    "../examples",
    "ground",
    "spin",
    "rotor",
    "pivot",
    " ",
    "a\\u{0}b",
    "\\n",
    "é∂",
];

fn pick<'a>(rng: &mut StdRng, xs: &[&'a str]) -> &'a str {
    xs[rng.random_range(0..xs.len())]
}

/// The mutations, by name (for statistics and reproduction messages).
pub const MUTATORS: &[&str] = &[
    "byte_flip",
    "byte_replace",
    "token_delete",
    "token_duplicate",
    "token_swap",
    "number_extreme",
    "string_extreme",
    "deep_nesting",
    "list_repeat",
    "splice",
];

/// Applies mutator `which` (index into [`MUTATORS`]) to `b`; `corpus` are the seed files' bytes.
/// Returns false (and leaves `b` unchanged) when the mutation does not apply or would exceed
/// [`MAX_INPUT`].
pub fn mutate(which: usize, b: &mut Vec<u8>, rng: &mut StdRng, corpus: &[Vec<u8>]) -> bool {
    let toks = tokenize(b);
    let out: Option<Vec<u8>> = match MUTATORS[which] {
        "byte_flip" if !b.is_empty() => {
            let mut v = b.clone();
            for _ in 0..rng.random_range(1..=8) {
                let i = rng.random_range(0..v.len());
                v[i] ^= 1 << rng.random_range(0..8);
            }
            Some(v)
        }
        "byte_replace" if !b.is_empty() => {
            const BYTES: &[u8] = b"()[]{},:\"\\/-+.eE019_ \n";
            let mut v = b.clone();
            for _ in 0..rng.random_range(1..=8) {
                let i = rng.random_range(0..v.len());
                v[i] = if rng.random_bool(0.7) { BYTES[rng.random_range(0..BYTES.len())] } else { rng.random() };
            }
            Some(v)
        }
        "token_delete" if !toks.is_empty() => {
            let k = rng.random_range(0..toks.len());
            let len = if rng.random_bool(0.8) { 1 } else { rng.random_range(1..=8) };
            let last = toks[(k + len - 1).min(toks.len() - 1)];
            Some(splice(b, toks[k].start, last.end, b""))
        }
        "token_duplicate" if !toks.is_empty() => {
            let t = toks[rng.random_range(0..toks.len())];
            let at = if rng.random_bool(0.5) { t.end } else { toks[rng.random_range(0..toks.len())].start };
            let copy = b[t.start..t.end].to_vec();
            Some(splice(b, at, at, &copy))
        }
        "token_swap" if !toks.is_empty() => {
            // Replace a token by a token of the same kind from any corpus file: an enum variant
            // by another, a name by another name (duplicates, unknown references), a number by
            // another.
            let t = toks[rng.random_range(0..toks.len())];
            let other = &corpus[rng.random_range(0..corpus.len())];
            let same: Vec<Token> = tokenize(other).into_iter().filter(|o| o.kind == t.kind).collect();
            (!same.is_empty()).then(|| {
                let o = same[rng.random_range(0..same.len())];
                splice(b, t.start, t.end, &other[o.start..o.end])
            })
        }
        "number_extreme" => {
            let nums: Vec<&Token> = toks.iter().filter(|t| t.kind == Tok::Number).collect();
            (!nums.is_empty()).then(|| {
                let t = nums[rng.random_range(0..nums.len())];
                let new = if rng.random_bool(0.1) {
                    // A very long digit string (up to 10^5 digits), sometimes with a fraction.
                    let len = 10usize.pow(rng.random_range(2..=5));
                    let mut s = "9".repeat(len);
                    if rng.random_bool(0.5) {
                        s.insert_str(0, "0.");
                    }
                    s
                } else {
                    pick(rng, NUMBERS).to_string()
                };
                splice(b, t.start, t.end, new.as_bytes())
            })
        }
        "string_extreme" => {
            let strs: Vec<&Token> = toks.iter().filter(|t| t.kind == Tok::Str).collect();
            (!strs.is_empty()).then(|| {
                let t = strs[rng.random_range(0..strs.len())];
                let inner = match rng.random_range(0..10) {
                    0 => "x".repeat(100_000),
                    1 => "a/".repeat(rng.random_range(1..=50)) + "b",
                    2 => "../".repeat(rng.random_range(1..=20)) + "etc/passwd",
                    _ => pick(rng, STRINGS).to_string(),
                };
                splice(b, t.start, t.end, format!("\"{inner}\"").as_bytes())
            })
        }
        "deep_nesting" if !toks.is_empty() => {
            // Wrap a value (a number, string or bracketed group) in k brackets.
            let values: Vec<usize> = (0..toks.len())
                .filter(|&k| matches!(toks[k].kind, Tok::Number | Tok::Str | Tok::Open | Tok::Ident))
                .collect();
            (!values.is_empty()).then(|| {
                let k = values[rng.random_range(0..values.len())];
                let end = match toks[k].kind {
                    Tok::Open => matching(&toks, k).map_or(b.len(), |m| toks[m].end),
                    _ => toks[k].end,
                };
                let depth = [1000, 10_000, 100_000][rng.random_range(0..3)];
                let (open, close) = if rng.random_bool(0.5) { ("[", "]") } else { ("(", ")") };
                let mut v = Vec::with_capacity(b.len() + 2 * depth);
                v.extend_from_slice(&b[..toks[k].start]);
                v.extend_from_slice(open.repeat(depth).as_bytes());
                v.extend_from_slice(&b[toks[k].start..end]);
                v.extend_from_slice(close.repeat(depth).as_bytes());
                v.extend_from_slice(&b[end..]);
                v
            })
        }
        "list_repeat" => {
            // Repeat one element of a `[...]` list 10–1000 times.
            let lists: Vec<usize> =
                (0..toks.len()).filter(|&k| toks[k].kind == Tok::Open && b[toks[k].start] == b'[').collect();
            (!lists.is_empty()).then(|| {
                let k = lists[rng.random_range(0..lists.len())];
                // An unclosed list runs to the end of the input.
                let (close, close_at) = matching(&toks, k).map_or((toks.len(), b.len()), |m| (m, toks[m].start));
                // Element boundaries: commas at depth 1.
                let mut bounds = vec![toks[k].end];
                let mut depth = 0i64;
                for t in &toks[k + 1..close] {
                    match t.kind {
                        Tok::Open => depth += 1,
                        Tok::Close => depth -= 1,
                        Tok::Comma if depth == 0 => bounds.push(t.end),
                        _ => {}
                    }
                }
                bounds.push(close_at);
                let e = rng.random_range(0..bounds.len() - 1);
                let mut elem = b[bounds[e]..bounds[e + 1]].to_vec();
                let trimmed_end = elem.iter().rposition(|c| !c.is_ascii_whitespace()).map_or(0, |p| p + 1);
                elem.truncate(trimmed_end);
                if !elem.ends_with(b",") {
                    elem.push(b',');
                }
                let times = if rng.random_bool(0.5) { 1000 } else { rng.random_range(10..1000) };
                // Within the size cap (a repeated element may itself be huge).
                let times = times.min(MAX_INPUT.saturating_sub(b.len()) / elem.len());
                let rep = elem.repeat(times);
                splice(b, bounds[e], bounds[e], &rep)
            })
        }
        "splice" => {
            // Replace a token range here by a token range of another corpus file.
            let other = &corpus[rng.random_range(0..corpus.len())];
            let ot = tokenize(other);
            (!toks.is_empty() && !ot.is_empty()).then(|| {
                let (a, c) = range(rng, toks.len());
                let (oa, oc) = range(rng, ot.len());
                splice(b, toks[a].start, toks[c].end, &other[ot[oa].start..ot[oc].end])
            })
        }
        _ => None,
    };
    match out {
        Some(v) if v.len() <= MAX_INPUT => {
            *b = v;
            true
        }
        _ => false,
    }
}

/// A random token range `a..=c` of at most 40 tokens in `0..n`.
fn range(rng: &mut StdRng, n: usize) -> (usize, usize) {
    let a = rng.random_range(0..n);
    let c = (a + rng.random_range(0..40)).min(n - 1);
    (a, c)
}

/// `b` with `start..end` replaced by `with`.
fn splice(b: &[u8], start: usize, end: usize, with: &[u8]) -> Vec<u8> {
    let mut v = Vec::with_capacity(b.len() - (end - start) + with.len());
    v.extend_from_slice(&b[..start]);
    v.extend_from_slice(with);
    v.extend_from_slice(&b[end..]);
    v
}

/// Candidate reductions of a failing input, lazily, largest first: drop comments and spacing
/// (keeping colons), halve an over-long token (a 10^5-char string or digit string), then delete
/// token ranges of halving sizes down to single
/// tokens. The shrinker keeps the first candidate that still fails and starts over.
pub fn reductions(b: &[u8]) -> impl Iterator<Item = Vec<u8>> + '_ {
    let toks = tokenize(b);
    // First the comments and blank space between tokens: one line per token's gap at most.
    let mut bare = Vec::with_capacity(b.len());
    let mut prev = 0;
    for t in &toks {
        if t.start > prev {
            bare.push(if b[prev..t.start].contains(&b':') { b':' } else { b' ' });
        }
        bare.extend_from_slice(&b[t.start..t.end]);
        prev = t.end;
    }
    let bare = (bare.len() < b.len()).then_some(bare);
    let long: Vec<Token> = toks.iter().copied().filter(|t| t.end - t.start > 64).collect();
    let halve = long.into_iter().map(move |t| {
        // Cut the middle half, keeping a string's quotes.
        let len = t.end - t.start;
        let from = t.start + len / 4;
        splice(b, from, from + len / 2, b"")
    });
    let mut chunks = Vec::new();
    let mut chunk = toks.len().next_power_of_two() / 2;
    while chunk >= 1 {
        chunks.push(chunk);
        chunk /= 2;
    }
    let delete = chunks.into_iter().flat_map(move |chunk| {
        let toks = toks.clone();
        (0..toks.len()).step_by(chunk).map(move |k| {
            let last = (k + chunk).min(toks.len()) - 1;
            splice(b, toks[k].start, toks[last].end, b"")
        })
    });
    bare.into_iter().chain(halve).chain(delete)
}
