//! The watchdog's stop time: the instant past which an analysis's loops stop (integration steps,
//! continuation points, Campbell speeds, response orders), and the time budget it came from, for
//! the message. The study runner sets it from each analysis's plan (`study::plan::Watchdog`); the
//! solvers only read it, so a library call without a deadline runs as before.

use std::time::Instant;

/// When a running analysis must stop, and the time budget that gave that instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Deadline {
    /// The instant past which every loop that checks it stops.
    pub at: Instant,
    /// The budget, s of wall time from the analysis's start.
    pub budget_s: f64,
}

impl Deadline {
    /// A deadline `budget_s` of wall time from now (a budget past ~30 years is taken as none
    /// reachable).
    pub fn after(budget_s: f64) -> Self {
        let far = std::time::Duration::from_secs_f64(budget_s.clamp(0.0, 1e9));
        let now = Instant::now();
        Self { at: now.checked_add(far).unwrap_or(now + std::time::Duration::from_secs(1_000_000_000)), budget_s }
    }

    /// Whether the deadline has passed.
    pub fn passed(&self) -> bool {
        Instant::now() >= self.at
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
