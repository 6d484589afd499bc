//! Knobs and settings. A method declares each knob with the type its
//! settings take (`Knob::new::<u32>("spp", ...)`); a setting holds typed
//! values, read from text once, where a grid spec or a cached choice is
//! read, and keeps the text each value was given as, which reports show.

use std::collections::BTreeMap;

use serde::{Serialize, Serializer};

use crate::choice::Choice;

/// A knob a method declares: its name (the command-line flag without
/// `--`), what it does, the kind of its values and the values its default
/// grid tries.
#[derive(Debug, Clone, Copy)]
pub struct Knob {
    /// The knob's name in grids and settings.
    pub name: &'static str,
    /// What the knob does, in a few words.
    pub help: &'static str,
    /// The values it takes.
    pub kind: KnobKind,
    /// Values swept when the user names no grid for this knob (empty: the
    /// method's default value only), spelled as a grid spec spells them.
    pub default_grid: &'static [&'static str],
}

impl Knob {
    /// A knob whose values are `T`s, the type the method's settings take.
    pub const fn new<T: KnobType>(
        name: &'static str,
        help: &'static str,
        default_grid: &'static [&'static str],
    ) -> Knob {
        Knob {
            name,
            help,
            kind: T::KIND,
            default_grid,
        }
    }
}

/// The values a knob takes, and how its text is read.
#[derive(Debug, Clone, Copy)]
pub enum KnobKind {
    /// Integers from `min` to `max`, the range of the integer type the
    /// method takes; text outside it is refused as Rust's integer parser
    /// refuses it. Limits of the method's own (`spp` at least 1, ...) are
    /// its settings' checks, not the knob's.
    Integer {
        /// The smallest value.
        min: i128,
        /// The largest value.
        max: i128,
    },
    /// Numbers, read in single precision (`f32`) where `single`, else in
    /// double.
    Float {
        /// The method takes `f32`.
        single: bool,
    },
    /// `on` or `off` (also `true` or `false`).
    OnOff,
    /// The names of an enum of named values (such as
    /// [`Estimator`](crate::Estimator)'s `raymarch`, `tangent-sphere`, ...),
    /// read case-insensitively.
    Named {
        /// The canonical name of the value `text` names, or why none.
        parse: fn(&str) -> Result<&'static str, String>,
    },
}

/// A knob's value, as its method takes it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum KnobValue {
    /// A value of a [`KnobKind::Integer`] knob.
    Integer(i128),
    /// A value of a [`KnobKind::Float`] knob (an `f32` knob's widened exactly).
    Float(f64),
    /// A value of a [`KnobKind::OnOff`] knob.
    OnOff(bool),
    /// A value of a [`KnobKind::Named`] knob: its canonical name.
    Named(&'static str),
}

impl KnobKind {
    /// The value `text` spells; the error says why it is not one (Rust's
    /// parse message, the choice's, or "expected on or off").
    pub fn parse(self, text: &str) -> Result<KnobValue, String> {
        match self {
            KnobKind::Integer { min, max } => parse_integer(text, min, max).map(KnobValue::Integer),
            KnobKind::Float { single: true } => text
                .parse::<f32>()
                .map(|v| KnobValue::Float(v.into()))
                .map_err(|e| e.to_string()),
            KnobKind::Float { single: false } => text.parse::<f64>().map(KnobValue::Float).map_err(|e| e.to_string()),
            KnobKind::OnOff => match text {
                "on" | "true" => Ok(KnobValue::OnOff(true)),
                "off" | "false" => Ok(KnobValue::OnOff(false)),
                _ => Err("expected on or off".into()),
            },
            KnobKind::Named { parse } => parse(text).map(KnobValue::Named),
        }
    }
}

/// `text` as an integer in `min..=max`, refused with the messages of
/// Rust's integer parser (`"-1".parse::<u32>()`: "invalid digit found in
/// string"), so that a knob refuses what the type it stands for refuses.
fn parse_integer(text: &str, min: i128, max: i128) -> Result<i128, String> {
    const TOO_LARGE: &str = "number too large to fit in target type";
    const TOO_SMALL: &str = "number too small to fit in target type";
    let value = if min >= 0 {
        // An unsigned type has no sign to read: "-1" is an invalid digit.
        let v = text.parse::<u128>().map_err(|e| e.to_string())?;
        i128::try_from(v).map_err(|_| TOO_LARGE.to_string())?
    } else {
        text.parse::<i128>().map_err(|e| e.to_string())?
    };
    if value > max {
        Err(TOO_LARGE.into())
    } else if value < min {
        Err(TOO_SMALL.into())
    } else {
        Ok(value)
    }
}

/// A type a knob's values have: integers, floats, `bool` (on/off) and the
/// library's enums of named values (such as [`Estimator`](crate::Estimator)).
pub trait KnobType: Copy {
    /// The kind of knob whose values are of this type.
    const KIND: KnobKind;
    /// The value as a knob holds it.
    fn to_value(self) -> KnobValue;
    /// The value a knob holds; `None` where it is not of this type.
    fn from_value(value: KnobValue) -> Option<Self>;
    /// How the value is spelled where code, not a user, gives it.
    fn spelling(self) -> String;
}

