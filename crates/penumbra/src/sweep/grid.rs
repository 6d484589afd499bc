//! A grid of knob settings: `--grid 'spp=4,8,16'` per knob, the method's
//! default grid for knobs not named, every combination in order.

use std::collections::BTreeMap;

use crate::error::{Error, Result};

/// A knob a method declares: its name (the command-line flag without
/// `--`), what it does, and the values its default grid tries.
#[derive(Debug, Clone, Copy)]
pub struct Knob {
    pub name: &'static str,
    pub help: &'static str,
    /// Values swept when the user names no grid for this knob (empty: the
    /// method's default value only).
    pub default_grid: &'static [&'static str],
}

/// One setting: a value for every knob the grid varies or fixes.
#[derive(Debug, Clone, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(transparent)]
pub struct Setting(pub BTreeMap<String, String>);

impl Setting {
    /// The value of `knob`, parsed; `None` where the setting leaves the
    /// method's default.
    pub fn get<T: std::str::FromStr>(&self, knob: &str) -> Result<Option<T>>
    where
        T::Err: std::fmt::Display,
    {
        self.0
            .get(knob)
            .map(|v| v.parse::<T>().map_err(|e| bad_value(knob, v, e)))
            .transpose()
    }

    /// The value of a knob whose values are names, spelled as on the
    /// command line.
    pub fn get_enum<T: crate::choice::Choice>(&self, knob: &str) -> Result<Option<T>> {
        self.0
            .get(knob)
            .map(|v| T::parse(v).map_err(|e| bad_value(knob, v, e)))
            .transpose()
    }

    /// `on`/`off` (also `true`/`false`).
    pub fn get_on_off(&self, knob: &str) -> Result<Option<bool>> {
        self.0
            .get(knob)
            .map(|v| match v.as_str() {
                "on" | "true" => Ok(true),
                "off" | "false" => Ok(false),
                _ => Err(bad_value(knob, v, "expected on or off")),
            })
            .transpose()
    }

    /// `knob=value` pairs, comma-separated, for labels.
    pub fn label(&self) -> String {
        let parts: Vec<String> = self.0.iter().map(|(k, v)| format!("{k}={v}")).collect();
        parts.join(" ")
    }
}

fn bad_value(knob: &str, value: &str, e: impl std::fmt::Display) -> Error {
    Error::param("grid", format!("{knob}={value}: {e}"))
}

/// The knobs varied, each with its values, in the order given.
#[derive(Debug, Clone, Default)]
pub struct Grid {
    pub axes: Vec<(String, Vec<String>)>,
}

/// The most settings one sweep runs (each is a full run of the method).
pub const MAX_SETTINGS: usize = 4096;

impl Grid {
    /// The grid `specs` ask for (`knob=v1,v2,...` each) over `knobs`: named
    /// knobs take the given values, the others their default grid.
    pub fn parse(specs: &[String], knobs: &[Knob]) -> Result<Grid> {
        let mut given: Vec<(String, Vec<String>)> = Vec::new();
        for spec in specs {
            let (name, values) = spec
                .split_once('=')
                .ok_or_else(|| Error::param("grid", format!("'{spec}' is not KNOB=V1,V2,...")))?;
            let name = name.trim().trim_start_matches("--").to_string();
            if !knobs.iter().any(|k| k.name == name) {
                let known: Vec<&str> = knobs.iter().map(|k| k.name).collect();
                let problem = format!("unknown knob '{name}'; this method's knobs: {}", known.join(", "));
                return Err(Error::param("grid", problem));
            }
            if given.iter().any(|(n, _)| *n == name) {
                return Err(Error::param("grid", format!("knob '{name}' is given twice")));
            }
            let values: Vec<String> = values.split(',').map(|v| v.trim().to_string()).collect();
            if values.iter().any(String::is_empty) {
                return Err(Error::param("grid", format!("'{spec}' has an empty value")));
            }
            given.push((name, values));
        }
        let defaults: Vec<(String, Vec<String>)> = knobs
            .iter()
            .filter(|k| !k.default_grid.is_empty() && !given.iter().any(|(n, _)| n == k.name))
            .map(|k| {
                (
                    k.name.to_string(),
                    k.default_grid.iter().map(|v| v.to_string()).collect(),
                )
            })
            .collect();
        given.extend(defaults);
        let grid = Grid { axes: given };
        let count = grid.len();
        if count > MAX_SETTINGS {
            let problem = format!("has {count} settings; at most {MAX_SETTINGS} (give fewer values)");
            return Err(Error::param("grid", problem));
        }
        Ok(grid)
    }

    /// The number of settings: the product of the axes' lengths.
    pub fn len(&self) -> usize {
        self.axes
            .iter()
            .map(|(_, v)| v.len())
            .fold(1usize, usize::saturating_mul)
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Every setting, the last axis varying fastest.
    pub fn settings(&self) -> Vec<Setting> {
        let mut out = vec![Setting(BTreeMap::new())];
        for (name, values) in &self.axes {
            out = out
                .into_iter()
                .flat_map(|s| {
                    values.iter().map(move |v| {
                        let mut next = s.0.clone();
                        next.insert(name.clone(), v.clone());
                        Setting(next)
                    })
                })
                .collect();
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const KNOBS: [Knob; 3] = [
        Knob {
            name: "spp",
            help: "",
            default_grid: &["4", "8"],
        },
        Knob {
            name: "filter",
            help: "",
            default_grid: &[],
        },
        Knob {
            name: "steps",
            help: "",
            default_grid: &["2", "4", "8"],
        },
    ];

    #[test]
    fn given_knobs_replace_defaults_and_every_combination_appears() {
        let grid = Grid::parse(&["filter=on,off".into(), "--spp=16".into()], &KNOBS).unwrap();
        let settings = grid.settings();
        assert_eq!(settings.len(), 2 * 3);
        assert_eq!(grid.len(), 6);
        assert!(settings.iter().all(|s| s.0["spp"] == "16"));
        let distinct: std::collections::HashSet<String> = settings.iter().map(Setting::label).collect();
        assert_eq!(distinct.len(), 6);
        assert_eq!(settings[0].get::<u32>("steps").unwrap(), Some(2));
        assert_eq!(settings[0].get_on_off("filter").unwrap(), Some(true));
    }

    #[test]
    fn bad_specs_name_the_problem() {
        for (spec, words) in [
            ("spp", "KNOB=V1"),
            ("foo=1", "unknown knob 'foo'"),
            ("spp=1,,2", "empty value"),
        ] {
            let e = Grid::parse(&[spec.into()], &KNOBS).unwrap_err().to_string();
            assert!(e.contains(words), "{spec}: {e}");
        }
        let twice = Grid::parse(&["spp=1".into(), "spp=2".into()], &KNOBS).unwrap_err();
        assert!(twice.to_string().contains("twice"));
        let s = Grid::parse(&["spp=x".into()], &KNOBS).unwrap().settings();
        assert!(s[0].get::<u32>("spp").unwrap_err().to_string().contains("spp=x"));
    }
}
