//! The exact tracer must agree with the every-triangle oracle on every ray: 100%, for any-hit
//! and closest-hit, on static, moving and deforming geometry.

use glimpse_core::sampling::uniform_sphere;
use glimpse_core::{Mat4, Ray, Rng, Vec3};
use glimpse_scene::{Deformation, Instance, Material, Mesh, Motion, Scene};
use glimpse_trace::{BruteForce, ClosestHit, ExactTracer, ShadowCache, Visibility};

fn random_rays(frame: &glimpse_scene::SceneFrame, n: usize, seed: u64) -> Vec<(Ray, f32)> {
    let b = frame.bounds;
    let mut rng = Rng::new(seed, 0);
    (0..n)
        .map(|i| {
            let o = b.min + (b.max - b.min) * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 1.2 - b.extent() * 0.1;
            let d = uniform_sphere(rng.next_2d());
            let t_max = if i % 3 == 0 { f32::INFINITY } else { rng.next_f32() * b.extent().length() };
            (Ray::new(o, d), t_max)
        })
        .collect()
}

/// Returns (any-hit agreement, closest-hit agreement) as fractions.
fn compare(scene: &Scene, time: f32, rays: usize) -> (f64, f64) {
    let frame = scene.at(time);
    let bvh = ExactTracer::build(&frame);
    let brute = BruteForce::new(&frame);
    let rays = random_rays(&frame, rays, 99);
    let mut any_ok = 0;
    let mut closest_ok = 0;
    for (ray, t_max) in &rays {
        any_ok += (bvh.occluded(ray, *t_max) == brute.occluded(ray, *t_max)) as usize;
        let (a, b) = (bvh.closest_hit(ray, *t_max), brute.closest_hit(ray, *t_max));
        let same = match (a, b) {
            (None, None) => true,
            // Equal triangles, or a tie in t between two triangles (shared edges), or the same
            // hit found through an instance transform (rounding differs in object space).
            (Some(a), Some(b)) => (a.instance, a.triangle) == (b.instance, b.triangle) || (a.t - b.t).abs() <= 1e-5 * a.t.max(1.0),
            _ => false,
        };
        closest_ok += same as usize;
    }
    let n = rays.len() as f64;
    // The same rays together (packets in a static scene, one by one otherwise): the oracle's.
    let mut packed = vec![false; rays.len()];
    bvh.occluded_many(&rays, &mut packed);
    let packet_wrong = rays.iter().zip(&packed).filter(|((ray, t_max), p)| brute.occluded(ray, *t_max) != **p).count();
    assert_eq!(packet_wrong, 0, "occluded_many differs from the oracle on incoherent rays");
    assert_eq!(shadow_cache_disagreements(&bvh, &brute, &frame), 0, "the shadow cache changed an answer");
    assert_eq!(closest_packet_disagreements(&bvh, &rays), 0, "closest_hits differs from closest_hit on incoherent rays");
    assert_eq!(closest_packet_disagreements(&bvh, &coherent_rays(&frame)), 0, "closest_hits differs from closest_hit on coherent rays");
    (any_ok as f64 / n, closest_ok as f64 / n)
}

/// Shadow rays as the VPL reference traces them: from one point to a cluster of nearby points,
/// sharing a [`ShadowCache`]. Returns how many answers differ from the oracle's (and prints how
/// many rays were blocked, so the remembered triangle had work to do).
fn shadow_cache_disagreements(bvh: &ExactTracer, brute: &BruteForce, frame: &glimpse_scene::SceneFrame) -> usize {
    let b = frame.bounds;
    let mut rng = Rng::new(17, 2);
    let mut point = || b.min + (b.max - b.min) * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
    let (mut wrong, mut blocked, mut rays) = (0, 0, 0);
    for bundle in 0..200 {
        let (origin, target) = (point(), point());
        let mut cache = ShadowCache::default();
        // Bundles of several sizes, so that packets come full, partial and split in two.
        let count = [32, 64, 100][bundle % 3];
        let mut segments = Vec::with_capacity(count);
        for k in 0..count {
            let jitter = Vec3::new((k % 4) as f32, ((k / 4) % 4) as f32, (k / 16) as f32) * 0.05;
            let to = target + jitter - origin;
            segments.push((Ray::new(origin, to.normalize()), to.length()));
        }
        let mut packed = vec![false; count];
        bvh.occluded_many(&segments, &mut packed);
        for ((ray, t_max), p) in segments.iter().zip(packed) {
            let cached = bvh.occluded_cached(ray, *t_max, &mut cache);
            let oracle = brute.occluded(ray, *t_max);
            wrong += (cached != oracle) as usize + (p != oracle) as usize;
            blocked += oracle as usize;
            rays += 1;
        }
    }
    println!("shadow cache and packets: {blocked} of {rays} coherent shadow rays blocked, {wrong} answers differ from the oracle");
    wrong
}

