//! Runtime CPU-feature dispatch for the hot row kernels: the kernel is written
//! once as plain loops (so it reads like its shader) and compiled twice, for
//! the baseline target and with AVX2 enabled, which lets LLVM vectorise it
//! 8 or 16 lanes wide on machines that have it. No code is AVX2-only.

/// Defines `fn $name(args) -> ret` that runs `$body`, using an AVX2+FMA build
/// of it when the CPU has those features.
macro_rules! dispatch {
    ($(#[$m:meta])* $vis:vis fn $name:ident($($arg:ident : $ty:ty),* $(,)?) $(-> $ret:ty)? $body:block) => {
        $(#[$m])*
        $vis fn $name($($arg: $ty),*) $(-> $ret)? {
            #[inline(always)]
            fn inner($($arg: $ty),*) $(-> $ret)? $body
            #[cfg(target_arch = "x86_64")]
            {
                #[target_feature(enable = "avx2,fma")]
                fn avx2($($arg: $ty),*) $(-> $ret)? { inner($($arg),*) }
                if std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma") {
                    // SAFETY: the CPU has AVX2 and FMA, checked just above.
                    return unsafe { avx2($($arg),*) };
                }
            }
            inner($($arg),*)
        }
    };
}
pub(crate) use dispatch;

/// Pixels per chunk of the chunked row kernels (32 bytes: one AVX2 register of u8).
pub(crate) const CHUNK: usize = 32;

/// `r[t0..t0 + CHUNK]` as an array, so that loops over it have a constant trip count and vectorise.
#[inline(always)]
pub(crate) fn chunk<T>(r: &[T], t0: usize) -> &[T; CHUNK] {
    r[t0..t0 + CHUNK].try_into().expect("CHUNK elements")
}
