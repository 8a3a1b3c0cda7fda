//! Runtime CPU-feature dispatch for the hot row kernels: the kernel is written
//! once as plain loops (so it reads like its shader) and compiled twice, for
//! the baseline target and with AVX2 enabled, which lets LLVM vectorise it
//! 8 or 16 lanes wide on machines that have it. No code is AVX2-only.

/// Defines `fn $name(args) -> ret` that runs `$body`, using an AVX2+FMA build
/// of it (with the bit instructions every AVX2 CPU has: `popcnt`, `lzcnt`,
/// BMI1/2, so that `count_ones` and friends are one instruction) when the CPU
/// has those features.
macro_rules! dispatch {
    ($(#[$m:meta])* $vis:vis fn $name:ident($($arg:ident : $ty:ty),* $(,)?) $(-> $ret:ty)? $body:block) => {
        $crate::cpu::simd::dispatch! {
            $(#[$m])* $vis fn $name<const _AVX2>($($arg: $ty),*) $(-> $ret)? $body
        }
    };
    // `fn name<const FLAG>(..)`: the body sees `FLAG`, true in the AVX2 build
    // only, to call hand-written AVX2 code (`#[target_feature(enable = "avx2")]`
    // functions inline into that build).
    ($(#[$m:meta])* $vis:vis fn $name:ident<const $flag:ident>($($arg:ident : $ty:ty),* $(,)?) $(-> $ret:ty)? $body:block) => {
        $(#[$m])*
        $vis fn $name($($arg: $ty),*) $(-> $ret)? {
            #[inline(always)]
            fn inner<const $flag: bool>($($arg: $ty),*) $(-> $ret)? $body
            #[cfg(target_arch = "x86_64")]
            {
                #[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
                fn avx2($($arg: $ty),*) $(-> $ret)? { inner::<true>($($arg),*) }
                if $crate::cpu::simd::has_avx2() {
                    // SAFETY: the CPU has these features, checked just above.
                    return unsafe { avx2($($arg),*) };
                }
            }
            inner::<false>($($arg),*)
        }
    };
}
pub(crate) use dispatch;

/// Whether the CPU has what [`dispatch!`]'s fast build is compiled for: AVX2,
/// FMA, `popcnt`, `lzcnt`, BMI1 and BMI2 (each detection is cached by std).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(crate) fn has_avx2() -> bool {
    std::is_x86_feature_detected!("avx2")
        && std::is_x86_feature_detected!("fma")
        && std::is_x86_feature_detected!("popcnt")
        && std::is_x86_feature_detected!("lzcnt")
        && std::is_x86_feature_detected!("bmi1")
        && std::is_x86_feature_detected!("bmi2")
}

/// Pixels per chunk of the chunked row kernels (32 bytes: one AVX2 register of u8).
pub(crate) const CHUNK: usize = 32;

/// `r[t0..t0 + CHUNK]` as an array, so that loops over it have a constant trip count and vectorise.
#[inline(always)]
pub(crate) fn chunk<T>(r: &[T], t0: usize) -> &[T; CHUNK] {
    r[t0..t0 + CHUNK].try_into().expect("CHUNK elements")
}

/// Starts of the CHUNK-wide windows that cover `x0..x1` (`x1 - x0 >= CHUNK`):
/// every CHUNK from `x0`, and a last one ending at `x1` that overlaps its
/// predecessor (kernels whose output depends only on their input rewrite the
/// same values there).
#[inline]
pub(crate) fn chunk_starts(x0: usize, x1: usize) -> ChunkStarts {
    debug_assert!(x1 >= x0 + CHUNK, "chunk_starts: {x0}..{x1} is narrower than a chunk");
    ChunkStarts { next: Some(x0), last: x1 - CHUNK }
}

/// The iterator of [`chunk_starts`] (one compare per step, cheaper in the row
/// kernels than a chained `step_by`).
pub(crate) struct ChunkStarts {
    next: Option<usize>,
    last: usize,
}

impl Iterator for ChunkStarts {
    type Item = usize;

    #[inline(always)]
    fn next(&mut self) -> Option<usize> {
        let t = self.next?.min(self.last);
        self.next = (t < self.last).then_some(t + CHUNK);
        Some(t)
    }
}

/// Bit j set where `c[j] == value`: two 16-byte compares and movemasks
/// (SSE2, every x86-64 has it), or a plain loop elsewhere.
#[inline(always)]
pub(crate) fn eq_bits(c: &[u8; CHUNK], value: u8) -> u32 {
    #[cfg(all(target_arch = "x86_64", target_feature = "sse2"))]
    {
        use std::arch::x86_64::{__m128i, _mm_cmpeq_epi8, _mm_loadu_si128, _mm_movemask_epi8, _mm_set1_epi8};
        // SAFETY: the cfg guarantees SSE2, all these intrinsics need; the two
        // unaligned 16-byte loads read c[0..16] and c[16..32], in bounds.
        unsafe {
            let v = _mm_set1_epi8(value as i8);
            let a = _mm_loadu_si128(c.as_ptr().cast::<__m128i>());
            let b = _mm_loadu_si128(c.as_ptr().add(16).cast::<__m128i>());
            let lo = _mm_movemask_epi8(_mm_cmpeq_epi8(a, v)) as u32 & 0xffff;
            let hi = _mm_movemask_epi8(_mm_cmpeq_epi8(b, v)) as u32 & 0xffff;
            lo | hi << 16
        }
    }
    #[cfg(not(all(target_arch = "x86_64", target_feature = "sse2")))]
    {
        let mut bits = 0u32;
        for (j, &v) in c.iter().enumerate() {
            bits |= ((v == value) as u32) << j;
        }
        bits
    }
}

/// Calls `f(x)` for each `x` with `v[x] == value`, in order, 32 bytes per
/// compare (rows of classes are mostly other values).
#[inline]
pub(crate) fn for_each_eq(v: &[u8], value: u8, mut f: impl FnMut(usize)) {
    let mut x = 0;
    while x + CHUNK <= v.len() {
        let mut bits = eq_bits(chunk(v, x), value);
        while bits != 0 {
            f(x + bits.trailing_zeros() as usize);
            bits &= bits - 1;
        }
        x += CHUNK;
    }
    for (k, &b) in v[x..].iter().enumerate() {
        if b == value {
            f(x + k);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chunk_starts_cover_the_range_and_end_at_its_end() {
        for (x0, x1) in [(0, 32), (1, 33), (0, 64), (5, 70), (3, 100)] {
            let starts: Vec<usize> = chunk_starts(x0, x1).collect();
            assert_eq!((starts[0], *starts.last().unwrap() + CHUNK), (x0, x1));
            assert!(starts.windows(2).all(|p| p[0] < p[1] && p[1] <= p[0] + CHUNK), "{starts:?}");
        }
    }

    #[test]
    fn eq_bits_and_for_each_eq_find_every_match() {
        for len in [0usize, 1, 31, 32, 33, 64, 100] {
            let v: Vec<u8> = (0..len).map(|i| [2u8, 0, 255, 2, 1, 130, 0x82, 3][(i * 7 + i / 3) % 8]).collect();
            for value in [0u8, 2, 255, 0x82] {
                let mut got = vec![];
                for_each_eq(&v, value, |x| got.push(x));
                let want: Vec<usize> = (0..len).filter(|&i| v[i] == value).collect();
                assert_eq!(got, want, "len {len} value {value}");
            }
        }
    }
}