/// Rays through the same points together (`closest_hits`: packets in a static scene) against
/// each one alone: how many differ in `t` or barycentrics (bit for bit), or in the triangle,
/// other than by a tie: two triangles hit at the same distance, or within one rounding of it
/// (at a shared vertex the triangle test, which compares t·det with t_max·det, lets the first
/// one found hide the other), where the first visited wins and the packet visits in another order.
fn closest_packet_disagreements(bvh: &ExactTracer, rays: &[(Ray, f32)]) -> usize {
    let mut packed = vec![None; rays.len()];
    bvh.closest_hits(rays, &mut packed);
    let (mut wrong, mut hits, mut ties) = (0, 0, 0);
    for ((ray, t_max), p) in rays.iter().zip(packed) {
        let alone = bvh.closest_hit(ray, *t_max);
        let bits = |h: Option<glimpse_trace::Hit>| h.map(|h| h.t.to_bits());
        if bits(p) != bits(alone) {
            // A tie within rounding: capped at the farther of the two hits, the ray finds
            // nothing (the nearer one is hidden by the farther one's t_max).
            let tie = match (p, alone) {
                (Some(a), Some(b)) => (a.t - b.t).abs() <= 1e-6 * a.t.max(b.t) && bvh.closest_hit(ray, a.t.max(b.t)).is_none(),
                _ => false,
            };
            if tie {
                ties += 1;
            } else {
                wrong += 1;
            }
        } else if let (Some(a), Some(b)) = (p, alone) {
            hits += 1;
            if (a.instance, a.triangle) != (b.instance, b.triangle) {
                ties += 1;
            } else if (a.b1.to_bits(), a.b2.to_bits()) != (b.b1.to_bits(), b.b2.to_bits()) {
                wrong += 1;
            }
        }
    }
    println!("closest_hits: {hits} of {} rays hit, {ties} ties in t won by another triangle, {wrong} differ", rays.len());
    wrong
}

/// Bundles of 64 rays from one point through a small patch (a light's shadow-map tile), with
/// some sizes that split packets.
fn coherent_rays(frame: &glimpse_scene::SceneFrame) -> Vec<(Ray, f32)> {
    let b = frame.bounds;
    let mut rng = Rng::new(23, 4);
    let mut point = || b.min + (b.max - b.min) * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
    let mut rays = Vec::new();
    for bundle in 0..100 {
        let (origin, target) = (point() * 1.2, point());
        for k in 0..[64, 40, 64][bundle % 3] {
            let jitter = Vec3::new((k % 8) as f32, (k / 8) as f32, 0.0) * 0.02 * b.extent().length();
            rays.push((Ray::new(origin, target + jitter - origin), if k % 5 == 0 { 2.0 } else { f32::INFINITY }));
        }
    }
    rays
}

fn soup(n: usize, seed: u64) -> Scene {
    let mut rng = Rng::new(seed, 1);
    let mut mesh = Mesh { name: "soup".into(), ..Default::default() };
    for i in 0..n {
        let c = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 4.0;
        for _ in 0..3 {
            mesh.positions.push(c + (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5) * 0.6);
        }
        let b = 3 * i as u32;
        mesh.indices.push([b, b + 1, b + 2]);
    }
    let mut s = Scene { name: "soup".into(), ..Default::default() };
    s.add_material(Material::default());
    s.add_mesh(mesh, Mat4::IDENTITY);
    s
}

#[test]
fn static_scenes_agree_100_percent() {
    for (name, scene) in [("cornell", glimpse_scene::load("cornell").unwrap()), ("soup-5000", soup(5000, 3))] {
        let (any, closest) = compare(&scene, 0.0, 20_000);
        println!("{name}: any-hit agreement {:.4}%, closest-hit agreement {:.4}%", any * 100.0, closest * 100.0);
        assert_eq!(any, 1.0);
        assert_eq!(closest, 1.0);
    }
}

