//! Cache prefetch hints: asking the CPU to start loading memory that a
//! later loop will read, so that the cache misses of many independent
//! lookups overlap instead of following one another.

/// Asks the CPU to bring the cache line holding `value` into the cache (a
/// hint: no effect on results; nothing on other architectures).
#[inline(always)]
pub fn prefetch<T>(value: &T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch is a hint that never faults, and the pointer comes
    // from a live reference.
    unsafe {
        std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(
            (value as *const T).cast(),
        )
    };
    #[cfg(not(target_arch = "x86_64"))]
    let _ = value;
}
