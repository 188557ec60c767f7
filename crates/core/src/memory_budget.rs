//! The memory budget: before a big allocation (the frame's GBuffer and images, a procedural
//! mesh, the BVH over a scene) glimpse estimates its size and refuses, with one error naming the
//! size and the budget, when it would not fit — instead of aborting half-way with "memory
//! allocation failed" (status 134) or being killed by the OOM killer.
//!
//! The budget is the process's setting (`--max-memory`, [`set_budget`]), else the machine's
//! available memory (`MemAvailable` in /proc/meminfo, read once), else unlimited where that is
//! unknown. The estimates are conservative sums of the buffers' element sizes, documented at
//! each constant; they are not measurements.

use std::sync::OnceLock;
use std::sync::atomic::{AtomicU64, Ordering};

/// Bytes per pixel of a frame: the GBuffer (position, normal, shading normal, albedo, emission,
/// view direction: 6 × 12 B; depth, material, instance: 3 × 4 B; uv: 8 B = 92 B) plus six RGB
/// f32 images (technique, reference, error maps, tone-mapped copies: 6 × 12 B = 72 B).
pub const FRAME_BYTES_PER_PIXEL: u64 = 92 + 72;

/// Bytes per mesh vertex: position, normal (12 B each), uv (8 B), and their world-space copies
/// in the scene frame (24 B).
pub const BYTES_PER_VERTEX: u64 = 56;

/// Bytes per triangle: indices (12 B), the BVH's triangle copy and reference (~48 B) and its
/// share of nodes (~32 B × 2 nodes per leaf of ≤ 4 triangles, rounded up to 40 B).
pub const BYTES_PER_TRIANGLE: u64 = 100;

static BUDGET: AtomicU64 = AtomicU64::new(0);

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{what} needs about {} but the memory budget is {} ({source_of_budget}); use a smaller size or raise --max-memory", human(*.bytes), human(*.budget))]
pub struct BudgetError {
    pub what: String,
    pub bytes: u64,
    pub budget: u64,
    pub source_of_budget: &'static str,
}

/// Sets the budget for this process (0: back to the machine's available memory).
pub fn set_budget(bytes: u64) {
    BUDGET.store(bytes, Ordering::Relaxed);
}

/// The budget in bytes and where it comes from.
pub fn budget() -> (u64, &'static str) {
    match BUDGET.load(Ordering::Relaxed) {
        0 => match available_memory() {
            Some(b) => (b, "the machine's available memory"),
            None => (u64::MAX, "unknown available memory"),
        },
        b => (b, "--max-memory"),
    }
}

/// `MemAvailable` from /proc/meminfo (read once per process), or `None` where there is none.
pub fn available_memory() -> Option<u64> {
    static AVAILABLE: OnceLock<Option<u64>> = OnceLock::new();
    *AVAILABLE.get_or_init(|| {
        let text = std::fs::read_to_string("/proc/meminfo").ok()?;
        let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
        let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
        Some(kib * 1024)
    })
}

/// Refuses `bytes` for `what` when it exceeds the budget.
pub fn check(what: impl Into<String>, bytes: u64) -> Result<(), BudgetError> {
    let (budget, source_of_budget) = budget();
    if bytes > budget { Err(BudgetError { what: what.into(), bytes, budget, source_of_budget }) } else { Ok(()) }
}

/// The frame of a `width` × `height` image ([`FRAME_BYTES_PER_PIXEL`]).
pub fn check_frame(width: u32, height: u32) -> Result<(), BudgetError> {
    let bytes = width as u64 * height as u64 * FRAME_BYTES_PER_PIXEL;
    check(format!("a {width}x{height} frame (GBuffer and images)"), bytes)
}

/// A mesh of `vertices` and `triangles`, with its share of the BVH.
pub fn check_mesh(what: impl Into<String>, vertices: u64, triangles: u64) -> Result<(), BudgetError> {
    check(what, vertices.saturating_mul(BYTES_PER_VERTEX).saturating_add(triangles.saturating_mul(BYTES_PER_TRIANGLE)))
}

/// Parses a size such as `512M`, `8G`, `1.5GiB` or `1000000` (bytes; K/M/G/T are powers of 1024).
pub fn parse_bytes(s: &str) -> Result<u64, String> {
    let t = s.trim();
    let split = t.find(|c: char| c.is_ascii_alphabetic()).unwrap_or(t.len());
    let (number, unit) = t.split_at(split);
    let value: f64 = number.trim().parse().map_err(|_| format!("'{s}' is not a size (use e.g. 512M or 8G)"))?;
    let scale: u64 = match unit.trim().to_ascii_lowercase().trim_end_matches("ib").trim_end_matches('b') {
        "" => 1,
        "k" => 1 << 10,
        "m" => 1 << 20,
        "g" => 1 << 30,
        "t" => 1 << 40,
        _ => return Err(format!("'{s}': unknown unit '{unit}' (use K, M, G or T)")),
    };
    let bytes = value * scale as f64;
    if !bytes.is_finite() || bytes < 1.0 || bytes > u64::MAX as f64 {
        return Err(format!("'{s}' must be a positive size"));
    }
    Ok(bytes as u64)
}

/// `12.3 GiB`, `512.0 MiB`, `900 B`.
pub fn human(bytes: u64) -> String {
    const UNITS: [&str; 5] = ["B", "KiB", "MiB", "GiB", "TiB"];
    let mut v = bytes as f64;
    let mut u = 0;
    while v >= 1024.0 && u < UNITS.len() - 1 {
        v /= 1024.0;
        u += 1;
    }
    if u == 0 { format!("{bytes} B") } else { format!("{v:.1} {}", UNITS[u]) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse_and_print() {
        assert_eq!(parse_bytes("512M"), Ok(512 << 20));
        assert_eq!(parse_bytes("8G"), Ok(8 << 30));
        assert_eq!(parse_bytes("1.5GiB"), Ok(3 << 29));
        assert_eq!(parse_bytes("1000"), Ok(1000));
        assert!(parse_bytes("0").is_err() && parse_bytes("12Q").is_err() && parse_bytes("lots").is_err());
        assert_eq!(human(22_548_578_304), "21.0 GiB");
    }

    #[test]
    fn the_16384_squared_frame_is_refused_under_a_small_budget() {
        // The only test in this crate that sets the budget (it is process-wide).
        set_budget(1 << 30);
        let e = check_frame(16384, 16384).unwrap_err();
        println!("{e}");
        assert!(e.to_string().contains("16384x16384") && e.to_string().contains("41.0 GiB") && e.to_string().contains("1.0 GiB"));
        assert!(check_frame(512, 512).is_ok());
        assert!(check_mesh("quad", 4097 * 4097, 2 * 4096 * 4096).is_err());
        set_budget(0);
        println!("available memory: {:?}", available_memory().map(human));
    }
}
