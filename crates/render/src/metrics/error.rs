//! Errors of the image metrics, and the input checks every metric runs first.
//!
//! A metric never panics on bad input: two images of different sizes, an image whose pixel
//! buffer does not match its size, an empty image, or a NaN/infinite channel value are errors
//! that name the image (test or reference) and, for values, the pixel and channel.

use glimpse_core::Image;

/// Which of the two compared images an error is about.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Which {
    Test,
    Reference,
}

impl std::fmt::Display for Which {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Which::Test => "test",
            Which::Reference => "reference",
        })
    }
}

#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum MetricsError {
    #[error("image sizes differ: test is {test_width}×{test_height}, reference is {reference_width}×{reference_height}")]
    SizeMismatch { test_width: u32, test_height: u32, reference_width: u32, reference_height: u32 },
    #[error("{image} image is {width}×{height} but holds {pixels} pixels")]
    Malformed { image: Which, width: u32, height: u32, pixels: usize },
    #[error("the images have zero size")]
    Empty,
    #[error("{image} image has a non-finite value ({value}) at pixel ({x}, {y}), channel {channel}")]
    NonFinite { image: Which, x: u32, y: u32, channel: usize, value: f32 },
    #[error("the mask has {got} entries but the images have {expected} pixels")]
    MaskLength { expected: usize, got: usize },
    #[error("the mask selects no pixel")]
    EmptyMask,
    #[error("SSIM needs images of at least {min}×{min} pixels (its window), got {width}×{height}")]
    TooSmallForSsim { width: u32, height: u32, min: u32 },
    #[error("invalid parameter: {0}")]
    InvalidParameter(String),
    #[error("visibility bitsets: {0}")]
    Visibility(String),
}

/// Checks that `test` and `reference` can be compared: same non-zero size, pixel buffers that
/// match it, and only finite values (the first offending pixel is named, test image first).
pub fn check_pair(test: &Image, reference: &Image) -> Result<(), MetricsError> {
    if (test.width, test.height) != (reference.width, reference.height) {
        return Err(MetricsError::SizeMismatch {
            test_width: test.width,
            test_height: test.height,
            reference_width: reference.width,
            reference_height: reference.height,
        });
    }
    for (which, image) in [(Which::Test, test), (Which::Reference, reference)] {
        if image.pixels.len() != image.width as usize * image.height as usize {
            return Err(MetricsError::Malformed { image: which, width: image.width, height: image.height, pixels: image.pixels.len() });
        }
    }
    if test.pixels.is_empty() {
        return Err(MetricsError::Empty);
    }
    for (which, image) in [(Which::Test, test), (Which::Reference, reference)] {
        check_finite(which, image)?;
    }
    Ok(())
}

fn check_finite(which: Which, image: &Image) -> Result<(), MetricsError> {
    let Some(i) = image.pixels.iter().position(|p| !p.is_finite()) else { return Ok(()) };
    let p = image.pixels[i].to_array();
    let channel = p.iter().position(|v| !v.is_finite()).unwrap_or(0);
    let w = image.width as usize;
    Err(MetricsError::NonFinite { image: which, x: (i % w) as u32, y: (i / w) as u32, channel, value: p[channel] })
}

/// Checks an optional pixel mask (`true` = include the pixel) against the pixel count and
/// returns how many pixels it selects.
pub fn check_mask(mask: Option<&[bool]>, pixels: usize) -> Result<usize, MetricsError> {
    let Some(mask) = mask else { return Ok(pixels) };
    if mask.len() != pixels {
        return Err(MetricsError::MaskLength { expected: pixels, got: mask.len() });
    }
    match mask.iter().filter(|&&m| m).count() {
        0 => Err(MetricsError::EmptyMask),
        n => Ok(n),
    }
}
