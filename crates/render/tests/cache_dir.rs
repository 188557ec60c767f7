//! `GLIMPSE_CACHE` set but empty must not put caches in the current directory; the structure
//! caches follow it unless turned off (as `glimpse suite` does).

#[test]
fn empty_glimpse_cache_turns_disk_caches_off() {
    // SAFETY: this test binary has this one test, so no other thread reads the environment.
    unsafe { std::env::set_var("GLIMPSE_CACHE", "") };
    assert_eq!(glimpse_render::cache_dir(), None);
    unsafe { std::env::set_var("GLIMPSE_CACHE", "/tmp/glimpse-cache-test") };
    assert_eq!(glimpse_render::cache_dir(), Some(std::path::PathBuf::from("/tmp/glimpse-cache-test")));
    assert_eq!(glimpse_render::structure_cache_dir(), glimpse_render::cache_dir());
    glimpse_render::set_structure_cache(false);
    assert_eq!(glimpse_render::structure_cache_dir(), None);
    assert!(glimpse_render::cache_dir().is_some(), "the references' cache stays");
    glimpse_render::set_structure_cache(true);
    assert_eq!(glimpse_render::structure_cache_dir(), glimpse_render::cache_dir());
    unsafe {
        std::env::remove_var("GLIMPSE_CACHE");
        std::env::set_var("XDG_CACHE_HOME", "");
        std::env::set_var("HOME", "/home/someone");
    };
    assert_eq!(glimpse_render::cache_dir(), Some(std::path::PathBuf::from("/home/someone/.cache/glimpse")));
}
