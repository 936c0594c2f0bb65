//! The FMI 2.0 variable attributes that both sides of the standard spell the same way: the
//! exporter's variable table ([`super::model`]) and the host's reader of
//! `modelDescription.xml` (`crate::host::description`).

/// `causality` (FMI 2.0.5 §2.2.7, default `local`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Causality {
    Parameter,
    CalculatedParameter,
    Input,
    Output,
    Local,
    Independent,
}

/// `variability` (FMI 2.0.5 §2.2.7, default `continuous`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Variability {
    Constant,
    Fixed,
    Tunable,
    Discrete,
    Continuous,
}

/// `initial` (FMI 2.0.5 §2.2.7).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Initial {
    Exact,
    Approx,
    Calculated,
}

/// `as_str` (the spelling in `modelDescription.xml`), `parse` and `Display` of an attribute.
#[macro_export]
#[doc(hidden)]
macro_rules! fmi_str_enum {
    ($ty:ident { $($text:literal => $var:ident),* $(,)? }) => {
        impl $ty {
            /// The spelling used in modelDescription.xml.
            pub fn as_str(self) -> &'static str {
                match self { $($ty::$var => $text),* }
            }
            /// Parse the XML spelling.
            pub fn parse(s: &str) -> Option<Self> {
                match s { $($text => Some($ty::$var),)* _ => None }
            }
        }
        impl std::fmt::Display for $ty {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str(self.as_str())
            }
        }
    };
}

fmi_str_enum!(Causality { "parameter" => Parameter, "calculatedParameter" => CalculatedParameter,
    "input" => Input, "output" => Output, "local" => Local, "independent" => Independent });
fmi_str_enum!(Variability { "constant" => Constant, "fixed" => Fixed, "tunable" => Tunable,
    "discrete" => Discrete, "continuous" => Continuous });
fmi_str_enum!(Initial { "exact" => Exact, "approx" => Approx, "calculated" => Calculated });
