//! Plain image types shared by every stage, and the SPEC 0 input conversion.
//!
//! Stages work on [`Plane<T>`]: a dense row-major `width x height` array, the
//! same layout a GPU storage buffer has. Callers hand in a [`GrayView`], which
//! borrows any 8-bit buffer with a row stride (a camera frame, an
//! `image::GrayImage`) without copying.

use crate::error::{Error, Result};
use std::path::Path;

/// Largest accepted width or height. Keeps every integer stage (Otsu's
/// exact comparison in particular) inside its proven range; see docs/algorithm.md.
pub const MAX_SIDE: u32 = 16384;

/// A dense row-major image of `T`, `data.len() == width * height`.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Plane<T> {
    /// Columns.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// Pixels, row after row.
    pub data: Vec<T>,
}

impl<T: Copy + Default> Plane<T> {
    /// A plane filled with `T::default()`.
    pub fn new(width: u32, height: u32) -> Self {
        Self { width, height, data: vec![T::default(); width as usize * height as usize] }
    }
}

impl<T: Copy + Default> Plane<T> {
    /// Makes this a `width x height` plane, reusing the allocation. Contents
    /// are unspecified afterwards: for buffers a pass overwrites entirely.
    pub fn reshape(&mut self, width: u32, height: u32) {
        self.width = width;
        self.height = height;
        let n = width as usize * height as usize;
        if n > self.data.capacity() {
            // The old pixels need not survive: a fresh zeroed allocation (calloc,
            // whose new pages come zeroed) instead of copying them over and
            // clearing the rest, which touched each new page twice.
            self.data = vec![T::default(); n];
        } else {
            self.data.resize(n, T::default());
        }
    }
}

impl<T: Copy> Plane<T> {
    /// Wraps `data`; fails when its length is not `width * height`.
    pub fn from_vec(width: u32, height: u32, data: Vec<T>) -> Result<Self> {
        if data.len() != width as usize * height as usize {
            return Err(Error::InvalidImage {
                width,
                height,
                reason: format!("buffer has {} elements, expected {}", data.len(), width as usize * height as usize),
            });
        }
        Ok(Self { width, height, data })
    }

    /// Pixel at (x, y); panics out of range (internal use with checked indices).
    #[inline(always)]
    pub fn at(&self, x: u32, y: u32) -> T {
        self.data[y as usize * self.width as usize + x as usize]
    }

    /// Pixel at (x, y) with coordinates clamped into the image (replicate border).
    #[inline(always)]
    pub fn clamped(&self, x: i32, y: i32) -> T {
        let x = x.clamp(0, self.width as i32 - 1) as usize;
        let y = y.clamp(0, self.height as i32 - 1) as usize;
        self.data[y * self.width as usize + x]
    }

    /// Row `y` as a slice.
    #[inline(always)]
    pub fn row(&self, y: u32) -> &[T] {
        let w = self.width as usize;
        &self.data[y as usize * w..(y as usize + 1) * w]
    }

    /// Number of pixels.
    pub fn len(&self) -> usize {
        self.data.len()
    }

    /// True for a 0-pixel plane.
    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }
}

impl Plane<u8> {
    /// Borrow as a [`GrayView`].
    pub fn view(&self) -> GrayView<'_> {
        GrayView { width: self.width, height: self.height, stride: self.width as usize, data: &self.data }
    }
}

/// A borrowed 8-bit gray image with a row stride in bytes.
#[derive(Clone, Copy, Debug)]
pub struct GrayView<'a> {
    width: u32,
    height: u32,
    stride: usize,
    data: &'a [u8],
}

impl<'a> GrayView<'a> {
    /// Checks that `data` holds `height` rows of `stride >= width` bytes (the
    /// last row may be just `width` long) and that the size is within limits.
    pub fn new(width: u32, height: u32, stride: usize, data: &'a [u8]) -> Result<Self> {
        check_size(width, height)?;
        if stride < width as usize {
            return Err(Error::InvalidImage {
                width,
                height,
                reason: format!("row stride {stride} is less than the width"),
            });
        }
        let need = stride.checked_mul(height as usize - 1).and_then(|n| n.checked_add(width as usize));
        let Some(_) = need.filter(|&n| n <= data.len()) else {
            return Err(Error::InvalidImage {
                width,
                height,
                reason: format!(
                    "buffer has {} bytes, {} needed for stride {stride}",
                    data.len(),
                    need.map_or("more than usize::MAX".into(), |n| n.to_string())
                ),
            });
        };
        Ok(Self { width, height, stride, data })
    }

