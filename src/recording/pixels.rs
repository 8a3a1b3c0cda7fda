//! An image message's pixels as the 8-bit gray plane the detector takes
//! (SPEC 0): the raw encodings of `sensor_msgs/Image` and
//! `foxglove.RawImage`, with `step` honoured, and compressed PNG/JPEG files
//! decoded as `lfast detect` decodes image files.

use super::wire::ImageMsg;
use crate::error::{Error, Result};
use crate::image::{Plane, check_size, decode_limits, into_gray, luma_bt601};

/// The raw encodings taken, in the order the errors list them.
pub const RAW_ENCODINGS: &str =
    "mono8, mono16, rgb8, bgr8, rgba8, bgra8 (and 8UC1, 16UC1, 8UC3, 8UC4 as OpenCV's mono8, mono16, bgr8, bgra8)";

/// Bytes per pixel of a raw encoding, and how a pixel becomes gray.
#[derive(Clone, Copy)]
enum Layout {
    Mono8,
    Mono16,
    /// Three or four channels; `r` and `b` are the byte offsets of red and blue.
    Colour {
        bytes: usize,
        r: usize,
        b: usize,
    },
}

fn layout(encoding: &str) -> Option<Layout> {
    Some(match encoding {
        "mono8" | "8UC1" => Layout::Mono8,
        "mono16" | "16UC1" => Layout::Mono16,
        "rgb8" => Layout::Colour { bytes: 3, r: 0, b: 2 },
        "bgr8" | "8UC3" => Layout::Colour { bytes: 3, r: 2, b: 0 },
        "rgba8" => Layout::Colour { bytes: 4, r: 0, b: 2 },
        "bgra8" | "8UC4" => Layout::Colour { bytes: 4, r: 2, b: 0 },
        _ => return None,
    })
}

fn unsupported(reason: String) -> Error {
    Error::Unsupported { reason }
}

fn invalid(width: u32, height: u32, reason: String) -> Error {
    Error::InvalidImage { width, height, reason }
}

/// Raw pixels to gray: mono8 as is, mono16 `v >> 8`, colour by OpenCV's
/// BT.601 luma; rows `step` bytes apart.
fn raw(width: u32, height: u32, encoding: &str, big_endian: bool, step: u32, data: &[u8]) -> Result<Plane<u8>> {
    let Some(l) = layout(encoding) else {
        return Err(unsupported(format!("image encoding `{encoding}` (taken: {RAW_ENCODINGS})")));
    };
    check_size(width, height)?;
    let bpp = match l {
        Layout::Mono8 => 1,
        Layout::Mono16 => 2,
        Layout::Colour { bytes, .. } => bytes,
    };
    let row = width as usize * bpp;
    let step = step as usize;
    if step < row {
        return Err(invalid(width, height, format!("step {step} is less than a {encoding} row of {row} bytes")));
    }
    let need = step * (height as usize - 1) + row;
    if data.len() < need {
        return Err(invalid(
            width,
            height,
            format!("{} bytes of {encoding} data, {need} needed for {height} rows {step} bytes apart", data.len()),
        ));
    }
    let mut out = Vec::with_capacity(width as usize * height as usize);
    for y in 0..height as usize {
        let r = &data[y * step..y * step + row];
        match l {
            Layout::Mono8 => out.extend_from_slice(r),
            Layout::Mono16 if big_endian => out.extend(r.chunks_exact(2).map(|p| p[0])),
            Layout::Mono16 => out.extend(r.chunks_exact(2).map(|p| p[1])),
            Layout::Colour { bytes, r: ri, b: bi } => {
                out.extend(r.chunks_exact(bytes).map(|p| luma_bt601(p[ri], p[1], p[bi])))
            }
        }
    }
    Plane::from_vec(width, height, out)
}

/// A compressed image: PNG or JPEG, as the format string or the bytes say.
fn compressed(format: &str, data: &[u8]) -> Result<Plane<u8>> {
    let f = format.to_ascii_lowercase();
    let guessed = image::guess_format(data).ok();
    let fmt = match guessed {
        Some(g @ (image::ImageFormat::Png | image::ImageFormat::Jpeg)) => g,
        _ if f.contains("png") || f.contains("jpeg") || f.contains("jpg") => {
            return Err(invalid(0, 0, format!("the data is not a {format} file")));
        }
        _ => return Err(unsupported(format!("compressed image format `{format}` (taken: png, jpeg)"))),
    };
    let mut reader = image::ImageReader::with_format(std::io::Cursor::new(data), fmt);
    reader.limits(decode_limits());
    let img = reader
        .decode()
        .map_err(|e| Error::Image { path: std::path::PathBuf::from(format!("{format} image")), source: e })?;
    into_gray(img)
}

