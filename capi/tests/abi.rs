//! The C functions called as C calls them: one detector shared by two
//! threads gives the single-thread results, results are freed by one call,
//! and bad pointers come back as statuses with messages.

use lfast_capi::*;
use std::ffi::CStr;
use std::ptr;

fn last_error() -> String {
    unsafe { CStr::from_ptr(lfast_last_error()) }.to_string_lossy().into_owned()
}

/// A 96 x 80 test card: a bright square with a notch, corners for L-FAST.
fn card() -> (Vec<u8>, LfastImage) {
    let (w, h) = (96u32, 80u32);
    let mut px = vec![20u8; (w * h) as usize];
    for y in 20..60 {
        for x in 24..72 {
            if !(x > 40 && y > 40) {
                px[(y * w + x) as usize] = 220;
            }
        }
    }
    let img = LfastImage { data: px.as_ptr().cast(), width: w, height: h, stride: w as usize, format: 0 };
    (px, img)
}

/// Keypoints and descriptors of one call, copied out, and the result freed.
fn run(det: *const LfastDetector, img: &LfastImage) -> (Vec<LfastKeyPoint>, Vec<u8>) {
    let mut out: *mut LfastFeatures = ptr::null_mut();
    assert_eq!(
        unsafe { lfast_detect_and_compute(det, img, ptr::null(), &mut out) },
        LfastStatus::Ok,
        "{}",
        last_error()
    );
    let f = unsafe { &*out };
    let kps = if f.count == 0 { vec![] } else { unsafe { std::slice::from_raw_parts(f.keypoints, f.count) }.to_vec() };
    let desc =
        if f.count == 0 { vec![] } else { unsafe { std::slice::from_raw_parts(f.descriptors, 32 * f.count) }.to_vec() };
    unsafe { lfast_features_free(out) };
    (kps, desc)
}

/// A detector and an image shared by threads, as C code shares pointers.
struct Shared(*mut LfastDetector, LfastImage);
// SAFETY: the C ABI documents LfastDetector as usable from several threads at
// once, and the image's pixels are only read
unsafe impl Sync for Shared {}

#[test]
fn two_threads_on_one_detector_get_the_single_thread_results() {
    let cfg = LfastConfig { n_levels: 2, ..lfast_config_default() };
    let mut det: *mut LfastDetector = ptr::null_mut();
    assert_eq!(unsafe { lfast_detector_new(&cfg, LfastBackend::Cpu as i32, &mut det) }, LfastStatus::Ok);
    let (_px, img) = card();
    let want = run(det, &img);
    assert!(!want.0.is_empty(), "the test card has corners");
    let shared = Shared(det, img);
    std::thread::scope(|s| {
        for _ in 0..2 {
            let (shared, want) = (&shared, &want);
            s.spawn(move || {
                for _ in 0..5 {
                    assert_eq!(&run(shared.0, &shared.1), want);
                }
            });
        }
    });
    unsafe { lfast_detector_free(det) };
}

#[test]
fn bad_pointers_are_statuses_with_messages() {
    let (_px, img) = card();
    let mut out: *mut LfastFeatures = ptr::null_mut();
    let s = unsafe { lfast_detect(ptr::null(), &img, ptr::null(), &mut out) };
    assert_eq!((s, last_error().as_str()), (LfastStatus::NullPointer, "`detector` is NULL"));
    assert!(out.is_null());
    let mut det: *mut LfastDetector = ptr::null_mut();
    let s = unsafe { lfast_detector_new(ptr::null(), 7, &mut det) };
    assert_eq!(s, LfastStatus::InvalidArgument);
    assert!(last_error().contains("backend"), "{}", last_error());
    assert!(det.is_null());
    let bad = c"border = 3";
    let s = unsafe { lfast_detector_new_toml(bad.as_ptr(), 2, &mut det) };
    assert_eq!(s, LfastStatus::InvalidConfig);
    assert!(last_error().contains("`border`"), "{}", last_error());
    assert!(unsafe { lfast_detector_backend(ptr::null()) }.is_null());
}
