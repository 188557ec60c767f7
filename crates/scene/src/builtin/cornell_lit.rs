//! The Cornell box lit by every kind of light at once, so that one small scene exercises all five
//! papers (`glimpse demo`): its ceiling area light (ROMA's soft shadows, light cuts' VPLs, the
//! wavelet cache), four small point lights inside the box (the voxel array and its shadow-map
//! baselines), and a procedural sky seen through the open front (DVF), its 2° sun dim (5× the
//! sky) so the environment stays close to the low frequencies DVF assumes.

use crate::{Environment, Light, Scene};
use glimpse_core::Vec3;

pub fn cornell_lit() -> Scene {
    let mut s = super::cornell();
    s.name = "cornell-lit".into();
    // Metres, inside the 0.55 m box: four lights at mid height, off the blocks.
    for (p, c) in [
        (Vec3::new(0.12, 0.40, 0.12), Vec3::new(0.020, 0.016, 0.012)),
        (Vec3::new(0.44, 0.42, 0.14), Vec3::new(0.012, 0.016, 0.020)),
        (Vec3::new(0.15, 0.30, 0.45), Vec3::new(0.016, 0.020, 0.012)),
        (Vec3::new(0.40, 0.45, 0.50), Vec3::new(0.018, 0.018, 0.018)),
    ] {
        s.lights.push(Light::point(p, c));
    }
    s.environment = Some(Environment::procedural_sky(64, Vec3::new(0.3, 0.6, -1.0), 5.0));
    s
}
