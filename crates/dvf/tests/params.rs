//! The DVF's defaults and `profile=paper`: ours traces both hemispheres (double-sided surfaces
//! are common in real scenes), the paper's profile only the front one, and an explicit `sides`
//! overrides either.

use glimpse_dvf::DvfParams;
use glimpse_render::Params;

fn read(pairs: &[&str]) -> DvfParams {
    DvfParams::default().read(&Params::parse(pairs).expect("valid pairs")).expect("valid params")
}

#[test]
fn default_is_double_sided_and_paper_profile_is_front_only() {
    assert!(read(&[]).both_sides);
    assert!(!read(&["profile=paper"]).both_sides);
    assert!(!read(&["sides=front"]).both_sides);
    assert!(read(&["profile=paper", "sides=both"]).both_sides);
    // The profile changes nothing else.
    assert_eq!(DvfParams { both_sides: true, ..read(&["profile=paper"]) }, read(&[]));
    assert!(DvfParams::default().read(&Params::parse(&["profile=fast"]).unwrap()).is_err());
}
