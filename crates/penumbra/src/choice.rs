//! Settings whose values are names (`--estimator tangent-sphere`,
//! `positional=nearest` in a sweep's grid): each such enum lists its values
//! and their names once, so that grids, budgets and command lines built on
//! the library spell them alike.

/// An enum of named values.
pub trait Choice: Copy + Sized + 'static {
    /// Every value, in the order they are listed to a user.
    const ALL: &'static [Self];

    /// The value's name (lower case, words joined by `-`).
    fn name(self) -> &'static str;

    /// The value named `text` (case-insensitive); the error says which
    /// name was not known.
    fn parse(text: &str) -> Result<Self, String> {
        Self::ALL
            .iter()
            .copied()
            .find(|v| v.name().eq_ignore_ascii_case(text))
            .ok_or_else(|| format!("invalid variant: {text}"))
    }
}

/// Implements [`Choice`] for an enum: `choice!(Estimator { Raymarch =
/// "raymarch", TangentSphere = "tangent-sphere" });`. Crate-internal: its
/// expansion names the crate-private `choice` module, so it is hidden from
/// the public docs.
#[doc(hidden)]
#[macro_export]
macro_rules! choice {
    ($ty:ident { $($variant:ident = $name:literal),+ $(,)? }) => {
        impl $crate::choice::Choice for $ty {
            const ALL: &'static [Self] = &[$($ty::$variant),+];

            fn name(self) -> &'static str {
                match self {
                    $($ty::$variant => $name),+
                }
            }
        }
    };
}

#[cfg(test)]
mod tests {
    use super::Choice;

    #[derive(Debug, Clone, Copy, PartialEq, Eq)]
    enum Side {
        Left,
        FarRight,
    }
    crate::choice!(Side { Left = "left", FarRight = "far-right" });

    #[test]
    fn names_parse_back_case_insensitively_and_unknown_names_are_refused() {
        for &v in Side::ALL {
            assert_eq!(Side::parse(v.name()), Ok(v));
        }
        assert_eq!(Side::parse("FAR-RIGHT"), Ok(Side::FarRight));
        assert_eq!(Side::parse("up"), Err("invalid variant: up".to_string()));
    }
}
