//! Reading environment images: equirectangular Radiance RGBE and OpenEXR files, decided
//! by their content, within a memory budget.

use crate::error::{bail, Result};

/// Reads an equirectangular environment image (Radiance RGBE `.hdr`/`.pic` or OpenEXR
/// `.exr`, by content): (width, height, linear RGB triples). The file must be a regular
/// file of at most `limit` bytes; `check(width, height, file bytes)` decides from the
/// header, before any pixel is decoded (a memory budget). IMAP_ERR_IO when the file
/// cannot be read, IMAP_ERR_PARSE naming the file when it is not such an image,
/// IMAP_ERR_MEMORY_BUDGET past `limit`.
pub fn read_image(
    path: &std::path::Path,
    limit: u64,
    check: &dyn Fn(usize, usize, u64) -> Result<()>,
) -> Result<(usize, usize, Vec<f32>)> {
    use crate::error::{Error, ImapStatus};
    use crate::files::{read_regular, ReadError};
    use image::ImageDecoder;
    let shown = path.display();
    let bytes = read_regular(path, limit).map_err(|e| match e {
        ReadError::TooLarge { .. } => Error::new(
            ImapStatus::ImapErrMemoryBudget,
            format!("{shown}: {e}: over the memory budget"),
        ),
        e => Error::new(ImapStatus::ImapErrIo, format!("{shown}: {e}")),
    })?;
    let file_bytes = bytes.len() as u64;
    let mut reader = image::ImageReader::new(std::io::Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| Error::new(ImapStatus::ImapErrIo, format!("{shown}: {e}")))?;
    match reader.format() {
        Some(image::ImageFormat::Hdr) | Some(image::ImageFormat::OpenExr) => {}
        other => bail!(
            ImapErrParse,
            "{shown}: not a Radiance HDR or OpenEXR image ({})",
            other.map_or("format not recognised".to_string(), |f| format!("{f:?}"))
        ),
    }
    // The budget decides from the header, before a pixel is decoded; the decoder's own
    // allocations are held to what the budget leaves.
    reader.no_limits();
    let decode_error = |e: image::ImageError| match e {
        image::ImageError::IoError(e) => Error::new(ImapStatus::ImapErrIo, format!("{shown}: {e}")),
        image::ImageError::Limits(e) => {
            Error::new(ImapStatus::ImapErrMemoryBudget, format!("{shown}: {e}"))
        }
        e => Error::new(ImapStatus::ImapErrParse, format!("{shown}: {e}")),
    };
    let mut decoder = reader.into_decoder().map_err(decode_error)?;
    let (w, h) = decoder.dimensions();
    check(w as usize, h as usize, file_bytes)?;
    let mut limits = image::Limits::default();
    limits.max_alloc = Some(limit);
    decoder.set_limits(limits).map_err(decode_error)?;
    let img = image::DynamicImage::from_decoder(decoder).map_err(decode_error)?;
    let rgb = img.into_rgb32f();
    let (w, h) = (rgb.width() as usize, rgb.height() as usize);
    Ok((w, h, rgb.into_raw()))
}
