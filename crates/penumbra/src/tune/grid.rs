//! A grid of knob settings: `knob=v1,v2,...` per knob named, the method's
//! default grid for knobs not named, every combination in order. The
//! text is read here, once: a value its knob does not take is refused
//! with the grid, before any setting runs.

use super::knob::{Given, Knob, Setting};
use crate::error::{Error, Result};

/// The knobs varied, each with its values, in the order given.
#[derive(Debug, Clone, Default)]
pub struct Grid {
    /// Each knob's name and values: the ones named first, in the order
    /// named, then the other knobs' default grids.
    pub axes: Vec<(&'static str, Vec<Given>)>,
}

/// The most settings one sweep runs (each is a full run of the method).
pub const MAX_SETTINGS: usize = 4096;

impl Grid {
    /// The grid `specs` ask for (`knob=v1,v2,...` each) over `knobs`: named
    /// knobs take the given values, the others their default grid. The
    /// specs' shape and the grid's size are checked before any value is
    /// read; errors name the `grid` parameter.
    pub fn parse(specs: &[String], knobs: &[Knob]) -> Result<Grid> {
        let mut given: Vec<(&Knob, Vec<&str>)> = Vec::new();
        for spec in specs {
            let (name, values) = spec
                .split_once('=')
                .ok_or_else(|| Error::param("grid", format!("'{spec}' is not KNOB=V1,V2,...")))?;
            let name = name.trim().trim_start_matches("--");
            let Some(knob) = knobs.iter().find(|k| k.name == name) else {
                let known: Vec<&str> = knobs.iter().map(|k| k.name).collect();
                let problem = format!("unknown knob '{name}'; this method's knobs: {}", known.join(", "));
                return Err(Error::param("grid", problem));
            };
            if given.iter().any(|(k, _)| k.name == name) {
                return Err(Error::param("grid", format!("knob '{name}' is given twice")));
            }
            let values: Vec<&str> = values.split(',').map(str::trim).collect();
            if values.iter().any(|v| v.is_empty()) {
                return Err(Error::param("grid", format!("'{spec}' has an empty value")));
            }
            given.push((knob, values));
        }
        let defaults: Vec<(&Knob, Vec<&str>)> = knobs
            .iter()
            .filter(|k| !k.default_grid.is_empty() && !given.iter().any(|(g, _)| g.name == k.name))
            .map(|k| (k, k.default_grid.to_vec()))
            .collect();
        given.extend(defaults);
        let count = given.iter().map(|(_, v)| v.len()).fold(1usize, usize::saturating_mul);
        if count > MAX_SETTINGS {
            let problem = format!("has {count} settings; at most {MAX_SETTINGS} (give fewer values)");
            return Err(Error::param("grid", problem));
        }
        let axes = given
            .into_iter()
            .map(|(knob, texts)| {
                let values = texts
                    .into_iter()
                    .map(|text| {
                        Given::read(knob, text).map_err(|e| Error::param("grid", format!("{}={text}: {e}", knob.name)))
                    })
                    .collect::<Result<Vec<Given>>>()?;
                Ok((knob.name, values))
            })
            .collect::<Result<_>>()?;
        Ok(Grid { axes })
    }

    /// The number of settings: the product of the axes' lengths.
    pub fn len(&self) -> usize {
        self.axes
            .iter()
            .map(|(_, v)| v.len())
            .fold(1usize, usize::saturating_mul)
    }

