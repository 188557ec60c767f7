//! Technique parameters from `--set key=value`. Each technique reads the keys it knows with a
//! default (the paper's setting) and a valid range; [`Params::finish`] then rejects any key no
//! one read, so a typo is an error rather than a silently ignored setting.

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
        self.effective.borrow_mut().insert(key.to_owned(), v.to_string());
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
        self.effective.borrow_mut().insert(key.to_owned(), v.to_string());
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
        self.effective.borrow_mut().insert(key.to_owned(), v.to_string());
        Ok(v)
    }

    pub fn bool(&self, key: &str, default: bool) -> Result<bool, ParamError> {
        let v = match self.raw(key).map(|s| s.as_str()) {
            None => default,
            Some("true" | "1" | "yes" | "on") => true,
            Some("false" | "0" | "no" | "off") => false,
            Some(s) => return Err(invalid(key, s, "expected true or false")),
        };
        self.effective.borrow_mut().insert(key.to_owned(), v.to_string());
        Ok(v)
    }

    /// The raw value (or `default`), for keys that take a word or a number (`points=auto`).
    pub fn text(&self, key: &str, default: &str) -> String {
        let v = self.raw(key).cloned().unwrap_or_else(|| default.to_owned());
        self.effective.borrow_mut().insert(key.to_owned(), v.clone());
        v
    }

    /// One of `choices`.
    pub fn choice(&self, key: &str, default: &str, choices: &[&str]) -> Result<String, ParamError> {
        let v = self.raw(key).cloned().unwrap_or_else(|| default.to_owned());
        if !choices.contains(&v.as_str()) {
            return Err(invalid(key, &v, &format!("expected one of {}", choices.join(", "))));
        }
        self.effective.borrow_mut().insert(key.to_owned(), v.clone());
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
}
