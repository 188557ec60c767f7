//! What a scene file says about how to render it (Mitsuba's film, sampler and integrator):
//! defaults the command line uses when its own flags are not given.

/// Rendering defaults from the scene file; `None` leaves the command line's default.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RenderHints {
    /// Image size, width × height.
    pub size: Option<(u32, u32)>,
    /// Samples per pixel.
    pub spp: Option<u32>,
    /// Path depth in glimpse's count of scattering vertices (`pt`'s `max_depth`: 1 = direct light
    /// only); -1 = unbounded (Russian roulette ends paths).
    pub max_depth: Option<i32>,
    /// Pixel reconstruction filter: "box", "tent" or "gaussian".
    pub filter: Option<String>,
}
