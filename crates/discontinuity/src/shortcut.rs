//! The search's shortcuts, each a check that spares minimisations without changing a
//! switch. A test turns one off to compare the search without it, and counts the
//! minimisations each way; outside tests a shortcut is always on and counts nothing.

#[cfg(test)]
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

pub(crate) struct Shortcut {
    #[cfg(test)]
    off: AtomicBool,
    #[cfg(test)]
    minimised: AtomicUsize,
}

impl Shortcut {
    pub(crate) const fn new() -> Self {
        Shortcut {
            #[cfg(test)]
            off: AtomicBool::new(false),
            #[cfg(test)]
            minimised: AtomicUsize::new(0),
        }
    }

    /// Whether the shortcut is taken (always, but while a test has turned it off).
    #[inline(always)]
    pub(crate) fn on(&self) -> bool {
        #[cfg(test)]
        return !self.off.load(Ordering::Relaxed);
        #[cfg(not(test))]
        true
    }

    /// Counts one minimisation the shortcut did not spare (in tests).
    #[inline(always)]
    pub(crate) fn minimising(&self) {
        #[cfg(test)]
        self.minimised.fetch_add(1, Ordering::Relaxed);
    }

    /// The kinetostatic switches of the job `text` with the shortcut off, then on, and
    /// the minimisations counted each way. The switches and counts are process-wide, so
    /// one comparison runs at a time (the crate's other unit tests do not search).
    #[cfg(test)]
    pub(crate) fn both_ways(&self, text: &str) -> [(Vec<crate::Discontinuity>, usize); 2] {
        static ONE_AT_A_TIME: std::sync::Mutex<()> = std::sync::Mutex::new(());
        let _alone = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
        use clearance_grid::SampleSource;
        use clearance_model::{JobSpec, Mode};
        use clearance_solver::Model;
        let job = JobSpec::from_toml_str(text, "case.toml").unwrap();
        let (model, source) = (Model::from_job(&job), SampleSource::new(&job));
        let opts = crate::SearchOptions { dip_threshold: job.analysis.discontinuity_load_fraction * job.weight() };
        [true, false].map(|off| {
            self.off.store(off, Ordering::Relaxed);
            self.minimised.store(0, Ordering::Relaxed);
            let found = crate::find_discontinuities(&model, &source, Mode::Kinetostatic, &opts);
            self.off.store(false, Ordering::Relaxed);
            (found, self.minimised.load(Ordering::Relaxed))
        })
    }
}
