//! Scene overrides shared by the commands that take a scene: an environment, a sun, point
//! lights and a camera given on the command line, then the default light for a scene that still
//! has none (see `glimpse_scene::auto`).

use anyhow::{Context, Result};
use clap::Args;
use glimpse_core::Vec3;
use glimpse_scene::{Camera, Light, Scene};
use std::path::PathBuf;

#[derive(Args, Clone, Debug)]
pub struct SceneArgs {
    /// Multiplies every length of the scene (positions, motion, lights, camera) keeping the
    /// picture: the same scene in other units (0.01: centimetres read as metres).
    #[arg(long, default_value_t = 1.0, value_name = "S")]
    pub scale: f32,
    /// Pixel filter the primary samples are drawn from: box (default), tent, gaussian or
    /// pixel-centre (overrides the scene's [film] filter).
    #[arg(long, value_name = "FILTER", value_parser = parse_filter)]
    pub filter: Option<glimpse_scene::Filter>,
    /// Primary samples per pixel: the technique shades this many GBuffers, each with every
    /// pixel's next filter sample, and the images are averaged (anti-aliasing; overrides the
    /// scene's [film] samples). `pt --spp` paths are traced per primary sample.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=65536))]
    pub film_samples: Option<u32>,
    /// Environment map (equirectangular .hdr or .exr, +y up) replacing the scene's.
    #[arg(long, value_name = "FILE")]
    pub env: Option<PathBuf>,
    /// Multiplies the --env map.
    #[arg(long, default_value_t = 1.0, value_name = "S", allow_negative_numbers = true)]
    pub env_scale: f32,
    /// Adds a sun: a directional light coming FROM direction x,y,z (e.g. 1,2,1).
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_direction)]
    pub sun: Option<Vec3>,
    /// The sun's irradiance (W/m², white) on a surface facing it.
    #[arg(long, default_value_t = 3.0, value_name = "R")]
    pub sun_radiance: f32,
    /// Adds a point light: point:X,Y,Z:INTENSITY (W/sr, white); repeatable.
    #[arg(long = "light", value_name = "point:X,Y,Z:I", value_parser = parse_light)]
    pub lights: Vec<Light>,
    /// Replaces the camera: pos=X,Y,Z:target=X,Y,Z[:fov=DEGREES] (vertical field of view, default 45).
    #[arg(long, value_name = "pos=X,Y,Z:target=X,Y,Z[:fov=DEG]", value_parser = parse_camera)]
    pub camera: Option<Camera>,
}

impl SceneArgs {
    /// The overrides as the library takes them.
    pub fn overrides(&self) -> glimpse_scene::SceneOverrides {
        glimpse_scene::SceneOverrides {
            scale: self.scale,
            filter: self.filter,
            film_samples: self.film_samples,
            env: self.env.clone(),
            env_scale: self.env_scale,
            sun: self.sun,
            sun_radiance: self.sun_radiance,
            lights: self.lights.clone(),
            camera: self.camera.clone(),
        }
    }

    /// Applies the overrides, then the default light if the scene still has none (said on stderr).
    pub fn apply(&self, scene: &mut Scene) -> Result<()> {
        if self.overrides().apply(scene).map_err(anyhow::Error::msg)? {
            eprintln!("note: {}", glimpse_scene::auto::DEFAULT_LIGHT_NOTE);
        }
        Ok(())
    }
}

/// `x,y,z`, finite.
pub fn parse_vec3(s: &str) -> Result<Vec3, String> {
    let v: Vec<f32> = s
        .split(',')
        .map(|c| c.trim().parse::<f32>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("'{s}' is not x,y,z (three numbers)"))?;
    match v[..] {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok(Vec3::new(x, y, z)),
        _ => Err(format!("'{s}' is not x,y,z (three finite numbers)")),
    }
}

fn nonzero(v: Vec3, s: &str) -> Result<Vec3, String> {
    if v.length() > 0.0 { Ok(v) } else { Err(format!("'{s}': the direction must not be zero")) }
}

/// A non-zero `x,y,z` direction.
pub fn parse_direction(s: &str) -> Result<Vec3, String> {
    nonzero(parse_vec3(s)?, s)
}

