//! Technique parameters from `--set key=value`. Each technique reads the keys it knows with a
//! default (the paper's setting) and a valid range; [`Params::finish`] then rejects any key no
//! one read, so a typo is an error rather than a silently ignored setting.
//!
//! Every read is also recorded with its kind, range or choices and default
//! ([`Params::described`]), so a user interface can build a widget per key from the technique's
//! own parameter list: the same keys and ranges `--set` accepts.

use std::cell::RefCell;
use std::collections::{BTreeMap, BTreeSet};

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ParamError {
    #[error("--set {0}: expected key=value")]
    Syntax(String),
    #[error("parameter '{key}' = '{value}': {message}")]
    Invalid { key: String, value: String, message: String },
    #[error("unknown parameter '{key}' for {technique}{suggestion} (known: {known})")]
    Unknown { key: String, technique: String, known: String, suggestion: String },
}

#[derive(Clone, Debug, Default)]
pub struct Params {
    values: BTreeMap<String, String>,
    read: RefCell<BTreeSet<String>>,
    /// Every key asked for and its effective value, for reports.
    effective: RefCell<BTreeMap<String, String>>,
    /// Every key read successfully, in the order first read: kind, range, default and value.
    described: RefCell<Vec<ParamInfo>>,
}

/// What a technique accepts for one key: the reader it used and that reader's range or choices.
#[derive(Clone, Debug, PartialEq)]
pub enum ParamKind {
    /// `Params::f32`: a float in `[min, max]` (`max` may be infinite).
    F32 { min: f32, max: f32 },
    /// `Params::u32`: an integer in `[min, max]`.
    U32 { min: u32, max: u32 },
    /// `Params::i64`: a signed integer in `[min, max]`.
    I64 { min: i64, max: i64 },
    /// `Params::bool`.
    Bool,
    /// `Params::choice`: one of these words.
    Choice(Vec<String>),
    /// `Params::text`: any word or number (`points=auto`).
    Text,
}

/// One parameter as a technique read it.
#[derive(Clone, Debug, PartialEq)]
pub struct ParamInfo {
    pub key: String,
    pub kind: ParamKind,
    /// The technique's default, as `--set` would spell it.
    pub default: String,
    /// The effective value (the one given, or the default).
    pub value: String,
}

impl Params {
    /// From `key=value` strings.
    pub fn parse<S: AsRef<str>>(pairs: &[S]) -> Result<Params, ParamError> {
        let mut values = BTreeMap::new();
        for p in pairs {
            let p = p.as_ref();
            let (k, v) = p.split_once('=').ok_or_else(|| ParamError::Syntax(p.to_owned()))?;
            if k.trim().is_empty() {
                return Err(ParamError::Syntax(p.to_owned()));
            }
            values.insert(k.trim().to_owned(), v.trim().to_owned());
        }
        Ok(Params { values, ..Default::default() })
    }

    /// Records a successful read: its effective value and its description.
    fn record(&self, key: &str, kind: ParamKind, default: String, value: String) {
        self.effective.borrow_mut().insert(key.to_owned(), value.clone());
        let info = ParamInfo { key: key.to_owned(), kind, default, value };
        let mut described = self.described.borrow_mut();
        // A key read twice keeps its first place and its latest reading, as `effective` does.
        match described.iter_mut().find(|d| d.key == key) {
            Some(d) => *d = info,
            None => described.push(info),
        }
    }

    fn raw(&self, key: &str) -> Option<&String> {
        self.read.borrow_mut().insert(key.to_owned());
        self.values.get(key)
    }

    /// A float in `[min, max]` (`inf` allowed when `max` is infinite).
    pub fn f32(&self, key: &str, default: f32, min: f32, max: f32) -> Result<f32, ParamError> {
        let v = match self.raw(key) {
            None => default,
            Some(s) => {
                let v: f32 = s.parse().map_err(|_| invalid(key, s, "not a number"))?;
                if v.is_nan() || v < min || v > max {
                    return Err(invalid(key, s, &format!("must lie in [{min}, {max}]")));
                }
                v
            }
        };
        self.record(key, ParamKind::F32 { min, max }, default.to_string(), v.to_string());
        Ok(v)
    }

