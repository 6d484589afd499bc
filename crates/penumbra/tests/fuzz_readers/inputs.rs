//! Inputs shared by the readers: special values, the edits that mutate
//! seeds, and the generators of numbers and lines that structured inputs
//! are made of.

use proptest::collection::vec;
use proptest::prelude::*;
use proptest::sample::{Index, select};

use crate::harness::KIB;

/// Number texts that break parsers: out of f32 and u32 range, signed zero,
/// non-finite spellings, near-misses of the number grammar.
const EXTREMES: &[&str] = &[
    "1e39",
    "-1e39",
    "3.4028235e38",
    "-3.4028235e38",
    "3e38",
    "1e38",
    "1e-46",
    "1e-45",
    "-0",
    "-0.0",
    "0",
    "1",
    "-1",
    "nan",
    "NaN",
    "-nan",
    "inf",
    "-inf",
    "infinity",
    "-Infinity",
    "1.#INF",
    "4294967295",
    "4294967296",
    "4294967297",
    "2147483648",
    "-2147483649",
    "-4294967297",
    "99999999999",
    "-99999999999",
    "18446744073709551616",
    "-9223372036854775809",
    "1e308",
    "1e309",
    "0x10",
    "1e",
    "+",
    "-",
    ".",
    "1.2.3",
    "00000000000000000000000001",
    "",
];

/// Special f32 values for binary formats and generated text.
pub const SPECIAL_F32: &[f32] = &[
    0.0,
    -0.0,
    1.0,
    -1.0,
    0.5,
    1e-45,
    -1e-45,
    f32::MIN_POSITIVE,
    f32::MAX,
    f32::MIN,
    f32::INFINITY,
    f32::NEG_INFINITY,
    f32::NAN,
    1e30,
    -1e30,
    16777217.0,
];

/// Special u32 words for binary headers: sizes on and past every limit.
pub const SPECIAL_U32: &[u32] = &[
    0,
    1,
    2,
    3,
    4,
    8,
    32,
    96,
    127,
    128,
    129,
    255,
    256,
    511,
    512,
    513,
    16383,
    16384,
    16385,
    65536,
    0x7fff_ffff,
    0x8000_0000,
    u32::MAX - 1,
    u32::MAX,
    0x7fc0_0000, // NaN
    0x7f80_0000, // +inf
    0xff80_0000, // -inf
    0x8000_0001, // -1e-45
    0x3f80_0000, // 1.0
    0xbf80_0000, // -1.0
];

/// Tokens worth inserting into text formats (and header lines).
const TOKENS: &[&[u8]] = &[
    b"\n",
    b"\r\n",
    b"\r",
    b" ",
    b"\t",
    b"#",
    b"/",
    b"//",
    b"-",
    b"+",
    b".",
    b",",
    b"e",
    b"\0",
    b"\xef\xbb\xbf",
    b"\xff\xfe",
    b"\xe2\x80\xa8",
    b"v ",
    b"vn ",
    b"f ",
    b"f 1 2 3\n",
    b"o ",
    b"g ",
    b"s ",
    b"usemtl ",
    b"mtllib ",
    b"newmtl ",
    b"Kd ",
    b"xyz ",
    b"spectral ",
    b"{",
    b"}",
    b"[",
    b"]",
    b"\"",
    b":",
    b"null",
    b"true",
    b"1e39",
    b"-0",
    b"nan",
    b"inf",
    b"4294967297",
    b"-Y ",
    b"+X ",
    b"\x02\x02",
    b"\x01\x01\x01",
];