    /// Re-checks size and buffer length: a view made from a [`Plane`] (whose
    /// fields are public) has not been through [`GrayView::new`].
    pub fn check(&self) -> Result<()> {
        GrayView::new(self.width, self.height, self.stride, self.data).map(|_| ())
    }

    /// Columns.
    pub fn width(&self) -> u32 {
        self.width
    }
    /// Rows.
    pub fn height(&self) -> u32 {
        self.height
    }
    /// Row `y`, `width` bytes.
    pub fn row(&self, y: u32) -> &'a [u8] {
        let s = y as usize * self.stride;
        &self.data[s..s + self.width as usize]
    }
    /// Copies the pixels into `out`, reusing its allocation.
    pub fn copy_into(&self, out: &mut Plane<u8>) {
        out.reshape(self.width, self.height);
        let w = self.width as usize;
        for (y, row) in out.data.chunks_exact_mut(w).enumerate() {
            row.copy_from_slice(self.row(y as u32));
        }
    }

    /// [`copy_into`](Self::copy_into) in bands of rows on the current rayon
    /// pool: a frame's first step, which the other threads would otherwise wait out.
    pub fn par_copy_into(&self, out: &mut Plane<u8>) {
        use rayon::prelude::*;
        out.reshape(self.width, self.height);
        let w = self.width as usize;
        const BAND: usize = 64;
        if w == 0 {
            return;
        }
        out.data.par_chunks_mut(w * BAND).enumerate().for_each(|(b, rows)| {
            for (k, row) in rows.chunks_exact_mut(w).enumerate() {
                row.copy_from_slice(self.row((b * BAND + k) as u32));
            }
        });
    }

    /// A dense copy.
    pub fn to_plane(&self) -> Plane<u8> {
        if self.stride == self.width as usize {
            let n = self.width as usize * self.height as usize;
            return Plane { width: self.width, height: self.height, data: self.data[..n].to_vec() };
        }
        let mut data = Vec::with_capacity(self.width as usize * self.height as usize);
        for y in 0..self.height {
            data.extend_from_slice(self.row(y));
        }
        Plane { width: self.width, height: self.height, data }
    }
}

impl<'a> From<&'a image::GrayImage> for GrayView<'a> {
    fn from(img: &'a image::GrayImage) -> Self {
        let (w, h) = img.dimensions();
        GrayView { width: w, height: h, stride: w as usize, data: img.as_raw() }
    }
}

impl<'a> From<&'a Plane<u8>> for GrayView<'a> {
    fn from(p: &'a Plane<u8>) -> Self {
        p.view()
    }
}

/// Fails for an empty image or one larger than [`MAX_SIDE`] on a side.
pub fn check_size(width: u32, height: u32) -> Result<()> {
    if width == 0 || height == 0 {
        return Err(Error::InvalidImage { width, height, reason: "the image is empty".into() });
    }
    if width > MAX_SIDE || height > MAX_SIDE {
        return Err(Error::InvalidImage {
            width,
            height,
            reason: format!("a side exceeds the limit of {MAX_SIDE} pixels"),
        });
    }
    Ok(())
}

/// OpenCV's integer BT.601 luma (SPEC 0): `(19596 R + 38470 G + 7470 B + 32768) >> 16`,
/// what OpenCV 4.x and 5.x `cvtColor(COLOR_BGR2GRAY)` computes for 8-bit input, so that
/// converting to gray with cv2 first gives the same keypoints as passing colour.
///
/// ```
/// assert_eq!(lfast::image::luma_bt601(255, 255, 255), 255);
/// assert_eq!(lfast::image::luma_bt601(255, 0, 0), 76);
/// assert_eq!(lfast::image::luma_bt601(0, 0, 255), 29);
/// ```
#[inline]
pub fn luma_bt601(r: u8, g: u8, b: u8) -> u8 {
    ((19596 * r as u32 + 38470 * g as u32 + 7470 * b as u32 + 32768) >> 16) as u8
}