    /// An integer in `[min, max]`.
    pub fn u32(&self, key: &str, default: u32, min: u32, max: u32) -> Result<u32, ParamError> {
        let v = match self.raw(key) {
            None => default,
            Some(s) => {
                let v: u64 = s.parse().map_err(|_| invalid(key, s, "not a non-negative integer"))?;
                if v < min as u64 || v > max as u64 {
                    return Err(invalid(key, s, &format!("must lie in [{min}, {max}]")));
                }
                v as u32
            }
        };
        self.record(key, ParamKind::U32 { min, max }, default.to_string(), v.to_string());
        Ok(v)
    }

    /// A signed integer in `[min, max]`.
    pub fn i64(&self, key: &str, default: i64, min: i64, max: i64) -> Result<i64, ParamError> {
        let v = match self.raw(key) {
            None => default,
            Some(s) => {
                let v: i64 = s.parse().map_err(|_| invalid(key, s, "not an integer"))?;
                if v < min || v > max {
                    return Err(invalid(key, s, &format!("must lie in [{min}, {max}]")));
                }
                v
            }
        };
        self.record(key, ParamKind::I64 { min, max }, default.to_string(), v.to_string());
        Ok(v)
    }

    pub fn bool(&self, key: &str, default: bool) -> Result<bool, ParamError> {
        let v = match self.raw(key).map(|s| s.as_str()) {
            None => default,
            Some("true" | "1" | "yes" | "on") => true,
            Some("false" | "0" | "no" | "off") => false,
            Some(s) => return Err(invalid(key, s, "expected true or false")),
        };
        self.record(key, ParamKind::Bool, default.to_string(), v.to_string());
        Ok(v)
    }

    /// The raw value (or `default`), for keys that take a word or a number (`points=auto`).
    pub fn text(&self, key: &str, default: &str) -> String {
        let v = self.raw(key).cloned().unwrap_or_else(|| default.to_owned());
        self.record(key, ParamKind::Text, default.to_owned(), v.clone());
        v
    }

    /// One of `choices`.
    pub fn choice(&self, key: &str, default: &str, choices: &[&str]) -> Result<String, ParamError> {
        let v = self.raw(key).cloned().unwrap_or_else(|| default.to_owned());
        if !choices.contains(&v.as_str()) {
            return Err(invalid(key, &v, &format!("expected one of {}", choices.join(", "))));
        }
        let kind = ParamKind::Choice(choices.iter().map(|c| (*c).to_owned()).collect());
        self.record(key, kind, default.to_owned(), v.clone());
        Ok(v)
    }

    /// Errors if a key was given that no reader asked for.
    pub fn finish(&self, technique: &str) -> Result<(), ParamError> {
        let read = self.read.borrow();
        match self.values.keys().find(|k| !read.contains(*k)) {
            None => Ok(()),
            Some(k) => Err(ParamError::Unknown {
                key: k.clone(),
                suggestion: glimpse_core::suggest::did_you_mean(k, read.iter().map(String::as_str)),
                technique: technique.to_owned(),
                known: if read.is_empty() { "none".into() } else { read.iter().cloned().collect::<Vec<_>>().join(", ") },
            }),
        }
    }

    /// Every parameter a technique read, with its effective value.
    pub fn effective(&self) -> BTreeMap<String, String> {
        self.effective.borrow().clone()
    }

    /// Every parameter a technique read, in the order first read, with its kind, range or
    /// choices, default and effective value: what a user interface needs to build its widgets.
    pub fn described(&self) -> Vec<ParamInfo> {
        self.described.borrow().clone()
    }
}

