//! The process's peak resident memory, for the report's stages: what a
//! pipeline budgets a job by.

/// The largest resident set the process has had so far, in bytes
/// (`getrusage`'s `ru_maxrss`); none where the system does not say.
/// It only grows: a stage's value above the one before it is that stage's
/// new peak; in a batch it includes the assets run before in the process.
pub fn peak_resident_bytes() -> Option<u64> {
    #[cfg(target_os = "linux")]
    {
        // SAFETY: getrusage writes one rusage into the zeroed struct we own.
        let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
        let ok = unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut usage) } == 0;
        // Linux gives kibibytes.
        (ok && usage.ru_maxrss > 0).then(|| usage.ru_maxrss as u64 * 1024)
    }
    #[cfg(not(target_os = "linux"))]
    {
        None
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_peak_grows_with_what_the_process_holds() {
        let Some(before) = super::peak_resident_bytes() else {
            return;
        };
        // More than the peak so far, every page written: resident at once.
        let size = before as usize + (64 << 20);
        let block = vec![1u8; size];
        assert!(block.iter().step_by(4096).all(|&b| b == 1));
        let after = super::peak_resident_bytes().unwrap();
        assert!(after >= size as u64, "{before} -> {after}, held {size}");
    }
}