/// [`luma_bt601`] of every pixel of `raw` (`C` bytes per pixel, red, green,
/// blue first), 16 pixels per step: with AVX2 the loads become shuffles and
/// the sums vector lanes (a 3840x2160 RGB frame: 6 ms, against 16 pixel by pixel).
#[inline(always)]
fn luma_blocks<const C: usize>(raw: &[u8], out: &mut [u8]) {
    let n = raw.len() / C;
    let out = &mut out[..n];
    for (o, i) in out.chunks_exact_mut(16).zip(raw.chunks_exact(16 * C)) {
        let (mut r, mut g, mut b) = ([0u32; 16], [0u32; 16], [0u32; 16]);
        for k in 0..16 {
            (r[k], g[k], b[k]) = (i[C * k] as u32, i[C * k + 1] as u32, i[C * k + 2] as u32);
        }
        for k in 0..16 {
            // luma_bt601, written out so that the lanes stay u32
            o[k] = ((19596 * r[k] + 38470 * g[k] + 7470 * b[k] + 32768) >> 16) as u8;
        }
    }
    let done = n / 16 * 16;
    for (o, p) in out[done..].iter_mut().zip(raw[done * C..].chunks_exact(C)) {
        *o = luma_bt601(p[0], p[1], p[2]);
    }
}

crate::cpu::simd::dispatch! {
    /// [`luma_bt601`] of every pixel of packed RGB8 bytes, into `out[..raw.len() / 3]`.
    fn rgb8_to_gray_into(raw: &[u8], out: &mut [u8]) {
        luma_blocks::<3>(raw, out)
    }
}

/// [`luma_bt601`] of every pixel of packed RGB8 bytes.
fn rgb8_to_gray(raw: &[u8]) -> Vec<u8> {
    let mut out = vec![0; raw.len() / 3];
    rgb8_to_gray_into(raw, &mut out);
    out
}

/// [`luma_bt601`] of every pixel of packed RGBA8 bytes (alpha ignored).
fn rgba8_to_gray(raw: &[u8]) -> Vec<u8> {
    let mut out = vec![0; raw.len() / 4];
    rgba8_to_gray_into(raw, &mut out);
    out
}

crate::cpu::simd::dispatch! {
    /// [`luma_bt601`] of every pixel of packed RGBA8 bytes (alpha ignored), into `out[..raw.len() / 4]`.
    fn rgba8_to_gray_into(raw: &[u8], out: &mut [u8]) {
        luma_blocks::<4>(raw, out)
    }
}

/// Converts any decoded image to 8-bit gray as SPEC 0 says: colour by
/// [`luma_bt601`], 16-bit by `v >> 8` (per channel, before luma), alpha ignored.
/// Float images are clamped to [0, 1] and scaled by 255 with rounding.
pub fn to_gray(img: &image::DynamicImage) -> Result<Plane<u8>> {
    use image::DynamicImage as D;
    let (w, h) = (img.width(), img.height());
    check_size(w, h)?;
    let data: Vec<u8> = match img {
        D::ImageLuma8(b) => b.as_raw().clone(),
        D::ImageLumaA8(b) => b.pixels().map(|p| p.0[0]).collect(),
        D::ImageRgb8(b) => rgb8_to_gray(b.as_raw()),
        D::ImageRgba8(b) => rgba8_to_gray(b.as_raw()),
        D::ImageLuma16(b) => b.pixels().map(|p| (p.0[0] >> 8) as u8).collect(),
        D::ImageLumaA16(b) => b.pixels().map(|p| (p.0[0] >> 8) as u8).collect(),
        D::ImageRgb16(b) => {
            b.pixels().map(|p| luma_bt601((p.0[0] >> 8) as u8, (p.0[1] >> 8) as u8, (p.0[2] >> 8) as u8)).collect()
        }
        D::ImageRgba16(b) => {
            b.pixels().map(|p| luma_bt601((p.0[0] >> 8) as u8, (p.0[1] >> 8) as u8, (p.0[2] >> 8) as u8)).collect()
        }
        other => {
            let rgb = other.to_rgb32f();
            let q = |v: f32| (v.clamp(0.0, 1.0) * 255.0).round() as u8;
            rgb.pixels().map(|p| luma_bt601(q(p.0[0]), q(p.0[1]), q(p.0[2]))).collect()
        }
    };
    Plane::from_vec(w, h, data)
}

/// Decoding limits for files: no side over [`MAX_SIDE`], at most 1 GiB allocated,
/// so a crafted header cannot make the decoder allocate gigabytes.
pub fn decode_limits() -> image::Limits {
    let mut l = image::Limits::default();
    l.max_image_width = Some(MAX_SIDE);
    l.max_image_height = Some(MAX_SIDE);
    l.max_alloc = Some(1 << 30);
    l
}

/// Reads an image file and converts it to gray (SPEC 0), with [`decode_limits`].
/// [`GrayLoader`] does the same for a sequence of files, keeping its buffer.
pub fn load_gray(path: impl AsRef<Path>) -> Result<Plane<u8>> {
    GrayLoader::default().load(path)
}

