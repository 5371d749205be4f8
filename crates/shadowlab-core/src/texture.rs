//! Texture images read from a scene's [`TextureRef`]s: PNG, decoded to 8-bit RGBA (any colour
//! type and depth; a `tRNS` chunk becomes alpha). Other formats (JPEG) are reported, not read: the
//! core carries one small codec, the one with an alpha channel.

use crate::material::TextureRef;

/// An image, 8-bit RGBA, top row first.
#[derive(Debug, Clone, PartialEq)]
pub struct Rgba8 {
    pub width: u32,
    pub height: u32,
    pub texels: Vec<[u8; 4]>,
}

impl Rgba8 {
    /// Decodes a PNG.
    pub fn from_png(bytes: &[u8]) -> Result<Self, String> {
        let mut decoder = png::Decoder::new(std::io::Cursor::new(bytes));
        decoder.set_transformations(png::Transformations::normalize_to_color8());
        let mut reader = decoder.read_info().map_err(|e| format!("not a readable PNG: {e}"))?;
        let size = reader.output_buffer_size().ok_or("the PNG is too large")?;
        let mut buf = vec![0u8; size];
        let info = reader.next_frame(&mut buf).map_err(|e| format!("not a readable PNG: {e}"))?;
        let channels = match info.color_type {
            png::ColorType::Grayscale => 1,
            png::ColorType::GrayscaleAlpha => 2,
            png::ColorType::Rgb => 3,
            png::ColorType::Rgba => 4,
            png::ColorType::Indexed => return Err("an indexed PNG was not expanded".into()),
        };
        let (width, height) = (info.width, info.height);
        let mut texels = Vec::with_capacity(width as usize * height as usize);
        for row in buf.chunks(info.line_size).take(height as usize) {
            texels.extend(row.chunks(channels).take(width as usize).map(|px| match *px {
                [g] => [g, g, g, 255],
                [g, a] => [g, g, g, a],
                [r, g, b] => [r, g, b, 255],
                [r, g, b, a, ..] => [r, g, b, a],
                _ => [255; 4],
            }));
        }
        if width == 0 || height == 0 || texels.len() != width as usize * height as usize {
            return Err(format!("a {width}×{height} PNG has no pixels to read"));
        }
        Ok(Self { width, height, texels })
    }

    /// Reads the image a texture reference names: `Ok(None)` for a JPEG (no alpha channel, and no
    /// codec here), an error for what cannot be read.
    pub fn read(texture: &TextureRef) -> Result<Option<Self>, String> {
        match texture {
            TextureRef::Embedded { mime_type, .. } if mime_type.contains("jpeg") => Ok(None),
            TextureRef::Embedded { bytes, .. } => Self::from_png(bytes).map(Some),
            TextureRef::File(path) => {
                let jpeg =
                    path.extension().is_some_and(|e| e.eq_ignore_ascii_case("jpg") || e.eq_ignore_ascii_case("jpeg"));
                if jpeg {
                    return Ok(None);
                }
                let bytes = crate::load::read_regular(path).map_err(|e| format!("{}: {e}", path.display()))?;
                Self::from_png(&bytes).map(Some).map_err(|e| format!("{}: {e}", path.display()))
            }
        }
    }
}
