//! The watchdog's stop time: the point past which an analysis's loops stop (integration steps,
//! continuation points, Campbell speeds, response orders), and the time budget it came from, for
//! the message. The study runner sets it from each analysis's plan (`study::plan::Watchdog`); the
//! solvers only read it, so a library call without a deadline runs as before.
//!
//! The budget is spent only when both clocks have run through it: the wall time since the
//! deadline was set and the CPU time the process spent since then. The plan estimates CPU time,
//! so a loaded machine, which stretches wall time but not the work done, does not stop an
//! analysis that an idle machine would finish; other threads of the same process (parallel
//! tests, a caller running studies side by side), which add CPU time but not wall time, do not
//! either. A runaway computation spends CPU time, so it is still stopped, at most when the wall
//! clock too has gone through its budget. Where the process's CPU clock cannot be read, the
//! wall time alone decides.

use std::time::Instant;

/// When a running analysis must stop, and the time budget that gave that point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Deadline {
    /// The wall-clock instant before which the deadline cannot have passed.
    pub at: Instant,
    /// The budget, s of wall time and of the process's CPU time from the analysis's start.
    pub budget_s: f64,
    /// The process's CPU time, s, before which the deadline cannot have passed (NaN: the clock
    /// cannot be read, the wall time alone decides).
    cpu_at_s: f64,
}

impl Deadline {
    /// A deadline `budget_s` of wall time and of process CPU time from now (a budget past ~30
    /// years is taken as none reachable).
    pub fn after(budget_s: f64) -> Self {
        let budget = budget_s.clamp(0.0, 1e9);
        let far = std::time::Duration::from_secs_f64(budget);
        let now = Instant::now();
        let at = now.checked_add(far).unwrap_or(now + std::time::Duration::from_secs(1_000_000_000));
        Self { at, budget_s, cpu_at_s: process_cpu_s().map_or(f64::NAN, |c| c + budget) }
    }

    /// Whether the deadline has passed: its wall time has, and so has its CPU time. The CPU
    /// clock (a system call) is only read once the wall time is past.
    pub fn passed(&self) -> bool {
        let now = Instant::now();
        now >= self.at && self.passed_at(now, process_cpu_s())
    }

    /// [`Deadline::passed`] at wall instant `now` with the process's CPU time `cpu_s` (s; `None`
    /// when it cannot be read).
    pub fn passed_at(&self, now: Instant, cpu_s: Option<f64>) -> bool {
        now >= self.at && (self.cpu_at_s.is_nan() || cpu_s.is_none_or(|c| c >= self.cpu_at_s))
    }

    /// The watchdog's sentence for every stop it makes: `the analysis overran its time budget of
    /// 12.3 s` (`budget_s` in s; NaN without a deadline).
    pub fn overran(budget_s: f64) -> String {
        format!("the analysis overran its time budget of {budget_s:.1} s")
    }

    /// Whether an optional deadline has passed (`None`: never).
    pub fn passed_opt(d: Option<Deadline>) -> bool {
        d.is_some_and(|d| d.passed())
    }
}

/// The CPU time this process has spent, s (user and system, all threads); `None` where it
/// cannot be read.
pub fn process_cpu_s() -> Option<f64> {
    #[cfg(unix)]
    {
        let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
        // SAFETY: `ts` is a valid, writable timespec for the call to fill.
        let rc = unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut ts) };
        (rc == 0).then_some(ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9)
    }
    #[cfg(not(unix))]
    {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    /// Both clocks must pass: a loaded machine (wall past, CPU not) and busy sibling threads (CPU
    /// past, wall not) do not stop the analysis; a runaway (both past) does.
    #[test]
    fn the_deadline_needs_both_clocks_past() {
        let d = Deadline::after(2.0);
        let Some(cpu0) = process_cpu_s() else { return };
        let (early, late) = (d.at - Duration::from_millis(1), d.at + Duration::from_millis(1));
        // Only `d.at` and `d.cpu_at_s` are compared, so fixed readings test the rule exactly.
        assert!(!d.passed_at(late, Some(cpu0)), "wall time alone stopped it");
        assert!(!d.passed_at(early, Some(cpu0 + 10.0)), "CPU time alone stopped it");
        assert!(d.passed_at(late, Some(d.cpu_at_s)), "both past did not stop it");
        assert!(d.passed_at(late, None), "without a CPU clock the wall time decides");
        assert!(!d.passed(), "a 2 s budget passed at once");
    }
}
