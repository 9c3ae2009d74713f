//! The machine a run is on, and the process's memory: the only place that reads `/proc`
//! (Linux; elsewhere the figures are "unknown" and 0, never an error).

use serde::Serialize;

/// The machine the run was on.
#[derive(Clone, Debug, Serialize)]
pub struct Machine {
    /// CPU model (from /proc/cpuinfo).
    pub cpu: String,
    /// Logical cores available to the process.
    pub cores: usize,
    /// Rayon worker threads.
    pub threads: usize,
    /// Visibility backend in use (`embree` or `bvh`).
    pub backend: String,
}

impl Machine {
    /// Describe this machine; `backend` is the name of the visibility backend in use.
    pub fn detect(backend: &str) -> Machine {
        let cpu = std::fs::read_to_string("/proc/cpuinfo")
            .ok()
            .and_then(|s| {
                s.lines()
                    .find(|l| l.starts_with("model name"))
                    .and_then(|l| l.split(':').nth(1))
                    .map(|s| s.trim().to_string())
            })
            .unwrap_or_else(|| "unknown".into());
        Machine {
            cpu,
            cores: std::thread::available_parallelism().map_or(1, |n| n.get()),
            threads: rayon::current_num_threads(),
            backend: backend.to_string(),
        }
    }

    /// One line for reports.
    pub fn line(&self) -> String {
        format!(
            "CPU {}, {} cores ({} worker threads), visibility backend {}",
            self.cpu, self.cores, self.threads, self.backend
        )
    }
}

/// `(VmRSS, VmHWM)` of this process in MiB (0 where /proc is not available).
pub fn memory_mib() -> (f64, f64) {
    let s = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    let field = |name: &str| {
        s.lines()
            .find(|l| l.starts_with(name))
            .and_then(|l| l.split_whitespace().nth(1))
            .and_then(|v| v.parse::<f64>().ok())
            .map_or(0.0, |kb| kb / 1024.0)
    };
    (field("VmRSS:"), field("VmHWM:"))
}

/// Reset this process's high-water mark (VmHWM) to its current RSS (Linux: `5` written to
/// /proc/self/clear_refs). False where that is not possible.
pub fn reset_peak() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_machine_line_names_cores_and_backend() {
        let m = Machine::detect("bvh");
        assert!(m.cores >= 1 && m.threads >= 1);
        let line = m.line();
        assert!(
            line.contains("backend bvh") && line.contains(&m.cpu),
            "{line}"
        );
        let (rss, hwm) = memory_mib();
        assert!(rss >= 0.0 && hwm >= 0.0);
    }
}