/// Reads image files one after another as gray planes, like [`load_gray`],
/// decoding colour frames (8-bit RGB and RGBA) into one buffer it keeps: a
/// fresh one is paged in again for every file (a 3840x2160 colour JPEG: 25 MB,
/// ~6,000 page faults). [`load_into`](Self::load_into) also takes the
/// buffer of the gray plane, from a plane that is done with.
///
/// ```no_run
/// let mut loader = lfast::image::GrayLoader::default();
/// for f in ["a.jpg", "b.jpg"] {
///     let gray = loader.load(f)?;
///     println!("{f}: {}x{}", gray.width, gray.height);
/// }
/// # Ok::<(), lfast::Error>(())
/// ```
#[derive(Debug, Default)]
pub struct GrayLoader {
    colour: Vec<u8>,
}

impl GrayLoader {
    /// The gray plane of the image file at `path`; the buffer it decoded
    /// into stays for the next file.
    pub fn load(&mut self, path: impl AsRef<Path>) -> Result<Plane<u8>> {
        self.load_into(path, Vec::new())
    }

    /// [`load`](Self::load) with the plane's pixels in `out`'s allocation (a
    /// spent plane's `data`): 8-bit gray and colour files then allocate
    /// nothing once the buffers are large enough. `out` is dropped for
    /// other files, and for one more than twice the size the image needs.
    pub fn load_into(&mut self, path: impl AsRef<Path>, mut out: Vec<u8>) -> Result<Plane<u8>> {
        use image::{ColorType, ImageDecoder};
        let path = path.as_ref();
        let io = |source| Error::Io { path: path.to_path_buf(), source };
        let img_err = |source| Error::Image { path: path.to_path_buf(), source };
        let mut reader = image::ImageReader::open(path).map_err(io)?.with_guessed_format().map_err(io)?;
        reader.limits(decode_limits());
        let mut decoder = reader.into_decoder().map_err(img_err)?;
        // what `ImageReader::decode` checks: the decoded image within the limits' allocation
        let mut limits = decode_limits();
        limits.reserve(decoder.total_bytes()).map_err(img_err)?;
        decoder.set_limits(limits).map_err(img_err)?;
        let colour = decoder.color_type();
        if !matches!(colour, ColorType::L8 | ColorType::Rgb8 | ColorType::Rgba8) {
            return into_gray(image::DynamicImage::from_decoder(decoder).map_err(img_err)?);
        }
        let (w, h) = decoder.dimensions();
        check_size(w, h)?;
        // within the limits' 1 GiB: the reservation above passed
        let (bytes, px) = (decoder.total_bytes() as usize, w as usize * h as usize);
        let fit = |v: &mut Vec<u8>, n: usize| {
            // a fresh zeroed allocation when it must grow (its pages come
            // zeroed: no copy, no clearing), or when it is more than twice
            // the size (one huge frame would pin its buffer); else reused
            if v.capacity() < n || v.capacity() > 2 * n {
                *v = vec![0; n];
            } else {
                v.resize(n, 0);
            }
        };
        fit(&mut out, px);
        if colour == ColorType::L8 {
            decoder.read_image(&mut out).map_err(img_err)?;
        } else {
            fit(&mut self.colour, bytes);
            decoder.read_image(&mut self.colour).map_err(img_err)?;
            if colour == ColorType::Rgb8 {
                rgb8_to_gray_into(&self.colour, &mut out);
            } else {
                rgba8_to_gray_into(&self.colour, &mut out);
            }
        }
        Plane::from_vec(w, h, out)
    }
}

/// [`to_gray`] of an image the caller gives up: an 8-bit gray one (KITTI,
/// EuRoC, TUM frames) becomes the plane without a copy.
pub fn into_gray(img: image::DynamicImage) -> Result<Plane<u8>> {
    match img {
        image::DynamicImage::ImageLuma8(b) => {
            let (w, h) = b.dimensions();
            check_size(w, h)?;
            Plane::from_vec(w, h, b.into_raw())
        }
        img => to_gray(&img),
    }
}

