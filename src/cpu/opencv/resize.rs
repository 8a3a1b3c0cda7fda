//! `resize(INTER_LINEAR_EXACT)` for 8-bit gray (resize.cpp, `resize_bitExact`
//! with `interpolationLinear`): coefficients in 8-bit fixed point, the
//! horizontal pass in 8 fractional bits, the vertical in 16, rounded half up.

use crate::image::Plane;

/// Per destination index: source offset, weight of the next sample (/256),
/// and the range `[min, max)` that interpolates (left of it: the first
/// sample, right of it: the last).
struct Axis {
    ofs: Vec<usize>,
    c1: Vec<u32>,
    min: usize,
    max: usize,
}

fn axis(src: u32, dst: u32) -> Axis {
    let inv_scale = dst as f64 / src as f64;
    let scale = 1.0 / inv_scale;
    let (mut ofs, mut c1) = (vec![0usize; dst as usize], vec![0u32; dst as usize]);
    let (mut min, mut max) = (0usize, dst as usize);
    for d in 0..dst as usize {
        let f = scale * (d as f64 + 0.5) - 0.5;
        let i = f.floor();
        if i >= 0.0 && src > 1 {
            if i < (src - 1) as f64 {
                ofs[d] = i as usize;
                // ufixedpoint16(softdouble): cvRound(v * 256), negative -> 0
                c1[d] = ((f - i) * 256.0).round_ties_even() as u32;
            } else {
                ofs[d] = src as usize - 1;
                max = max.min(d);
            }
        } else {
            min = min.max(d + 1);
        }
    }
    Axis { ofs, c1, min, max }
}

/// One source row resized horizontally, in 8 fractional bits.
fn hline(row: &[u8], ax: &Axis, out: &mut [u32]) {
    let n = out.len();
    for (d, o) in out.iter_mut().enumerate() {
        *o = if d < ax.min {
            (row[0] as u32) << 8
        } else if d >= ax.max {
            (row[ax.ofs[n - 1]] as u32) << 8
        } else {
            let p = ax.ofs[d];
            (256 - ax.c1[d]) * row[p] as u32 + ax.c1[d] * row[p + 1] as u32
        };
    }
}

/// `cv::resize(src, (w, h), INTER_LINEAR_EXACT)`.
///
/// ```
/// let img = lfast::Plane::from_vec(4, 1, vec![0, 100, 200, 255]).unwrap();
/// let r = lfast::cpu::opencv::resize::resize_linear_exact(&img, 2, 1);
/// assert_eq!(r.data, [50, 228]); // (0 + 100) / 2, (200 + 255) / 2 rounded up
/// ```
pub fn resize_linear_exact(src: &Plane<u8>, w: u32, h: u32) -> Plane<u8> {
    let ax = axis(src.width, w);
    let ay = axis(src.height, h);
    let sw = src.width as usize;
    let row = |y: usize| &src.data[y * sw..(y + 1) * sw];
    let hl = |y: usize| {
        let mut v = vec![0u32; w as usize];
        hline(row(y), &ax, &mut v);
        v
    };
    let mut out = Plane::<u8>::new(w, h);
    let mut cache: Option<(usize, Vec<u32>, Vec<u32>)> = None;
    for d in 0..h as usize {
        let dst = &mut out.data[d * w as usize..(d + 1) * w as usize];
        if d < ay.min || d >= ay.max {
            let y = if d < ay.min { 0 } else { src.height as usize - 1 };
            for (o, v) in dst.iter_mut().zip(hl(y)) {
                *o = ((v + 128) >> 8) as u8;
            }
            continue;
        }
        let y = ay.ofs[d];
        let (r0, r1) = match cache.take() {
            Some((cy, a, b)) if cy == y => (a, b),
            Some((cy, _, b)) if cy + 1 == y => (b, hl(y + 1)),
            _ => (hl(y), hl(y + 1)),
        };
        let c1 = ay.c1[d];
        for (x, o) in dst.iter_mut().enumerate() {
            *o = ((r0[x] * (256 - c1) + r1[x] * c1 + 32768) >> 16) as u8;
        }
        cache = Some((y, r0, r1));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn by_hand() {
        // 5 -> 4: scale 1.25, f = 1.25 (d + 0.5) - 0.5 = 0.125, 1.375, 2.625, 3.875
        // weights of the next sample: 32, 96, 160, 224 (/256)
        let img = Plane::from_vec(5, 1, vec![0, 64, 128, 192, 255]).unwrap();
        let r = resize_linear_exact(&img, 4, 1);
        // 0*224 + 64*32 = 2048 -> 8; 64*160 + 128*96 = 22528 -> 88;
        // 128*96 + 192*160 = 43008 -> 168; 192*32 + 255*224 = 63264 -> 247.1 -> 247
        assert_eq!(r.data, [8, 88, 168, 247]);
    }

    #[test]
    fn identity_and_constant() {
        let img = Plane::from_vec(7, 5, (0..35u8).map(|v| v * 7).collect()).unwrap();
        assert_eq!(resize_linear_exact(&img, 7, 5).data, img.data);
        let c = Plane::from_vec(13, 11, vec![77; 143]).unwrap();
        assert!(resize_linear_exact(&c, 10, 9).data.iter().all(|&v| v == 77));
    }
}
