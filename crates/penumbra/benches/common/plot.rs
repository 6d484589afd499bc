//! Drawing primitives of the benches' PNG plots: pixels, lines, squares
//! and a 3x5 pixel font, on an `image::RgbImage` (out-of-bounds pixels
//! are dropped).

pub type Rgb = [u8; 3];

/// Advance of one character of `text`, in pixels.
pub const CHAR_WIDTH: i32 = 8;

pub fn put(img: &mut image::RgbImage, x: i32, y: i32, c: Rgb) {
    if x >= 0 && y >= 0 && (x as u32) < img.width() && (y as u32) < img.height() {
        img.put_pixel(x as u32, y as u32, image::Rgb(c));
    }
}

pub fn line(img: &mut image::RgbImage, a: (i32, i32), b: (i32, i32), c: Rgb) {
    let n = (b.0 - a.0).abs().max((b.1 - a.1).abs()).max(1);
    for i in 0..=n {
        let t = i as f64 / n as f64;
        let x = a.0 as f64 + t * (b.0 - a.0) as f64;
        let y = a.1 as f64 + t * (b.1 - a.1) as f64;
        put(img, x.round() as i32, y.round() as i32, c);
    }
}

/// A line drawn `on` pixels, skipped `off` pixels, and so on.
pub fn dashed(img: &mut image::RgbImage, a: (i32, i32), b: (i32, i32), c: Rgb, on: i32, off: i32) {
    let n = (b.0 - a.0).abs().max((b.1 - a.1).abs()).max(1);
    for i in 0..=n {
        if i % (on + off).max(1) >= on {
            continue;
        }
        let t = i as f64 / n as f64;
        let x = a.0 as f64 + t * (b.0 - a.0) as f64;
        let y = a.1 as f64 + t * (b.1 - a.1) as f64;
        put(img, x.round() as i32, y.round() as i32, c);
    }
}

pub fn square(img: &mut image::RgbImage, x: i32, y: i32, r: i32, c: Rgb, filled: bool) {
    for dy in -r..=r {
        for dx in -r..=r {
            if filled || dx.abs() == r || dy.abs() == r {
                put(img, x + dx, y + dy, c);
            }
        }
    }
}

/// Width of `s` drawn by `text`, in pixels.
pub fn text_width(s: &str) -> i32 {
    CHAR_WIDTH * s.chars().count() as i32
}

/// Labels in a 3x5 pixel font, drawn at scale 2 with `(x, y)` the top left:
/// digits, letters (lower case drawn as capitals) and `. - ( ) , : = %`;
/// any other character is a blank.
pub fn text(img: &mut image::RgbImage, x: i32, y: i32, s: &str, c: Rgb) {
    // Rows top to bottom; bit 4 is the left column.
    const GLYPHS: [(char, [u8; 5]); 45] = [
        ('0', [7, 5, 5, 5, 7]),
        ('1', [2, 6, 2, 2, 7]),
        ('2', [7, 1, 7, 4, 7]),
        ('3', [7, 1, 7, 1, 7]),
        ('4', [5, 5, 7, 1, 1]),
        ('5', [7, 4, 7, 1, 7]),
        ('6', [7, 4, 7, 5, 7]),
        ('7', [7, 1, 1, 1, 1]),
        ('8', [7, 5, 7, 5, 7]),
        ('9', [7, 5, 7, 1, 7]),
        ('.', [0, 0, 0, 0, 2]),
        ('-', [0, 0, 7, 0, 0]),
        ('(', [1, 2, 2, 2, 1]),
        (')', [4, 2, 2, 2, 4]),
        (',', [0, 0, 0, 2, 4]),
        (':', [0, 2, 0, 2, 0]),
        ('=', [0, 7, 0, 7, 0]),
        ('%', [5, 1, 2, 4, 5]),
        ('a', [2, 5, 7, 5, 5]),
        ('b', [6, 5, 6, 5, 6]),
        ('c', [3, 4, 4, 4, 3]),
        ('d', [6, 5, 5, 5, 6]),
        ('e', [7, 4, 6, 4, 7]),
        ('f', [7, 4, 6, 4, 4]),
        ('g', [3, 4, 5, 5, 3]),
        ('h', [5, 5, 7, 5, 5]),
        ('i', [7, 2, 2, 2, 7]),
        ('j', [1, 1, 1, 5, 2]),
        ('k', [5, 5, 6, 5, 5]),
        ('l', [4, 4, 4, 4, 7]),
        ('m', [5, 7, 7, 5, 5]),
        ('n', [6, 5, 5, 5, 5]),
        ('o', [2, 5, 5, 5, 2]),
        ('p', [6, 5, 6, 4, 4]),
        ('q', [2, 5, 5, 6, 3]),
        ('r', [6, 5, 6, 5, 5]),
        ('s', [3, 4, 2, 1, 6]),
        ('t', [7, 2, 2, 2, 2]),
        ('u', [5, 5, 5, 5, 7]),
        ('v', [5, 5, 5, 5, 2]),
        ('w', [5, 5, 7, 7, 5]),
        ('x', [5, 5, 2, 5, 5]),
        ('y', [5, 5, 2, 2, 2]),
        ('z', [7, 1, 2, 4, 7]),
        ('+', [0, 2, 7, 2, 0]),
    ];
    for (k, ch) in s.chars().enumerate() {
        let ch = ch.to_ascii_lowercase();
        let Some((_, rows)) = GLYPHS.iter().find(|(g, _)| *g == ch) else {
            continue;
        };
        for (ry, bits) in rows.iter().enumerate() {
            for rx in 0..3 {
                if bits & (4 >> rx) != 0 {
                    for (sx, sy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                        put(img, x + CHAR_WIDTH * k as i32 + 2 * rx + sx, y + 2 * ry as i32 + sy, c);
                    }
                }
            }
        }
    }
}
