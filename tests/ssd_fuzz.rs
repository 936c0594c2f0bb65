//! The SSD fuzzer (issue 34 item 10) and the linear-time check of SSD parsing (item 6,
//! acceptance 5).
//!
//! Seeded mutations of the shipped systems (`examples/systems/*/SystemStructure.ssd` and
//! their `.ssv` parameter files): bytes deleted or repeated, markup fragments, broken
//! comments, undefined entities, non-finite and huge numbers, deep nesting and many unknown
//! elements inserted. Every mutation is parsed by the SSD reader
//! (`geardyn::host::system::ssd::parse`): it must return a system or a message, never panic,
//! and each parse must stay within [`PARSE_BOUND`] of CPU time.

#[path = "common/cpu.rs"]
mod cpu;
#[path = "common/rng.rs"]
mod rng;

use std::path::{Path, PathBuf};
use std::time::Duration;

use cpu::thread_cpu;

use geardyn::host::system::ssd::{parse, Resources};
use rng::SplitMix64;

/// The longest any one parse of a mutated file may take (they are a few kB to a few MB).
const PARSE_BOUND: Duration = Duration::from_secs(1);

/// The `.ssv` files of a system, possibly mutated.
struct Files {
    dir: PathBuf,
    mutated: Option<(String, String)>,
}

impl Resources for Files {
    fn read(&self, source: &str) -> Result<String, String> {
        if let Some((name, text)) = &self.mutated {
            if name == source {
                return Ok(text.clone());
            }
        }
        std::fs::read_to_string(self.dir.join(source)).map_err(|e| format!("{source}: {e}"))
    }
}

fn systems() -> Vec<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/systems");
    let mut dirs: Vec<PathBuf> = std::fs::read_dir(root)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.join("SystemStructure.ssd").is_file())
        .collect();
    dirs.sort();
    assert!(dirs.len() >= 3, "{dirs:?}");
    dirs
}

const FRAGMENTS: [&str; 24] = [
    "<",
    ">",
    "/>",
    "</ssd:Elements>",
    "<ssd:Component name=\"x\" source=\"resources/x.fmu\"/>",
    "<!-- a -- b -->",
    "<!--",
    "&",
    "&bogus;",
    "&#0;",
    "&#x110000;",
    "\"",
    "'",
    "1e999",
    "NaN",
    "-inf",
    "1e-400",
    "<?xml version=\"1.0\"?>",
    "<![CDATA[ x ]]>",
    "<!DOCTYPE x [<!ENTITY a \"aaaaaaaaaa\">]>",
    " xmlns:ssd=\"\"",
    "\u{0}",
    "\u{feff}",
    "<ssv:Real name=\"p\" value=\"1e999\"/>",
];

/// One random change of `text` (always at character boundaries).
fn mutate(rng: &mut SplitMix64, text: &str) -> String {
    let chars: Vec<char> = text.chars().collect();
    let n = chars.len().max(1);
    let at = (rng.next() % n as u64) as usize;
    let len = 1 + (rng.next() % 64) as usize;
    let end = (at + len).min(chars.len());
    let (head, tail): (String, String) =
        (chars[..at].iter().collect(), chars[at..].iter().collect());
    match rng.next() % 8 {
        0 => head + &chars[end..].iter().collect::<String>(),
        1 => {
            let piece: String = chars[at..end].iter().collect();
            head + &piece.repeat(1 + (rng.next() % 50) as usize) + &tail
        }
        2 | 3 => head + FRAGMENTS[(rng.next() % FRAGMENTS.len() as u64) as usize] + &tail,
        4 => {
            // A number attribute replaced by an extreme.
            let extremes = [
                "1e999", "-1e999", "nan", "inf", "1e308", "-0", "4.9e-324", "",
            ];
            let x = extremes[(rng.next() % extremes.len() as u64) as usize];
            text.replacen("value=\"", &format!("value=\"{x}"), 1)
                .replacen("factor=\"", &format!("factor=\"{x}"), 1)
        }
        5 => {
            let depth = 1 + (rng.next() % 2000) as usize;
            head + &"<u>".repeat(depth) + &"</u>".repeat(depth) + &tail
        }
        6 => {
            let count = 1 + (rng.next() % 5000) as usize;
            head + &"<ssd:Unknown a=\"1\"/>\n".repeat(count) + &tail
        }
        _ => head + "\n" + &tail,
    }
}