    /// No setting at all (an axis without values).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Every setting, the last axis varying fastest.
    pub fn settings(&self) -> Vec<Setting> {
        let mut out = vec![Setting::default()];
        for (name, values) in &self.axes {
            out = out
                .into_iter()
                .flat_map(|s| values.iter().map(move |v| s.clone().with_given(name, v.clone())))
                .collect();
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tune::knob::KnobValue;

    const KNOBS: [Knob; 4] = [
        Knob::new::<u32>("spp", "", &["4", "8"]),
        Knob::new::<bool>("filter", "", &[]),
        Knob::new::<u32>("steps", "", &["2", "4", "8"]),
        Knob::new::<f32>("radius", "", &[]),
    ];

    fn parse(specs: &[&str]) -> Result<Grid> {
        let specs: Vec<String> = specs.iter().map(|s| s.to_string()).collect();
        Grid::parse(&specs, &KNOBS)
    }

    #[test]
    fn given_knobs_replace_defaults_and_every_combination_appears() {
        let grid = parse(&["filter=on,off", "--spp=16", "radius= 0.5"]).unwrap();
        let names: Vec<&str> = grid.axes.iter().map(|(n, _)| *n).collect();
        assert_eq!(names, ["filter", "spp", "radius", "steps"]);
        let settings = grid.settings();
        assert_eq!(settings.len(), 2 * 3);
        assert_eq!(grid.len(), 6);
        assert!(settings.iter().all(|s| s.get::<u32>("spp") == Some(16)));
        assert!(settings.iter().all(|s| s.get::<f32>("radius") == Some(0.5)));
        let distinct: std::collections::HashSet<String> = settings.iter().map(Setting::label).collect();
        assert_eq!(distinct.len(), 6);
        assert_eq!(settings[0].get::<u32>("steps"), Some(2));
        assert_eq!(settings[1].get::<u32>("steps"), Some(4), "the last axis varies fastest");
        assert_eq!(settings[0].get::<bool>("filter"), Some(true));
        assert_eq!(settings[3].get::<bool>("filter"), Some(false));
    }

    #[test]
    fn values_are_typed_and_keep_their_spelling() {
        let grid = parse(&["spp=08,16", "filter=true"]).unwrap();
        let (_, spp) = &grid.axes[0];
        assert_eq!(spp[0].value, KnobValue::Integer(8));
        assert_eq!(spp[0].text, "08");
        let s = &grid.settings()[0];
        assert_eq!(s.get::<bool>("filter"), Some(true));
        assert_eq!(s.text("filter"), Some("true"));
    }

    #[test]
    fn bad_specs_are_refused_with_what_is_wrong() {
        for (specs, message) in [
            (&["spp"][..], "'spp' is not KNOB=V1,V2,..."),
            (
                &["foo=1"],
                "unknown knob 'foo'; this method's knobs: spp, filter, steps, radius",
            ),
            (&["spp=1,,2"], "'spp=1,,2' has an empty value"),
            (&["spp=1", "spp=2"], "knob 'spp' is given twice"),
            (&["spp=x"], "spp=x: invalid digit found in string"),
            (&["spp=-1"], "spp=-1: invalid digit found in string"),
            (
                &["spp=4294967296"],
                "spp=4294967296: number too large to fit in target type",
            ),
            (&["filter=yes"], "filter=yes: expected on or off"),
            (&["radius=big"], "radius=big: invalid float literal"),
        ] {
            let e = parse(specs).unwrap_err();
            assert_eq!(e, Error::param("grid", message), "{specs:?}");
        }
        let many: Vec<String> = (1..=4097).map(|i| i.to_string()).collect();
        let e = parse(&[&format!("spp={}", many.join(","))]).unwrap_err();
        assert_eq!(
            e,
            Error::param("grid", "has 12291 settings; at most 4096 (give fewer values)")
        );
    }

    #[test]
    fn the_shape_of_the_specs_is_checked_before_any_value() {
        let e = parse(&["spp=x", "foo=1"]).unwrap_err();
        assert!(e.to_string().contains("unknown knob 'foo'"), "{e}");
        let huge: Vec<String> = (0..5000).map(|_| "x".to_string()).collect();
        let e = parse(&[&format!("spp={}", huge.join(","))]).unwrap_err();
        assert!(e.to_string().contains("at most 4096"), "{e}");
    }
}
