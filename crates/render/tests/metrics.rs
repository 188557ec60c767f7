//! Tests of the image metrics (`glimpse_render::metrics`). Every test prints what it measured
//! before asserting. They sit in `mod metrics` so `cargo test -p glimpse-render metrics` runs them.

mod metrics {
    use glimpse_core::{Image, ToneMap, Vec3};
    use glimpse_render::metrics::*;
    use std::path::Path;
    use std::process::Command;

    /// A deterministic hash in [0,1).
    fn hash(x: u32, y: u32, seed: u32) -> f32 {
        let mut h = x.wrapping_mul(0x8da6_b343) ^ y.wrapping_mul(0xd816_3841) ^ seed.wrapping_mul(0xcb1a_b31f);
        h ^= h >> 13;
        h = h.wrapping_mul(0x5bd1_e995);
        h ^= h >> 15;
        (h >> 8) as f32 / (1u32 << 24) as f32
    }

    /// A smooth LDR image with some texture, values in [0.05, 0.95].
    fn ldr_image(w: u32, h: u32) -> Image {
        Image::from_fn(w, h, |x, y| {
            let (u, v) = (x as f32 / w as f32, y as f32 / h as f32);
            let t = 0.1 * (hash(x / 3, y / 3, 7) - 0.5);
            Vec3::new(0.2 + 0.6 * u + t, 0.5 + 0.3 * (6.0 * v).sin() * u, 0.3 + 0.4 * v - t).clamp(Vec3::splat(0.05), Vec3::splat(0.95))
        })
    }

    /// An HDR "render": a lit gradient, a bright emitter and a dark corner.
    fn hdr_image(w: u32, h: u32) -> Image {
        Image::from_fn(w, h, |x, y| {
            let (u, v) = (x as f32 / w as f32, y as f32 / h as f32);
            let base = Vec3::new(0.8, 0.6, 0.4) * (0.05 + 2.0 * u * v) + Vec3::splat(0.2 * hash(x / 4, y / 4, 3));
            let d2 = (u - 0.7).powi(2) + (v - 0.3).powi(2);
            base + Vec3::new(30.0, 25.0, 20.0) * (-d2 * 200.0).exp()
        })
    }

