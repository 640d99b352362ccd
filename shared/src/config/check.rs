//! What a section's `validate()` returns: every value it refuses, each naming its key and what is
//! allowed. The config loader prefixes them with the file; a library that is handed a section
//! directly (a classifier built in a test, a bench) gets the same errors.

use std::fmt;

/// The range a value must lie in.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Allowed {
    /// Lower bound.
    pub lo: f64,
    /// Upper bound (inclusive).
    pub hi: f64,
    /// The lower bound itself is refused.
    pub lo_exclusive: bool,
}

impl Allowed {
    /// `lo` to `hi`, both included.
    pub const fn closed(lo: f64, hi: f64) -> Self {
        Allowed {
            lo,
            hi,
            lo_exclusive: false,
        }
    }

    /// Above `lo`, up to `hi` included.
    pub const fn above(lo: f64, hi: f64) -> Self {
        Allowed {
            lo,
            hi,
            lo_exclusive: true,
        }
    }

    /// Whether `value` lies in the range (NaN never does).
    pub fn contains(&self, value: f64) -> bool {
        let above_lo = if self.lo_exclusive {
            value > self.lo
        } else {
            value >= self.lo
        };
        above_lo && value <= self.hi
    }
}

impl fmt::Display for Allowed {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.lo_exclusive {
            write!(f, "above {} up to {}", self.lo, self.hi)
        } else {
            write!(f, "{} to {}", self.lo, self.hi)
        }
    }
}

/// One value a section refuses.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ParamError {
    /// A value outside its range.
    #[error("{key} = {value} is out of range: allowed {allowed}")]
    OutOfRange {
        /// The key, with its section (`foliage.k3`).
        key: String,
        /// The value given.
        value: f64,
        /// What is allowed.
        allowed: Allowed,
    },
    /// A rule that ties a key to others (`foliage.d_min_m` below `foliage.d_max_m`, an odd
    /// kernel, a file that must be named).
    #[error("{message}")]
    Rule {
        /// The key at fault, with its section.
        key: String,
        /// What is wrong and what is allowed, naming the keys.
        message: String,
    },
}

impl ParamError {
    /// The key at fault, with its section.
    pub fn key(&self) -> &str {
        match self {
            ParamError::OutOfRange { key, .. } | ParamError::Rule { key, .. } => key,
        }
    }
}

/// Every value a section (or a whole config) refuses, in the order checked; shown joined by
/// `; `.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{}", join(.0))]
pub struct Invalid(pub Vec<ParamError>);

fn join(errors: &[ParamError]) -> String {
    let shown: Vec<String> = errors.iter().map(ToString::to_string).collect();
    shown.join("; ")
}

impl Invalid {
    /// The error about `key`, if there is one.
    pub fn get(&self, key: &str) -> Option<&ParamError> {
        self.0.iter().find(|e| e.key() == key)
    }
}

/// Collects what a `validate()` refuses.
#[derive(Debug, Default)]
pub struct Checks(Vec<ParamError>);

impl Checks {
    /// Refuses `value` unless it lies in `allowed`.
    pub fn range(&mut self, key: impl Into<String>, value: f64, allowed: Allowed) {
        if !allowed.contains(value) {
            self.0.push(ParamError::OutOfRange {
                key: key.into(),
                value,
                allowed,
            });
        }
    }

    /// Refuses `value` unless `lo <= value <= hi`.
    pub fn check(&mut self, key: impl Into<String>, value: f64, lo: f64, hi: f64) {
        self.range(key, value, Allowed::closed(lo, hi));
    }

    /// Refuses `value` unless it is a finite number (for a value with no range of its own:
    /// TOML reads `nan` and `inf`).
    pub fn finite(&mut self, key: impl Into<String>, value: f64) {
        if !value.is_finite() {
            let key = key.into();
            self.0.push(ParamError::Rule {
                message: format!("{key} = {value} is not a finite number"),
                key,
            });
        }
    }

