//! Draws the `foxglove.ImageAnnotations` of an MCAP file written by `lfast
//! detect --format mcap --include-images` over its image, as Foxglove's Image
//! panel draws them: each circle's outline (its `thickness` in pixels, its
//! `outline_color`) of its `diameter` around its `position`, in image
//! coordinates whose origin is the top-left pixel's corner. Everything drawn
//! comes from the file's messages: the image through
//! `lfast::recording` and the circles decoded with the Foxglove SDK's schema.
//!
//! ```text
//! # docs/img/mcap_overlay.png: the bundled CC0 camera image as a 3-frame FFV1 video
//! ffmpeg -loop 1 -i tests/data/camera_cc0_v0.18plus.png -frames:v 3 -r 10 -c:v ffv1 -pix_fmt gray camera.mkv
//! cargo run --release -- detect camera.mkv --out out --format mcap --include-images --n-features 500 --backend cpu
//! cargo run --release --example mcap_overlay -- out/camera.lfast.mcap 0 docs/img/mcap_overlay.png
//! ```

use foxglove::Decode;
use foxglove::schemas::ImageAnnotations;
use lfast::recording::{Recording, Selection};
use std::io::Read;

fn fail(msg: impl std::fmt::Display) -> ! {
    eprintln!("mcap_overlay: {msg}");
    std::process::exit(1);
}

/// Every image topic's annotations topic: `TOPIC/lfast/keypoints`.
fn image_topic(annotations: &str) -> Option<&str> {
    annotations.strip_suffix("/lfast/keypoints")
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [file, frame, out] = args.as_slice() else {
        fail("usage: mcap_overlay FILE.lfast.mcap FRAME OUT.png");
    };
    let frame: u64 = frame.parse().unwrap_or_else(|_| fail(format!("`{frame}` is not a frame index")));
    let mut bytes = Vec::new();
    std::fs::File::open(file).and_then(|mut f| f.read_to_end(&mut bytes)).unwrap_or_else(|e| fail(e));
    // the annotations of frame FRAME: the FRAME-th message on the keypoints topic
    let mut found = None;
    let mut k = 0;
    for m in mcap::MessageStream::new(&bytes).unwrap_or_else(|e| fail(e)) {
        let m = m.unwrap_or_else(|e| fail(e));
        if let Some(topic) = image_topic(&m.channel.topic) {
            if k == frame {
                let a = ImageAnnotations::decode(&m.data[..]).unwrap_or_else(|e| fail(e));
                found = Some((topic.to_string(), m.log_time, a));
                break;
            }
            k += 1;
        }
    }
    let Some((topic, log_time, ann)) = found else { fail(format!("{file} has no frame {frame}")) };
    // the image of the same log time on the image topic
    let sel = Selection { topic: Some(topic.clone()), ..Selection::default() };
    let rec = Recording::open(file, &sel).unwrap_or_else(|e| fail(e));
    let packet = rec
        .map(|p| p.unwrap_or_else(|e| fail(e)))
        .find(|p| p.time_ns == log_time)
        .unwrap_or_else(|| fail(format!("no image on {topic} at {log_time} ns (written without --include-images?)")));
    let gray = packet.decode().unwrap_or_else(|e| fail(e)).image;
    let mut img = image::RgbImage::from_fn(gray.width, gray.height, |x, y| {
        let v = gray.at(x, y);
        image::Rgb([v, v, v])
    });
    for c in &ann.circles {
        let (Some(p), Some(col)) = (c.position, c.outline_color) else { continue };
        let rgb =
            image::Rgb([(col.r * 255.0).round() as u8, (col.g * 255.0).round() as u8, (col.b * 255.0).round() as u8]);
        let (r, half) = (c.diameter / 2.0, c.thickness.max(1.0) / 2.0);
        // pixels whose centres lie within the outline's band
        let (x0, x1) = ((p.x - r - half).floor().max(0.0) as u32, (p.x + r + half).ceil() as u32);
        let (y0, y1) = ((p.y - r - half).floor().max(0.0) as u32, (p.y + r + half).ceil() as u32);
        for y in y0..y1.min(img.height()) {
            for x in x0..x1.min(img.width()) {
                let d = ((x as f64 + 0.5 - p.x).powi(2) + (y as f64 + 0.5 - p.y).powi(2)).sqrt();
                if (d - r).abs() <= half {
                    img.put_pixel(x, y, rgb);
                }
            }
        }
    }
    img.save(out).unwrap_or_else(|e| fail(e));
    println!("{out}: frame {frame} of {topic} at {log_time} ns, {} circles", ann.circles.len());
}
