//! Caller images (strided gray, BGR or BGRA, 8 or 16 bits) as the library's
//! 8-bit gray input, converted exactly as `lfast detect` and the Python
//! package convert them (SPEC 0): 16-bit samples by `v >> 8`, colour by
//! [`lfast::image::luma_bt601`], alpha ignored.

use crate::status::{Failure, invalid, null};
use lfast::image::{check_size, luma_bt601};
use lfast::{GrayView, Plane};
use std::ffi::c_void;

/// Layout of the pixels of an `LfastImage`, in OpenCV's channel order.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LfastPixelFormat {
    /// One 8-bit channel (`CV_8UC1`).
    Gray8 = 0,
    /// One 16-bit channel in native byte order (`CV_16UC1`).
    Gray16 = 1,
    /// Blue, green, red, 8 bits each (`CV_8UC3`).
    Bgr8 = 2,
    /// Blue, green, red, 16 bits each (`CV_16UC3`).
    Bgr16 = 3,
    /// Blue, green, red, alpha, 8 bits each (`CV_8UC4`); alpha is ignored.
    Bgra8 = 4,
    /// Blue, green, red, alpha, 16 bits each (`CV_16UC4`); alpha is ignored.
    Bgra16 = 5,
}

impl LfastPixelFormat {
    fn from_raw(v: i32) -> Option<Self> {
        use LfastPixelFormat as F;
        Some(match v {
            0 => F::Gray8,
            1 => F::Gray16,
            2 => F::Bgr8,
            3 => F::Bgr16,
            4 => F::Bgra8,
            5 => F::Bgra16,
            _ => return None,
        })
    }
    /// (channels, bytes per sample)
    fn layout(self) -> (usize, usize) {
        use LfastPixelFormat as F;
        match self {
            F::Gray8 => (1, 1),
            F::Gray16 => (1, 2),
            F::Bgr8 => (3, 1),
            F::Bgr16 => (3, 2),
            F::Bgra8 => (4, 1),
            F::Bgra16 => (4, 2),
        }
    }
}

/// A borrowed image: `height` rows of `width` pixels, row `y` starting at
/// `data + y * stride` bytes. The buffer must hold `stride * (height - 1)`
/// bytes plus one row of pixels, and stay valid during the call.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct LfastImage {
    /// First byte of the first row.
    pub data: *const c_void,
    /// Pixels per row, >= 1.
    pub width: u32,
    /// Rows, >= 1.
    pub height: u32,
    /// Bytes from the start of one row to the next, >= `width` times the pixel size.
    pub stride: usize,
    /// An `LfastPixelFormat` value.
    pub format: i32,
}

/// The input as the library reads it: a view of the caller's bytes when it is
/// 8-bit gray already, else a converted dense copy.
pub(crate) enum Gray<'a> {
    View(GrayView<'a>),
    Owned(Plane<u8>),
}

impl Gray<'_> {
    pub(crate) fn view(&self) -> GrayView<'_> {
        match self {
            Gray::View(v) => *v,
            Gray::Owned(p) => p.view(),
        }
    }
}

/// Reads `img` (named `what` in messages) as 8-bit gray.
///
/// # Safety
/// `img`, when not NULL, points to an [`LfastImage`] whose `data` holds the
/// bytes its `width`, `height`, `stride` and `format` describe.
pub(crate) unsafe fn gray<'a>(img: *const LfastImage, what: &str) -> Result<Gray<'a>, Failure> {
    // SAFETY: the caller passes NULL or a valid LfastImage
    let img = unsafe { img.as_ref() }.ok_or_else(|| null(what))?;
    let format = LfastPixelFormat::from_raw(img.format).ok_or_else(|| {
        invalid(format!("{what}: unknown pixel format {} (expected an LfastPixelFormat, 0..=5)", img.format))
    })?;
    if img.data.is_null() {
        return Err(null(&format!("{what}.data")));
    }
    let (w, h) = (img.width, img.height);
    check_size(w, h).map_err(|e| invalid(format!("{what}: {e}")))?;
    let (channels, sample) = format.layout();
    let row_bytes = w as usize * channels * sample;
    if img.stride < row_bytes {
        return Err(invalid(format!(
            "{what}: stride {} bytes is less than a row ({w} pixels of {format:?} = {row_bytes} bytes)",
            img.stride
        )));
    }
    let len = img
        .stride
        .checked_mul(h as usize - 1)
        .and_then(|n| n.checked_add(row_bytes))
        .filter(|&n| n <= isize::MAX as usize)
        .ok_or_else(|| invalid(format!("{what}: stride {} x height {h} overflows", img.stride)))?;
    // SAFETY: the caller guarantees `len` readable bytes at `data` for the call
    let bytes: &'a [u8] = unsafe { std::slice::from_raw_parts(img.data.cast::<u8>(), len) };
    if format == LfastPixelFormat::Gray8 {
        let v = GrayView::new(w, h, img.stride, bytes).map_err(|e| invalid(format!("{what}: {e}")))?;
        return Ok(Gray::View(v));
    }
    let sample_at = |row: &[u8], i: usize| -> u8 {
        if sample == 1 { row[i] } else { (u16::from_ne_bytes([row[2 * i], row[2 * i + 1]]) >> 8) as u8 }
    };
    let mut data = Vec::with_capacity(w as usize * h as usize);
    for y in 0..h as usize {
        let row = &bytes[y * img.stride..y * img.stride + row_bytes];
        for x in 0..w as usize {
            let p = x * channels;
            data.push(if channels == 1 {
                sample_at(row, p)
            } else {
                luma_bt601(sample_at(row, p + 2), sample_at(row, p + 1), sample_at(row, p))
            });
        }
    }
    Ok(Gray::Owned(Plane::from_vec(w, h, data)?))
}

