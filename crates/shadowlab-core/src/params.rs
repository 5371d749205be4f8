//! Named, typed parameters with defaults, ranges and validation.
//!
//! One mechanism serves the options of built-in scenes (`terrain:sun=0.27`) and the parameters of
//! shadow techniques (`pcf:taps=16`, `--set map_size=2048`): the CLI, the reports and a UI all read the
//! same definitions, so a parameter is declared once, with its range and its documentation.

use std::fmt;

/// The type and the valid range of a parameter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ParamKind {
    Bool,
    /// An integer in `min..=max`.
    Int {
        min: i64,
        max: i64,
    },
    /// A finite real number in `min..=max`.
    Float {
        min: f64,
        max: f64,
    },
    /// One of a fixed set of names.
    Choice(&'static [&'static str]),
}

/// A parameter value.
#[derive(Debug, Clone, PartialEq)]
pub enum ParamValue {
    Bool(bool),
    Int(i64),
    Float(f64),
    Choice(&'static str),
}

impl fmt::Display for ParamValue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Bool(v) => write!(f, "{v}"),
            Self::Int(v) => write!(f, "{v}"),
            Self::Float(v) => write!(f, "{v}"),
            Self::Choice(v) => write!(f, "{v}"),
        }
    }
}

impl ParamValue {
    /// The value as JSON (numbers stay numbers, so scripts can compare them).
    pub fn to_json(&self) -> serde_json::Value {
        match self {
            Self::Bool(v) => serde_json::Value::Bool(*v),
            Self::Int(v) => serde_json::Value::from(*v),
            Self::Float(v) => serde_json::Value::from(*v),
            Self::Choice(v) => serde_json::Value::from(*v),
        }
    }
}

/// The declaration of one parameter.
#[derive(Debug, Clone)]
pub struct ParamDef {
    pub name: &'static str,
    pub kind: ParamKind,
    pub default: ParamValue,
    /// One line for `--help`-style listings.
    pub doc: &'static str,
}

impl ParamDef {
    pub const fn bool(name: &'static str, default: bool, doc: &'static str) -> Self {
        Self { name, kind: ParamKind::Bool, default: ParamValue::Bool(default), doc }
    }

    pub const fn int(name: &'static str, default: i64, min: i64, max: i64, doc: &'static str) -> Self {
        Self { name, kind: ParamKind::Int { min, max }, default: ParamValue::Int(default), doc }
    }

    pub const fn float(name: &'static str, default: f64, min: f64, max: f64, doc: &'static str) -> Self {
        Self { name, kind: ParamKind::Float { min, max }, default: ParamValue::Float(default), doc }
    }

    pub const fn choice(
        name: &'static str,
        default: &'static str,
        choices: &'static [&'static str],
        doc: &'static str,
    ) -> Self {
        Self { name, kind: ParamKind::Choice(choices), default: ParamValue::Choice(default), doc }
    }

    /// A human-readable range: `1..=16`, `[0, 1]`, `uniform|log|practical`, `true|false`.
    pub fn range_text(&self) -> String {
        match self.kind {
            ParamKind::Bool => "true|false".to_owned(),
            ParamKind::Int { min, max } => format!("{min}..={max}"),
            ParamKind::Float { min, max } => format!("[{min}, {max}]"),
            ParamKind::Choice(choices) => choices.join("|"),
        }
    }

    /// Parses and range-checks `text` for this parameter.
    pub fn parse(&self, text: &str) -> Result<ParamValue, ParamError> {
        let text = text.trim();
        let bad = |reason: String| ParamError::BadValue { name: self.name.to_owned(), value: text.to_owned(), reason };
        match self.kind {
            ParamKind::Bool => match text.to_ascii_lowercase().as_str() {
                "true" | "1" | "yes" | "on" => Ok(ParamValue::Bool(true)),
                "false" | "0" | "no" | "off" => Ok(ParamValue::Bool(false)),
                _ => Err(bad("expected true or false".to_owned())),
            },
            ParamKind::Int { min, max } => {
                let v: i64 = text.parse().map_err(|_| bad("expected an integer".to_owned()))?;
                if v < min || v > max {
                    return Err(bad(format!("out of range {min}..={max}")));
                }
                Ok(ParamValue::Int(v))
            }
            ParamKind::Float { min, max } => {
                let v: f64 = text.parse().map_err(|_| bad("expected a number".to_owned()))?;
                if !v.is_finite() {
                    return Err(bad("must be finite".to_owned()));
                }
                if v < min || v > max {
                    return Err(bad(format!("out of range [{min}, {max}]")));
                }
                Ok(ParamValue::Float(v))
            }
            ParamKind::Choice(choices) => choices
                .iter()
                .find(|c| c.eq_ignore_ascii_case(text))
                .map(|c| ParamValue::Choice(c))
                .ok_or_else(|| bad(format!("expected one of {}", choices.join(", ")))),
        }
    }
}

