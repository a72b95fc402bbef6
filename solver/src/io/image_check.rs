//! The rule for every image a reader keeps: its bytes are a PNG or a JPEG that decodes whole
//! within the size limits. Readers keep images encoded ([`super::Image`]) and writers copy
//! those bytes into exports, so this check is what stops a file that only claims to be a
//! texture (a `uri` naming `/etc/passwd`, a text file renamed `.png`) from leaving with the
//! user's export. The image is decoded once here and the pixels dropped.

use std::io::Cursor;

/// Largest width or height of a texture, in pixels.
pub const MAX_IMAGE_SIDE: u32 = 16_384;

/// Most bytes the decoder may allocate for one image (RGBA8 at 8192×8192 and its buffers).
pub const MAX_IMAGE_ALLOC: u64 = 512 << 20;

/// The MIME type (`"image/png"` or `"image/jpeg"`) of `bytes` once they decoded as that image.
///
/// `declared`: the MIME type the file states for them, if any; bytes of another type than
/// declared are refused. Errors: one phrase saying what the bytes are not (for a notice that
/// names the image).
pub(crate) fn decoded_mime(bytes: &[u8], declared: Option<&str>) -> Result<&'static str, String> {
    use image::ImageFormat;
    let format = match image::guess_format(bytes) {
        Ok(f @ (ImageFormat::Png | ImageFormat::Jpeg)) => f,
        Ok(other) => return Err(format!("a {other:?} image, not a PNG or JPEG")),
        Err(_) => return Err("not a PNG or JPEG image".to_string()),
    };
    let mime = if format == ImageFormat::Png { "image/png" } else { "image/jpeg" };
    if let Some(declared) = declared.filter(|d| !d.eq_ignore_ascii_case(mime)) {
        return Err(format!("declared {declared} but its bytes are {mime}"));
    }
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(MAX_IMAGE_SIDE);
    limits.max_image_height = Some(MAX_IMAGE_SIDE);
    limits.max_alloc = Some(MAX_IMAGE_ALLOC);
    let mut reader = image::ImageReader::with_format(Cursor::new(bytes), format);
    reader.limits(limits);
    reader.decode().map_err(|e| format!("does not decode as {mime} ({e})"))?;
    Ok(mime)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    fn encoded(format: image::ImageFormat, w: u32, h: u32) -> Vec<u8> {
        let img = image::RgbImage::from_pixel(w, h, image::Rgb([200, 100, 50]));
        let mut out = Cursor::new(Vec::new());
        img.write_to(&mut out, format).unwrap();
        out.into_inner()
    }

    #[test]
    fn png_and_jpeg_that_decode_are_kept() {
        let png = encoded(image::ImageFormat::Png, 3, 2);
        let jpeg = encoded(image::ImageFormat::Jpeg, 3, 2);
        assert_eq!(decoded_mime(&png, None), Ok("image/png"));
        assert_eq!(decoded_mime(&png, Some("image/PNG")), Ok("image/png"));
        assert_eq!(decoded_mime(&jpeg, Some("image/jpeg")), Ok("image/jpeg"));
    }

    #[test]
    fn other_bytes_are_refused() {
        let png = encoded(image::ImageFormat::Png, 3, 2);
        let e = decoded_mime(b"root:x:0:0:root:/root:/bin/bash\n", None).unwrap_err();
        assert!(e.contains("not a PNG or JPEG"), "{e}");
        let e = decoded_mime(&png, Some("image/jpeg")).unwrap_err();
        assert!(e.contains("declared image/jpeg"), "{e}");
        // A PNG signature over garbage, and a PNG cut short.
        let mut fake = b"\x89PNG\r\n\x1a\n".to_vec();
        fake.extend_from_slice(b"not really a png");
        assert!(decoded_mime(&fake, None).unwrap_err().contains("does not decode"));
        assert!(decoded_mime(&png[..png.len() / 2], None).is_err());
        let e = decoded_mime(b"BM\0\0\0\0\0\0\0\0", None).unwrap_err();
        assert!(e.contains("Bmp"), "{e}");
    }

    #[test]
    fn images_past_the_size_limit_are_refused() {
        let wide = encoded(image::ImageFormat::Png, MAX_IMAGE_SIDE + 1, 1);
        let e = decoded_mime(&wide, None).unwrap_err();
        assert!(e.contains("does not decode"), "{e}");
        assert!(decoded_mime(&encoded(image::ImageFormat::Png, MAX_IMAGE_SIDE, 1), None).is_ok());
    }
}
