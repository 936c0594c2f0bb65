//! modelDescription.xml parser and validator (src/host/description.rs, check.rs): a valid
//! description round-trips into the typed model; every rejected input names the element,
//! attribute, value and line; the validator reports the rules of FMI 2.0.5 §2.2.

use geardyn::host::check::check;
use geardyn::host::description::{parse, Causality, Initial, Value, VarType, Variability};

const GOOD: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName="Gear" guid="{abc}" generationTool="t"
    variableNamingConvention="structured">
  <CoSimulation modelIdentifier="Gear" canHandleVariableCommunicationStepSize="true"
      canGetAndSetFMUstate="1" maxOutputDerivativeOrder="0"/>
  <UnitDefinitions>
    <Unit name="m"><BaseUnit m="1"/><DisplayUnit name="mm" factor="1000"/></Unit>
    <Unit name="N"><BaseUnit kg="1" m="1" s="-2"/></Unit>
  </UnitDefinitions>
  <TypeDefinitions>
    <SimpleType name="Force"><Real unit="N"/></SimpleType>
    <SimpleType name="Mode"><Enumeration><Item name="a" value="1"/><Item name="b" value="2"/></Enumeration></SimpleType>
  </TypeDefinitions>
  <LogCategories><Category name="logEvents" description="events"/></LogCategories>
  <DefaultExperiment startTime="0" stopTime="0.05" stepSize="1e-4" tolerance="1e-8"/>
  <ModelVariables>
    <ScalarVariable name="k" valueReference="0" causality="parameter" variability="fixed" description="stiffness">
      <Real start="1e8"/>
    </ScalarVariable>
    <ScalarVariable name="F" valueReference="1" causality="input"><Real declaredType="Force" start="1000"/></ScalarVariable>
    <ScalarVariable name="dte" valueReference="2" causality="output" initial="calculated"><Real unit="m" displayUnit="mm"/></ScalarVariable>
    <ScalarVariable name="mode" valueReference="0" causality="parameter" variability="fixed"><Enumeration declaredType="Mode" start="1"/></ScalarVariable>
    <ScalarVariable name="on" valueReference="0" causality="parameter" variability="tunable"><Boolean start="true"/></ScalarVariable>
    <ScalarVariable name="x" valueReference="3"><Real/></ScalarVariable>
    <ScalarVariable name="der(x)" valueReference="4"><Real derivative="6"/></ScalarVariable>
  </ModelVariables>
  <ModelStructure>
    <Outputs><Unknown index="3" dependencies=""/></Outputs>
    <Derivatives><Unknown index="7" dependencies="6 2" dependenciesKind="dependent dependent"/></Derivatives>
    <InitialUnknowns><Unknown index="3"/><Unknown index="6"/><Unknown index="7"/></InitialUnknowns>
  </ModelStructure>
</fmiModelDescription>
"#;

fn with(from: &str, to: &str) -> String {
    assert!(GOOD.contains(from), "test bug: {from:?} not in GOOD");
    GOOD.replacen(from, to, 1)
}

fn parse_err(xml: &str) -> String {
    parse(xml, "modelDescription.xml").expect_err("must be rejected")
}

fn problems(xml: &str) -> Vec<String> {
    check(&parse(xml, "modelDescription.xml").expect("parses"))
}

#[test]
fn good_description_parses_and_validates() {
    let md = parse(GOOD, "modelDescription.xml").unwrap();
    assert_eq!(md.model_name, "Gear");
    let cs = md.co_simulation.as_ref().unwrap();
    assert!(cs.can_handle_variable_communication_step_size && cs.can_get_and_set_fmu_state);
    assert!(!cs.can_serialize_fmu_state);
    let de = md.default_experiment.as_ref().unwrap();
    assert_eq!(
        (de.stop_time, de.step_size, de.tolerance),
        (Some(0.05), Some(1e-4), Some(1e-8))
    );
    assert_eq!(md.unit_definitions[0].display_units[0].factor, 1000.0);
    assert_eq!(md.log_categories[0].name, "logEvents");
    let k = md.variable("k").unwrap();
    assert_eq!(
        (k.causality, k.variability, k.start.clone(), k.line),
        (
            Causality::Parameter,
            Variability::Fixed,
            Some(Value::Real(1e8)),
            17
        )
    );
    assert_eq!(k.description.as_deref(), Some("stiffness"));
    let f = md.variable("F").unwrap();
    assert_eq!(md.unit_of(f), Some("N")); // inherited from declaredType
    assert_eq!(f.effective_initial(), None);
    let dte = md.variable("dte").unwrap();
    assert_eq!(dte.effective_initial(), Some(Initial::Calculated));
    assert_eq!(md.variable("mode").unwrap().var_type, VarType::Enumeration);
    assert_eq!(md.variable("on").unwrap().start, Some(Value::Boolean(true)));
    assert_eq!(md.variable("der(x)").unwrap().derivative, Some(6));
    assert_eq!(md.model_structure.outputs[0].dependencies, Some(vec![]));
    assert_eq!(
        md.model_structure.derivatives.as_ref().unwrap()[0].dependencies,
        Some(vec![6, 2])
    );
    assert_eq!(check(&md), Vec::<String>::new());
}

