//! A 3×5 bitmap font for the figures drawn over the picture: digits, capitals and a few signs.

/// The rows of `c`'s glyph, top first, 3 bits each (bit 2 the left column); `None` for a
/// character the font lacks. Lower case is drawn as upper case.
fn glyph(c: char) -> Option<[u8; 5]> {
    Some(match c.to_ascii_uppercase() {
        '0' => [0b111, 0b101, 0b101, 0b101, 0b111],
        '1' => [0b010, 0b110, 0b010, 0b010, 0b111],
        '2' => [0b111, 0b001, 0b111, 0b100, 0b111],
        '3' => [0b111, 0b001, 0b111, 0b001, 0b111],
        '4' => [0b101, 0b101, 0b111, 0b001, 0b001],
        '5' => [0b111, 0b100, 0b111, 0b001, 0b111],
        '6' => [0b111, 0b100, 0b111, 0b101, 0b111],
        '7' => [0b111, 0b001, 0b001, 0b001, 0b001],
        '8' => [0b111, 0b101, 0b111, 0b101, 0b111],
        '9' => [0b111, 0b101, 0b111, 0b001, 0b111],
        'A' => [0b010, 0b101, 0b111, 0b101, 0b101],
        'B' => [0b110, 0b101, 0b110, 0b101, 0b110],
        'C' => [0b011, 0b100, 0b100, 0b100, 0b011],
        'D' => [0b110, 0b101, 0b101, 0b101, 0b110],
        'E' => [0b111, 0b100, 0b110, 0b100, 0b111],
        'F' => [0b111, 0b100, 0b110, 0b100, 0b100],
        'G' => [0b011, 0b100, 0b101, 0b101, 0b011],
        'H' => [0b101, 0b101, 0b111, 0b101, 0b101],
        'I' => [0b111, 0b010, 0b010, 0b010, 0b111],
        'J' => [0b001, 0b001, 0b001, 0b101, 0b010],
        'K' => [0b101, 0b101, 0b110, 0b101, 0b101],
        'L' => [0b100, 0b100, 0b100, 0b100, 0b111],
        'M' => [0b101, 0b111, 0b111, 0b101, 0b101],
        'N' => [0b110, 0b101, 0b101, 0b101, 0b101],
        'O' => [0b010, 0b101, 0b101, 0b101, 0b010],
        'P' => [0b110, 0b101, 0b110, 0b100, 0b100],
        'Q' => [0b010, 0b101, 0b101, 0b110, 0b011],
        'R' => [0b110, 0b101, 0b110, 0b101, 0b101],
        'S' => [0b011, 0b100, 0b010, 0b001, 0b110],
        'T' => [0b111, 0b010, 0b010, 0b010, 0b010],
        'U' => [0b101, 0b101, 0b101, 0b101, 0b111],
        'V' => [0b101, 0b101, 0b101, 0b101, 0b010],
        'W' => [0b101, 0b101, 0b111, 0b111, 0b101],
        'X' => [0b101, 0b101, 0b010, 0b101, 0b101],
        'Y' => [0b101, 0b101, 0b010, 0b010, 0b010],
        'Z' => [0b111, 0b001, 0b010, 0b100, 0b111],
        '.' => [0b000, 0b000, 0b000, 0b000, 0b010],
        '%' => [0b101, 0b001, 0b010, 0b100, 0b101],
        '/' => [0b001, 0b001, 0b010, 0b100, 0b100],
        ':' => [0b000, 0b010, 0b000, 0b010, 0b000],
        '-' => [0b000, 0b000, 0b111, 0b000, 0b000],
        ' ' => [0; 5],
        _ => return None,
    })
}

/// Width of a character cell in font pixels (3 of glyph, 1 of space).
const ADVANCE: usize = 4;

/// Draws `text` into `pixels` (`width` pixels a row, `0x00RRGGBB`) from `(x, y)` (its top
/// left corner) in `colour`, each font pixel `scale × scale` screen pixels, on a dark box one
/// font pixel wider all round so that it reads on any picture. Characters the font lacks are
/// drawn as `?`-less gaps; whatever falls outside the buffer is clipped.
pub fn draw_text(
    pixels: &mut [u32],
    width: usize,
    (x, y): (usize, usize),
    text: &str,
    scale: usize,
    colour: u32,
) {
    let height = pixels.len() / width.max(1);
    let scale = scale.max(1);
    let mut put = |px: usize, py: usize, c: u32| {
        for sy in 0..scale {
            for sx in 0..scale {
                let (xx, yy) = (px * scale + sx, py * scale + sy);
                if xx < width && yy < height {
                    pixels[yy * width + xx] = c;
                }
            }
        }
    };
    let (fx, fy) = (x / scale, y / scale);
    let cells = text.chars().count() * ADVANCE;
    for py in fy..fy + 7 {
        for px in fx..fx + cells + 1 {
            put(px, py, 0x0010_1010);
        }
    }
    for (i, c) in text.chars().enumerate() {
        let Some(rows) = glyph(c) else { continue };
        for (r, bits) in rows.iter().enumerate() {
            for col in 0..3 {
                if bits >> (2 - col) & 1 != 0 {
                    put(fx + 1 + i * ADVANCE + col, fy + 1 + r, colour);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_is_drawn_in_its_colour_on_a_dark_box_and_clipped() {
        let (w, h) = (40, 10);
        let mut pixels = vec![0x00ff_ffff; w * h];
        draw_text(&mut pixels, w, (0, 0), "1.0%", 1, 0x00ff_0000);
        // "1": the top row of its glyph is 010, one font pixel in from the box's edge.
        assert_eq!(pixels[1 + 1 + w], 0x00ff_0000);
        assert_eq!(pixels[0], 0x0010_1010);
        assert!(pixels.iter().filter(|&&p| p == 0x00ff_0000).count() > 10);
        // Far right of the text: untouched.
        assert_eq!(pixels[39], 0x00ff_ffff);
        // Drawn off the buffer: no panic.
        draw_text(&mut pixels, w, (38, 8), "WIDE TEXT", 2, 0x0000_ff00);
        assert!(glyph('q').is_some() && glyph('~').is_none());
    }
}
