//! The PLY header: `ply`, `format`, `element` and `property` lines up to
//! `end_header`, checked against the bytes that follow it before anything
//! is allocated for the body.

use crate::error::{Error, Result};

/// A scalar type of a property (both spellings of the PLY 1.0 names).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(name: &str) -> Option<Scalar> {
        Some(match name {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    /// Bytes of one value in a binary body.
    pub fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    pub fn is_integer(self) -> bool {
        !matches!(self, Scalar::F32 | Scalar::F64)
    }

    /// The range of an integer type (f64 holds every 32-bit integer exactly).
    pub fn range(self) -> (f64, f64) {
        match self {
            Scalar::I8 => (i8::MIN as f64, i8::MAX as f64),
            Scalar::U8 => (0.0, u8::MAX as f64),
            Scalar::I16 => (i16::MIN as f64, i16::MAX as f64),
            Scalar::U16 => (0.0, u16::MAX as f64),
            Scalar::I32 => (i32::MIN as f64, i32::MAX as f64),
            Scalar::U32 => (0.0, u32::MAX as f64),
            Scalar::F32 | Scalar::F64 => (f64::NEG_INFINITY, f64::INFINITY),
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Scalar::I8 => "char",
            Scalar::U8 => "uchar",
            Scalar::I16 => "short",
            Scalar::U16 => "ushort",
            Scalar::I32 => "int",
            Scalar::U32 => "uint",
            Scalar::F32 => "float",
            Scalar::F64 => "double",
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    Scalar(Scalar),
    /// A count of type `count`, then that many values of type `item`.
    List {
        count: Scalar,
        item: Scalar,
    },
}

#[derive(Debug, Clone)]
pub struct Property {
    pub name: String,
    pub kind: Kind,
}

#[derive(Debug, Clone)]
pub struct Element {
    pub name: String,
    pub count: u64,
    pub properties: Vec<Property>,
    /// The header line that declared it.
    pub line: usize,
}

impl Element {
    pub fn property(&self, name: &str) -> Option<(usize, &Property)> {
        self.properties.iter().enumerate().find(|(_, p)| p.name == name)
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    Ascii,
    Binary { big_endian: bool },
}

#[derive(Debug, Clone)]
pub struct Header {
    pub format: Format,
    pub elements: Vec<Element>,
    /// Offset of the first byte after the `end_header` line.
    pub body: usize,
    /// The line number of `end_header` (ASCII bodies count on from it).
    pub end_line: usize,
}

/// Parses the header and checks that the body can hold what it declares.
/// Errors name the header line and the problem.
pub fn parse(bytes: &[u8]) -> Result<Header> {
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    let mut pos = 0;
    let mut line_no = 0;
    loop {
        line_no += 1;
        let at = |problem: String| Error::input(format!("header line {line_no}"), problem);
        if pos >= bytes.len() {
            return Err(Error::input(
                "header",
                format!("ends after {} lines without an end_header line", line_no - 1),
            ));
        }
        let end = bytes[pos..]
            .iter()
            .position(|&b| b == b'\n')
            .map_or(bytes.len(), |i| pos + i);
        let raw = &bytes[pos..end];
        pos = (end + 1).min(bytes.len());
        let text = String::from_utf8_lossy(raw);
        let mut tokens = text.split_ascii_whitespace();
        let keyword = tokens.next().unwrap_or("");
        if line_no == 1 {
            if text.trim_end_matches('\r') != "ply" {
                return Err(at("the file does not start with the PLY magic line 'ply'".into()));
            }
            continue;
        }
        let args: Vec<&str> = tokens.collect();
        match keyword {
            "comment" | "obj_info" | "" => {}
            "format" => {
                if format.is_some() {
                    return Err(at("a second format line".into()));
                }
                format = Some(parse_format(&args).map_err(at)?);
            }
            "element" => {
                let [name, count] = args[..] else {
                    return Err(at(format!("expected 'element NAME COUNT', got '{}'", text.trim())));
                };
                let count = count.parse::<u64>().map_err(|_| {
                    at(format!(
                        "element '{name}' count '{count}' is not a non-negative integer"
                    ))
                })?;
                if elements.iter().any(|e| e.name == name) {
                    return Err(at(format!("element '{name}' is declared twice")));
                }
                elements.push(Element {
                    name: name.into(),
                    count,
                    properties: Vec::new(),
                    line: line_no,
                });
            }
            "property" => {
                let Some(element) = elements.last_mut() else {
                    return Err(at("property before any element".into()));
                };
                let property = parse_property(&args).map_err(at)?;
                if element.property(&property.name).is_some() {
                    return Err(at(format!(
                        "property '{}' is declared twice in element '{}'",
                        property.name, element.name
                    )));
                }
                element.properties.push(property);
            }
            "end_header" => break,
            other => return Err(at(format!("unknown header keyword '{other}'"))),
        }
    }
    let format = format.ok_or_else(|| Error::input("header", "has no format line"))?;
    let header = Header {
        format,
        elements,
        body: pos,
        end_line: line_no,
    };
    check_size(&header, bytes.len() - pos)?;
    Ok(header)
}

fn parse_format(args: &[&str]) -> std::result::Result<Format, String> {
    let [encoding, version] = args[..] else {
        return Err(format!("expected 'format ENCODING 1.0', got '{}'", args.join(" ")));
    };
    if version != "1.0" {
        return Err(format!("version '{version}' (PLY has only 1.0)"));
    }
    match encoding {
        "ascii" => Ok(Format::Ascii),
        "binary_little_endian" => Ok(Format::Binary { big_endian: false }),
        "binary_big_endian" => Ok(Format::Binary { big_endian: true }),
        other => Err(format!(
            "encoding '{other}' is none of ascii, binary_little_endian, binary_big_endian"
        )),
    }
}

fn parse_property(args: &[&str]) -> std::result::Result<Property, String> {
    let scalar = |name: &str| Scalar::parse(name).ok_or_else(|| format!("unknown property type '{name}'"));
    match args {
        ["list", count, item, name] => {
            let count = scalar(count)?;
            if !count.is_integer() {
                return Err(format!(
                    "list '{name}' has a {} count; counts are integers",
                    count.name()
                ));
            }
            Ok(Property {
                name: name.to_string(),
                kind: Kind::List {
                    count,
                    item: scalar(item)?,
                },
            })
        }
        [ty, name] if *ty != "list" => Ok(Property {
            name: name.to_string(),
            kind: Kind::Scalar(scalar(ty)?),
        }),
        _ => Err(format!(
            "expected 'property TYPE NAME' or 'property list COUNT_TYPE TYPE NAME', got 'property {}'",
            args.join(" ")
        )),
    }
}

/// Refuses a header whose elements cannot fit in the `available` bytes
/// after it, before any of them is allocated: a binary record takes at least
/// its scalars and list counts; an ASCII record at least one character and
/// one separator per value (the file's last value may lack its separator).
fn check_size(header: &Header, available: usize) -> Result<()> {
    let mut need: u128 = 0;
    for e in &header.elements {
        let per_record: u128 = e
            .properties
            .iter()
            .map(|p| match (header.format, p.kind) {
                (Format::Ascii, _) => 2,
                (_, Kind::Scalar(s) | Kind::List { count: s, .. }) => s.size() as u128,
            })
            .sum();
        let bytes = per_record * e.count as u128;
        need += bytes;
        let slack = u128::from(header.format == Format::Ascii);
        if need > available as u128 + slack {
            return Err(Error::input(
                format!("header line {}", e.line),
                format!(
                    "element '{}' declares {} records of at least {per_record} bytes ({bytes} bytes), \
                     but {} bytes follow the header{}",
                    e.name,
                    e.count,
                    available,
                    if need > bytes {
                        format!(" and the elements before it take at least {}", need - bytes)
                    } else {
                        String::new()
                    }
                ),
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn error(text: &str) -> String {
        parse(text.as_bytes()).unwrap_err().to_string()
    }

    #[test]
    fn reads_elements_properties_and_both_type_spellings() {
        let text = "ply\r\nformat binary_big_endian 1.0\ncomment x\nobj_info y\nelement vertex 2\n\
                    property float32 x\nproperty list uint8 int32 l\nend_header\n";
        let mut bytes = text.as_bytes().to_vec();
        bytes.extend([0; 10]);
        let h = parse(&bytes).unwrap();
        assert_eq!(h.format, Format::Binary { big_endian: true });
        assert_eq!(h.body, text.len());
        assert_eq!(h.end_line, 8);
        let e = &h.elements[0];
        assert_eq!((e.name.as_str(), e.count, e.line), ("vertex", 2, 5));
        assert_eq!(e.properties[0].kind, Kind::Scalar(Scalar::F32));
        let list = Kind::List {
            count: Scalar::U8,
            item: Scalar::I32,
        };
        assert_eq!(e.property("l").map(|(i, p)| (i, p.kind)), Some((1, list)));
    }

    #[test]
    fn header_errors_name_the_line() {
        let cases = [
            (
                "plyx\n",
                "header line 1: the file does not start with the PLY magic line 'ply'",
            ),
            (
                "ply\nformat ascii 1.0\n",
                "header: ends after 2 lines without an end_header line",
            ),
            ("ply\nend_header\n", "header: has no format line"),
            (
                "ply\nformat ascii 2.0\n",
                "header line 2: version '2.0' (PLY has only 1.0)",
            ),
            (
                "ply\nformat binary 1.0\n",
                "header line 2: encoding 'binary' is none of",
            ),
            (
                "ply\nformat ascii 1.0\nformat ascii 1.0\n",
                "header line 3: a second format line",
            ),
            ("ply\nproperty float x\n", "header line 2: property before any element"),
            (
                "ply\nelement v -1\n",
                "header line 2: element 'v' count '-1' is not a non-negative integer",
            ),
            (
                "ply\nelement v 1\nelement v 1\n",
                "header line 3: element 'v' is declared twice",
            ),
            (
                "ply\nelement v 1\nproperty float x\nproperty int x\n",
                "header line 4: property 'x' is declared twice",
            ),
            (
                "ply\nelement v 1\nproperty float64x x\n",
                "header line 3: unknown property type 'float64x'",
            ),
            (
                "ply\nelement v 1\nproperty list float int l\n",
                "header line 3: list 'l' has a float count",
            ),
            (
                "ply\nelement v 1\nproperty float\n",
                "header line 3: expected 'property TYPE NAME'",
            ),
            ("ply\nvertex 3\n", "header line 2: unknown header keyword 'vertex'"),
        ];
        for (text, expected) in cases {
            let e = error(text);
            assert!(e.starts_with(expected), "{text:?} gave {e}");
        }
    }

    #[test]
    fn counts_are_checked_against_the_bytes_after_the_header() {
        let binary = "ply\nformat binary_little_endian 1.0\nelement a 2\nproperty double d\nelement b 3\n\
                      property list uchar int l\nend_header\n";
        let with = |n: usize| [binary.as_bytes(), &vec![0; n]].concat();
        assert!(parse(&with(16 + 3)).is_ok(), "2 doubles and 3 list counts");
        let e = parse(&with(16 + 2)).unwrap_err().to_string();
        assert_eq!(
            e,
            "header line 5: element 'b' declares 3 records of at least 1 bytes (3 bytes), but 18 bytes follow \
             the header and the elements before it take at least 16"
        );
        // ASCII: a character and a separator per value, the last one bare.
        let ascii = "ply\nformat ascii 1.0\nelement a 2\nproperty int i\nproperty int j\nend_header\n";
        assert!(parse(format!("{ascii}1 2\n3 4").as_bytes()).is_ok());
        assert!(parse(format!("{ascii}1 2\n3").as_bytes()).is_err());
        // Counts past u64 arithmetic.
        let huge = "ply\nformat binary_little_endian 1.0\nelement a 18446744073709551615\nproperty double d\n\
                    element b 18446744073709551615\nproperty double d\nend_header\n";
        assert!(error(huge).contains("18446744073709551615 records"));
    }
}
