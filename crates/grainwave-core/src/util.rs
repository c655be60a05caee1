//! Small deterministic helpers.

use rayon::prelude::*;

/// Runs `f` on a worker thread of the current rayon pool (directly when already on one).
///
/// Every parallel loop started from outside the pool pays for a hand-over to a worker; a step has
/// several such loops. Entering the pool once per batch of steps removes that cost (measured: 28 %
/// of the step time for 300 grains).
pub fn in_pool<R: Send>(f: impl FnOnce() -> R + Send) -> R {
    if rayon::current_thread_index().is_some() {
        f()
    } else {
        rayon::scope(|_| f())
    }
}

/// Fixed chunk length of deterministic parallel reductions.
pub const REDUCE_CHUNK: usize = 2048;

/// Σ f(k) for k in 0..n, summed in fixed chunks so the result does not depend on the number of
/// threads (rayon's own `sum` splits work adaptively and would change the rounding).
pub fn det_sum(n: usize, f: impl Fn(usize) -> f64 + Sync + Send) -> f64 {
    let partial: Vec<f64> = (0..n.div_ceil(REDUCE_CHUNK))
        .into_par_iter()
        .map(|c| {
            let mut s = 0.0;
            for k in c * REDUCE_CHUNK..((c + 1) * REDUCE_CHUNK).min(n) {
                s += f(k);
            }
            s
        })
        .collect();
    partial.iter().sum()
}

/// max f(k) for k in 0..n (0 when n = 0); exact, hence deterministic.
pub fn det_max(n: usize, f: impl Fn(usize) -> f64 + Sync + Send) -> f64 {
    (0..n).into_par_iter().with_min_len(REDUCE_CHUNK).map(f).reduce(|| 0.0, f64::max)
}

/// 64-bit FNV-1a hash, used for bitwise state fingerprints.
#[derive(Clone, Copy, Debug)]
pub struct Fnv64(u64);

impl Default for Fnv64 {
    fn default() -> Self {
        Fnv64(0xcbf2_9ce4_8422_2325)
    }
}

impl Fnv64 {
    /// Mixes bytes in.
    pub fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 ^= b as u64;
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    /// Mixes the bit pattern of a float in.
    pub fn write_f64(&mut self, x: f64) {
        self.write(&x.to_bits().to_le_bytes());
    }
    /// The hash.
    pub fn finish(&self) -> u64 {
        self.0
    }
}

/// Whether the processor has AVX-512 F and VL. When it does not, writes
/// `skipped: CPU lacks AVX-512 F and VL: {what}` to stderr past the test harness's output capture
/// (so that `cargo test` shows it): the unit tests of the AVX-512 paths would otherwise pass
/// without having run them.
#[cfg(test)]
pub(crate) fn avx512_or_skip(what: &str) -> bool {
    #[cfg(target_arch = "x86_64")]
    let has = std::arch::is_x86_feature_detected!("avx512f") && std::arch::is_x86_feature_detected!("avx512vl");
    #[cfg(not(target_arch = "x86_64"))]
    let has = false;
    if !has {
        use std::io::Write;
        let _ = writeln!(std::io::stderr().lock(), "skipped: CPU lacks AVX-512 F and VL: {what}");
    }
    has
}
