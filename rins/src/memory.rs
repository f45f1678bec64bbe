//! The allocator's settings for batches of runs.

/// Keeps freed memory in the process instead of handing it back to the
/// kernel (glibc's `mallopt`; elsewhere nothing). A Monte Carlo run
/// allocates and frees about 7 MB (its recording and trajectory); with
/// glibc's defaults the next run takes a page fault for every 4 KiB of
/// it again (measured on a five-minute rotary run: 1,800 faults, an
/// eighth of the run's time). Blocks up to 32 MB (glibc's largest
/// setting; a one-hour recording is 26 MB) come from the heap, and up to
/// 256 MB of freed heap stays mapped.
pub fn keep_freed_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: mallopt only changes two thresholds of the allocator; it
    // takes any value and reports a refused one by returning 0.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, 32 << 20);
        libc::mallopt(libc::M_TRIM_THRESHOLD, 256 << 20);
    }
}