#[test]
fn byte_order_mark_is_accepted() {
    let md = parse(&format!("\u{feff}{GOOD}"), "modelDescription.xml").unwrap();
    assert_eq!(md.variable("k").unwrap().line, 17);
}

#[test]
fn malformed_and_truncated_xml_name_the_line() {
    let e = parse_err(&with("<Real start=\"1e8\"/>", "<Real start=\"1e8\">"));
    assert!(
        e.contains("malformed XML at line") || e.contains("line"),
        "{e}"
    );
    let cut = &GOOD[..GOOD.find("<ModelStructure>").unwrap()];
    let e = parse_err(cut);
    assert!(e.contains("truncated XML") && e.contains("line"), "{e}");
    let e = parse_err(&with("<Unit name=\"N\">", "<Unit name=\"N>"));
    assert!(e.contains("line"), "{e}");
    let e = parse_err("");
    assert!(e.contains("no XML element"), "{e}");
    let e = parse_err("<fmi2ModelDescription fmiVersion=\"2.0\"/>");
    assert!(
        e.contains("<fmi2ModelDescription>") && e.contains("expected <fmiModelDescription>"),
        "{e}"
    );
}

#[test]
fn wrong_fmi_versions_are_named() {
    let e = parse_err(&with("fmiVersion=\"2.0\"", "fmiVersion=\"1.0\""));
    assert!(e.contains("fmiVersion=\"1.0\" is FMI 1.0"), "{e}");
    let e = parse_err(&with("fmiVersion=\"2.0\"", "fmiVersion=\"3.0\""));
    assert!(e.contains("fmiVersion=\"3.0\" is FMI 3.0"), "{e}");
    let e = parse_err(&with("fmiVersion=\"2.0\" ", ""));
    assert!(e.contains("no fmiVersion attribute"), "{e}");
}

#[test]
fn bad_attribute_values_name_variable_attribute_value_and_line() {
    let e = parse_err(&with("valueReference=\"2\"", "valueReference=\"two\""));
    assert!(
        e.contains("ScalarVariable \"dte\" (#3, line 21)") && e.contains("valueReference=\"two\""),
        "{e}"
    );
    let e = parse_err(&with("causality=\"input\"", "causality=\"inputt\""));
    assert!(
        e.contains("\"F\"") && e.contains("causality=\"inputt\" is not one of"),
        "{e}"
    );
    let e = parse_err(&with("<Real start=\"1e8\"/>", "<Real start=\"1e8x\"/>"));
    assert!(
        e.contains("\"k\"") && e.contains("line 17") && e.contains("start=\"1e8x\""),
        "{e}"
    );
    let e = parse_err(&with(
        "<Boolean start=\"true\"/>",
        "<Boolean start=\"yes\"/>",
    ));
    assert!(
        e.contains("\"on\"") && e.contains("start=\"yes\" is not a boolean"),
        "{e}"
    );
    let e = parse_err(&with(
        "<ScalarVariable name=\"x\" valueReference=\"3\">",
        "<ScalarVariable valueReference=\"3\">",
    ));
    assert!(
        e.contains("<ScalarVariable> #6 (line 24): required attribute name is missing"),
        "{e}"
    );
    let e = parse_err(&with(
        "<Real/></ScalarVariable>\n    <ScalarVariable name=\"der(x)\"",
        "</ScalarVariable>\n    <ScalarVariable name=\"der(x)\"",
    ));
    assert!(
        e.contains("\"x\"") && e.contains("exactly one type element"),
        "{e}"
    );
    let e = parse_err(&with(
        "canGetAndSetFMUstate=\"1\"",
        "canGetAndSetFMUstate=\"maybe\"",
    ));
    assert!(
        e.contains("<CoSimulation>: canGetAndSetFMUstate=\"maybe\""),
        "{e}"
    );
    let e = parse_err(&with("stopTime=\"0.05\"", "stopTime=\"soon\""));
    assert!(e.contains("<DefaultExperiment>: stopTime=\"soon\""), "{e}");
    let e = parse_err(&with(
        "<Unknown index=\"3\" dependencies=\"\"/>",
        "<Unknown index=\"x\"/>",
    ));
    assert!(e.contains("<Outputs>/<Unknown> #1: index=\"x\""), "{e}");
    let e = parse_err(&with(
        "<Item name=\"b\" value=\"2\"/>",
        "<Item name=\"b\" value=\"2.5\"/>",
    ));
    assert!(
        e.contains("<SimpleType name=\"Mode\">/<Item name=\"b\">: value=\"2.5\""),
        "{e}"
    );
    let e = parse_err(&with("modelIdentifier=\"Gear\" ", ""));
    assert!(
        e.contains("<CoSimulation>: required attribute modelIdentifier is missing"),
        "{e}"
    );
    let e = parse_err(&with("guid=\"{abc}\"", ""));
    assert!(e.contains("guid is missing"), "{e}");
}