macro_rules! integer_knobs {
    ($($t:ty),*) => {$(
        impl KnobType for $t {
            const KIND: KnobKind = KnobKind::Integer { min: <$t>::MIN as i128, max: <$t>::MAX as i128 };
            fn to_value(self) -> KnobValue {
                KnobValue::Integer(self as i128)
            }
            fn from_value(value: KnobValue) -> Option<Self> {
                match value {
                    KnobValue::Integer(v) => <$t>::try_from(v).ok(),
                    _ => None,
                }
            }
            fn spelling(self) -> String {
                self.to_string()
            }
        }
    )*};
}
integer_knobs!(u32, u64, usize, i32, i64);

impl KnobType for f32 {
    const KIND: KnobKind = KnobKind::Float { single: true };
    fn to_value(self) -> KnobValue {
        KnobValue::Float(self.into())
    }
    fn from_value(value: KnobValue) -> Option<Self> {
        match value {
            // Exact: an f32 knob's values were read as f32.
            KnobValue::Float(v) => Some(v as f32),
            _ => None,
        }
    }
    fn spelling(self) -> String {
        self.to_string()
    }
}

impl KnobType for f64 {
    const KIND: KnobKind = KnobKind::Float { single: false };
    fn to_value(self) -> KnobValue {
        KnobValue::Float(self)
    }
    fn from_value(value: KnobValue) -> Option<Self> {
        match value {
            KnobValue::Float(v) => Some(v),
            _ => None,
        }
    }
    fn spelling(self) -> String {
        self.to_string()
    }
}

impl KnobType for bool {
    const KIND: KnobKind = KnobKind::OnOff;
    fn to_value(self) -> KnobValue {
        KnobValue::OnOff(self)
    }
    fn from_value(value: KnobValue) -> Option<Self> {
        match value {
            KnobValue::OnOff(v) => Some(v),
            _ => None,
        }
    }
    fn spelling(self) -> String {
        if self { "on" } else { "off" }.into()
    }
}

impl<T: Choice> KnobType for T {
    const KIND: KnobKind = KnobKind::Named { parse: parse_name::<T> };
    fn to_value(self) -> KnobValue {
        KnobValue::Named(self.name())
    }
    fn from_value(value: KnobValue) -> Option<Self> {
        match value {
            KnobValue::Named(name) => T::ALL.iter().copied().find(|v| v.name() == name),
            _ => None,
        }
    }
    fn spelling(self) -> String {
        self.name().into()
    }
}

fn parse_name<T: Choice>(text: &str) -> Result<&'static str, String> {
    T::parse(text).map(T::name)
}

/// A knob's value and the text it was given as (what reports show).
#[derive(Debug, Clone, PartialEq)]
pub struct Given {
    /// The value.
    pub value: KnobValue,
    /// Its text: the user's spelling, or the canonical one where code gave it.
    pub text: String,
}

impl Given {
    /// `value`, spelled canonically.
    pub fn of<T: KnobType>(value: T) -> Given {
        Given {
            value: value.to_value(),
            text: value.spelling(),
        }
    }

    /// `text` read as a value of `knob`; the error is the parse's.
    pub fn read(knob: &Knob, text: &str) -> Result<Given, String> {
        Ok(Given {
            value: knob.kind.parse(text)?,
            text: text.to_string(),
        })
    }
}

/// One setting: a value for every knob the grid varies or fixes (knobs
/// left out keep the method's default). Serialised as a map of knob name
/// to text.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Setting(BTreeMap<&'static str, Given>);

impl Setting {
    /// The value of `knob`; `None` where the setting leaves the method's
    /// default.
    ///
    /// # Panics
    /// Where the knob's values are not `T`s: the method asked for another
    /// type than it declared.
    pub fn get<T: KnobType>(&self, knob: &str) -> Option<T> {
        let given = self.0.get(knob)?;
        let value = T::from_value(given.value);
        assert!(
            value.is_some(),
            "knob '{knob}' holds {:?}, not a {}",
            given.value,
            std::any::type_name::<T>()
        );
        value
    }

    /// The setting with `knob` set to `value`.
    pub fn with<T: KnobType>(self, knob: &'static str, value: T) -> Setting {
        self.with_given(knob, Given::of(value))
    }

    /// The setting with `knob` set to `given`.
    pub fn with_given(mut self, knob: &'static str, given: Given) -> Setting {
        self.0.insert(knob, given);
        self
    }

    /// The text `knob`'s value was given as; `None` where the setting
    /// leaves it.
    pub fn text(&self, knob: &str) -> Option<&str> {
        self.0.get(knob).map(|g| g.text.as_str())
    }