/// Writes an 8-bit plane as a PNG.
pub fn save_gray(plane: &Plane<u8>, path: impl AsRef<Path>) -> Result<()> {
    let path = path.as_ref();
    image::save_buffer(path, &plane.data, plane.width, plane.height, image::ExtendedColorType::L8)
        .map_err(|source| Error::Image { path: path.to_path_buf(), source })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colour_to_gray_equals_luma_of_each_pixel() {
        // sizes around the 16-pixel step, every byte value in every channel
        let mut s = 0x9e37_79b9u32;
        let mut next = move || {
            s ^= s << 13;
            s ^= s >> 17;
            s ^= s << 5;
            s as u8
        };
        for (w, h) in [(1u32, 1u32), (15, 1), (16, 1), (17, 3), (37, 5), (256, 3)] {
            let rgb: Vec<u8> = (0..w * h * 3).map(|_| next()).collect();
            let rgba: Vec<u8> = (0..w * h * 4).map(|_| next()).collect();
            let want3: Vec<u8> = rgb.chunks(3).map(|p| luma_bt601(p[0], p[1], p[2])).collect();
            let want4: Vec<u8> = rgba.chunks(4).map(|p| luma_bt601(p[0], p[1], p[2])).collect();
            let img3 = image::DynamicImage::ImageRgb8(image::RgbImage::from_raw(w, h, rgb).unwrap());
            let img4 = image::DynamicImage::ImageRgba8(image::RgbaImage::from_raw(w, h, rgba).unwrap());
            assert_eq!(to_gray(&img3).unwrap().data, want3, "RGB {w}x{h}");
            assert_eq!(to_gray(&img4).unwrap().data, want4, "RGBA {w}x{h}");
        }
        // the extremes of each channel
        for (r, g, b) in [(255, 255, 255), (255, 0, 0), (0, 255, 0), (0, 0, 255), (0, 0, 0)] {
            let img = image::DynamicImage::ImageRgb8(image::RgbImage::from_pixel(17, 1, image::Rgb([r, g, b])));
            assert!(to_gray(&img).unwrap().data.iter().all(|&v| v == luma_bt601(r, g, b)));
        }
    }

    #[test]
    fn loader_equals_decoding_each_file_afresh() {
        // colour frames growing and shrinking (the kept buffer), gray, RGBA, 16-bit, JPEG, a broken file
        let dir = tempfile::tempdir().unwrap();
        let mut files = Vec::new();
        for (i, (w, h, kind)) in [
            (64u32, 48u32, "rgb"),
            (300, 200, "rgb"),
            (17, 5, "rgba"),
            (40, 30, "gray"),
            (33, 21, "rgb16"),
            (96, 64, "jpeg"),
            (20, 20, "rgb"),
        ]
        .into_iter()
        .enumerate()
        {
            // smooth ramps plus noise, so the JPEG keeps detail to decode
            let px = |x: u32, y: u32, c: u32| {
                let noise = (x ^ y.rotate_left(7) ^ c.rotate_left(13)).wrapping_mul(0x9e37_79b9) >> 28;
                ((x * 7 + y * 3 + c * 50) as u8).wrapping_add(noise as u8)
            };
            let img = match kind {
                "rgb" | "jpeg" => image::DynamicImage::ImageRgb8(image::RgbImage::from_fn(w, h, |x, y| {
                    image::Rgb([px(x, y, 0), px(x, y, 1), px(x, y, 2)])
                })),
                "rgba" => image::DynamicImage::ImageRgba8(image::RgbaImage::from_fn(w, h, |x, y| {
                    image::Rgba([px(x, y, 0), px(x, y, 1), px(x, y, 2), px(x, y, 3)])
                })),
                "gray" => {
                    image::DynamicImage::ImageLuma8(image::GrayImage::from_fn(w, h, |x, y| image::Luma([px(x, y, 0)])))
                }
                _ => image::DynamicImage::ImageRgb16(image::ImageBuffer::from_fn(w, h, |x, y| {
                    image::Rgb([px(x, y, 0) as u16 * 255 + x as u16, px(x, y, 1) as u16 * 257, (y * 999) as u16])
                })),
            };
            let path = dir.path().join(format!("{i}.{}", if kind == "jpeg" { "jpg" } else { "png" }));
            img.save(&path).unwrap();
            files.push(path);
        }
        let broken = dir.path().join("broken.png");
        std::fs::write(&broken, &std::fs::read(&files[1]).unwrap()[..400]).unwrap();
        files.insert(3, broken.clone());
        let mut loader = GrayLoader::default();
        // the second round hands the previous plane's buffer back, as lfast detect's decoders do
        let mut spent = Vec::new();
        for round in 0..2 {
            for f in &files {
                let got = if round == 0 { loader.load(f) } else { loader.load_into(f, std::mem::take(&mut spent)) };
                if *f == broken {
                    let e = got.unwrap_err().to_string();
                    assert!(e.contains("broken.png"), "{e}");
                    continue;
                }
                let want = to_gray(&image::open(f).unwrap()).unwrap();
                let got = got.unwrap();
                assert_eq!(got, want, "{} (round {round})", f.display());
                spent = got.data;
            }
        }
    }
}