#[test]
fn moving_and_deforming_instances_agree_100_percent() {
    let mut scene = soup(2000, 5);
    // A second instance of the same mesh that spins, and a deforming copy.
    scene.instances.push(Instance {
        mesh: 0,
        motion: Motion::Orbit {
            base: Mat4::from_translation(Vec3::new(5.0, 0.0, 0.0)) * Mat4::from_scale(Vec3::new(1.0, 0.5, 2.0)),
            center: Vec3::new(7.0, 2.0, 2.0),
            axis: Vec3::new(0.3, 1.0, 0.1),
            period_s: 3.0,
            phase: 0.1,
        },
    });
    let mut wavy = scene.meshes[0].clone();
    wavy.deformation =
        Some(Deformation::Wave { amplitude: 0.3, wavelength: 1.5, period_s: 2.0, direction: Vec3::X, displacement: Vec3::Y });
    scene.meshes.push(wavy);
    scene.instances.push(Instance::fixed(1, Mat4::from_translation(Vec3::new(0.0, 0.0, 5.0))));
    let mut tracer = ExactTracer::build(&scene.at(0.0));
    for t in [0.0, 0.7, 1.9] {
        let (any, closest) = compare(&scene, t, 10_000);
        println!("t={t}: any-hit {:.4}%, closest-hit {:.4}%", any * 100.0, closest * 100.0);
        assert_eq!(any, 1.0);
        assert_eq!(closest, 1.0);
        // The per-frame update (refit + TLAS) answers like a fresh build.
        let frame = scene.at(t);
        tracer.update(&frame);
        let fresh = ExactTracer::build(&frame);
        for (ray, t_max) in random_rays(&frame, 5000, 7) {
            assert_eq!(
                tracer.closest_hit(&ray, t_max).map(|h| (h.instance, h.triangle)),
                fresh.closest_hit(&ray, t_max).map(|h| (h.instance, h.triangle))
            );
        }
    }
}

#[test]
fn bunny_from_shared_agrees_100_percent() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/scenes/stanford-bunny/stanford-bunny.obj");
    if !std::path::Path::new(path).exists() {
        println!("skipped: {path} not found (../shared is absent)");
        return;
    }
    let scene = match glimpse_scene::load(path) {
        Ok(s) => s,
        Err(e) => {
            println!("skipped: the OBJ loader could not load the bunny: {e}");
            return;
        }
    };
    let (any, closest) = compare(&scene, 0.0, 2_000);
    println!("bunny ({} triangles): any-hit {:.4}%, closest-hit {:.4}%", scene.triangle_count(), any * 100.0, closest * 100.0);
    assert_eq!(any, 1.0);
    assert_eq!(closest, 1.0);
}

/// One cosine-weighted secondary ray from each of 64 × 64 camera hits of `scene` seen by `cam`:
/// (rays that hit their own triangle again, rays, the largest origin offset).
fn secondary_self_hits(scene: &Scene, cam: &glimpse_scene::Camera, seed: u64) -> (u32, u32, f32) {
    let frame = scene.at(0.0);
    let tracer = ExactTracer::build(&frame);
    let (mut self_hits, mut total, mut largest_offset) = (0, 0, 0.0f32);
    let mut rng = Rng::new(seed, 2);
    for y in 0..64 {
        for x in 0..64 {
            let ray = cam.ray(x as f32 * 4.0 + 2.0, y as f32 * 4.0 + 2.0, 256, 256);
            let Some(hit) = tracer.closest_hit(&ray, f32::INFINITY) else { continue };
            let sp = glimpse_trace::SurfacePoint::from_hit(&frame, &ray, &hit);
            let d = glimpse_core::Frame::from_z(sp.normal).to_world(glimpse_core::sampling::cosine_hemisphere(rng.next_2d()));
            let r = sp.spawn(d);
            largest_offset = largest_offset.max((r.origin - sp.position).length());
            if let Some(h2) = tracer.closest_hit(&r, f32::INFINITY) {
                self_hits += (h2.instance == hit.instance && h2.triangle == hit.triangle) as u32;
            }
            total += 1;
        }
    }
    (self_hits, total, largest_offset)
}

#[test]
fn rays_from_surfaces_do_not_hit_their_own_triangle() {
    // At scale 10⁻³ the old offset floor (10⁻⁴ units) would be 5 % of the box; at 10³ the
    // coordinates' rounding error is a thousand times larger in absolute terms.
    for scale in [1.0, 1e-3, 1e3] {
        let mut scene = glimpse_scene::load("cornell").unwrap();
        scene.rescale(scale).unwrap();
        let (self_hits, total, _) = secondary_self_hits(&scene, &scene.camera_or_default(1.0), 1);
        println!("scale {scale}: self-intersections: {self_hits} of {total} secondary rays");
        assert_eq!(self_hits, 0);
    }
}

