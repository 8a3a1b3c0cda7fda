//! `--draw`: keypoints over the image as `cv2.drawKeypoints` with
//! `DRAW_RICH_KEYPOINTS` draws them: a circle of the keypoint's size and a line
//! from the centre along its orientation; the colour tells the pyramid level.

use crate::KeyPoint;
use crate::image::Plane;
use image::{ImageEncoder, Rgb, RgbImage};

const PALETTE: [[u8; 3]; 8] = [
    [255, 64, 64],
    [64, 255, 64],
    [64, 160, 255],
    [255, 220, 0],
    [255, 0, 255],
    [0, 255, 255],
    [255, 140, 0],
    [200, 200, 255],
];

fn put(img: &mut RgbImage, x: i64, y: i64, c: Rgb<u8>) {
    if x >= 0 && y >= 0 && x < img.width() as i64 && y < img.height() as i64 {
        img.put_pixel(x as u32, y as u32, c);
    }
}

fn line(img: &mut RgbImage, (x0, y0): (i64, i64), (x1, y1): (i64, i64), c: Rgb<u8>) {
    let (dx, dy) = ((x1 - x0).abs(), -(y1 - y0).abs());
    let (sx, sy) = (if x0 < x1 { 1 } else { -1 }, if y0 < y1 { 1 } else { -1 });
    let (mut x, mut y, mut err) = (x0, y0, dx + dy);
    loop {
        put(img, x, y, c);
        if x == x1 && y == y1 {
            break;
        }
        let e2 = 2 * err;
        if e2 >= dy {
            err += dy;
            x += sx;
        }
        if e2 <= dx {
            err += dx;
            y += sy;
        }
    }
}

fn circle(img: &mut RgbImage, (cx, cy): (i64, i64), r: i64, c: Rgb<u8>) {
    // midpoint circle
    let (mut x, mut y, mut d) = (r, 0i64, 1 - r);
    while x >= y {
        for (px, py) in [(x, y), (y, x), (-y, x), (-x, y), (-x, -y), (-y, -x), (y, -x), (x, -y)] {
            put(img, cx + px, cy + py, c);
        }
        y += 1;
        if d < 0 {
            d += 2 * y + 1;
        } else {
            x -= 1;
            d += 2 * (y - x) + 1;
        }
    }
}

/// The colour of pyramid level `octave`.
pub fn level_colour(octave: i32) -> Rgb<u8> {
    Rgb(PALETTE[octave.rem_euclid(PALETTE.len() as i32) as usize])
}

/// The gray image as RGB.
fn gray_rgb(gray: &Plane<u8>) -> RgbImage {
    RgbImage::from_fn(gray.width, gray.height, |x, y| {
        let v = gray.at(x, y);
        Rgb([v, v, v])
    })
}

/// Keypoints as rings of one `radius` at their positions, coloured by
/// pyramid level: where they are, without [`overlay`]'s circles of the
/// keypoints' sizes, which cover one another on the coarse levels.
pub fn markers(gray: &Plane<u8>, kps: &[KeyPoint], radius: i64) -> RgbImage {
    let mut img = gray_rgb(gray);
    for k in kps {
        circle(&mut img, (k.pt.x.round() as i64, k.pt.y.round() as i64), radius, level_colour(k.octave));
    }
    img
}

/// The overlay as an RGB image.
pub fn overlay(gray: &Plane<u8>, kps: &[KeyPoint]) -> RgbImage {
    let mut img = gray_rgb(gray);
    for k in kps {
        let c = level_colour(k.octave);
        let centre = (k.pt.x.round() as i64, k.pt.y.round() as i64);
        let r = ((k.size / 2.0).round() as i64).max(1);
        circle(&mut img, centre, r, c);
        if k.angle >= 0.0 {
            let a = (k.angle as f64).to_radians();
            let end = (
                (k.pt.x as f64 + a.cos() * r as f64).round() as i64,
                (k.pt.y as f64 + a.sin() * r as f64).round() as i64,
            );
            line(&mut img, centre, end, c);
        }
    }
    img
}

/// [`overlay`] encoded as PNG.
pub fn overlay_png(gray: &Plane<u8>, kps: &[KeyPoint]) -> crate::Result<Vec<u8>> {
    let img = overlay(gray, kps);
    let mut buf = Vec::new();
    image::codecs::png::PngEncoder::new(&mut buf)
        .write_image(img.as_raw(), img.width(), img.height(), image::ExtendedColorType::Rgb8)
        .map_err(|source| crate::Error::Image { path: "overlay.png".into(), source })?;
    Ok(buf)
}

/// An 8-bit gray or RGB image encoded as PNG.
pub fn png(data: &[u8], w: u32, h: u32, color: image::ExtendedColorType) -> crate::Result<Vec<u8>> {
    let mut buf = Vec::new();
    image::codecs::png::PngEncoder::new(&mut buf)
        .write_image(data, w, h, color)
        .map_err(|source| crate::Error::Image { path: "image.png".into(), source })?;
    Ok(buf)
}
