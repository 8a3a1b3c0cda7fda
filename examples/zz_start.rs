use lfast::gpu::context::{GpuContext, GpuOptions};
fn main() {
    let t0 = std::time::Instant::now();
    let img = lfast::image::load_gray("/work/shared/data/kitti/seq01_000000-000050/image_0/000000.png").unwrap();
    let small = lfast::Plane::<u8>::new(64, 48);
    let ctx = GpuContext::new(&GpuOptions::default()).unwrap();
    let t1 = t0.elapsed();
    let det = lfast::gpu::GpuDetector::new(ctx, lfast::Config::default()).unwrap();
    let t2 = t0.elapsed();
    let mut ws2 = None;
    det.detect_and_compute(&mut ws2, small.view(), None).unwrap();
    let t3 = t0.elapsed();
    det.detect_and_compute(&mut ws2, small.view(), None).unwrap();
    let t3b = t0.elapsed();
    let mut ws = None;
    det.detect_and_compute(&mut ws, img.view(), None).unwrap();
    let t4 = t0.elapsed();
    det.detect_and_compute(&mut ws, img.view(), None).unwrap();
    let t5 = t0.elapsed();
    println!(
        "ctx {:?} pipelines {:?} small1 {:?} small2 {:?} kitti1 {:?} kitti2 {:?}",
        t1,
        t2 - t1,
        t3 - t2,
        t3b - t3,
        t4 - t3b,
        t5 - t4
    );
}
