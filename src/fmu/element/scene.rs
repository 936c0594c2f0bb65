//! The scene of an element FMU (`docs/elements.md`): one `[element]` table (`kind`, `name`,
//! `description` and the element's fields, [`crate::model::elements`]), the initial motion
//! `[initial]` and the integrator and default experiment `[solver]`. Unknown keys are
//! rejected; messages name the field and its value.

use serde::Deserialize;

use crate::model::elements::{ElementSpec, Rotation};
use crate::solve::rk::{Method, RkOptions};

/// A validated element scene.
#[derive(Debug, Clone, PartialEq)]
pub struct ElementScene {
    pub name: String,
    pub description: String,
    pub element: ElementSpec,
    /// Angle and speed at `t = 0` (all zero for the stateless shaft).
    pub initial: Rotation,
    pub solver: ElementSolver,
}

/// `[solver]`: DOP853 tolerances and the default experiment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ElementSolver {
    pub rtol: f64,
    pub atol: f64,
    pub stop_time: f64,
    pub output_interval: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneSpec {
    element: toml::Table,
    initial: Option<InitialSpec>,
    #[serde(default)]
    solver: SolverSpec,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct InitialSpec {
    #[serde(default)]
    angle: f64,
    #[serde(default)]
    speed: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SolverSpec {
    #[serde(default = "default_rtol")]
    rtol: f64,
    #[serde(default = "default_atol")]
    atol: f64,
    #[serde(default = "default_stop_time")]
    stop_time: f64,
    output_interval: Option<f64>,
}

fn default_rtol() -> f64 {
    1e-10
}
fn default_atol() -> f64 {
    1e-12
}
fn default_stop_time() -> f64 {
    1.0
}

impl Default for SolverSpec {
    fn default() -> Self {
        SolverSpec {
            rtol: default_rtol(),
            atol: default_atol(),
            stop_time: default_stop_time(),
            output_interval: None,
        }
    }
}

/// Whether a scene text is an element scene (it has a top-level `[element]` table).
pub fn is_element_text(text: &str) -> bool {
    text.parse::<toml::Table>()
        .is_ok_and(|t| t.contains_key("element"))
}

impl ElementScene {
    /// Parses and validates a scene; `origin` (the file) starts every message.
    pub fn from_toml_str(text: &str, origin: &str) -> Result<ElementScene, String> {
        let err = |e: String| format!("scene '{origin}': {e}");
        let spec: SceneSpec = toml::from_str(text).map_err(|e| err(e.to_string()))?;
        let mut table = spec.element;
        let mut take_string = |key: &str| -> Result<Option<String>, String> {
            match table.remove(key) {
                None => Ok(None),
                Some(toml::Value::String(s)) => Ok(Some(s)),
                Some(v) => Err(err(format!("element.{key} = {v}: must be a string"))),
            }
        };
        let name = take_string("name")?
            .ok_or_else(|| err("element.name is missing (the model name)".into()))?;
        let description = take_string("description")?.unwrap_or_default();
        if name.trim().is_empty() {
            return Err(err("element.name is empty".into()));
        }
        let element: ElementSpec = toml::Value::Table(table)
            .try_into()
            .map_err(|e: toml::de::Error| err(format!("[element]: {}", e.message())))?;
        element.validate("element").map_err(err)?;
        let stateless = matches!(element, ElementSpec::Shaft(_));
        if stateless && spec.initial.is_some() {
            return Err(err(
                "[initial]: a shaft has no state (its motion comes from its flange inputs)".into(),
            ));
        }
        let initial = spec.initial.unwrap_or_default();
        let initial = Rotation {
            angle: initial.angle,
            speed: initial.speed,
        };
        for (key, x) in [("angle", initial.angle), ("speed", initial.speed)] {
            if !x.is_finite() {
                return Err(err(format!("initial.{key} = {x}: must be finite")));
            }
        }
        let s = spec.solver;
        let solver = ElementSolver {
            rtol: s.rtol,
            atol: s.atol,
            stop_time: s.stop_time,
            output_interval: s.output_interval.unwrap_or(s.stop_time / 1000.0),
        };
        solver
            .rk_options()
            .validate()
            .map_err(|e| err(format!("solver.{e}")))?;
        if !(solver.stop_time.is_finite() && solver.stop_time > 0.0) {
            return Err(err(format!(
                "solver.stop_time = {}: must be a finite number > 0 s",
                solver.stop_time
            )));
        }
        let oi = solver.output_interval;
        if !(oi.is_finite() && oi > 0.0 && oi <= solver.stop_time) {
            return Err(err(format!(
                "solver.output_interval = {oi}: must be > 0 and <= stop_time s"
            )));
        }
        Ok(ElementScene {
            name,
            description,
            element,
            initial,
            solver,
        })
    }
}

impl ElementSolver {
    /// DOP853 at the scene's tolerances.
    pub fn rk_options(&self) -> RkOptions {
        RkOptions {
            rtol: self.rtol,
            atol: self.atol,
            ..RkOptions::new(Method::Dop853)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<ElementScene, String> {
        ElementScene::from_toml_str(text, "test.toml")
    }

    #[test]
    fn bad_values_and_keys_are_named() {
        let e = parse("[element]\nkind = \"inertia\"\nname = \"j\"\ninertia = -2.0\n").unwrap_err();
        assert!(e.contains("element.inertia = -2"), "{e}");
        let e = parse("[element]\nkind = \"load\"\nname = \"l\"\ninertia = 1.0\nmass = 3\n")
            .unwrap_err();
        assert!(e.contains("mass"), "{e}");
        let e = parse(
            "[element]\nkind = \"shaft\"\nname = \"s\"\nstiffness = 1e4\n[initial]\nspeed = 1.0\n",
        )
        .unwrap_err();
        assert!(e.contains("[initial]"), "{e}");
        let e = parse(
            "[element]\nkind = \"shaft\"\nname = \"s\"\nstiffness = 1e4\n[solver]\nrtol = -1.0\n",
        )
        .unwrap_err();
        assert!(e.contains("solver.rtol = -1"), "{e}");
        let e = parse("[element]\nkind = \"shaft\"\nstiffness = 1e4\n").unwrap_err();
        assert!(e.contains("element.name"), "{e}");
        let e = parse("[element]\nkind = \"motor\"\nname = \"m\"\ninertia = 0.01\n[element.curve]\nspeed = [0.0, 10.0]\ntorque = [1.0, -1.0]\n")
            .unwrap_err();
        assert!(e.contains("element.curve.torque[1] = -1"), "{e}");
    }

    #[test]
    fn a_good_scene_parses() {
        let s = parse(
            "[element]\nkind = \"inertia\"\nname = \"j\"\ninertia = 2.0\n[initial]\nspeed = 3.0\n",
        )
        .unwrap();
        assert_eq!(s.initial.speed, 3.0);
        assert_eq!(s.solver.output_interval, 1e-3);
        assert!(is_element_text("[element]\nkind = \"x\""));
        assert!(!is_element_text("name = \"x\""));
    }
}
