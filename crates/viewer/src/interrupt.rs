//! Ctrl-C (SIGINT) and SIGTERM as a request to stop, for the commands that write a file as
//! they run (`viewer sim --out`, `viewer device monitor`, `viewer gui --record`).
//!
//! By default either signal kills the process wherever it is: a run log's buffered rows are
//! lost and the file ends where the last buffer flush happened to cut it, mid-row. With
//! [`Interrupt::install`] the signal only sets a flag (the handler does nothing else, so it
//! is async-signal-safe). Each command polls it outside its tick (one atomic load), finishes
//! the row it is on, flushes, and exits with [`Interrupt::exit_code`]: 128 + the signal's
//! number, 130 for SIGINT and 143 for SIGTERM, what a shell reports for a command the signal
//! ended, so that a script tells an interrupted run from a finished one. A second signal,
//! if the clean stop hangs, ends the process at once with the signal's default action.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

/// SIGINT's number (Ctrl-C in a terminal).
pub const SIGINT: i32 = 2;
/// SIGTERM's number (`kill`, a service manager stopping the process).
pub const SIGTERM: i32 = 15;

/// Whether SIGINT or SIGTERM arrived since [`Interrupt::install`]. Cloning shares the flag.
#[derive(Clone, Debug, Default)]
pub struct Interrupt {
    requested: Arc<AtomicBool>,
    /// The number of the first signal that arrived, 0 before one has.
    signal: Arc<AtomicUsize>,
}

impl Interrupt {
    /// Replaces the default action of SIGINT and SIGTERM (end the process) by setting this
    /// flag; the second signal ends the process as the default action would. Once per process:
    /// later calls return the same flag. Where the OS has no such signals (not unix) nothing is
    /// installed and the flag never rises.
    pub fn install() -> std::io::Result<Interrupt> {
        static INSTALLED: std::sync::OnceLock<Interrupt> = std::sync::OnceLock::new();
        if let Some(installed) = INSTALLED.get() {
            return Ok(installed.clone());
        }
        let interrupt = Interrupt::default();
        #[cfg(unix)]
        for signal in [SIGINT, SIGTERM] {
            use signal_hook::flag;
            // The order matters: the second signal finds the flag already up and ends the
            // process; the first only raises it.
            flag::register_conditional_default(signal, interrupt.requested.clone())?;
            flag::register_usize(signal, interrupt.signal.clone(), signal as usize)?;
            flag::register(signal, interrupt.requested.clone())?;
        }
        Ok(INSTALLED.get_or_init(|| interrupt).clone())
    }

    /// Whether a signal arrived: an atomic load, for a loop to poll.
    pub fn requested(&self) -> bool {
        self.requested.load(Ordering::Relaxed)
    }

    /// The signal that arrived (its number), if one has.
    pub fn signal(&self) -> Option<i32> {
        if !self.requested() {
            return None;
        }
        match self.signal.load(Ordering::SeqCst) {
            0 => None,
            n => i32::try_from(n).ok(),
        }
    }

    /// The signal's name, for messages: `SIGINT`, `SIGTERM`.
    pub fn signal_name(&self) -> Option<&'static str> {
        self.signal().map(|n| match n {
            SIGINT => "SIGINT",
            SIGTERM => "SIGTERM",
            _ => "a signal",
        })
    }

    /// The exit status of a command the signal stopped: 128 + its number (130 for SIGINT,
    /// 143 for SIGTERM); `None` when no signal arrived.
    pub fn exit_code(&self) -> Option<u8> {
        self.signal().and_then(|n| u8::try_from(128 + n).ok())
    }

    /// Raises the flag as `signal` would (tests, and code that stops a run the same way).
    pub fn raise(&self, signal: i32) {
        if let Ok(n) = usize::try_from(signal) {
            let _ = self
                .signal
                .compare_exchange(0, n, Ordering::SeqCst, Ordering::SeqCst);
        }
        self.requested.store(true, Ordering::SeqCst);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exit_codes_are_128_plus_the_signal() {
        let interrupt = Interrupt::default();
        assert!(!interrupt.requested());
        assert_eq!(interrupt.exit_code(), None);
        let shared = interrupt.clone();
        interrupt.raise(SIGINT);
        assert!(shared.requested());
        assert_eq!(shared.exit_code(), Some(130));
        assert_eq!(shared.signal_name(), Some("SIGINT"));
        // The first signal is the one reported.
        interrupt.raise(SIGTERM);
        assert_eq!(shared.exit_code(), Some(130));
        let term = Interrupt::default();
        term.raise(SIGTERM);
        assert_eq!(term.exit_code(), Some(143));
    }
}