/// A malformed parameter assignment.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ParamError {
    #[error("unknown parameter '{name}' (known: {known})")]
    Unknown { name: String, known: String },
    #[error("parameter '{name}' = '{value}': {reason}")]
    BadValue { name: String, value: String, reason: String },
    #[error("malformed assignment '{text}': expected KEY=VALUE")]
    Malformed { text: String },
}

/// Values for a list of parameter definitions: every parameter always has a valid value.
#[derive(Debug, Clone)]
pub struct ParamSet {
    defs: &'static [ParamDef],
    values: Vec<ParamValue>,
}

impl ParamSet {
    /// All parameters at their defaults.
    pub fn new(defs: &'static [ParamDef]) -> Self {
        Self { defs, values: defs.iter().map(|d| d.default.clone()).collect() }
    }

    pub fn defs(&self) -> &'static [ParamDef] {
        self.defs
    }

    pub fn has(&self, name: &str) -> bool {
        self.index(name).is_some()
    }

    fn index(&self, name: &str) -> Option<usize> {
        self.defs.iter().position(|d| d.name == name)
    }

    /// Sets `name` from text, validating type and range.
    pub fn set(&mut self, name: &str, text: &str) -> Result<(), ParamError> {
        let i = self.index(name).ok_or_else(|| ParamError::Unknown {
            name: name.to_owned(),
            known: if self.defs.is_empty() {
                "none".to_owned()
            } else {
                self.defs.iter().map(|d| d.name).collect::<Vec<_>>().join(", ")
            },
        })?;
        self.values[i] = self.defs[i].parse(text)?;
        Ok(())
    }

    /// Applies `K=V` assignments in order.
    pub fn apply<'a>(&mut self, assignments: impl IntoIterator<Item = (&'a str, &'a str)>) -> Result<(), ParamError> {
        for (k, v) in assignments {
            self.set(k, v)?;
        }
        Ok(())
    }

    pub fn value(&self, name: &str) -> Option<&ParamValue> {
        self.index(name).map(|i| &self.values[i])
    }

    /// `(definition, current value)` pairs in declaration order.
    pub fn iter(&self) -> impl Iterator<Item = (&'static ParamDef, &ParamValue)> {
        self.defs.iter().zip(&self.values)
    }

    /// The value of a boolean parameter. Panics only on a programming error (a name that the
    /// definitions do not declare with this type), never on user input.
    pub fn bool(&self, name: &str) -> bool {
        match self.value(name) {
            Some(ParamValue::Bool(v)) => *v,
            other => panic!("parameter '{name}' is not a declared bool: {other:?}"),
        }
    }

    pub fn int(&self, name: &str) -> i64 {
        match self.value(name) {
            Some(ParamValue::Int(v)) => *v,
            other => panic!("parameter '{name}' is not a declared int: {other:?}"),
        }
    }

    pub fn float(&self, name: &str) -> f64 {
        match self.value(name) {
            Some(ParamValue::Float(v)) => *v,
            other => panic!("parameter '{name}' is not a declared float: {other:?}"),
        }
    }

    pub fn choice(&self, name: &str) -> &'static str {
        match self.value(name) {
            Some(ParamValue::Choice(v)) => v,
            other => panic!("parameter '{name}' is not a declared choice: {other:?}"),
        }
    }

    /// `{"name": value, ...}` for reports.
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::Value::Object(self.iter().map(|(d, v)| (d.name.to_owned(), v.to_json())).collect())
    }
}