/// The same box 10 km and 1,000 km from the origin (coordinates whose rounding error is
/// millimetres and metres): no secondary ray hits its own triangle, and the offset stays a few
/// rounding errors, not a length of the scene: until session 25 it was 10⁻⁴ × the coordinates
/// (1 m at 10 km, half the box), and contact shadows vanished from the references of a scene
/// placed far from the origin.
#[test]
fn rays_far_from_the_origin_leave_their_triangle_by_a_few_rounding_errors() {
    for far in [1e4f32, 1e6] {
        let mut scene = glimpse_scene::load("cornell").unwrap();
        let shift = Mat4::from_translation(Vec3::new(far, 0.0, far));
        scene.instances.iter_mut().for_each(|i| i.motion = Motion::Fixed(shift * i.motion.at(0.0)));
        let mut cam = scene.camera_or_default(1.0);
        cam.position += Vec3::new(far, 0.0, far);
        cam.target += Vec3::new(far, 0.0, far);
        let (self_hits, total, largest_offset) = secondary_self_hits(&scene, &cam, 3);
        // γ₇ of the coordinates: the interpolated point's rounding-error bound.
        let bound = 7.0 * f32::EPSILON / 2.0 / (1.0 - 7.0 * f32::EPSILON / 2.0) * far * 1.001;
        println!(
            "{far:e} from the origin: {self_hits} of {total} secondary rays hit their own triangle; largest offset {largest_offset:.3e} ({:.1}× the rounding bound)",
            largest_offset / bound
        );
        assert_eq!(self_hits, 0);
        assert!(largest_offset < 10.0 * bound, "offset {largest_offset} against the bound {bound}");
    }
}

/// Points near the origin on a triangle that reaches 3,000 units out carry a rounding error of
/// about γ₇ × 3,000 ≈ 10⁻³ units, ten times the old absolute offset (10⁻⁴ · max(|p|, 1)): their
/// rays started on the wrong side of their own triangle. The offset relative to the point's
/// error scale (`Σ|bᵢ·pᵢ|`) clears it.
#[test]
fn rays_from_near_the_origin_of_a_huge_triangle_leave_it() {
    let mut mesh = Mesh { name: "huge".into(), ..Default::default() };
    // Tilted so that no coordinate of the plane is exactly representable everywhere.
    let tilt = glimpse_core::Mat3::from_rotation_x(0.37) * glimpse_core::Mat3::from_rotation_z(0.21);
    mesh.positions =
        [Vec3::new(-3000.0, 0.0, -3000.0), Vec3::new(3000.0, 0.0, -3000.0), Vec3::new(0.0, 0.0, 3000.0)].map(|v| tilt * v).to_vec();
    mesh.indices.push([0, 1, 2]);
    let mut scene = Scene { name: "huge".into(), ..Default::default() };
    scene.add_material(Material::default());
    scene.add_mesh(mesh, Mat4::IDENTITY);
    let frame = scene.at(0.0);
    let tracer = ExactTracer::build(&frame);
    let normal = tilt * Vec3::Y;
    let mut rng = Rng::new(9, 4);
    let (mut self_hits, mut total) = (0, 0);
    for _ in 0..20_000 {
        // A camera ray down onto the plane at a point within 10⁻² of the origin.
        let target = tilt * (Vec3::new(rng.next_f32() - 0.5, 0.0, rng.next_f32() - 0.5) * 0.02);
        let eye = target + (normal + tilt * Vec3::new(rng.next_f32() - 0.5, 0.0, rng.next_f32() - 0.5)) * 5.0;
        let ray = Ray::new(eye, (target - eye).normalize());
        let Some(hit) = tracer.closest_hit(&ray, f32::INFINITY) else { continue };
        let sp = glimpse_trace::SurfacePoint::from_hit(&frame, &ray, &hit);
        // Grazing and steep directions on the side the camera is.
        let d = glimpse_core::Frame::from_z(sp.normal).to_world(glimpse_core::sampling::cosine_hemisphere(rng.next_2d()));
        self_hits += tracer.occluded(&sp.spawn(d), f32::INFINITY) as u32;
        total += 1;
    }
    println!("near the origin of a 6,000-unit triangle: {self_hits} of {total} rays hit it again");
    assert!(total > 19_000);
    assert_eq!(self_hits, 0);
}
