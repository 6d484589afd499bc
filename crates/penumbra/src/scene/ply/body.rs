//! The values of a PLY body, one at a time: ASCII tokens or binary scalars
//! of either byte order. Every value comes out as f64, which holds every
//! PLY integer (at most 32 bits) and float exactly.

use super::header::Scalar;

/// Where values come from. Problems are plain text; the caller adds the
/// element, record and property (and `place`).
pub trait Body {
    /// The next value, of type `ty`.
    fn value(&mut self, ty: Scalar) -> Result<f64, String>;
    /// Skips `n` values of type `ty` (a list the mesh does not use).
    fn skip(&mut self, ty: Scalar, n: u64) -> Result<(), String>;
    /// Skips `n` records of `size` bytes each, if this body can do so in one
    /// step (binary): elements of scalars the mesh does not use.
    fn skip_records(&mut self, size: usize, n: u64) -> Option<Result<(), String>>;
    /// Where the last value read is (or the next one was looked for), for
    /// messages ("line 12", "byte 345").
    fn place(&self) -> String;
    /// Where data is left after the last element, if any: anything but
    /// whitespace (ASCII) or any byte (binary).
    fn leftover(&mut self) -> Option<String>;
}

/// A whitespace-separated ASCII body. Records are not required to be one
/// per line (some writers wrap long lists), but lines are counted for
/// messages.
pub struct Ascii<'a> {
    bytes: &'a [u8],
    pos: usize,
    line: usize,
    /// The line of the last token read (or looked for, at the end).
    token_line: usize,
}

impl<'a> Ascii<'a> {
    /// The body `bytes`, whose first line is line `first_line` of the file.
    pub fn new(bytes: &'a [u8], first_line: usize) -> Ascii<'a> {
        Ascii {
            bytes,
            pos: 0,
            line: first_line,
            token_line: first_line,
        }
    }

    fn skip_space(&mut self) {
        while let Some(&b) = self.bytes.get(self.pos) {
            if !b.is_ascii_whitespace() {
                break;
            }
            self.line += usize::from(b == b'\n');
            self.pos += 1;
        }
    }

    fn token(&mut self) -> Option<&'a [u8]> {
        self.skip_space();
        self.token_line = self.line;
        let start = self.pos;
        while self.bytes.get(self.pos).is_some_and(|b| !b.is_ascii_whitespace()) {
            self.pos += 1;
        }
        (self.pos > start).then(|| &self.bytes[start..self.pos])
    }
}

/// How a token is shown in a message: at most 40 characters of it.
fn shown(token: &[u8]) -> String {
    let text = String::from_utf8_lossy(token);
    match text.char_indices().nth(40) {
        Some((cut, _)) => format!("'{}...'", &text[..cut]),
        None => format!("'{text}'"),
    }
}

impl Body for Ascii<'_> {
    fn value(&mut self, ty: Scalar) -> Result<f64, String> {
        let token = self
            .token()
            .ok_or_else(|| format!("the file ends where a {} value should be", ty.name()))?;
        let text = std::str::from_utf8(token).map_err(|_| format!("{} is not a number", shown(token)))?;
        let not_a_number = || format!("{} is not a number ({})", shown(token), ty.name());
        match ty {
            // A float is parsed as f32 directly: through f64 a decimal could
            // round twice and land on the neighbour of the f32 it denotes.
            Scalar::F32 => {
                let v = text.parse::<f32>().map_err(|_| not_a_number())?;
                if v.is_infinite() && text.parse::<f64>().is_ok_and(f64::is_finite) {
                    return Err(format!("{} is out of the range of float", shown(token)));
                }
                return Ok(v.into());
            }
            Scalar::F64 => return text.parse::<f64>().map_err(|_| not_a_number()),
            _ => {}
        }
        let value = text
            .parse::<i64>()
            .map_err(|_| format!("{} is not an integer ({})", shown(token), ty.name()))?;
        let (lo, hi) = ty.range();
        if (value as f64) < lo || (value as f64) > hi {
            return Err(format!("{value} is out of the range of {}", ty.name()));
        }
        Ok(value as f64)
    }

    fn skip(&mut self, ty: Scalar, n: u64) -> Result<(), String> {
        // Each value is checked as the other values are: a malformed file
        // is malformed wherever it is.
        for _ in 0..n {
            self.value(ty)?;
        }
        Ok(())
    }

    fn skip_records(&mut self, _: usize, _: u64) -> Option<Result<(), String>> {
        None
    }

    fn place(&self) -> String {
        format!("line {}", self.token_line)
    }

    fn leftover(&mut self) -> Option<String> {
        self.token()?;
        Some(self.place())
    }
}

/// A binary body in either byte order.
pub struct Binary<'a> {
    bytes: &'a [u8],
    pos: usize,
    /// Where the last value read starts (or would have).
    mark: usize,
    big_endian: bool,
    /// Offset of the body in the file, for messages.
    offset: usize,
}

impl<'a> Binary<'a> {
    pub fn new(bytes: &'a [u8], big_endian: bool, offset: usize) -> Binary<'a> {
        Binary {
            bytes,
            pos: 0,
            mark: 0,
            big_endian,
            offset,
        }
    }

    /// Advances past `n` bytes, or says how many are missing (for `what`,
    /// built only then: this runs once per value).
    fn take(&mut self, n: u128, what: impl FnOnce() -> String) -> Result<usize, String> {
        let left = self.bytes.len() - self.pos;
        self.mark = self.pos;
        if n > left as u128 {
            return Err(format!(
                "the file ends here: {} needs {n} bytes, {left} are left",
                what()
            ));
        }
        let start = self.pos;
        self.pos += n as usize;
        Ok(start)
    }
}

impl Body for Binary<'_> {
    fn value(&mut self, ty: Scalar) -> Result<f64, String> {
        let at = self.take(ty.size() as u128, || format!("a {} value", ty.name()))?;
        let b = &self.bytes[at..at + ty.size()];
        let mut word = [0u8; 8];
        word[..b.len()].copy_from_slice(b);
        if self.big_endian {
            word[..b.len()].reverse();
        }
        // `word` now holds the value little-endian in its first bytes.
        let [b0, b1, b2, b3, ..] = word;
        Ok(match ty {
            Scalar::I8 => b0 as i8 as f64,
            Scalar::U8 => b0 as f64,
            Scalar::I16 => i16::from_le_bytes([b0, b1]) as f64,
            Scalar::U16 => u16::from_le_bytes([b0, b1]) as f64,
            Scalar::I32 => i32::from_le_bytes([b0, b1, b2, b3]) as f64,
            Scalar::U32 => u32::from_le_bytes([b0, b1, b2, b3]) as f64,
            Scalar::F32 => f32::from_le_bytes([b0, b1, b2, b3]) as f64,
            Scalar::F64 => f64::from_le_bytes(word),
        })
    }

    fn skip(&mut self, ty: Scalar, n: u64) -> Result<(), String> {
        let what = || format!("a list of {n} {} values", ty.name());
        self.take(n as u128 * ty.size() as u128, what).map(|_| ())
    }

    fn skip_records(&mut self, size: usize, n: u64) -> Option<Result<(), String>> {
        let what = || format!("{n} records of {size} bytes");
        Some(self.take(n as u128 * size as u128, what).map(|_| ()))
    }

    fn place(&self) -> String {
        format!("byte {}", self.offset + self.mark)
    }

    fn leftover(&mut self) -> Option<String> {
        self.mark = self.pos;
        (self.pos < self.bytes.len()).then(|| self.place())
    }
}