fn invalid(key: &str, value: &str, message: &str) -> ParamError {
    ParamError::Invalid { key: key.to_owned(), value: value.to_owned(), message: message.to_owned() }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_defaults_ranges_and_rejects_unknown_keys() {
        let p = Params::parse(&["radius=0.5", "typo=3"]).unwrap();
        assert_eq!(p.f32("radius", 1.0, 0.0, f32::INFINITY).unwrap(), 0.5);
        assert_eq!(p.u32("n", 4, 1, 16).unwrap(), 4);
        let e = p.finish("ao-exact").unwrap_err().to_string();
        assert!(e.contains("unknown parameter 'typo' for ao-exact") && e.contains("radius"), "{e}");
        let bad = Params::parse(&["radius=-1"]).unwrap();
        assert!(bad.f32("radius", 1.0, 0.0, f32::INFINITY).unwrap_err().to_string().contains("must lie in"));
        let nan = Params::parse(&["radius=nan"]).unwrap();
        assert!(nan.f32("radius", 1.0, 0.0, f32::INFINITY).is_err());
        assert_eq!(Params::parse(&["radius=inf"]).unwrap().f32("radius", 1.0, 0.0, f32::INFINITY).unwrap(), f32::INFINITY);
        assert!(Params::parse(&["noequals"]).is_err());
    }

    #[test]
    fn describes_every_read_with_its_kind_range_and_default() {
        let p = Params::parse(&["radius=0.5", "steps=7", "mode=b", "flag=on", "bad=11"]).unwrap();
        p.f32("radius", f32::INFINITY, 0.0, f32::INFINITY).unwrap();
        p.u32("steps", 4, 1, u32::MAX).unwrap();
        p.i64("offset", -3, -10, 10).unwrap();
        p.bool("flag", false).unwrap();
        p.choice("mode", "a", &["a", "b"]).unwrap();
        p.text("points", "auto");
        // A failed read is not described (the technique does not build).
        assert!(p.u32("bad", 1, 0, 10).is_err());
        let d = p.described();
        for i in &d {
            println!("{} = {} (default {}): {:?}", i.key, i.value, i.default, i.kind);
        }
        let keys: Vec<&str> = d.iter().map(|i| i.key.as_str()).collect();
        assert_eq!(keys, ["radius", "steps", "offset", "flag", "mode", "points"], "in the order read");
        assert_eq!(d[0].kind, ParamKind::F32 { min: 0.0, max: f32::INFINITY });
        assert_eq!((d[0].default.as_str(), d[0].value.as_str()), ("inf", "0.5"));
        assert_eq!(d[1].kind, ParamKind::U32 { min: 1, max: u32::MAX });
        assert_eq!((d[1].default.as_str(), d[1].value.as_str()), ("4", "7"));
        assert_eq!(d[2].kind, ParamKind::I64 { min: -10, max: 10 });
        assert_eq!(d[2].value, "-3");
        assert_eq!((d[3].kind.clone(), d[3].value.as_str()), (ParamKind::Bool, "true"));
        assert_eq!(d[4].kind, ParamKind::Choice(vec!["a".into(), "b".into()]));
        assert_eq!((d[4].default.as_str(), d[4].value.as_str()), ("a", "b"));
        assert_eq!((d[5].kind.clone(), d[5].value.as_str()), (ParamKind::Text, "auto"));
        // The described values are the effective ones, and every value reads back through `--set`.
        let effective = p.effective();
        assert!(d.iter().all(|i| effective[&i.key] == i.value));
        let again = Params::parse(&d.iter().map(|i| format!("{}={}", i.key, i.value)).collect::<Vec<_>>()).unwrap();
        assert_eq!(again.f32("radius", 1.0, 0.0, f32::INFINITY).unwrap(), 0.5);
        assert!(again.bool("flag", false).unwrap());
    }

    #[test]
    fn a_key_read_twice_keeps_its_place_and_the_latest_reading() {
        let p = Params::parse(&["b=2"]).unwrap();
        p.u32("a", 1, 0, 10).unwrap();
        p.u32("b", 1, 0, 10).unwrap();
        p.u32("a", 5, 0, 100).unwrap();
        let d = p.described();
        assert_eq!(d.len(), 2);
        assert_eq!((d[0].key.as_str(), d[0].default.as_str(), d[0].kind.clone()), ("a", "5", ParamKind::U32 { min: 0, max: 100 }));
    }

    #[test]
    fn every_registered_technique_describes_what_it_reads() {
        // Parameters of the techniques this crate registers: read, described, all with a kind.
        let scene = glimpse_scene::load("cornell").unwrap();
        let registry = crate::registry::Registry::new(crate::techniques());
        for t in registry.all() {
            let params = Params::default();
            if (t.create)(&scene, &crate::Settings::default(), &params).is_err() {
                continue;
            }
            let d = params.described();
            println!("{}: {}", t.id, d.iter().map(|i| format!("{}={}", i.key, i.value)).collect::<Vec<_>>().join(", "));
            assert_eq!(d.len(), params.effective().len(), "{}: every effective key is described", t.id);
            assert!(d.iter().all(|i| i.value == i.default), "{}: with nothing set, every value is the default", t.id);
        }
    }
}