/// `point:X,Y,Z:INTENSITY`.
pub fn parse_light(s: &str) -> Result<Light, String> {
    let parts: Vec<&str> = s.split(':').collect();
    let [kind, pos, intensity] = parts[..] else {
        return Err(format!("'{s}' is not point:X,Y,Z:INTENSITY"));
    };
    if kind != "point" {
        return Err(format!("'{s}': unknown light kind '{kind}' (only 'point'; use --sun for a directional light)"));
    }
    let i: f32 = intensity.parse().map_err(|_| format!("'{s}': intensity '{intensity}' is not a number"))?;
    if !(i.is_finite() && i >= 0.0) {
        return Err(format!("'{s}': intensity must be a finite number ≥ 0"));
    }
    Ok(Light::point(parse_vec3(pos)?, Vec3::splat(i)))
}

/// `pos=X,Y,Z:target=X,Y,Z[:fov=DEG]`.
pub fn parse_camera(s: &str) -> Result<Camera, String> {
    let (mut pos, mut target, mut fov) = (None, None, 45.0f32);
    for part in s.split(':') {
        let (key, value) = part.split_once('=').ok_or_else(|| format!("'{s}': '{part}' is not KEY=VALUE (pos, target, fov)"))?;
        match key {
            "pos" => pos = Some(parse_vec3(value)?),
            "target" => target = Some(parse_vec3(value)?),
            "fov" => fov = value.parse().map_err(|_| format!("'{s}': fov '{value}' is not a number of degrees"))?,
            other => return Err(format!("'{s}': unknown camera key '{other}' (pos, target, fov)")),
        }
    }
    let (Some(pos), Some(target)) = (pos, target) else {
        return Err(format!("'{s}': the camera needs pos=X,Y,Z and target=X,Y,Z"));
    };
    if !(fov > 0.0 && fov < 180.0) {
        return Err(format!("'{s}': fov must lie strictly between 0 and 180 degrees"));
    }
    nonzero(target - pos, s).map_err(|_| format!("'{s}': pos and target must differ"))?;
    if (target - pos).normalize().cross(Vec3::Y).length() < 1e-4 {
        return Err(format!("'{s}': the camera looks straight up or down; tilt the target a little"));
    }
    Ok(Camera::look_at(pos, target, Vec3::Y, fov))
}

/// Sets the size of rayon's global pool (`--threads N`); 0 keeps rayon's default (all cores).
pub fn set_threads(n: usize) -> Result<()> {
    if n > 0 {
        rayon::ThreadPoolBuilder::new().num_threads(n).build_global().context("--threads: setting up the thread pool")?;
    }
    Ok(())
}

fn parse_filter(s: &str) -> Result<glimpse_scene::Filter, String> {
    glimpse_scene::Filter::from_name(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn overrides_parse_and_reject_bad_values() {
        assert_eq!(parse_vec3("1, 2,3"), Ok(Vec3::new(1.0, 2.0, 3.0)));
        assert!(parse_vec3("1,2").is_err() && parse_vec3("1,2,nan").is_err());
        let l = parse_light("point:0,1,0:5").unwrap();
        assert_eq!((l.position, l.intensity), (Vec3::Y, Vec3::splat(5.0)));
        assert!(parse_light("spot:0,1,0:5").unwrap_err().contains("unknown light kind"));
        assert!(parse_light("point:0,1,0:-1").is_err());
        let c = parse_camera("pos=0,1,5:target=0,1,0:fov=30").unwrap();
        assert!((c.fov - 30f32.to_radians()).abs() < 1e-6 && c.position == Vec3::new(0.0, 1.0, 5.0));
        assert!(parse_camera("pos=0,1,5").unwrap_err().contains("needs pos"));
        assert!(parse_camera("pos=0,1,5:target=0,1,5").unwrap_err().contains("differ"));
        assert!(parse_camera("pos=0,1,5:target=0,0,0:fov=200").is_err());
        assert!(parse_camera("pos=0,1,5:look=0,0,0").unwrap_err().contains("unknown camera key"));
    }
}
