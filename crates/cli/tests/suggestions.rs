//! "Did you mean" for `--set` keys and for every technique in `eval -t`'s list (issue #16).

use std::process::Command;

fn stderr(args: &[&str]) -> (bool, String) {
    let o = Command::new(env!("CARGO_BIN_EXE_glimpse")).args(args).env("GLIMPSE_CACHE", "").output().expect("the glimpse binary runs");
    (o.status.success(), String::from_utf8_lossy(&o.stderr).into_owned())
}

#[test]
fn misspelt_parameters_and_techniques_get_a_suggestion() {
    // A path that does not exist, in a folder removed when the test ends (also when it fails).
    let dir = tempfile::Builder::new().prefix("glimpse-suggest-").tempdir().unwrap();
    let out = dir.path().join("suggest");
    let out = out.to_str().unwrap();
    let (ok, e) = stderr(&["render", "cornell", "-t", "ao-exact", "--set", "raduis=1", "--size", "8x8", "-o", &format!("{out}.png")]);
    assert!(!ok && e.contains("unknown parameter 'raduis'") && e.contains("did you mean 'radius'?"), "{e}");
    let (ok, e) = stderr(&["eval", "cornell", "-t", "ao-exact,ao-roam", "--size", "8x8", "-o", out]);
    assert!(!ok && e.contains("did you mean 'ao-roma'?"), "{e}");
    let (ok, e) = stderr(&["eval", "cornell", "-t", "ao-roma", "--set", "resolutoin=64", "--size", "8x8", "-o", out]);
    assert!(!ok && e.contains("did you mean 'resolution'?"), "{e}");
}