/// Splits `KEY=VALUE`.
pub fn split_assignment(text: &str) -> Result<(&str, &str), ParamError> {
    match text.split_once('=') {
        Some((k, v)) if !k.trim().is_empty() => Ok((k.trim(), v.trim())),
        _ => Err(ParamError::Malformed { text: text.to_owned() }),
    }
}

/// `KEY=VALUE` pairs in the order given.
pub type Assignments<'a> = Vec<(&'a str, &'a str)>;

/// Splits a spec `ID` or `ID:K=V,K=V,...` into the id and its assignments.
pub fn parse_spec(spec: &str) -> Result<(&str, Assignments<'_>), ParamError> {
    let (id, rest) = match spec.split_once(':') {
        Some((id, rest)) => (id.trim(), Some(rest)),
        None => (spec.trim(), None),
    };
    let mut assignments = Vec::new();
    if let Some(rest) = rest {
        for part in rest.split(',').filter(|p| !p.trim().is_empty()) {
            assignments.push(split_assignment(part)?);
        }
    }
    Ok((id, assignments))
}

#[cfg(test)]
mod tests {
    use super::*;

    static DEFS: &[ParamDef] = &[
        ParamDef::bool("focus", false, "focus the map"),
        ParamDef::int("splits", 1, 1, 16, "cascades"),
        ParamDef::float("lambda", 0.5, 0.0, 1.0, "split blend"),
        ParamDef::choice("scheme", "log", &["uniform", "log", "practical"], "split scheme"),
    ];

    #[test]
    fn defaults_and_assignment() {
        let mut p = ParamSet::new(DEFS);
        assert!(!p.bool("focus"));
        assert_eq!(p.choice("scheme"), "log");
        p.apply([("focus", "true"), ("splits", "4"), ("lambda", "0.25"), ("scheme", "Uniform")]).unwrap();
        assert!(p.bool("focus"));
        assert_eq!(p.int("splits"), 4);
        assert_eq!(p.float("lambda"), 0.25);
        assert_eq!(p.choice("scheme"), "uniform");
        assert_eq!(p.to_json()["splits"], 4);
    }

    #[test]
    fn errors_name_the_parameter() {
        let mut p = ParamSet::new(DEFS);
        let e = p.set("splits", "17").unwrap_err();
        assert!(e.to_string().contains("splits") && e.to_string().contains("1..=16"), "{e}");
        assert!(matches!(p.set("lambda", "nan"), Err(ParamError::BadValue { .. })));
        assert!(matches!(p.set("lambda", "inf"), Err(ParamError::BadValue { .. })));
        assert!(matches!(p.set("focus", "maybe"), Err(ParamError::BadValue { .. })));
        assert!(matches!(p.set("scheme", "cubic"), Err(ParamError::BadValue { .. })));
        let e = p.set("bias", "1").unwrap_err();
        assert!(e.to_string().contains("focus, splits, lambda, scheme"), "{e}");
        // A failed assignment leaves the old value.
        assert_eq!(p.int("splits"), 1);
    }

    #[test]
    fn specs() {
        let (id, a) = parse_spec("cascaded:splits=4,scheme=log").unwrap();
        assert_eq!(id, "cascaded");
        assert_eq!(a, vec![("splits", "4"), ("scheme", "log")]);
        assert_eq!(parse_spec("hard").unwrap(), ("hard", vec![]));
        assert!(parse_spec("pcf:taps").is_err());
        assert!(parse_spec("pcf:=3").is_err());
    }
}