/// The gray plane of an image message.
pub fn gray(msg: &ImageMsg<'_>) -> Result<Plane<u8>> {
    match *msg {
        ImageMsg::Raw { width, height, encoding, big_endian, step, data, .. } => {
            raw(width, height, encoding, big_endian, step, data)
        }
        ImageMsg::Compressed { format, data, .. } => compressed(format, data),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn msg<'a>(encoding: &'a str, w: u32, h: u32, step: u32, data: &'a [u8]) -> ImageMsg<'a> {
        ImageMsg::Raw { stamp_ns: 0, width: w, height: h, encoding, big_endian: false, step, data }
    }

    #[test]
    fn every_raw_encoding_by_hand() {
        // 2x2, rows padded to 8 bytes
        let mono = [10, 20, 0, 0, 0, 0, 0, 0, 30, 40];
        assert_eq!(gray(&msg("mono8", 2, 2, 8, &mono)).unwrap().data, [10, 20, 30, 40]);
        // mono16 little-endian: the high byte
        let m16 = [0xff, 0x12, 0x00, 0x34, 0x01, 0xab, 0x99, 0xcd];
        assert_eq!(gray(&msg("mono16", 2, 2, 4, &m16)).unwrap().data, [0x12, 0x34, 0xab, 0xcd]);
        let be = ImageMsg::Raw {
            stamp_ns: 0,
            width: 2,
            height: 1,
            encoding: "16UC1",
            big_endian: true,
            step: 4,
            data: &[0x12, 0xff, 0x34, 0x00],
        };
        assert_eq!(gray(&be).unwrap().data, [0x12, 0x34]);
        // red, then blue: BT.601 luma 76 and 29
        let rgb = [255, 0, 0, 0, 0, 255];
        assert_eq!(gray(&msg("rgb8", 2, 1, 6, &rgb)).unwrap().data, [76, 29]);
        assert_eq!(gray(&msg("bgr8", 2, 1, 6, &rgb)).unwrap().data, [29, 76]);
        let rgba = [255, 0, 0, 7, 0, 0, 255, 7];
        assert_eq!(gray(&msg("rgba8", 2, 1, 8, &rgba)).unwrap().data, [76, 29]);
        assert_eq!(gray(&msg("bgra8", 2, 1, 8, &rgba)).unwrap().data, [29, 76]);
        // gray as colour is the gray (every v: (65536 v + 32768) >> 16 == v)
        let g: Vec<u8> = (0..=255).flat_map(|v| [v, v, v]).collect();
        assert_eq!(gray(&msg("bgr8", 256, 1, 768, &g)).unwrap().data, (0..=255).collect::<Vec<u8>>());
    }

    #[test]
    fn bad_raw_images_name_the_problem() {
        let e = gray(&msg("bayer_rggb8", 2, 2, 2, &[0; 4])).unwrap_err().to_string();
        assert!(e.contains("`bayer_rggb8`") && e.contains("mono8"), "{e}");
        let e = gray(&msg("mono8", 4, 2, 3, &[0; 8])).unwrap_err().to_string();
        assert!(e.contains("step 3 is less than a mono8 row of 4 bytes"), "{e}");
        let e = gray(&msg("mono8", 4, 2, 5, &[0; 8])).unwrap_err().to_string();
        assert!(e.contains("8 bytes of mono8 data, 9 needed"), "{e}");
        assert!(gray(&msg("mono8", 0, 2, 0, &[])).is_err());
    }

    #[test]
    fn compressed_png_and_jpeg_decode_as_files_do() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/coins.png");
        let png = std::fs::read(path).unwrap();
        let want = crate::image::load_gray(path).unwrap();
        for format in ["png", "mono8; png compressed mono8", ""] {
            let m = ImageMsg::Compressed { stamp_ns: 0, format, data: &png };
            assert_eq!(gray(&m).unwrap(), want, "{format}");
        }
        let e = gray(&ImageMsg::Compressed { stamp_ns: 0, format: "png", data: b"nope" }).unwrap_err();
        assert!(e.to_string().contains("not a png file"), "{e}");
        let e = gray(&ImageMsg::Compressed { stamp_ns: 0, format: "webp", data: b"RIFF" }).unwrap_err();
        assert!(e.to_string().contains("`webp`"), "{e}");
        let cut = gray(&ImageMsg::Compressed { stamp_ns: 0, format: "png", data: &png[..png.len() / 2] });
        assert!(cut.is_err());
    }
}
