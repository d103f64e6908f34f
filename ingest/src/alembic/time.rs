//! Time samplings and the choice of sample for `--frame`.
//!
//! Alembic times are seconds. A uniform or cyclic sampling repeats `times` (one cycle) every
//! `time_per_cycle` seconds; an acyclic one lists every sample's time.

/// One of the archive's time samplings.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct TimeSampling {
    /// Sample times of the first cycle (every sample for acyclic samplings); never empty.
    times: Vec<f64>,
    /// Seconds per cycle; `None` for acyclic samplings.
    time_per_cycle: Option<f64>,
}

/// The samples to blend for one time: `value = (1 − weight)·sample[lo] + weight·sample[hi]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Pick {
    pub lo: u32,
    pub hi: u32,
    pub weight: f64,
}

/// Which time to read.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum When {
    /// Every property's first sample (the default without `--frame`).
    First,
    /// Seconds.
    At(f64),
}

impl TimeSampling {
    /// A uniform (one time per cycle) or cyclic sampling.
    pub(super) fn cyclic(times: Vec<f64>, time_per_cycle: f64) -> Result<Self, String> {
        if times.is_empty() || !(time_per_cycle.is_finite() && time_per_cycle > 0.0) {
            return Err(format!("{} times per cycle of {time_per_cycle} s", times.len()));
        }
        Self::check(&times)?;
        Ok(TimeSampling { times, time_per_cycle: Some(time_per_cycle) })
    }

    /// An acyclic sampling.
    pub(super) fn acyclic(times: Vec<f64>) -> Result<Self, String> {
        Self::check(&times)?;
        let times = if times.is_empty() { vec![0.0] } else { times };
        Ok(TimeSampling { times, time_per_cycle: None })
    }

    fn check(times: &[f64]) -> Result<(), String> {
        if times.iter().any(|t| !t.is_finite()) || times.windows(2).any(|w| w[1] < w[0]) {
            return Err("sample times are not finite and increasing".into());
        }
        Ok(())
    }

    /// Seconds per frame if this sampling is uniform (one sample per cycle).
    pub(super) fn uniform_step(&self) -> Option<f64> {
        self.time_per_cycle.filter(|_| self.times.len() == 1)
    }

    /// Time of sample `index`.
    pub(super) fn time(&self, index: u32) -> f64 {
        let n = self.times.len();
        match self.time_per_cycle {
            Some(tpc) => {
                let (cycle, within) = (index as usize / n, index as usize % n);
                self.times[within] + cycle as f64 * tpc
            }
            None => self.times[(index as usize).min(n - 1)],
        }
    }

    /// The samples of a property with `count` samples to read at `when`: the last sample at or
    /// before the time and the next one, clamped to the first and last samples (held outside).
    pub(super) fn pick(&self, when: When, count: u32) -> Pick {
        let last = count.saturating_sub(1);
        let t = match when {
            When::At(t) if count > 1 => t,
            _ => return Pick { lo: 0, hi: 0, weight: 0.0 },
        };
        // A tolerance of a millionth of a second absorbs frame/fps rounding.
        const EPS: f64 = 1e-6;
        if t <= self.time(0) + EPS {
            return Pick { lo: 0, hi: 0, weight: 0.0 };
        }
        if t >= self.time(last) - EPS {
            return Pick { lo: last, hi: last, weight: 0.0 };
        }
        // Largest lo with time(lo) ≤ t (times increase with the index).
        let (mut lo, mut hi) = (0u32, last);
        while hi - lo > 1 {
            let mid = lo + (hi - lo) / 2;
            if self.time(mid) <= t + EPS {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let (t0, t1) = (self.time(lo), self.time(hi));
        if (t - t0).abs() <= EPS {
            return Pick { lo, hi: lo, weight: 0.0 };
        }
        Pick { lo, hi, weight: ((t - t0) / (t1 - t0)).clamp(0.0, 1.0) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniform_sampling_picks_and_blends() {
        // Blender at 24 fps from frame 1: sample i at (1 + i) / 24 s.
        let s = TimeSampling::cyclic(vec![1.0 / 24.0], 1.0 / 24.0).unwrap();
        assert_eq!(s.uniform_step(), Some(1.0 / 24.0));
        assert!((s.time(9) - 10.0 / 24.0).abs() < 1e-12);
        assert_eq!(s.pick(When::At(1.0 / 24.0), 10), Pick { lo: 0, hi: 0, weight: 0.0 });
        assert_eq!(s.pick(When::At(10.0 / 24.0), 10), Pick { lo: 9, hi: 9, weight: 0.0 });
        assert_eq!(s.pick(When::At(5.0 / 24.0), 10), Pick { lo: 4, hi: 4, weight: 0.0 });
        let p = s.pick(When::At(5.5 / 24.0), 10);
        assert_eq!((p.lo, p.hi), (4, 5));
        assert!((p.weight - 0.5).abs() < 1e-9);
        // Held outside the range, and a single sample is always sample 0.
        assert_eq!(s.pick(When::At(100.0), 10).lo, 9);
        assert_eq!(s.pick(When::At(-1.0), 10).lo, 0);
        assert_eq!(s.pick(When::At(5.0), 1).lo, 0);
        assert_eq!(s.pick(When::First, 10).lo, 0);
    }

    #[test]
    fn acyclic_and_cyclic_times() {
        let a = TimeSampling::acyclic(vec![0.0, 0.5, 2.0]).unwrap();
        let p = a.pick(When::At(1.25), 3);
        assert_eq!((p.lo, p.hi), (1, 2));
        assert!((p.weight - 0.5).abs() < 1e-12);
        let c = TimeSampling::cyclic(vec![0.0, 0.25], 1.0).unwrap();
        assert_eq!(c.time(3), 1.25);
        assert!(TimeSampling::cyclic(vec![], 1.0).is_err());
        assert!(TimeSampling::acyclic(vec![1.0, 0.0]).is_err());
    }
}