/// How a number token is replaced.
#[derive(Clone, Debug)]
pub enum NumberText {
    Extreme(&'static str),
    /// That many nines.
    Digits(u16),
    Float(f64),
    Int(i64),
}

impl NumberText {
    fn text(&self) -> String {
        match self {
            NumberText::Extreme(s) => s.to_string(),
            NumberText::Digits(n) => "9".repeat(*n as usize),
            NumberText::Float(x) => format!("{x:e}"),
            NumberText::Int(i) => i.to_string(),
        }
    }
}

fn number_text() -> impl Strategy<Value = NumberText> {
    prop_oneof![
        6 => select(EXTREMES).prop_map(NumberText::Extreme),
        1 => (1u16..400).prop_map(NumberText::Digits),
        2 => any::<f64>().prop_map(NumberText::Float),
        2 => any::<i64>().prop_map(NumberText::Int),
    ]
}

/// One edit of an input; positions are `Index`es, resolved against the
/// input's length when applied (so they shrink well).
#[derive(Clone, Debug)]
pub enum Edit {
    FlipBit(Index, u8),
    SetByte(Index, u8),
    Insert(Index, Vec<u8>),
    Delete(Index, u16),
    Truncate(Index),
    DuplicateLine(Index, u8),
    SwapLines(Index, Index),
    DeleteLine(Index),
    Number(Index, NumberText),
    /// A little-endian u32 over the 4-aligned word at the index.
    Word(Index, u32),
}

fn inserted() -> impl Strategy<Value = Vec<u8>> {
    prop_oneof![
        3 => select(TOKENS).prop_map(<[u8]>::to_vec),
        1 => vec(any::<u8>(), 1..12),
    ]
}

pub fn text_edit() -> impl Strategy<Value = Edit> {
    prop_oneof![
        1 => (any::<Index>(), 0u8..8).prop_map(|(i, b)| Edit::FlipBit(i, b)),
        1 => (any::<Index>(), any::<u8>()).prop_map(|(i, b)| Edit::SetByte(i, b)),
        3 => (any::<Index>(), inserted()).prop_map(|(i, b)| Edit::Insert(i, b)),
        2 => (any::<Index>(), 1u16..64).prop_map(|(i, n)| Edit::Delete(i, n)),
        1 => any::<Index>().prop_map(Edit::Truncate),
        2 => (any::<Index>(), 1u8..64).prop_map(|(i, n)| Edit::DuplicateLine(i, n)),
        2 => (any::<Index>(), any::<Index>()).prop_map(|(a, b)| Edit::SwapLines(a, b)),
        1 => any::<Index>().prop_map(Edit::DeleteLine),
        6 => (any::<Index>(), number_text()).prop_map(|(i, n)| Edit::Number(i, n)),
    ]
}

pub fn u32_word() -> impl Strategy<Value = u32> + Clone {
    prop_oneof![3 => select(SPECIAL_U32), 1 => any::<u32>()]
}

pub fn binary_edit() -> impl Strategy<Value = Edit> {
    prop_oneof![
        3 => (any::<Index>(), 0u8..8).prop_map(|(i, b)| Edit::FlipBit(i, b)),
        2 => (any::<Index>(), any::<u8>()).prop_map(|(i, b)| Edit::SetByte(i, b)),
        1 => (any::<Index>(), inserted()).prop_map(|(i, b)| Edit::Insert(i, b)),
        1 => (any::<Index>(), 1u16..256).prop_map(|(i, n)| Edit::Delete(i, n)),
        1 => any::<Index>().prop_map(Edit::Truncate),
        1 => (any::<Index>(), number_text()).prop_map(|(i, n)| Edit::Number(i, n)),
        5 => (any::<Index>(), u32_word()).prop_map(|(i, w)| Edit::Word(i, w)),
    ]
}

/// Byte ranges of the lines of `bytes`, newline included.
fn lines(bytes: &[u8]) -> Vec<std::ops::Range<usize>> {
    let mut out = Vec::new();
    let mut start = 0;
    for (i, &b) in bytes.iter().enumerate() {
        if b == b'\n' {
            out.push(start..i + 1);
            start = i + 1;
        }
    }
    if start < bytes.len() {
        out.push(start..bytes.len());
    }
    out
}

/// Byte ranges of number tokens: maximal runs of `0-9 . + - e E` holding
/// a digit, not glued to a letter before them.
fn numbers(bytes: &[u8]) -> Vec<std::ops::Range<usize>> {
    let part = |b: u8| b.is_ascii_digit() || matches!(b, b'.' | b'+' | b'-' | b'e' | b'E');
    let mut out = Vec::new();
    let mut i = 0;
    while i < bytes.len() {
        if !part(bytes[i]) {
            i += 1;
            continue;
        }
        let start = i;
        while i < bytes.len() && part(bytes[i]) {
            i += 1;
        }
        let glued = start > 0 && bytes[start - 1].is_ascii_alphabetic();
        if !glued && bytes[start..i].iter().any(u8::is_ascii_digit) {
            out.push(start..i);
        }
    }
    out
}

fn apply(edit: &Edit, b: &mut Vec<u8>) {
    let len = b.len();
    match edit {
        Edit::FlipBit(i, bit) if len > 0 => b[i.index(len)] ^= 1 << bit,
        Edit::SetByte(i, byte) if len > 0 => b[i.index(len)] = *byte,
        Edit::Insert(i, bytes) => {
            let at = i.index(len + 1);
            b.splice(at..at, bytes.iter().copied());
        }
        Edit::Delete(i, n) if len > 0 => {
            let at = i.index(len);
            b.drain(at..(at + *n as usize).min(len));
        }
        Edit::Truncate(i) if len > 0 => b.truncate(i.index(len)),
        Edit::DuplicateLine(i, times) => {
            let all = lines(b);
            if !all.is_empty() {
                let line = all[i.index(all.len())].clone();
                let mut copy = b[line.clone()].to_vec();
                if copy.last() != Some(&b'\n') {
                    copy.push(b'\n');
                }
                // At most 64 KiB more, so that inputs stay small.
                let times = (*times as usize).min((64 * KIB / copy.len()).max(1));
                let repeated: Vec<u8> = copy.iter().copied().cycle().take(copy.len() * times).collect();
                b.splice(line.start..line.start, repeated);
            }
        }
        Edit::SwapLines(x, y) => {
            let all = lines(b);
            if all.len() >= 2 {
                let (p, q) = (x.index(all.len()), y.index(all.len()));
                let mut order: Vec<usize> = (0..all.len()).collect();
                order.swap(p, q);
                *b = order.iter().flat_map(|&k| b[all[k].clone()].to_vec()).collect();
            }
        }
        Edit::DeleteLine(i) => {
            let all = lines(b);
            if !all.is_empty() {
                b.drain(all[i.index(all.len())].clone());
            }
        }
        Edit::Number(i, text) => {
            let all = numbers(b);
            if !all.is_empty() {
                let range = all[i.index(all.len())].clone();
                b.splice(range, text.text().into_bytes());
            }
        }
        Edit::Word(i, word) if len >= 4 => {
            let at = i.index(len / 4) * 4;
            b[at..at + 4].copy_from_slice(&word.to_le_bytes());
        }
        _ => {}
    }
}

/// A seed (shrinking towards the first) with up to `max_edits` edits.
pub fn mutated(
    seeds: Vec<Vec<u8>>,
    edit: impl Strategy<Value = Edit>,
    max_edits: usize,
) -> impl Strategy<Value = Vec<u8>> {
    (select(seeds), vec(edit, 0..=max_edits)).prop_map(|(mut bytes, edits)| {
        for e in &edits {
            apply(e, &mut bytes);
        }
        bytes
    })
}

/// Numbers for generated text: mostly plain, some extreme.
pub fn text_number() -> impl Strategy<Value = String> + Clone {
    prop_oneof![
        5 => (-100.0f32..100.0).prop_map(|x| x.to_string()),
        2 => select(EXTREMES).prop_map(String::from),
        1 => any::<f32>().prop_map(|x| format!("{x:e}")),
    ]
}

/// A generated file's wildness: the chance that each value in it is
/// malformed or extreme (0: well-formed statements only).
pub fn wildness() -> impl Strategy<Value = f64> {
    select(vec![0.0, 0.01, 0.05, 0.3])
}

/// `plain`, or `odd` with probability `wild`.
pub fn either<T: std::fmt::Debug + Clone>(
    wild: f64,
    plain: impl Strategy<Value = T> + Clone,
    odd: impl Strategy<Value = T> + Clone,
) -> impl Strategy<Value = T> + Clone {
    (prop::bool::weighted(wild), plain, odd).prop_map(|(w, p, o)| if w { o } else { p })
}

/// A number in `lo..hi`, or with probability `wild` an odd one.
pub fn number(wild: f64, lo: f32, hi: f32) -> impl Strategy<Value = String> + Clone {
    either(wild, (lo..hi).prop_map(|x| x.to_string()), text_number())
}

pub fn pick(choices: &'static [&'static str]) -> impl Strategy<Value = String> + Clone {
    select(choices).prop_map(String::from)
}

/// Lines joined by `\n` or `\r\n`, maybe after a byte-order mark.
fn joined(lines: Vec<String>, crlf: bool, bom: bool) -> Vec<u8> {
    let mut text = if bom { "\u{feff}".to_string() } else { String::new() };
    text.push_str(&lines.join(if crlf { "\r\n" } else { "\n" }));
    text.into_bytes()
}

/// Statements of a generated text format, in random line endings.
pub fn text_lines(line: impl Strategy<Value = String>, max: usize) -> impl Strategy<Value = Vec<u8>> {
    (vec(line, 0..max), any::<bool>(), prop::bool::weighted(0.1))
        .prop_map(|(lines, crlf, bom)| joined(lines, crlf, bom))
}

/// `n` numbered lines of `line` (`{}` taking the number).
pub fn numbered(n: usize, line: impl Fn(usize) -> String) -> String {
    (0..n).map(line).collect()
}
