//! What a run left out because the scene or the request did not need it
//! (a field no receiver consults, a truth nothing is compared with, a
//! kd-tree no path traverses): runners list it so `--json` can say what
//! was modelled and what was not. Pipelines never compiled are listed by
//! the device (`gpu::kernels::PipelineLog`).

use serde::Serialize;

#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Skipped {
    /// The kind of thing: "field", "kd-tree", "ray-traced truth", ...
    pub what: String,
    /// Which one, where there are several (a mesh's name).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    pub why: String,
}

impl Skipped {
    pub fn new(what: &str, why: impl Into<String>) -> Skipped {
        Skipped {
            what: what.into(),
            name: None,
            why: why.into(),
        }
    }

    pub fn named(what: &str, name: &str, why: impl Into<String>) -> Skipped {
        Skipped {
            name: Some(name.into()),
            ..Skipped::new(what, why)
        }
    }
}
