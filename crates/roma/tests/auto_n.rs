//! `n=auto` (ao-roma, gi-roma): n = 8 where the visible surfaces' AO rays mostly stay in the
//! scene (a closed room), the paper's 4 where they mostly leave it; `n=N` and `profile=paper`
//! keep the number.

use glimpse_render::{FrameContext, Params, Settings};
use glimpse_roma::RomaParams;
use glimpse_roma::auto::{CLOSED_ESCAPE_FRACTION, choose_n, escape_fraction};

fn read(pairs: &[&str]) -> RomaParams {
    RomaParams::with_auto_n().read(&Params::parse(pairs).unwrap(), false).unwrap()
}

#[test]
fn closed_rooms_get_more_directions_than_open_scenes() {
    assert!(read(&[]).auto_n);
    assert!(!read(&["n=6"]).auto_n && read(&["n=6"]).n == 6);
    assert!(!read(&["profile=paper"]).auto_n && read(&["profile=paper"]).n == 4);
    assert_eq!((choose_n(0.0), choose_n(CLOSED_ESCAPE_FRACTION), choose_n(1.0)), (8, 4, 4));

    // The Cornell box, open at the front, and the same box closed by a wall behind the camera.
    let open = glimpse_scene::builtin::cornell();
    let mut closed = open.clone();
    let b = closed.bounds();
    let cam = closed.camera_or_default(1.0);
    let (lo, hi) = (b.min - (b.max - b.min), b.max + (b.max - b.min));
    let z = cam.position.z + 0.1 * (cam.position.z - b.center().z).signum();
    let wall = glimpse_scene::Mesh::quad(
        "wall behind the camera",
        0,
        [
            glimpse_core::Vec3::new(lo.x, lo.y, z),
            glimpse_core::Vec3::new(hi.x, lo.y, z),
            glimpse_core::Vec3::new(hi.x, hi.y, z),
            glimpse_core::Vec3::new(lo.x, hi.y, z),
        ],
    );
    closed.add_mesh(wall, glimpse_core::Mat4::IDENTITY);
    let mut chosen = Vec::new();
    for (name, scene) in [("open", &open), ("closed", &closed)] {
        let ctx = FrameContext::new(scene, 0.0, 32, 32);
        let e = escape_fraction(&ctx.frame, &ctx.tracer, &ctx.camera, 0);
        let mut p = read(&[]);
        assert_eq!(p.resolve_n(&ctx.frame, &ctx.tracer, &ctx.camera, 0), Some(e));
        println!("{name} Cornell box: {:.1} % of AO rays escape → n = {}", 100.0 * e, p.n);
        chosen.push(p.n);
        // The technique reports its choice.
        let mut t = glimpse_roma::technique::AoRoma::new(&Settings { spp: 1, seed: 0 }, &Params::default()).unwrap();
        let stats = glimpse_render::Technique::prepare(&mut t, &ctx).unwrap();
        assert!(stats.metrics.iter().any(|(k, v)| k == "n" && *v == p.n as f64), "{:?}", stats.metrics);
    }
    assert_eq!(chosen, [4, 8]);
}