#[test]
fn validator_reports_semantic_problems() {
    let expect = |xml: String, needle: &str| {
        let p = problems(&xml);
        assert!(
            p.iter().any(|m| m.contains(needle)),
            "expected {needle:?} in {p:#?}"
        );
    };
    expect(
        with(
            "<Real declaredType=\"Force\" start=\"1000\"/>",
            "<Real declaredType=\"Force\"/>",
        ),
        "\"F\" (#2, line 20): has no start value",
    );
    expect(
        with(
            "<Real unit=\"m\" displayUnit=\"mm\"/>",
            "<Real start=\"1\" unit=\"m\" displayUnit=\"mm\"/>",
        ),
        "has initial=\"calculated\" but provides start=\"1.0\"",
    );
    expect(
        with(
            "causality=\"parameter\" variability=\"fixed\" description",
            "causality=\"parameter\" variability=\"continuous\" description",
        ),
        "causality=\"parameter\", variability=\"continuous\"",
    );
    expect(with("name=\"x\"", "name=\"k\""), "the name is not unique");
    expect(
        with(
            "<Real unit=\"m\" displayUnit=\"mm\"/>",
            "<Real unit=\"N/mm\"/>",
        ),
        "unit=\"N/mm\" is not defined",
    );
    expect(
        with("displayUnit=\"mm\"", "displayUnit=\"km\""),
        "displayUnit=\"km\" is not a <DisplayUnit> of unit \"m\"",
    );
    expect(
        with(
            "<Outputs><Unknown index=\"3\" dependencies=\"\"/></Outputs>",
            "<Outputs></Outputs>",
        ),
        "output variable \"dte\"",
    );
    expect(
        with(
            "<InitialUnknowns><Unknown index=\"3\"/>",
            "<InitialUnknowns>",
        ),
        "<InitialUnknowns>: missing \"dte\"",
    );
    expect(
        with(
            "<Unknown index=\"6\"/><Unknown index=\"7\"/>",
            "<Unknown index=\"6\"/><Unknown index=\"7\"/><Unknown index=\"1\"/>",
        ),
        "must not list \"k\"",
    );
    expect(
        with("dependencies=\"6 2\"", "dependencies=\"6 99\""),
        "dependencies contains \"99\"",
    );
    expect(
        with("modelIdentifier=\"Gear\"", "modelIdentifier=\"Gear Mesh\""),
        "modelIdentifier=\"Gear Mesh\" is not a C identifier",
    );
    expect(
        with("stopTime=\"0.05\"", "stopTime=\"-1\""),
        "stopTime=\"-1\" is before startTime",
    );
    expect(
        with("declaredType=\"Force\"", "declaredType=\"Torque\""),
        "declaredType=\"Torque\" is not defined",
    );
    expect(
        with("derivative=\"6\"", "derivative=\"60\""),
        "derivative=\"60\" is not a variable index",
    );
    expect(with("<Boolean start=\"true\"/>", "<Boolean start=\"true\"/></ScalarVariable><ScalarVariable name=\"on2\" valueReference=\"0\" causality=\"input\" variability=\"continuous\"><Boolean start=\"true\"/>"), "only Real may be continuous");
    // Model Exchange only.
    let me = with(
        "<CoSimulation modelIdentifier=\"Gear\"",
        "<ModelExchange modelIdentifier=\"Gear\"",
    );
    expect(me, "declares only <ModelExchange modelIdentifier=\"Gear\">");
}