fn fuzz(mutations: usize) {
    let mut rng = SplitMix64(0x55d0_3434);
    let dirs = systems();
    let (mut parsed, mut refused, mut panics, mut slow) = (0, 0, 0, 0);
    let mut slowest = Duration::ZERO;
    for i in 0..mutations {
        let dir = &dirs[i % dirs.len()];
        let ssd = std::fs::read_to_string(dir.join("SystemStructure.ssd")).unwrap();
        let mut files = Files {
            dir: dir.clone(),
            mutated: None,
        };
        let mut text = ssd;
        let ssv = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .find(|p| p.extension().is_some_and(|e| e == "ssv"));
        let rounds = 1 + (rng.next() % 3) as usize;
        match ssv {
            Some(p) if rng.chance(0.3) => {
                let mut v = std::fs::read_to_string(&p).unwrap();
                for _ in 0..rounds {
                    v = mutate(&mut rng, &v);
                }
                let name = p.file_name().unwrap().to_string_lossy().into_owned();
                files.mutated = Some((name, v));
            }
            _ => {
                for _ in 0..rounds {
                    text = mutate(&mut rng, &text);
                }
            }
        }
        let start = thread_cpu();
        let result =
            std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| parse(&text, &files)));
        let took = thread_cpu().saturating_sub(start);
        slowest = slowest.max(took);
        if took > PARSE_BOUND {
            slow += 1;
        }
        match result {
            Ok(Ok(_)) => parsed += 1,
            Ok(Err(e)) => {
                assert!(!e.trim().is_empty(), "mutation {i}: an empty message");
                refused += 1;
            }
            Err(_) => {
                panics += 1;
                println!("ssd fuzz: mutation {i} of {} panicked", dir.display());
            }
        }
    }
    println!(
        "ssd fuzz: {mutations} mutations of {} systems: {parsed} parsed, {refused} refused with a \
         message, {panics} panics, {slow} over {PARSE_BOUND:?} (slowest {:.1} ms)",
        dirs.len(),
        slowest.as_secs_f64() * 1e3
    );
    assert_eq!(panics, 0);
    assert_eq!(slow, 0);
}

#[test]
fn ssd_mutations() {
    fuzz(3000);
}

#[test]
#[ignore = "long: 1e5 SSD mutations; bash scripts/stress.sh"]
fn ssd_mutations_long() {
    fuzz(100_000);
}

/// A shipped system with `count` unknown elements inside `<ssd:System>`, flat or nested.
fn padded(count: usize, nested: bool) -> String {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/systems/drivetrain");
    let text = std::fs::read_to_string(dir.join("SystemStructure.ssd")).unwrap();
    let pad = if nested {
        "<ssd:Unknown>".repeat(count) + &"</ssd:Unknown>".repeat(count)
    } else {
        "<ssd:Unknown a=\"1\"/>\n".repeat(count)
    };
    let at = text.find("<ssd:Elements>").unwrap();
    format!("{}{pad}{}", &text[..at], &text[at..])
}

fn parse_seconds(text: &str) -> f64 {
    let files = Files {
        dir: PathBuf::new(),
        mutated: None,
    };
    (0..3)
        .map(|_| {
            let start = thread_cpu();
            let _ = parse(text, &files);
            thread_cpu().saturating_sub(start).as_secs_f64()
        })
        .fold(f64::INFINITY, f64::min)
}

/// Issue 34 item 6: N nested unknown elements took 0.06 / 0.23 / 0.87 s at N = 10k / 20k /
/// 40k, and 200k did not finish in 60 s. Nesting deeper than the reader's limit is now
/// refused at once, naming the line; 200k flat unknown elements are read in time linear in
/// the file: 16 times the elements take under 48 times the time (a quadratic reader would
/// take 256 times; a ratio measured in one run, best of three against noise).
#[test]
fn ssd_parsing_is_linear_in_the_file() {
    let files = Files {
        dir: PathBuf::new(),
        mutated: None,
    };
    let e = parse(&padded(200_000, true), &files).unwrap_err();
    assert!(
        e.contains("nested deeper than") && e.contains("line"),
        "{e}"
    );
    // 16x the elements: about 16x the time when linear, 256x when quadratic; the bound sits
    // between them with room for cache and allocator effects (4x against a bound of 8x
    // failed at 8.1x under load).
    let (small, large) = (padded(12_500, false), padded(200_000, false));
    let ratio = parse_seconds(&large) / parse_seconds(&small);
    println!("ssd parse: 16x the unknown elements took {ratio:.2}x the time");
    assert!(ratio < 48.0, "16x the elements took {ratio:.1}x the time");
}

/// Issue 34 item 8: `ssv:Real value="1e999"` was read as infinity; it is refused, naming the
/// file, the parameter and the value.
#[test]
fn a_non_finite_ssv_literal_is_refused() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/systems/two_stage");
    let ssd = std::fs::read_to_string(dir.join("SystemStructure.ssd")).unwrap();
    let ssv = std::fs::read_to_string(dir.join("stage1.ssv")).unwrap();
    let at = ssv.find("value=\"").expect("a value in stage1.ssv") + "value=\"".len();
    let end = at + ssv[at..].find('"').unwrap();
    for literal in ["1e999", "-1e999", "inf", "NaN"] {
        let files = Files {
            dir: dir.clone(),
            mutated: Some((
                "stage1.ssv".into(),
                format!("{}{literal}{}", &ssv[..at], &ssv[end..]),
            )),
        };
        let e = parse(&ssd, &files).unwrap_err();
        assert!(
            e.contains(&format!("value=\"{literal}\" is not a finite real number"))
                && e.contains("stage1.ssv"),
            "{literal}: {e}"
        );
    }
}
