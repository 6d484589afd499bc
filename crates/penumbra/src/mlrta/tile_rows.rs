//! An image's row-major buffer cut into the rows of non-overlapping tiles,
//! so that tiles traced in parallel write their pixels in place (no
//! tile-local buffers copied into the image afterwards).

use crate::error::{Error, Result};
use crate::mlrta::tiles::Rect;

/// For each of `rects` (in their order), its rows in `image` (a
/// `width`-wide row-major buffer) from top to bottom, each `rect.w` long.
/// Rectangles must lie inside the image and must not overlap: every pixel
/// has at most one writer.
pub(crate) fn tile_rows<'a, T>(image: &'a mut [T], width: usize, rects: &[Rect]) -> Result<Vec<Vec<&'a mut [T]>>> {
    let height = image.len().checked_div(width).unwrap_or(0);
    // Which rectangles cross each row.
    let mut crossing: Vec<Vec<usize>> = vec![Vec::new(); height];
    for (k, r) in rects.iter().enumerate() {
        let (x_end, y_end) = (r.x as usize + r.w as usize, r.y as usize + r.h as usize);
        if x_end > width || y_end > height {
            return Err(Error::input(
                "rects",
                format!("{r:?} lies outside the {width}x{height} image"),
            ));
        }
        for row in &mut crossing[r.y as usize..y_end] {
            row.push(k);
        }
    }
    let mut rows: Vec<Vec<&'a mut [T]>> = rects.iter().map(|r| Vec::with_capacity(r.h as usize)).collect();
    for (row, mut ks) in image.chunks_mut(width.max(1)).zip(crossing) {
        ks.sort_unstable_by_key(|&k| rects[k].x);
        let (mut rest, mut at) = (row, 0usize);
        for k in ks {
            let (x, w) = (rects[k].x as usize, rects[k].w as usize);
            if x < at {
                return Err(Error::input(
                    "rects",
                    format!("{:?} overlaps another rectangle", rects[k]),
                ));
            }
            let (_, from_x) = rest.split_at_mut(x - at);
            let (segment, after) = from_x.split_at_mut(w);
            rows[k].push(segment);
            (rest, at) = (after, x + w);
        }
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rect(x: u32, y: u32, w: u32, h: u32) -> Rect {
        Rect { x, y, w, h }
    }

    #[test]
    fn tiles_write_their_own_pixels() {
        let (width, height) = (10usize, 6usize);
        let mut image = vec![0u32; width * height];
        let rects = [rect(0, 0, 4, 3), rect(4, 0, 6, 3), rect(2, 3, 5, 3)];
        let rows = tile_rows(&mut image, width, &rects).unwrap();
        for (k, tile) in rows.into_iter().enumerate() {
            assert_eq!(tile.len(), rects[k].h as usize);
            for row in tile {
                assert_eq!(row.len(), rects[k].w as usize);
                row.fill(k as u32 + 1);
            }
        }
        for y in 0..height {
            for x in 0..width {
                let want = rects
                    .iter()
                    .position(|r| (r.x..r.x + r.w).contains(&(x as u32)) && (r.y..r.y + r.h).contains(&(y as u32)))
                    .map_or(0, |k| k as u32 + 1);
                assert_eq!(image[y * width + x], want, "pixel ({x}, {y})");
            }
        }
    }

    #[test]
    fn overlapping_or_outside_rectangles_are_refused() {
        let mut image = vec![0u8; 8 * 8];
        let overlap = [rect(0, 0, 4, 4), rect(3, 2, 4, 4)];
        assert!(tile_rows(&mut image, 8, &overlap).is_err());
        let outside = [rect(6, 0, 4, 4)];
        assert!(tile_rows(&mut image, 8, &outside).is_err());
        let below = [rect(0, 6, 4, 4)];
        assert!(tile_rows(&mut image, 8, &below).is_err());
    }
}
