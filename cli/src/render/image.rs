//! RGB images, PNG output and the heat-map colour ramp.

use std::io::BufWriter;
use std::path::Path;

use kdbeam::{Error, Result};

/// An 8-bit RGB image, rows top to bottom.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `3 · width · height` bytes, RGB.
    pub rgb: Vec<u8>,
}

impl Image {
    /// A black image.
    pub fn new(width: u32, height: u32) -> Self {
        Image {
            width,
            height,
            rgb: vec![0; 3 * width as usize * height as usize],
        }
    }

    /// Sets pixel `(x, y)` (row `y` from the top) to linear colour `c`, gamma-encoded (sRGB
    /// approximated by γ = 2.2), clamped to [0, 1]; NaN becomes 0.
    pub fn set_linear(&mut self, x: u32, y: u32, c: [f32; 3]) {
        let i = 3 * (y as usize * self.width as usize + x as usize);
        for (k, v) in c.into_iter().enumerate() {
            let v = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
            self.rgb[i + k] = (v.powf(1.0 / 2.2) * 255.0 + 0.5) as u8;
        }
    }

    /// Places `other` to the right of `self` (heights must match; the shorter is padded black).
    pub fn beside(&self, other: &Image) -> Image {
        let mut out = Image::new(self.width + other.width, self.height.max(other.height));
        for (img, x0) in [(self, 0), (other, self.width)] {
            for y in 0..img.height {
                let src = 3 * (y * img.width) as usize..3 * ((y + 1) * img.width) as usize;
                let dst = 3 * (y * out.width + x0) as usize;
                out.rgb[dst..dst + src.len()].copy_from_slice(&img.rgb[src]);
            }
        }
        out
    }

    /// Writes the image as a PNG.
    ///
    /// # Errors
    /// [`Error::Io`] when the file cannot be written.
    pub fn write_png(&self, path: &Path) -> Result<()> {
        let io = |source| Error::Io {
            path: path.to_path_buf(),
            source,
        };
        let file = std::fs::File::create(path).map_err(io)?;
        let mut encoder = png::Encoder::new(BufWriter::new(file), self.width, self.height);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        let png_err = |e: png::EncodingError| {
            io(match e {
                png::EncodingError::IoError(e) => e,
                other => std::io::Error::other(other.to_string()),
            })
        };
        let mut writer = encoder.write_header().map_err(png_err)?;
        writer.write_image_data(&self.rgb).map_err(png_err)?;
        writer.finish().map_err(png_err)
    }
}

/// The heat-map colour of `x` in [0, 1]: dark blue through green and yellow to white
/// (a perceptually ordered ramp); values outside are clamped.
pub fn heat_color(x: f32) -> [f32; 3] {
    const STOPS: [[f32; 3]; 6] = [
        [0.00, 0.00, 0.05],
        [0.05, 0.05, 0.45],
        [0.00, 0.45, 0.45],
        [0.30, 0.75, 0.10],
        [0.95, 0.85, 0.10],
        [1.00, 1.00, 1.00],
    ];
    let x = if x.is_nan() { 0.0 } else { x.clamp(0.0, 1.0) } * (STOPS.len() - 1) as f32;
    let i = (x as usize).min(STOPS.len() - 2);
    let f = x - i as f32;
    core::array::from_fn(|k| STOPS[i][k] * (1.0 - f) + STOPS[i + 1][k] * f)
}

/// An image size `WIDTHxHEIGHT` (or `WIDTHXHEIGHT`), each side from 1 to 16384, as the
/// commands' and examples' `--size` take it.
///
/// # Errors
/// A message saying what is wrong, for the command line.
pub fn parse_size(s: &str) -> std::result::Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or("expected WIDTHxHEIGHT, e.g. 1024x768")?;
    let parse = |v: &str| match v.trim().parse::<u32>() {
        Ok(n) if (1..=16384).contains(&n) => Ok(n),
        _ => Err(format!("{v:?} is not a size from 1 to 16384")),
    };
    Ok((parse(w)?, parse(h)?))
}