    /// Refuses every non-finite float (`nan`, `inf`, `-inf`) anywhere in `table`, naming its
    /// dotted key (`prefix` before it, e.g. `robot`): whatever a section does with the value,
    /// TOML's `nan` and `inf` never reach it.
    pub fn finite_table(&mut self, prefix: &str, table: &toml::Table) {
        fn walk(c: &mut Checks, key: String, v: &toml::Value) {
            match v {
                toml::Value::Float(f) => c.finite(key, *f),
                toml::Value::Array(a) => {
                    for (i, v) in a.iter().enumerate() {
                        walk(c, format!("{key}[{i}]"), v);
                    }
                }
                toml::Value::Table(t) => {
                    for (k, v) in t {
                        let key = if key.is_empty() {
                            k.clone()
                        } else {
                            format!("{key}.{k}")
                        };
                        walk(c, key, v);
                    }
                }
                _ => {}
            }
        }
        for (k, v) in table {
            let key = if prefix.is_empty() {
                k.clone()
            } else {
                format!("{prefix}.{k}")
            };
            walk(self, key, v);
        }
    }

    /// Refuses `key` with `message` unless `ok`.
    pub fn require(&mut self, ok: bool, key: impl Into<String>, message: impl Into<String>) {
        if !ok {
            self.0.push(ParamError::Rule {
                key: key.into(),
                message: message.into(),
            });
        }
    }

    /// Adds what another check refused.
    pub fn merge(&mut self, checked: Result<(), Invalid>) {
        if let Err(Invalid(e)) = checked {
            self.0.extend(e);
        }
    }

    /// Ok when nothing was refused.
    pub fn finish(self) -> Result<(), Invalid> {
        if self.0.is_empty() {
            Ok(())
        } else {
            Err(Invalid(self.0))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_name_key_value_and_range() {
        let mut c = Checks::default();
        c.check("velodyne.rpm", 50.0, 300.0, 1200.0);
        c.range("foliage.k3", 0.0, Allowed::above(0.0, 1000.0));
        c.check("velodyne.scan_laser", f64::NAN, 0.0, 15.0);
        c.check("map.cells", 200.0, 10.0, 2000.0);
        c.require(
            false,
            "planner.kernel_cells",
            "planner.kernel_cells = 12 must be odd",
        );
        let e = c.finish().expect_err("four refused");
        assert_eq!(e.0.len(), 4);
        assert_eq!(
            e.0[0].to_string(),
            "velodyne.rpm = 50 is out of range: allowed 300 to 1200"
        );
        assert_eq!(
            e.0[1].to_string(),
            "foliage.k3 = 0 is out of range: allowed above 0 up to 1000"
        );
        assert!(e.get("velodyne.scan_laser").is_some());
        assert_eq!(
            e.get("planner.kernel_cells").map(ParamError::key),
            Some("planner.kernel_cells")
        );
        assert!(e.to_string().contains("; foliage.k3 = 0"), "{e}");
        assert_eq!(Checks::default().finish(), Ok(()));
    }

    /// Issue 23 item 3: TOML reads `nan` and `inf`; a key without a range of its own let them
    /// through. Every non-finite float of a table is refused, named by its dotted key.
    #[test]
    fn issue23_3_non_finite_values_accepted_every_toml_nan_and_inf_is_named() {
        let t: toml::Table = toml::from_str(
            "a = 1.0\nb = nan\n[s]\nc = -inf\nd = [1.0, +inf]\n[[s.l]]\nlow = -nan\nhigh = 2.0\n",
        )
        .expect("toml");
        let mut c = Checks::default();
        c.finite_table("", &t);
        let e = c.finish().expect_err("four refused");
        let keys: Vec<&str> = e.0.iter().map(ParamError::key).collect();
        assert_eq!(keys, ["b", "s.c", "s.d[1]", "s.l[0].low"], "{e}");
        assert!(
            e.to_string().contains("s.c = -inf is not a finite number"),
            "{e}"
        );
        let mut c = Checks::default();
        c.finite("x", 1.5);
        c.finite_table("robot", &toml::from_str("radius_m = 0.3").expect("toml"));
        assert_eq!(c.finish(), Ok(()));
    }
}