    /// `image` with multiplicative per-pixel noise of relative amplitude `amp` (Monte Carlo-like).
    fn noisy(image: &Image, amp: f32, seed: u32) -> Image {
        Image::from_fn(image.width, image.height, |x, y| image.get(x, y) * (1.0 + amp * (2.0 * hash(x, y, seed) - 1.0)))
    }

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol
    }

    #[test]
    fn pixel_metrics_known_values() {
        let reference = Image::filled(8, 4, Vec3::splat(0.5));
        let test = Image::filled(8, 4, Vec3::splat(0.6));
        let (m, r, rel, p) = (
            mse(&test, &reference, None).unwrap(),
            rmse(&test, &reference, None).unwrap(),
            relmse(&test, &reference, None).unwrap(),
            psnr(&test, &reference, None).unwrap(),
        );
        println!("0.6 vs 0.5: mse {m:.9} rmse {r:.9} relmse {rel:.9} psnr {p:.6} dB");
        // f32 0.6 − 0.5 is not exactly 0.1: compare within the f32 rounding of the inputs.
        assert!(close(m, 0.01, 1e-8));
        assert!(close(r, 0.1, 1e-7));
        assert!(close(rel, 0.01 / (0.25 + RELMSE_EPSILON), 1e-7), "relMSE = 0.01 / (0.5² + ε)");
        assert!(close(p, 20.0, 1e-5), "PSNR = 10 log10(1 / 0.01)");
        let p4 = psnr_with_peak(&test, &reference, None, 4.0).unwrap();
        println!("psnr with peak 4: {p4:.6} dB (expected 20 + 20 log10 4 = {:.6})", 20.0 + 20.0 * 4f64.log10());
        assert!(close(p4, 20.0 + 20.0 * 4f64.log10(), 1e-5));

        let same = psnr(&reference, &reference, None).unwrap();
        println!("identical: mse {} psnr {same}", mse(&reference, &reference, None).unwrap());
        assert_eq!(same, f64::INFINITY);

        // One channel differs: the mean is over 3 channels.
        let red = Image::filled(8, 4, Vec3::new(0.8, 0.5, 0.5));
        let m1 = mse(&red, &reference, None).unwrap();
        println!("one channel off by 0.3: mse {m1:.9} (expected 0.09 / 3 = 0.03)");
        assert!(close(m1, 0.03, 1e-7));

        // HDR values are not clamped.
        let bright = Image::filled(2, 2, Vec3::splat(10.0));
        let brighter = Image::filled(2, 2, Vec3::splat(12.0));
        let (mh, relh) = (mse(&brighter, &bright, None).unwrap(), relmse(&brighter, &bright, None).unwrap());
        println!("12 vs 10: mse {mh} relmse {relh:.9}");
        assert_eq!(mh, 4.0);
        assert!(close(relh, 4.0 / (100.0 + RELMSE_EPSILON), 1e-12));
    }

    #[test]
    fn mask_restricts_the_mean_to_selected_pixels() {
        let reference = Image::filled(4, 4, Vec3::splat(0.25));
        // Left half off by 0.5 in every channel, right half exact.
        let test = Image::from_fn(4, 4, |x, _| Vec3::splat(if x < 2 { 0.75 } else { 0.25 }));
        let left: Vec<bool> = (0..16).map(|i| i % 4 < 2).collect();
        let right: Vec<bool> = left.iter().map(|b| !b).collect();
        let (all, l, r) = (
            mse(&test, &reference, None).unwrap(),
            mse(&test, &reference, Some(&left)).unwrap(),
            mse(&test, &reference, Some(&right)).unwrap(),
        );
        println!("mse all {all} left {l} right {r}");
        assert_eq!((all, l, r), (0.125, 0.25, 0.0));
        let e = mse(&test, &reference, Some(&left[..3])).unwrap_err();
        println!("short mask: {e}");
        assert_eq!(e, MetricsError::MaskLength { expected: 16, got: 3 });
        let e = relmse(&test, &reference, Some(&[false; 16])).unwrap_err();
        println!("empty mask: {e}");
        assert_eq!(e, MetricsError::EmptyMask);
    }

    #[test]
    fn bad_inputs_are_errors_not_panics() {
        let a = Image::filled(4, 3, Vec3::splat(0.5));
        let b = Image::filled(3, 4, Vec3::splat(0.5));
        let e = mse(&a, &b, None).unwrap_err();
        println!("size mismatch: {e}");
        assert!(matches!(e, MetricsError::SizeMismatch { test_width: 4, test_height: 3, reference_width: 3, reference_height: 4 }));
        assert!(matches!(Metrics::compute(&a, &b), Err(MetricsError::SizeMismatch { .. })));
        assert!(matches!(flip_hdr(&a, &b), Err(MetricsError::SizeMismatch { .. })));
        assert!(matches!(error_map(&a, &b, ErrorMapKind::Ssim), Err(MetricsError::SizeMismatch { .. })));

        let mut nan = a.clone();
        nan.set(2, 1, Vec3::new(0.5, f32::NAN, 0.5));
        let e = ssim(&nan, &a).unwrap_err();
        println!("NaN in test: {e}");
        assert!(matches!(e, MetricsError::NonFinite { image: Which::Test, x: 2, y: 1, channel: 1, .. }));
        assert!(e.to_string().contains("test image") && e.to_string().contains("(2, 1)"), "{e}");
        let mut inf = a.clone();
        inf.set(0, 2, Vec3::new(0.5, 0.5, f32::INFINITY));
        let e = Metrics::compute(&a, &inf).unwrap_err();
        println!("inf in reference: {e}");
        assert!(matches!(e, MetricsError::NonFinite { image: Which::Reference, x: 0, y: 2, channel: 2, .. }));
        for f in [flip_ldr, flip_hdr] {
            assert!(matches!(f(&nan, &a), Err(MetricsError::NonFinite { image: Which::Test, .. })));
        }

        let empty = Image::new(0, 0);
        let e = psnr(&empty, &empty, None).unwrap_err();
        println!("empty: {e}");
        assert_eq!(e, MetricsError::Empty);
        let malformed = Image { width: 4, height: 3, pixels: vec![Vec3::ZERO; 5] };
        let e = rmse(&a, &malformed, None).unwrap_err();
        println!("malformed: {e}");
        assert!(matches!(e, MetricsError::Malformed { image: Which::Reference, pixels: 5, .. }));
        let e = ssim(&a, &a).unwrap_err();
        println!("too small for SSIM: {e}");
        assert!(matches!(e, MetricsError::TooSmallForSsim { width: 4, height: 3, min: 11 }));
        let e = psnr_with_peak(&a, &a, None, 0.0).unwrap_err();
        println!("bad peak: {e}");
        assert!(matches!(e, MetricsError::InvalidParameter(_)));
    }

    /// SSIM straight from the definition: the 11×11 Gaussian window as a 2-D double loop, per
    /// channel, averaged — independent of the separable implementation.
    fn ssim_brute_force(test: &Image, reference: &Image) -> f64 {
        let g: Vec<f64> = (0..11).map(|i| (-((i as f64 - 5.0).powi(2)) / (2.0 * 1.5 * 1.5)).exp()).collect();
        let norm: f64 = g.iter().flat_map(|a| g.iter().map(move |b| a * b)).sum();
        let (c1, c2) = (0.01f64.powi(2), 0.03f64.powi(2));
        let (w, h) = (test.width, test.height);
        let mut total = 0.0;
        let mut count = 0.0;
        for c in 0..3 {
            for y0 in 0..=h - 11 {
                for x0 in 0..=w - 11 {
                    let mut s = [0.0f64; 5];
                    for j in 0..11 {
                        for i in 0..11 {
                            let wgt = g[i as usize] * g[j as usize] / norm;
                            let a = f64::from(test.get(x0 + i, y0 + j)[c].clamp(0.0, 1.0));
                            let b = f64::from(reference.get(x0 + i, y0 + j)[c].clamp(0.0, 1.0));
                            s[0] += wgt * a;
                            s[1] += wgt * b;
                            s[2] += wgt * a * a;
                            s[3] += wgt * b * b;
                            s[4] += wgt * a * b;
                        }
                    }
                    let [ma, mb, aa, bb, ab] = s;
                    let (va, vb, cab) = (aa - ma * ma, bb - mb * mb, ab - ma * mb);
                    total += ((2.0 * ma * mb + c1) * (2.0 * cab + c2)) / ((ma * ma + mb * mb + c1) * (va + vb + c2));
                    count += 1.0;
                }
            }
        }
        total / count
    }

    #[test]
    fn ssim_known_values() {
        let reference = ldr_image(24, 20);
        let same = ssim(&reference, &reference).unwrap();
        println!("identical: SSIM {same:.12}");
        assert!(close(same, 1.0, 1e-9));

        // Constant images: σ = 0, so SSIM is the luminance term (2ab + C1)/(a² + b² + C1).
        let (a, b) = (0.3f32, 0.5f32);
        let s = ssim(&Image::filled(16, 12, Vec3::splat(a)), &Image::filled(16, 12, Vec3::splat(b))).unwrap();
        let (a, b) = (f64::from(a), f64::from(b));
        let expected = (2.0 * a * b + 1e-4) / (a * a + b * b + 1e-4);
        println!("constant 0.3 vs 0.5: SSIM {s:.9}, luminance term {expected:.9}");
        assert!(close(s, expected, 1e-7));

        // A textured image plus a constant offset: the structure/contrast term is exactly 1 and
        // the luminance term depends on the local means; check against the brute-force definition.
        let offset = Image::from_fn(24, 20, |x, y| reference.get(x, y) + Vec3::splat(0.04));
        let (s_off, s_bf) = (ssim(&offset, &reference).unwrap(), ssim_brute_force(&offset, &reference));
        println!("texture + 0.04: SSIM {s_off:.12}, brute force {s_bf:.12}");
        assert!(close(s_off, s_bf, 1e-12));
        assert!(s_off < 1.0 && s_off > 0.98, "a small offset costs little");

        // Noise lowers SSIM; still the same as the brute force, map and mean agree.
        let noisy_image = noisy(&reference, 0.2, 11);
        let (s_noise, map) = ssim_map(&noisy_image, &reference).unwrap();
        let s_noise_bf = ssim_brute_force(&noisy_image, &reference);
        println!("20 % noise: SSIM {s_noise:.12}, brute force {s_noise_bf:.12}, map {}×{} mean {:.12}", map.width, map.height, map.mean());
        assert!(close(s_noise, s_noise_bf, 1e-12));
        assert_eq!((map.width, map.height), (14, 10));
        assert!(close(map.mean(), s_noise, 1e-6));
        assert!(s_noise < s_off);

        // Clamping: values above 1 count as 1.
        let over = Image::filled(12, 12, Vec3::splat(5.0));
        let one = Image::filled(12, 12, Vec3::splat(1.0));
        let s_clamp = ssim(&over, &one).unwrap();
        println!("5 vs 1 (clamped to 1 vs 1): SSIM {s_clamp}");
        assert_eq!(s_clamp, 1.0);
    }

    /// image-compare 0.5's `MSSIMSimple` is not Wang et al.'s SSIM: it uses non-overlapping 8×8
    /// windows with uniform weights (not a sliding 11×11 Gaussian), on 8-bit values with
    /// L = 255, and its σ² and σxy are window *sums*, not means (64× too large), which inflates
    /// the contrast/structure term towards 1. Only the luminance term is the same, so the
    /// numbers agree exactly where σ = 0 (constant images; C1 scales with L²), which is what
    /// we assert. On a textured image we print both to show the difference.
    #[test]
    fn ssim_cross_check_with_image_compare() {
        let gray = |v: u8| image::GrayImage::from_pixel(16, 16, image::Luma([v]));
        for (a, b) in [(100u8, 120u8), (30, 200), (0, 255), (77, 77)] {
            let theirs =
                image_compare::gray_similarity_structure(&image_compare::Algorithm::MSSIMSimple, &gray(a), &gray(b)).unwrap().score;
            let ours =
                ssim(&Image::filled(16, 16, Vec3::splat(f32::from(a) / 255.0)), &Image::filled(16, 16, Vec3::splat(f32::from(b) / 255.0)))
                    .unwrap();
            println!("constant {a} vs {b}: ours {ours:.9}, image-compare {theirs:.9}");
            assert!(close(ours, theirs, 1e-6));
        }
        let reference = ldr_image(32, 32);
        let test = noisy(&reference, 0.3, 5);
        let to_gray =
            |img: &Image| image::GrayImage::from_fn(32, 32, |x, y| image::Luma([(img.get(x, y).y.clamp(0.0, 1.0) * 255.0).round() as u8]));
        let theirs =
            image_compare::gray_similarity_structure(&image_compare::Algorithm::MSSIMSimple, &to_gray(&test), &to_gray(&reference))
                .unwrap()
                .score;
        let gy = |img: &Image| Image::from_fn(32, 32, |x, y| Vec3::splat((img.get(x, y).y.clamp(0.0, 1.0) * 255.0).round() / 255.0));
        let ours = ssim(&gy(&test), &gy(&reference)).unwrap();
        println!(
            "textured + 30 % noise (green channel, 8-bit): ours {ours:.6}, image-compare {theirs:.6} (different definitions, not compared)"
        );
        assert!(ours < theirs, "image-compare's summed variances push its score towards 1");
    }

    #[test]
    fn flip_ldr_basics() {
        println!("FLIP pixels per degree {FLIP_PIXELS_PER_DEGREE}");
        assert!(close(f64::from(FLIP_PIXELS_PER_DEGREE), 67.020_645, 1e-4));
        let reference = ldr_image(32, 24);
        let (same, map) = flip_ldr(&reference, &reference).unwrap();
        println!("identical: LDR-FLIP {same}, map max {}", map.max());
        assert_eq!(same, 0.0);
        let (small, _) = flip_ldr(&noisy(&reference, 0.05, 2), &reference).unwrap();
        let (large, map) = flip_ldr(&noisy(&reference, 0.3, 2), &reference).unwrap();
        println!("5 % noise: {small:.6}; 30 % noise: {large:.6}; map {}×{}", map.width, map.height);
        assert!(0.0 < small && small < large && large < 1.0);
        assert_eq!((map.width, map.height), (32, 24));
        assert!(close(map.mean(), large, 1e-12));
    }

    #[test]
    fn hdr_flip_exposures_and_tone_mapper() {
        // x_max: the ACES curve reaches 0.85 there.
        let x_max = 2f32.powf(HdrFlipExposures::from_reference(&Image::filled(4, 4, Vec3::ONE)).start);
        println!("x_max {x_max:.6}, tone map there {:.6}", aces_tone_map(x_max));
        assert!((aces_tone_map(x_max) - 0.85).abs() < 1e-5);
        // Narkowicz's fit at 0.6·x.
        let narkowicz = |x: f32| x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14);
        for x in [0.0f32, 0.1, 1.0, 7.0] {
            println!("ACES({x}) = {:.6}, Narkowicz(0.6·{x}) = {:.6}", aces_tone_map(x), narkowicz(0.6 * x));
            assert!((aces_tone_map(x) - narkowicz(0.6 * x)).abs() < 1e-6);
        }
        // Luminance 1 everywhere except one pixel of luminance 8: start = log2(x_max / 8),
        // stop = log2(x_max / 1), count = max(2, ⌈3⌉) = 3.
        let mut reference = Image::filled(5, 5, Vec3::ONE);
        reference.set(1, 1, Vec3::splat(8.0));
        let e = HdrFlipExposures::from_reference(&reference);
        println!("exposures {e:?}, steps {:?}", (0..e.count).map(|i| e.exposure(i)).collect::<Vec<_>>());
        assert!((e.start - (x_max / 8.0).log2()).abs() < 1e-6 && (e.stop - x_max.log2()).abs() < 1e-6);
        assert_eq!(e.count, 3);
        assert!((e.exposure(2) - e.stop).abs() < 1e-6);
        // Degenerate references.
        let black = HdrFlipExposures::from_reference(&Image::new(4, 4));
        let mostly_black = HdrFlipExposures::from_reference(&Image::from_fn(4, 4, |x, _| Vec3::splat(if x == 0 { 2.0 } else { 0.0 })));
        println!("all black: {black:?}; 3/4 black: {mostly_black:?}");
        assert_eq!(black, HdrFlipExposures { start: 0.0, stop: 0.0, count: 2 });
        assert!(mostly_black.stop.is_finite() && (mostly_black.stop - mostly_black.start).abs() < 1e-6);
    }

    #[test]
    fn flip_hdr_basics() {
        let reference = hdr_image(40, 32);
        let (same, _) = flip_hdr(&reference, &reference).unwrap();
        let full = flip_hdr_with(&noisy(&reference, 0.2, 9), &reference, HdrFlipExposures::from_reference(&reference)).unwrap();
        let levels: std::collections::BTreeSet<u32> = full.exposure_map.values.iter().map(|v| (v * 1000.0) as u32).collect();
        println!(
            "identical: HDR-FLIP {same}; 20 % noise: {:.6} with {:?}, exposure-map levels ×1000 {levels:?}",
            full.mean, full.exposures
        );
        assert_eq!(same, 0.0);
        assert!(full.mean > 0.0 && full.mean < 1.0);
        assert!(full.exposures.count >= 2);
        let e = flip_hdr_with(&reference, &reference, HdrFlipExposures { start: 1.0, stop: 0.0, count: 2 }).unwrap_err();
        println!("start > stop: {e}");
        assert!(matches!(e, MetricsError::InvalidParameter(_)));
    }

    /// HDR-FLIP's (start, stop, count) exposures as `flip-evaluator` reports them.
    type Exposures = (f64, f64, u32);

    /// Runs NVIDIA's `flip-evaluator` (PyPI) on two image files. Returns the mean and, for HDR,
    /// the exposures, or a reason to skip.
    fn reference_flip(reference: &Path, test: &Path, mode: &str) -> Result<(f64, Option<Exposures>), String> {
        // The Python API needs numpy; without it, run the same package's command-line tool.
        const SCRIPT: &str = r#"
import sys, os, re, subprocess
try:
    import flip_evaluator
except Exception as e:
    print("SKIP flip_evaluator is not importable:", e); sys.exit(0)
ref, test, mode, outdir = sys.argv[1:5]
try:
    import numpy
    _, mean, p = flip_evaluator.evaluate(ref, test, mode, applyMagma=False)
    print("MEAN", repr(float(mean)))
    if mode == "HDR":
        print("EXPOSURES", p["startExposure"], p["stopExposure"], p["numExposures"])
except ImportError:
    out = subprocess.run([sys.executable, "-c", "import sys; from flip_evaluator import flip_python_api as f; sys.argv[0] = 'flip'; f.main()",
                          "-r", ref, "-t", test, "-v", "2", "-nerm", "-nexm", "-d", outdir], capture_output=True, text=True).stdout
    print("MEAN", re.search(r"Mean: ([0-9.eE+-]+)", out).group(1))
    if mode == "HDR":
        g = lambda k: re.search(k + r"[^:]*: ([0-9.eE+-]+)", out).group(1)
        print("EXPOSURES", g("Start exposure"), g("Stop exposure"), g("Number of exposures"))
"#;
        let outdir = reference.parent().unwrap();
        let out = Command::new("python3")
            .args(["-c", SCRIPT])
            .arg(reference)
            .arg(test)
            .arg(mode)
            .arg(outdir)
            .output()
            .map_err(|e| format!("python3 could not be run: {e}"))?;
        let stdout = String::from_utf8_lossy(&out.stdout);
        if let Some(reason) = stdout.lines().find_map(|l| l.strip_prefix("SKIP ")) {
            return Err(reason.to_string());
        }
        let field = |key: &str| {
            stdout.lines().find_map(|l| l.strip_prefix(key).map(|r| r.split_whitespace().map(str::to_string).collect::<Vec<_>>()))
        };
        let mean = field("MEAN ")
            .and_then(|v| v.first()?.parse::<f64>().ok())
            .ok_or_else(|| format!("no mean from flip-evaluator: {stdout} {}", String::from_utf8_lossy(&out.stderr)))?;
        let exposures = field("EXPOSURES ").map(|v| (v[0].parse().unwrap(), v[1].parse().unwrap(), v[2].parse::<f64>().unwrap() as u32));
        Ok((mean, exposures))
    }

    /// A fresh folder, removed when the test ends (also when it fails or skips).
    fn temp_dir(name: &str) -> tempfile::TempDir {
        tempfile::Builder::new().prefix(&format!("glimpse-metrics-{name}-")).tempdir().unwrap()
    }

    /// LDR-FLIP against `flip-evaluator` on the PNGs our writer produces (the same 8-bit sRGB
    /// values `flip_ldr` compares). Differences come only from the FLIP versions (nv-flip builds
    /// v1.2-era C++, the package is v1.7) and float rounding: 1.4e-8 when measured.
    #[test]
    fn flip_ldr_cross_check_with_flip_evaluator() {
        let tmp = temp_dir("ldr");
        let dir = tmp.path();
        let reference = ldr_image(48, 40);
        let mut worst = 0.0f64;
        for (amp, seed) in [(0.05, 1), (0.3, 2)] {
            let test = noisy(&reference, amp, seed);
            let (rp, tp) = (dir.join("reference.png"), dir.join(format!("test{seed}.png")));
            reference.write(&rp, ToneMap::default()).unwrap();
            test.write(&tp, ToneMap::default()).unwrap();
            let ours = flip_ldr(&test, &reference).unwrap().0;
            match reference_flip(&rp, &tp, "LDR") {
                Err(reason) => {
                    println!("skipped: {reason} (ours: LDR-FLIP {ours:.6})");
                    return;
                }
                Ok((theirs, _)) => {
                    println!(
                        "LDR-FLIP, {:.0} % noise: ours {ours:.7}, flip-evaluator {theirs:.7}, difference {:.2e}",
                        amp * 100.0,
                        ours - theirs
                    );
                    worst = worst.max((ours - theirs).abs());
                }
            }
        }
        assert!(worst < 1e-6, "LDR-FLIP differs from flip-evaluator by {worst}");
    }

    /// HDR-FLIP against `flip-evaluator` on EXR files: the same automatic exposures, and means
    /// that agreed to 2e-7 when measured (float rounding between the C++ and our port).
    #[test]
    fn flip_hdr_cross_check_with_flip_evaluator() {
        let tmp = temp_dir("hdr");
        let dir = tmp.path();
        let reference = hdr_image(48, 40);
        let cases = [
            ("5 % noise", noisy(&reference, 0.05, 3)),
            ("20 % noise", noisy(&reference, 0.2, 4)),
            ("×1.3 bias", Image { pixels: reference.pixels.iter().map(|p| *p * 1.3).collect(), ..reference.clone() }),
        ];
        let rp = dir.join("reference.exr");
        // `Image::write`'s EXR (scanline, ZIP) is what `flip` reads here, so this also checks
        // that NVIDIA's loader accepts our files.
        reference.write(&rp, ToneMap::default()).unwrap();
        assert_eq!(Image::read(&rp).unwrap(), reference, "our EXR writer is exact");
        let mut worst = 0.0f64;
        for (i, (name, test)) in cases.iter().enumerate() {
            let tp = dir.join(format!("test{i}.exr"));
            test.write(&tp, ToneMap::default()).unwrap();
            let ours = flip_hdr_with(test, &reference, HdrFlipExposures::from_reference(&reference)).unwrap();
            match reference_flip(&rp, &tp, "HDR") {
                Err(reason) => {
                    println!("skipped: {reason} (ours: HDR-FLIP {:.6} with {:?})", ours.mean, ours.exposures);
                    return;
                }
                Ok((theirs, exposures)) => {
                    let e = ours.exposures;
                    println!(
                        "HDR-FLIP, {name}: ours {:.6} (start {:.6}, stop {:.6}, {} exposures), flip-evaluator {theirs:.6} {exposures:?}, difference {:+.2e} ({:+.2} %)",
                        ours.mean,
                        e.start,
                        e.stop,
                        e.count,
                        ours.mean - theirs,
                        100.0 * (ours.mean - theirs) / theirs
                    );
                    if let Some((start, stop, count)) = exposures {
                        assert!(close(f64::from(e.start), start, 1e-4) && close(f64::from(e.stop), stop, 1e-4), "exposures differ");
                        assert_eq!(e.count, count);
                    }
                    worst = worst.max((ours.mean - theirs).abs());
                }
            }
        }
        // 1e-6: measured ≤ 2e-7 with the Python API; the command-line fallback prints 6 decimals.
        assert!(worst < 1e-6, "HDR-FLIP differs from flip-evaluator by {worst:.2e}");
    }

    #[test]
    fn shadow_errors_spec_example() {
        let mut e = ShadowErrors::new();
        e.add_pixel(10, 5, 1000);
        println!(
            "n=1000 FV=10 FI=5: ε_v {:.4} %, |ε_s| {:.4} %, signed ε_s {:.4} %",
            100.0 * e.epsilon_v(),
            100.0 * e.epsilon_s_abs(),
            100.0 * e.epsilon_s_signed()
        );
        assert!(close(e.epsilon_v(), 0.015, 1e-15));
        assert!(close(e.epsilon_s_abs(), 0.005, 1e-15));
        assert!(close(e.epsilon_s_signed(), 0.005, 1e-15));

        // A second pixel with the opposite sign: |ε_s| keeps it, the signed mean cancels.
        let mut other = ShadowErrors::new();
        other.add_pixel(5, 10, 1000);
        other.add_pixel(0, 0, 0); // no lights: not counted
        e.merge(&other);
        println!(
            "+ pixel FV=5 FI=10: pixels {}, ε_v {:.4} %, |ε_s| {:.4} %, signed ε_s {:.4} %",
            e.pixels(),
            100.0 * e.epsilon_v(),
            100.0 * e.epsilon_s_abs(),
            100.0 * e.epsilon_s_signed()
        );
        assert_eq!(e.pixels(), 2);
        assert!(close(e.epsilon_v(), 0.015, 1e-15));
        assert!(close(e.epsilon_s_abs(), 0.005, 1e-15));
        assert!(close(e.epsilon_s_signed(), 0.0, 1e-15));
        assert_eq!(ShadowErrors::new().epsilon_v(), 0.0);
    }

    #[test]
    fn shadow_errors_from_visibility_bitsets() {
        // 3 pixels × 70 lights (2 words per pixel); pixel 2 is background.
        let lights = 70;
        let k = visibility_words_per_pixel(lights);
        assert_eq!(k, 2);
        let mut reference = vec![0u64; 3 * k];
        let mut test = reference.clone();
        let set = |bits: &mut [u64], p: usize, l: usize| bits[p * k + l / 64] |= 1 << (l % 64);
        // Pixel 0: lights 0..10 visible in both; the test also sees 65 and 69 (FV = 2), misses 3 (FI = 1).
        for l in 0..10 {
            set(&mut reference, 0, l);
            if l != 3 {
                set(&mut test, 0, l);
            }
        }
        set(&mut test, 0, 65);
        set(&mut test, 0, 69);
        // Padding bits past light 69 are ignored.
        test[1] |= 1 << 63;
        // Pixel 1: exact. Pixel 2 (not covered): all wrong.
        set(&mut reference, 1, 66);
        set(&mut test, 1, 66);
        test[2 * k] = u64::MAX;
        let covered = [true, true, false];
        let e = shadow_errors_from_visibility(&test, &reference, lights, Some(&covered)).unwrap();
        let (v, s) = ((2.0 + 1.0) / 70.0 / 2.0, (2.0 - 1.0) / 70.0 / 2.0);
        println!("pixels {}, ε_v {:.6} (expected {v:.6}), |ε_s| {:.6} (expected {s:.6})", e.pixels(), e.epsilon_v(), e.epsilon_s_abs());
        assert_eq!(e.pixels(), 2);
        assert!(close(e.epsilon_v(), v, 1e-15) && close(e.epsilon_s_abs(), s, 1e-15) && close(e.epsilon_s_signed(), s, 1e-15));
        let all = shadow_errors_from_visibility(&test, &reference, lights, None).unwrap();
        println!("without the coverage mask: pixels {}, ε_v {:.6}", all.pixels(), all.epsilon_v());
        assert_eq!(all.pixels(), 3);
        let err = shadow_errors_from_visibility(&test[..5], &reference, lights, None).unwrap_err();
        println!("bad length: {err}");
        assert!(matches!(err, MetricsError::Visibility(_)));
    }

    #[test]
    fn error_maps_use_magma_at_fixed_scales() {
        let reference = ldr_image(24, 16);
        let test = noisy(&reference, 0.2, 8);
        for kind in [
            ErrorMapKind::AbsDifference { max: 0.1 },
            ErrorMapKind::RelativeSquared { max: 0.05 },
            ErrorMapKind::Ssim,
            ErrorMapKind::FlipLdr,
            ErrorMapKind::FlipHdr,
        ] {
            let map = error_map(&test, &reference, kind).unwrap();
            let same = error_map(&reference, &reference, kind).unwrap();
            let black = magma(0.0);
            let on_scale = map.pixels.iter().filter(|p| **p != black).count();
            println!(
                "{kind:?}: {}×{}, {on_scale} of {} pixels above zero; identical images all magma(0): {}",
                map.width,
                map.height,
                map.len(),
                same.pixels.iter().all(|p| *p == black)
            );
            assert_eq!((map.width, map.height), (24, 16));
            assert!(same.pixels.iter().all(|p| *p == black));
            assert!(on_scale > 0);
        }
        // An absolute difference of exactly `max` is the brightest colour; the PNG shows FLIP's
        // 8-bit magma colours exactly.
        let a = Image::filled(2, 1, Vec3::splat(0.2));
        let b = Image::from_fn(2, 1, |x, _| Vec3::splat(if x == 0 { 0.2 } else { 0.3 }));
        let png = error_map(&b, &a, ErrorMapKind::AbsDifference { max: 0.1 }).unwrap().to_srgb8(ToneMap::default());
        println!(
            "PNG colours {:?} {:?}; magma 0 {:?}, magma 1 {:?}",
            png.get_pixel(0, 0).0,
            png.get_pixel(1, 0).0,
            colormap::magma_srgb8(0.0),
            colormap::magma_srgb8(1.0)
        );
        assert_eq!(png.get_pixel(0, 0).0, colormap::magma_srgb8(0.0));
        assert_eq!(png.get_pixel(1, 0).0, colormap::magma_srgb8(1.0));
        for i in 0..=255u8 {
            let t = f32::from(i) / 255.0;
            let round_trip = Image::filled(1, 1, magma(t)).to_srgb8(ToneMap::default());
            assert_eq!(round_trip.get_pixel(0, 0).0, colormap::magma_srgb8(t), "entry {i}");
        }
        let e = error_map(&b, &a, ErrorMapKind::RelativeSquared { max: 0.0 }).unwrap_err();
        println!("zero scale: {e}");
        assert!(matches!(e, MetricsError::InvalidParameter(_)));
    }

    #[test]
    fn metrics_summary() {
        let reference = hdr_image(32, 24);
        let test = noisy(&reference, 0.1, 21);
        let m = Metrics::compute(&test, &reference).unwrap();
        println!("{m:?}");
        println!("pairs {:?}", m.to_pairs());
        assert_eq!(m.to_pairs().map(|p| p.0), ["mse", "rmse", "relmse", "psnr", "ssim", "flip"]);
        assert_eq!(m.mse, mse(&test, &reference, None).unwrap());
        assert!(close(m.rmse, m.mse.sqrt(), 0.0));
        assert_eq!(m.relmse, relmse(&test, &reference, None).unwrap());
        assert_eq!(m.psnr, psnr(&test, &reference, None).unwrap());
        assert_eq!(m.ssim, ssim(&test, &reference).unwrap());
        assert_eq!(m.flip, flip_hdr(&test, &reference).unwrap().0);
        let same = Metrics::compute(&reference, &reference).unwrap();
        println!("identical: {same:?}");
        assert_eq!((same.mse, same.relmse, same.psnr, same.ssim, same.flip), (0.0, 0.0, f64::INFINITY, 1.0, 0.0));
        let mask: Vec<bool> = (0..reference.len()).map(|i| i % 2 == 0).collect();
        let masked = Metrics::compute_masked(&test, &reference, Some(&mask)).unwrap();
        println!("masked: {masked:?}");
        assert_eq!(masked.mse, mse(&test, &reference, Some(&mask)).unwrap());
        assert_eq!(masked.ssim, m.ssim);
    }
}
