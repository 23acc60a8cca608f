//! Farm plans read back (`farm piece`, `farm status`, `farm merge` read
//! `farm.toml` from a shared folder, where anyone may have edited it):
//! generated from the plan's real keys with values from the edges, then
//! damaged now and then. Every plan ends in a clean error naming
//! `farm.toml`, or in a plan whose pieces cover every frame's samples
//! exactly once. The seed is fixed (`PLSR_FUZZ_SEED`, `PLSR_FUZZ_CASES`
//! as for the renderer's fuzzers in tests/it/fuzz_parsers.rs).

use plsr_cli::farm::plan::FarmPlan;
use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed, TestRunner};

fn config() -> Config {
    let cases = std::env::var("PLSR_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(3000);
    let rng_seed = match std::env::var("PLSR_FUZZ_SEED").as_deref() {
        Ok("random") => RngSeed::Random,
        Ok(n) => RngSeed::Fixed(n.parse().expect("PLSR_FUZZ_SEED: a number or `random`")),
        Err(_) => RngSeed::Fixed(0x0915_1313),
    };
    Config {
        cases,
        rng_seed,
        failure_persistence: None,
        ..Config::default()
    }
}

/// An unsigned count below `good` as plans hold them, and now and then
/// one of the values that break code.
fn count(good: u64) -> BoxedStrategy<String> {
    prop_oneof![
        12 => (1u64..good).prop_map(move |v| v.to_string()),
        1 => prop::sample::select(vec![
            "0", "-1", "16777216", "16777217", "1000000", "1000001", "4294967295",
            "4294967296", "1099511627776", "9223372036854775807", "1.5", "\"4\"", "nan",
            "inf", "true", "[]",
        ])
        .prop_map(String::from),
    ]
    .boxed()
}

/// A plan's text: each key present (mostly) or not, a stray key now and
/// then, and a few damaged bytes or lines.
fn plan_text() -> impl Strategy<Value = String> {
    let scene = prop::sample::select(vec![
        "\"scene.toml\"",
        "\"/abs/scene.xml\"",
        "\"\"",
        "\"../up/scene.gltf\"",
        "1",
    ]);
    let frames = prop::option::weighted(0.3, (count(4), count(40))).prop_map(|f| {
        f.map(|(a, b)| format!("frames = [{a}, {b}]\n"))
            .unwrap_or_default()
    });
    let name = prop::sample::select(vec![
        "\"image\"",
        "\"a b\"",
        "\"\"",
        "\"../x\"",
        "\".hidden\"",
        "\"a/b\"",
        "\"é\"",
        "7",
    ]);
    let defines = prop::sample::select(vec![
        "",
        "",
        "",
        "",
        "defines = [[\"spp\", \"4\"]]\n",
        "defines = [[\"bad name\", \"4\"]]\n",
        "defines = [[\"\", \"\"]]\n",
        "defines = [[\"a\"]]\n",
        "defines = \"x\"\n",
    ]);
    let time = prop::sample::select(vec![
        "",
        "",
        "",
        "time = 0.5\n",
        "time = -1\n",
        "time = nan\n",
    ]);
    let stray = prop::sample::select(vec![
        "",
        "",
        "",
        "",
        "",
        "",
        "",
        "",
        "surprise = 1\n",
        "[table]\n",
        "spp = 2\n",
    ]);
    let damage = prop_oneof![
        6 => Just(Vec::new()),
        1 => prop::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..3),
    ];
    (
        (scene, count(70), count(8), frames),
        (name, prop::bool::ANY, defines, time, stray),
        damage,
        prop::option::weighted(0.05, any::<prop::sample::Index>()),
    )
        .prop_map(
            |((scene, spp, parts, frames), (name, png, defines, time, stray), damage, cut)| {
                let mut text = format!(
                    "scene = {scene}\nspp = {spp}\nparts = {parts}\n{frames}name = {name}\n\
                     png = {png}\n{defines}{time}{stray}"
                )
                .into_bytes();
                for (at, byte) in damage {
                    let k = at.index(text.len());
                    text[k] = byte;
                }
                if let Some(at) = cut {
                    text.truncate(at.index(text.len() + 1));
                }
                String::from_utf8_lossy(&text).into_owned()
            },
        )
}

#[test]
fn farm_plans_end_in_a_plan_or_a_clean_error() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("farm.toml");
    let (accepted, refused) = (std::cell::Cell::new(0u32), std::cell::Cell::new(0u32));
    let mut runner = TestRunner::new(config());
    let result = runner.run(&plan_text(), |text| {
        std::fs::write(&path, &text).unwrap();
        match FarmPlan::read(&path) {
            Err(e) => {
                let message = e.to_string();
                prop_assert!(
                    message.contains("farm.toml") && message.len() > "farm.toml: ".len() + 4,
                    "an unclear error: {message}\nplan:\n{text}"
                );
                refused.set(refused.get() + 1);
            }
            Ok(plan) => {
                prop_assert!(plan.check().is_ok());
                let n = plan.piece_count();
                prop_assert!(u64::from(n) <= plsr_cli::farm::plan::MAX_PIECES);
                prop_assert!(plan.piece(n).is_none(), "a piece past the count\n{text}");
                // The parts of one frame cover its samples once, in order.
                let mut next = 0;
                for i in 0..plan.parts.min(n) {
                    let p = plan.piece(i).unwrap();
                    prop_assert_eq!(p.samples.start, next, "piece {} of\n{}", i, text);
                    prop_assert!(p.samples.end > p.samples.start);
                    next = p.samples.end;
                }
                prop_assert_eq!(next, plan.spp, "the parts do not add up\n{}", text);
                accepted.set(accepted.get() + 1);
            }
        }
        Ok(())
    });
    if let Err(e) = result {
        panic!("farm plans: {e}");
    }
    let (accepted, refused) = (accepted.get(), refused.get());
    eprintln!("farm plans: {accepted} accepted, {refused} refused");
    let total = accepted + refused;
    assert!(
        accepted * 20 >= total && refused * 20 >= total,
        "{accepted} accepted, {refused} refused: the generator misses one outcome"
    );
}