/// Reads an optional mask: NULL is no mask, else 8-bit gray (nonzero = keep).
///
/// # Safety
/// As [`gray`].
pub(crate) unsafe fn mask<'a>(m: *const LfastImage) -> Result<Option<Gray<'a>>, Failure> {
    // SAFETY: forwarded from the caller
    let Some(r) = (unsafe { m.as_ref() }) else { return Ok(None) };
    if r.format != LfastPixelFormat::Gray8 as i32 {
        return Err(invalid(format!("mask: pixel format must be LFAST_PIXEL_FORMAT_GRAY8 (0), got {}", r.format)));
    }
    // SAFETY: forwarded from the caller
    unsafe { gray(m, "mask") }.map(Some)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn img(data: &[u8], w: u32, h: u32, stride: usize, format: LfastPixelFormat) -> LfastImage {
        LfastImage { data: data.as_ptr().cast(), width: w, height: h, stride, format: format as i32 }
    }

    fn dense(g: &Gray<'_>) -> Vec<u8> {
        g.view().to_plane().data
    }

    #[test]
    fn every_format_reads_as_the_same_gray() {
        // 3 x 2 gray with a stride of 5 pixels
        let g = [10u8, 200, 255, 0, 0, 0, 1, 128, 0, 0];
        let want = vec![10u8, 200, 255, 0, 1, 128];
        let v = unsafe { gray(&img(&g, 3, 2, 5, LfastPixelFormat::Gray8), "image") }.ok().unwrap();
        assert!(matches!(v, Gray::View(_)));
        assert_eq!(dense(&v), want);
        for (format, channels, sample) in [
            (LfastPixelFormat::Gray16, 1, 2),
            (LfastPixelFormat::Bgr8, 3, 1),
            (LfastPixelFormat::Bgr16, 3, 2),
            (LfastPixelFormat::Bgra8, 4, 1),
            (LfastPixelFormat::Bgra16, 4, 2),
        ] {
            // equal channels (luma of gray is gray), 16-bit low bytes that `>> 8` drops,
            // alpha 7, and two padding bytes a row
            let stride = 3 * channels * sample + 2;
            let mut buf = vec![0xeeu8; stride * 2];
            for (i, &v) in want.iter().enumerate() {
                let (y, x) = (i / 3, i % 3);
                for c in 0..channels {
                    let s = if c == 3 { 7u16 << 8 } else { (v as u16) << 8 | 0x5a };
                    let at = y * stride + (x * channels + c) * sample;
                    if sample == 1 {
                        buf[at] = (s >> 8) as u8;
                    } else {
                        buf[at..at + 2].copy_from_slice(&s.to_ne_bytes());
                    }
                }
            }
            let v = unsafe { gray(&img(&buf, 3, 2, stride, format), "image") }.ok().unwrap();
            assert_eq!(dense(&v), want, "{format:?}");
        }
    }

    #[test]
    fn colour_uses_opencv_luma_in_bgr_order() {
        let bgr = [255u8, 0, 0, 0, 0, 255];
        let v = unsafe { gray(&img(&bgr, 2, 1, 6, LfastPixelFormat::Bgr8), "image") }.ok().unwrap();
        assert_eq!(dense(&v), vec![luma_bt601(0, 0, 255), luma_bt601(255, 0, 0)]);
    }

    fn err(i: LfastImage) -> Failure {
        match unsafe { gray(&i, "image") } {
            Ok(_) => panic!("accepted"),
            Err(f) => f,
        }
    }

    #[test]
    fn bad_images_are_named_errors() {
        use crate::LfastStatus as S;
        let b = [0u8; 64];
        let f = err(LfastImage { data: std::ptr::null(), ..img(&b, 2, 2, 2, LfastPixelFormat::Gray8) });
        assert_eq!((f.0, f.1.as_str()), (S::NullPointer, "`image.data` is NULL"));
        let f = err(img(&b, 0, 2, 2, LfastPixelFormat::Gray8));
        assert_eq!(f.0, S::InvalidArgument);
        assert!(f.1.contains("empty"), "{}", f.1);
        let f = err(img(&b, 4, 2, 11, LfastPixelFormat::Bgr8));
        assert!(f.1.contains("stride 11 bytes is less than a row"), "{}", f.1);
        let f = err(LfastImage { format: 9, ..img(&b, 2, 2, 2, LfastPixelFormat::Gray8) });
        assert!(f.1.contains("unknown pixel format 9"), "{}", f.1);
        let f = err(img(&b, 2, 3, usize::MAX / 2, LfastPixelFormat::Gray8));
        assert!(f.1.contains("overflows"), "{}", f.1);
        assert_eq!(unsafe { gray(std::ptr::null(), "image") }.err().unwrap().0, S::NullPointer);
        let m = img(&b, 2, 2, 4, LfastPixelFormat::Gray16);
        assert!(unsafe { mask(&m) }.err().unwrap().1.contains("GRAY8"));
        assert!(unsafe { mask(std::ptr::null()) }.ok().unwrap().is_none());
    }
}
