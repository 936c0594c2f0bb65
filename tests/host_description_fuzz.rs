//! Property test: the modelDescription parser and validator never panic, whatever the input.
//!
//! 12,000 deterministic mutations (seeded xorshift, so a failure is reproducible) of two valid
//! descriptions: byte flips, truncations, deletions and duplications of ranges, insertion of
//! XML fragments that hit the typed conversion (bad numbers, unknown enums, huge indices,
//! stray elements and attributes). Every result must be `Ok` or an `Err` with a non-empty
//! message; an `Ok` is also run through the validator.

use geardyn::host::check::check;
use geardyn::host::description::parse;

const SEEDS: [&str; 2] = [
    r#"<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName="Gear" guid="{abc}">
  <CoSimulation modelIdentifier="Gear" canHandleVariableCommunicationStepSize="true"/>
  <UnitDefinitions><Unit name="m"><BaseUnit m="1"/><DisplayUnit name="mm" factor="1000"/></Unit></UnitDefinitions>
  <TypeDefinitions><SimpleType name="Mode"><Enumeration><Item name="a" value="1"/></Enumeration></SimpleType></TypeDefinitions>
  <LogCategories><Category name="logEvents"/></LogCategories>
  <DefaultExperiment startTime="0" stopTime="0.05" stepSize="1e-4"/>
  <ModelVariables>
    <ScalarVariable name="k" valueReference="0" causality="parameter" variability="fixed"><Real start="1e8"/></ScalarVariable>
    <ScalarVariable name="F" valueReference="1" causality="input"><Real start="1000"/></ScalarVariable>
    <ScalarVariable name="dte" valueReference="2" causality="output"><Real unit="m"/></ScalarVariable>
    <ScalarVariable name="mode" valueReference="0" causality="parameter" variability="fixed"><Enumeration declaredType="Mode" start="1"/></ScalarVariable>
    <ScalarVariable name="x" valueReference="3"><Real/></ScalarVariable>
    <ScalarVariable name="der(x)" valueReference="4"><Real derivative="5"/></ScalarVariable>
  </ModelVariables>
  <ModelStructure>
    <Outputs><Unknown index="3" dependencies=""/></Outputs>
    <Derivatives><Unknown index="6" dependencies="5 2" dependenciesKind="dependent dependent"/></Derivatives>
    <InitialUnknowns><Unknown index="3"/><Unknown index="5"/><Unknown index="6"/></InitialUnknowns>
  </ModelStructure>
</fmiModelDescription>
"#,
    r#"<fmiModelDescription fmiVersion="2.0" modelName="m" guid="g"><CoSimulation modelIdentifier="m"/><ModelVariables><ScalarVariable name="b" valueReference="0" causality="input" variability="discrete"><Boolean start="false"/></ScalarVariable><ScalarVariable name="s" valueReference="0" causality="parameter" variability="fixed"><String start="x"/></ScalarVariable></ModelVariables><ModelStructure/></fmiModelDescription>"#,
];

const FRAGMENTS: &[&str] = &[
    "<",
    ">",
    "/>",
    "\"",
    "=",
    "&",
    "&amp;",
    "&#0;",
    "<![CDATA[x]]>",
    "<!-- c -->",
    "\u{0}",
    "é",
    "<ScalarVariable name=\"z\" valueReference=\"9\"><Real/></ScalarVariable>",
    "<ScalarVariable/>",
    "<Real/>",
    "<Integer start=\"1\"/>",
    "<Unknown index=\"0\"/>",
    "<Unknown index=\"4294967295\"/>",
    "<Unknown index=\"99999999999\"/>",
    " index=\"-1\"",
    " start=\"NaN\"",
    " start=\"INF\"",
    " start=\"1e999\"",
    " valueReference=\"-3\"",
    " causality=\"bogus\"",
    " variability=\"constant\"",
    " initial=\"exact\"",
    " derivative=\"0\"",
    " derivative=\"4294967295\"",
    " dependencies=\"1 x\"",
    " dependenciesKind=\"odd\"",
    " fmiVersion=\"3.0\"",
    "<ModelVariables>",
    "</ModelVariables>",
    "<ModelStructure>",
    "<DefaultExperiment stopTime=\"-1\" stepSize=\"0\"/>",
    "<Item name=\"q\" value=\"2147483648\"/>",
    "<BaseUnit kg=\"1.5\"/>",
    "<Annotations><Tool name=\"x\"><a b=\"c\"/></Tool></Annotations>",
];

struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        // xorshift64*
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    fn below(&mut self, n: usize) -> usize {
        if n == 0 {
            0
        } else {
            (self.next() % n as u64) as usize
        }
    }
}

fn mutate(rng: &mut Rng, input: &[u8]) -> Vec<u8> {
    let mut b = input.to_vec();
    for _ in 0..1 + rng.below(4) {
        let len = b.len();
        let at = rng.below(len + 1);
        match rng.below(6) {
            0 if len > 0 => {
                let i = rng.below(len);
                b[i] ^= 1 << rng.below(8);
            }
            1 => b.truncate(at),
            2 => {
                let end = (at + rng.below(64)).min(len);
                b.drain(at..end);
            }
            3 => {
                let end = (at + rng.below(200)).min(len);
                let piece = b[at..end].to_vec();
                b.splice(at..at, piece);
            }
            _ => {
                let f = FRAGMENTS[rng.below(FRAGMENTS.len())].as_bytes();
                b.splice(at..at, f.iter().copied());
            }
        }
    }
    b
}

#[test]
fn parser_and_validator_never_panic_on_12000_mutations() {
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    let (mut ok, mut err) = (0usize, 0usize);
    for i in 0..12_000 {
        let seed = SEEDS[i % SEEDS.len()].as_bytes();
        let bytes = mutate(&mut rng, seed);
        // The archive layer rejects non-UTF-8; the parser gets text.
        let text = String::from_utf8_lossy(&bytes);
        match parse(&text, "modelDescription.xml") {
            Ok(md) => {
                ok += 1;
                let _ = check(&md);
            }
            Err(e) => {
                err += 1;
                assert!(!e.is_empty(), "empty error message for mutation #{i}");
            }
        }
    }
    assert_eq!(ok + err, 12_000);
    // Both paths must be exercised, or the mutator is broken.
    assert!(ok > 100 && err > 100, "ok = {ok}, err = {err}");
}
