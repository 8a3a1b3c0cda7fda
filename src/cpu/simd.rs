//! Runtime CPU-feature dispatch for the hot row kernels: the kernel is written
//! once as plain loops (so it reads like its shader) and compiled three times,
//! for the baseline target, with AVX2 and with AVX-512 enabled, which lets
//! LLVM vectorise it 8, 16 or 32 lanes wide on machines that have them. No
//! code is AVX2- or AVX-512-only, and every build computes the same integers
//! and the same f32 operations in the same order: the outputs are bit-identical
//! whichever runs (`simd::tests::every_tier_gives_the_same_features`).

use std::sync::atomic::{AtomicU8, Ordering};

/// Defines `fn $name(args) -> ret` that runs `$body`, using the build of it
/// for the [`tier`] this process runs: AVX-512 (x86-64-v4: F, BW, CD, DQ,
/// VL) or AVX2+FMA, each with the bit instructions every such CPU has
/// (`popcnt`, `lzcnt`, BMI1/2, so that `count_ones` and friends are one
/// instruction), else the baseline.
macro_rules! dispatch {
    ($(#[$m:meta])* $vis:vis fn $name:ident($($arg:ident : $ty:ty),* $(,)?) $(-> $ret:ty)? $body:block) => {
        $crate::cpu::simd::dispatch! {
            $(#[$m])* $vis fn $name<const _AVX2>($($arg: $ty),*) $(-> $ret)? $body
        }
    };
    // `fn name<const FLAG>(..)`: the body sees `FLAG`, true in the AVX2 and
    // AVX-512 builds only, to call hand-written AVX2 code
    // (`#[target_feature(enable = "avx2")]` functions inline into both).
    ($(#[$m:meta])* $vis:vis fn $name:ident<const $flag:ident>($($arg:ident : $ty:ty),* $(,)?) $(-> $ret:ty)? $body:block) => {
        $crate::cpu::simd::dispatch! {
            @up_to Avx512 $(#[$m])* $vis fn $name<const $flag>($($arg: $ty),*) $(-> $ret)? $body
        }
    };
    // `@up_to TIER`: the builds up to that tier run ([`dispatch_avx2!`]).
    (@up_to $max:ident $(#[$m:meta])* $vis:vis fn $name:ident<const $flag:ident>($($arg:ident : $ty:ty),* $(,)?) $(-> $ret:ty)? $body:block) => {
        $(#[$m])*
        $vis fn $name($($arg: $ty),*) $(-> $ret)? {
            #[inline(always)]
            fn inner<const $flag: bool>($($arg: $ty),*) $(-> $ret)? $body
            #[cfg(target_arch = "x86_64")]
            {
                #[target_feature(enable = "avx512f,avx512bw,avx512cd,avx512dq,avx512vl,avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
                fn avx512($($arg: $ty),*) $(-> $ret)? { inner::<true>($($arg),*) }
                #[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
                fn avx2($($arg: $ty),*) $(-> $ret)? { inner::<true>($($arg),*) }
                match $crate::cpu::simd::tier().min($crate::cpu::simd::Tier::$max) {
                    // SAFETY: the CPU has these features (`tier` never exceeds `detected_tier`).
                    $crate::cpu::simd::Tier::Avx512 => return unsafe { avx512($($arg),*) },
                    // SAFETY: as above.
                    $crate::cpu::simd::Tier::Avx2 => return unsafe { avx2($($arg),*) },
                    $crate::cpu::simd::Tier::Baseline => {}
                }
            }
            inner::<false>($($arg),*)
        }
    };
}
pub(crate) use dispatch;

/// [`dispatch!`] without the AVX-512 build, for kernels whose AVX-512 build
/// measured slower than their AVX2 one: the AVX-512 tier runs the AVX2 build.
macro_rules! dispatch_avx2 {
    ($(#[$m:meta])* $vis:vis fn $name:ident<const $flag:ident>($($arg:ident : $ty:ty),* $(,)?) $(-> $ret:ty)? $body:block) => {
        $crate::cpu::simd::dispatch! {
            @up_to Avx2 $(#[$m])* $vis fn $name<const $flag>($($arg: $ty),*) $(-> $ret)? $body
        }
    };
}
pub(crate) use dispatch_avx2;

/// The builds of a [`dispatch!`] kernel, in order.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Tier {
    /// The target's baseline (SSE2 on x86-64).
    Baseline = 1,
    /// AVX2, FMA, `popcnt`, `lzcnt`, BMI1, BMI2.
    Avx2 = 2,
    /// The AVX2 tier's features and AVX-512 F, BW, CD, DQ and VL (x86-64-v4).
    Avx512 = 3,
}

impl Tier {
    /// The tiers, in order.
    pub const ALL: [Tier; 3] = [Tier::Baseline, Tier::Avx2, Tier::Avx512];

    /// Its name, as `LFAST_SIMD` and `lfast info` spell it.
    pub fn name(self) -> &'static str {
        match self {
            Tier::Baseline => "baseline",
            Tier::Avx2 => "avx2",
            Tier::Avx512 => "avx512",
        }
    }

    /// The tier named `s` ([`Tier::name`]), if any.
    pub fn from_name(s: &str) -> Option<Tier> {
        Tier::ALL.into_iter().find(|t| t.name() == s)
    }
}

/// The tier the kernels run, as a `Tier` number; 0 until first read.
static TIER: AtomicU8 = AtomicU8::new(0);

/// The best tier this CPU has.
pub fn detected_tier() -> Tier {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::is_x86_feature_detected as has;
        let avx2 = has!("avx2") && has!("fma") && has!("popcnt") && has!("lzcnt") && has!("bmi1") && has!("bmi2");
        let avx512 = has!("avx512f") && has!("avx512bw") && has!("avx512cd") && has!("avx512dq") && has!("avx512vl");
        if avx2 && avx512 {
            return Tier::Avx512;
        }
        if avx2 {
            return Tier::Avx2;
        }
    }
    Tier::Baseline
}

/// The tier the kernels run: the CPU's best, at most the one the
/// environment variable `LFAST_SIMD` names (`baseline`, `avx2`, `avx512`;
/// read once), to compare the builds' speed or to rule one out.
#[inline(always)]
pub fn tier() -> Tier {
    match TIER.load(Ordering::Relaxed) {
        3 => Tier::Avx512,
        2 => Tier::Avx2,
        1 => Tier::Baseline,
        _ => {
            let cap = std::env::var("LFAST_SIMD").ok().and_then(|v| Tier::from_name(&v)).unwrap_or(Tier::Avx512);
            let t = detected_tier().min(cap);
            TIER.store(t as u8, Ordering::Relaxed);
            t
        }
    }
}

/// Runs the kernels at `t` (at most the CPU's best) from now on, in every
/// thread, and returns the tier set: the tests compare the tiers' outputs
/// (which are equal, so tests running meanwhile are not disturbed).
#[cfg(test)]
pub(crate) fn set_tier(t: Tier) -> Tier {
    let t = detected_tier().min(t);
    TIER.store(t as u8, Ordering::Relaxed);
    t
}

/// Pixels per chunk of the chunked row kernels (32 bytes: one AVX2 register of u8).
pub(crate) const CHUNK: usize = 32;

/// `r[t0..t0 + CHUNK]` as an array, so that loops over it have a constant trip count and vectorise.
#[inline(always)]
pub(crate) fn chunk<T>(r: &[T], t0: usize) -> &[T; CHUNK] {
    chunk_n::<CHUNK, T>(r, t0)
}

/// [`chunk`] of `N` elements (kernels whose AVX-512 build takes 64 pixels a step).
#[inline(always)]
pub(crate) fn chunk_n<const N: usize, T>(r: &[T], t0: usize) -> &[T; N] {
    r[t0..t0 + N].try_into().expect("N elements")
}

/// Starts of the CHUNK-wide windows that cover `x0..x1` (`x1 - x0 >= CHUNK`):
/// every CHUNK from `x0`, and a last one ending at `x1` that overlaps its
/// predecessor (kernels whose output depends only on their input rewrite the
/// same values there).
#[inline]
pub(crate) fn chunk_starts(x0: usize, x1: usize) -> ChunkStarts {
    chunk_starts_n::<CHUNK>(x0, x1)
}

/// [`chunk_starts`] for windows `N` wide (`x1 - x0 >= N`).
#[inline]
pub(crate) fn chunk_starts_n<const N: usize>(x0: usize, x1: usize) -> ChunkStarts<N> {
    debug_assert!(x1 >= x0 + N, "chunk_starts: {x0}..{x1} is narrower than a chunk");
    ChunkStarts { next: Some(x0), last: x1 - N }
}

/// The iterator of [`chunk_starts`] (one compare per step, cheaper in the row
/// kernels than a chained `step_by`).
pub(crate) struct ChunkStarts<const N: usize = CHUNK> {
    next: Option<usize>,
    last: usize,
}

impl<const N: usize> Iterator for ChunkStarts<N> {
    type Item = usize;

    #[inline(always)]
    fn next(&mut self) -> Option<usize> {
        let t = self.next?.min(self.last);
        self.next = (t < self.last).then_some(t + N);
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

    /// Features of every image at every tier this CPU has (and, as the
    /// builds are selected per process, the baseline and AVX2 builds on an
    /// AVX-512 machine): bit-identical keypoints and descriptors, in four
    /// configs, with and without a mask, on sizes around the 16-, 32- and
    /// 64-byte vector widths, and the colour conversion of a colour file.
    #[test]
    fn every_tier_gives_the_same_features() {
        use crate::cpu::CpuDetector;
        use crate::image::Plane;
        use crate::{Config, DescriptorKind, Mode};
        let data = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/");
        let mut images: Vec<Plane<u8>> = ["coins.png", "text.png", "astronaut_256.png"]
            .iter()
            .map(|f| crate::image::load_gray(format!("{data}{f}")).expect("test image"))
            .collect();
        // blocks on a ramp with noise, at widths around the vector sizes
        let mut r = crate::rng::SplitMix64::new(5);
        for (w, h) in [(97u32, 80u32), (127, 65), (193, 71), (321, 49)] {
            let blocks: Vec<[u64; 5]> = (0..12).map(|_| std::array::from_fn(|_| r.next_u64())).collect();
            let data = (0..w * h)
                .map(|i| {
                    let (x, y) = ((i % w) as u64, (i / w) as u64);
                    let mut v = (x * 200 / w as u64) as u8 / 2 + (r.next_u64() % 9) as u8;
                    for b in &blocks {
                        if (b[0] % w as u64..b[0] % w as u64 + 5 + b[2] % 40).contains(&x)
                            && (b[1] % h as u64..b[1] % h as u64 + 5 + b[3] % 30).contains(&y)
                        {
                            v = b[4] as u8;
                        }
                    }
                    v
                })
                .collect();
            images.push(Plane::from_vec(w, h, data).expect("plane size"));
        }
        let configs = [
            Config::default(),
            Config::paper(),
            Config { mode: Mode::Branch, snap_radius: 1, ..Config::default() },
            Config {
                descriptor: DescriptorKind::Opencv,
                n_features: 300,
                distribution: true,
                fill_fast_ini: 20,
                fill_fast_min: 7,
                snap_radius: 1,
                ..Config::default()
            },
        ];
        let run = || {
            let colour = crate::image::load_gray(format!("{data}astronaut_256.png")).expect("colour image");
            let mut out = vec![format!("{:?}", colour.data)];
            for cfg in &configs {
                let det = CpuDetector::new(cfg.clone()).expect("valid config");
                for img in &images {
                    let mask = Plane::from_vec(
                        img.width,
                        img.height,
                        (0..img.width * img.height).map(|i| (i % 7 != 0) as u8).collect(),
                    )
                    .expect("mask size");
                    for m in [None, Some(mask.view())] {
                        let (kps, desc) = det.detect_and_compute(img.view(), m).expect("features");
                        let bits: Vec<_> = kps
                            .iter()
                            .map(|k| {
                                (
                                    k.pt.x.to_bits(),
                                    k.pt.y.to_bits(),
                                    k.size.to_bits(),
                                    k.angle.to_bits(),
                                    k.response.to_bits(),
                                    k.octave,
                                    k.class_id,
                                )
                            })
                            .collect();
                        out.push(format!("{bits:?} {desc:?}"));
                    }
                }
            }
            out
        };
        let best = detected_tier();
        let want = {
            set_tier(Tier::Baseline);
            run()
        };
        assert!(want.iter().skip(1).any(|f| f.len() > 1000), "the images have features");
        for t in [Tier::Avx2, Tier::Avx512].into_iter().filter(|&t| t <= best) {
            assert_eq!(set_tier(t), t);
            let got = run();
            for (i, (g, w)) in got.iter().zip(&want).enumerate() {
                assert!(g == w, "tier {t:?} differs from the baseline build in case {i}");
            }
        }
        set_tier(best);
    }

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
