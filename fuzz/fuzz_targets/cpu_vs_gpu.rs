//! CPU vs GPU (lavapipe in practice) on arbitrary tiny images: bit-identical.
//! Needs an adapter (WGPU_ADAPTER_NAME=llvmpipe); panics at start without one.
#![no_main]
use std::sync::Mutex;

static STATE: Mutex<Option<lfast_fuzz::GpuState>> = Mutex::new(None);

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let mut st = STATE.lock().unwrap_or_else(|p| p.into_inner());
    let st = st.get_or_insert_with(|| {
        let ctx = lfast::gpu::GpuContext::new(&Default::default())
            .expect("a GPU adapter (set WGPU_ADAPTER_NAME=llvmpipe)");
        lfast_fuzz::GpuState::new(ctx)
    });
    lfast_fuzz::cpu_vs_gpu(data, st);
});