    /// Every knob the setting sets, by name, with its text.
    pub fn texts(&self) -> impl Iterator<Item = (&'static str, &str)> {
        self.0.iter().map(|(k, g)| (*k, g.text.as_str()))
    }

    /// `knob=value` pairs, space-separated, for labels.
    pub fn label(&self) -> String {
        let parts: Vec<String> = self.texts().map(|(k, v)| format!("{k}={v}")).collect();
        parts.join(" ")
    }

    /// The setting `texts` spell (a map of knob name to text, as a setting
    /// is serialised) over `knobs`; `None` where a name is not one of the
    /// knobs or a text does not read as its value.
    pub fn read(texts: &BTreeMap<String, String>, knobs: &[Knob]) -> Option<Setting> {
        let mut setting = Setting::default();
        for (name, text) in texts {
            let knob = knobs.iter().find(|k| k.name == name)?;
            setting = setting.with_given(knob.name, Given::read(knob, text).ok()?);
        }
        Some(setting)
    }
}

impl Serialize for Setting {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.collect_map(self.texts())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, Clone, Copy, PartialEq, Eq)]
    enum Shape {
        Round,
        FlatTop,
    }
    crate::choice!(Shape { Round = "round", FlatTop = "flat-top" });

    #[test]
    fn integers_are_refused_as_their_type_refuses_them() {
        for text in ["-1", "4294967296", "x", "1.5", "-", "+"] {
            assert_eq!(
                u32::KIND.parse(text).unwrap_err(),
                text.parse::<u32>().unwrap_err().to_string(),
                "{text}"
            );
        }
        for text in [
            "-9223372036854775809",
            "9223372036854775808",
            "1e3",
            "99999999999999999999999999999999999999999",
        ] {
            assert_eq!(
                i64::KIND.parse(text).unwrap_err(),
                text.parse::<i64>().unwrap_err().to_string(),
                "{text}"
            );
        }
        assert_eq!(
            usize::KIND.parse("18446744073709551615"),
            Ok(KnobValue::Integer(usize::MAX as i128))
        );
        assert_eq!(u32::KIND.parse("+08"), Ok(KnobValue::Integer(8)));
        assert_eq!(i64::KIND.parse("-5"), Ok(KnobValue::Integer(-5)));
    }

    #[test]
    fn floats_on_off_and_names_read_as_the_method_takes_them() {
        let tenth = f32::KIND.parse("0.1").unwrap();
        assert_eq!(f32::from_value(tenth), Some(0.1f32));
        assert_eq!(f64::KIND.parse("0.1"), Ok(KnobValue::Float(0.1)));
        assert_eq!(
            f32::KIND.parse("x").unwrap_err(),
            "x".parse::<f32>().unwrap_err().to_string()
        );
        assert_eq!(bool::KIND.parse("true"), Ok(KnobValue::OnOff(true)));
        assert_eq!(bool::KIND.parse("off"), Ok(KnobValue::OnOff(false)));
        assert_eq!(bool::KIND.parse("yes").unwrap_err(), "expected on or off");
        assert_eq!(Shape::KIND.parse("Flat-Top"), Ok(KnobValue::Named("flat-top")));
        assert_eq!(Shape::KIND.parse("square").unwrap_err(), "invalid variant: square");
    }

    #[test]
    fn a_setting_keeps_typed_values_and_their_spelling() {
        const KNOBS: [Knob; 3] = [
            Knob::new::<u32>("spp", "", &[]),
            Knob::new::<bool>("filter", "", &[]),
            Knob::new::<Shape>("shape", "", &[]),
        ];
        let s = Setting::default()
            .with_given("spp", Given::read(&KNOBS[0], "08").unwrap())
            .with("filter", true)
            .with("shape", Shape::FlatTop);
        assert_eq!(s.get::<u32>("spp"), Some(8));
        assert_eq!(s.get::<bool>("filter"), Some(true));
        assert_eq!(s.get::<Shape>("shape"), Some(Shape::FlatTop));
        assert_eq!(s.get::<u32>("steps"), None);
        assert_eq!(s.label(), "filter=on shape=flat-top spp=08");
        let json = serde_json::to_string(&s).unwrap();
        assert_eq!(json, r#"{"filter":"on","shape":"flat-top","spp":"08"}"#);
        let texts: BTreeMap<String, String> = serde_json::from_str(&json).unwrap();
        assert_eq!(Setting::read(&texts, &KNOBS), Some(s));
        let bad: BTreeMap<String, String> = [("spp".into(), "x".into())].into();
        assert_eq!(Setting::read(&bad, &KNOBS), None);
        let unknown: BTreeMap<String, String> = [("res".into(), "8".into())].into();
        assert_eq!(Setting::read(&unknown, &KNOBS), None);
    }

    #[test]
    #[should_panic(expected = "not a")]
    fn asking_for_another_type_than_declared_is_a_bug() {
        Setting::default().with("spp", 8u32).get::<bool>("spp");
    }
}
